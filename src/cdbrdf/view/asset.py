"""Tables and meshes packed for the viewer's GPU: a binary blob and a JSON header.

A table asset holds, in one little-endian blob:

- ``lookup``: the table's :class:`~cdbrdf.interp.LookupGrid` values (the pole
  rule already applied by :func:`cdbrdf.interp.prepare`: elevation node 0 is
  theta = 0 and holds the ring mean), as an RGBA texture array with one
  layer per curvature. Each layer is the paper's Fig. 7 image (rows: light
  directions, columns: view directions, elevation inside an azimuth group,
  with the lookup's elevation nodes) read in row-major order and folded into
  rows of :func:`texture_shape`'s width: texel ``i = row * n_columns +
  column`` lies at ``(i % width, i // width)``, so a fine isotropic table
  (8,100 view directions at 2 degrees) fits as well as the paper's grid.
  float32, or float16 when the float32 texture is larger than
  :data:`FLOAT16_ABOVE_BYTES` (``precision="auto"``);
- ``samples``: the stored samples (float32, the table's channels) for the
  mosaic read-out;
- ``measured`` (uint8), ``fill_method`` (uint8 codes, names in the header)
  and ``fill_source`` (int32 flat index, -1 measured, -2 unknown) per sample.

A mesh asset (:func:`mesh_asset`) holds positions, normals, tangents, the
curvature, UVs and indices; a mesh with a curvature map
(:class:`cdbrdf.mesh.CurvatureMap`, ``metadata["curvature_map"]``) also holds
its own shape operator per vertex with the UV layout's handedness
(``shape``) and the map's prefiltered levels (``map``: every level's texels,
level 0 first, two RGBA texels each, :func:`cdbrdf.view.map_asset.map_atlas`),
which the page looks up per fragment by the rule of :mod:`cdbrdf.mesh.curvature_map`.

The header names the axes (degrees, 1/mm), the lookup's nodes and steps, the
symmetry (an isotropic table is uploaded as it is and the shader applies the
rotation rule of :mod:`cdbrdf.interp`), channels, quantity, material, and
where each block lies in the blob.

The texture must fit WebGL2's guaranteed limits (:data:`WEBGL2_MIN_LIMITS`:
what every WebGL2 implementation supports); :func:`check_texture` refuses a
larger table naming the limit, and :func:`resample` puts a table on a smaller
grid (``cdbrdf view --grid``). The page checks the real limits of the GPU
again when it uploads.
"""

from __future__ import annotations

import json
import logging
import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..errors import LimitError, OptionError
from .map_asset import map_atlas, uv_handedness

__all__ = [
    "ASSET_FORMAT",
    "ASSET_VERSION",
    "FLOAT16_ABOVE_BYTES",
    "PRECISIONS",
    "WEBGL2_MIN_LIMITS",
    "VIEWER_CANVAS",
    "VIEWER_FOV_DEG",
    "Asset",
    "check_texture",
    "mesh_asset",
    "parse_grid",
    "resample",
    "table_asset",
    "texture_shape",
]

_LOG = logging.getLogger(__name__)

#: Name and version of the asset layout (the header's ``format`` and ``version``).
ASSET_FORMAT = "cdbrdf-viewer-asset"
ASSET_VERSION = 1

#: The texture sizes every WebGL2 implementation supports (the specification's minimums).
WEBGL2_MIN_LIMITS: Mapping[str, int] = {"MAX_TEXTURE_SIZE": 2048, "MAX_ARRAY_TEXTURE_LAYERS": 256}

#: ``precision="auto"``: float16 textures when the float32 texture would be larger than this.
FLOAT16_ABOVE_BYTES = 64 * 2**20

#: Valid ``precision`` values of :func:`table_asset`.
PRECISIONS: tuple[str, ...] = ("auto", "float32", "float16")

_FLOAT16_MAX = 65504.0

#: The page's canvas (pixels) and its lens's vertical field of view (degrees): what a mesh is first framed for.
VIEWER_CANVAS: tuple[int, int] = (960, 600)
VIEWER_FOV_DEG = 35.0



@dataclass(frozen=True)
class Asset:
    """One packed asset: a JSON-serialisable header and its binary blob.

    Attributes
    ----------
    header
        Shapes, types and metadata, JSON-serialisable.
    blob
        The packed arrays.
    """

    header: dict[str, Any]
    blob: bytes

    def header_json(self) -> str:
        """The header as compact JSON.

        Returns
        -------
        str
            The JSON text.
        """
        return json.dumps(self.header, separators=(",", ":"), allow_nan=False)


class _Blob:
    """Appends arrays to a little-endian blob (4-byte aligned) and records where each lies."""

    def __init__(self) -> None:
        self.parts: list[bytes] = []
        self.size = 0
        self.blocks: dict[str, dict[str, Any]] = {}

    def add(self, name: str, a: NDArray[Any], dtype: str) -> None:
        arr = np.ascontiguousarray(a, dtype=np.dtype(dtype).newbyteorder("<"))
        data = arr.tobytes()
        self.blocks[name] = {"offset": self.size, "bytes": len(data), "dtype": dtype, "shape": list(arr.shape)}
        self.parts.append(data)
        self.size += len(data)
        pad = (-self.size) % 4
        if pad:
            self.parts.append(b"\0" * pad)
            self.size += pad

    def bytes(self) -> bytes:
        return b"".join(self.parts)


def texture_shape(table: Any, *, max_width: int = WEBGL2_MIN_LIMITS["MAX_TEXTURE_SIZE"]) -> tuple[int, int, int]:
    """The size of a table's lookup texture (pole nodes included).

    A layer's ``n_light * n_view`` texels are folded into rows of at most ``max_width``.

    Parameters
    ----------
    table
        The table.
    max_width
        The widest row, texels.

    Returns
    -------
    tuple of int
        ``(width, height, layers)``.
    """
    lg = table.lookup_grid()
    k, pl, tl, pv, tv, _ = lg.shape
    n = pl * tl * pv * tv
    width = min(n, int(max_width))
    return width, -(-n // width), k


def check_texture(table: Any, *, name: str = "table", limits: Mapping[str, int] = WEBGL2_MIN_LIMITS) -> None:
    """Refuse a table whose lookup texture exceeds ``limits`` (default: WebGL2's guaranteed ones).

    Parameters
    ----------
    table
        The table.
    name
        Its name, for messages.
    limits
        The GPU's limits by WebGL name.

    Raises
    ------
    LimitError
        Naming the limit, the size asked for and ``--grid`` resampling.
    """
    tex = limits["MAX_TEXTURE_SIZE"]
    lay = limits["MAX_ARRAY_TEXTURE_LAYERS"]
    _, h, layers = texture_shape(table, max_width=tex)
    lg = table.lookup_grid()
    n = int(np.prod(lg.shape[1:5]))
    problems = []
    if h > tex:
        problems.append(f"{n:,} light x view directions per curvature > MAX_TEXTURE_SIZE^2 = {tex * tex:,} texels")
    if layers > lay:
        problems.append(f"{layers} curvatures (texture layers) > MAX_ARRAY_TEXTURE_LAYERS {lay}")
    if problems:
        raise LimitError(
            f"{name}: too large for the viewer's GPU texture (WebGL2 guarantees only "
            f"MAX_TEXTURE_SIZE {tex} and MAX_ARRAY_TEXTURE_LAYERS {lay}): {'; '.join(problems)}; "
            "resample it with --grid THETA_STEP,PHI_STEP (degrees, e.g. --grid 15,30)"
        )


def parse_grid(text: str) -> tuple[float, float, int | None]:
    """Read a ``--grid`` value.

    Parameters
    ----------
    text
        ``"THETA_STEP,PHI_STEP[,N_KAPPA]"``.

    Returns
    -------
    theta_step_deg, phi_step_deg : float
        The steps, degrees.
    n_kappa : int or None
        The curvature count, if given.

    Raises
    ------
    OptionError
        For anything else (the message shows the form).
    """
    parts = [p.strip() for p in str(text).split(",")]
    form = "THETA_STEP,PHI_STEP[,N_KAPPA] in degrees like 15,30"
    if len(parts) not in (2, 3):
        raise OptionError(f"grid: expected {form}, got {text!r}")
    try:
        ts, ps = float(parts[0]), float(parts[1])
        nk = int(parts[2]) if len(parts) == 3 else None
    except ValueError:
        raise OptionError(f"grid: expected {form}, got {text!r}") from None
    if not (math.isfinite(ts) and 0 < ts <= 90 and math.isfinite(ps) and 0 < ps <= 360):
        raise OptionError(f"grid: steps must lie in (0, 90] and (0, 360] degrees, got {text!r}")
    if abs(360.0 / ps - round(360.0 / ps)) > 1e-9:
        raise OptionError(f"grid: the azimuth step {ps:g} does not divide 360")
    if nk is not None and not 1 <= nk <= WEBGL2_MIN_LIMITS["MAX_ARRAY_TEXTURE_LAYERS"]:
        raise OptionError(f"grid: N_KAPPA must lie in [1, {WEBGL2_MIN_LIMITS['MAX_ARRAY_TEXTURE_LAYERS']}], "
                          f"got {parts[2]!r}")
    return ts, ps, nk


def resample(table: Any, *, theta_step_deg: float, phi_step_deg: float, n_kappa: int | None = None) -> Any:
    """The table evaluated (:meth:`~cdbrdf.table.CDBRDF.evaluate`) onto a regular grid.

    Elevations ``0, step, ...`` up to the table's last elevation, azimuths
    ``0, step, ...``; the curvature axis kept, or ``n_kappa`` evenly spaced
    curvatures over its range. The symmetry is kept. Every sample of the
    result is an interpolated value: the result is marked measured
    everywhere and its attributes say ``resampled_from`` (the old shape).

    Parameters
    ----------
    table
        The table.
    theta_step_deg, phi_step_deg
        The steps, degrees.
    n_kappa
        Number of curvatures; default: the table's axis.

    Returns
    -------
    CDBRDF
        The resampled table.
    """
    from ..grid import Grid
    from ..table import CDBRDF

    g = table.grid
    th_max = float(max(g.theta_l[-1], g.theta_v[-1]))
    if n_kappa is None or n_kappa == g.kappa.size:
        kappa = g.kappa
    elif n_kappa == 1:
        kappa = np.array([0.0 if g.kappa[0] <= 0.0 <= g.kappa[-1] else float(g.kappa[g.kappa.size // 2])])
    else:
        kappa = np.linspace(float(g.kappa[0]), float(g.kappa[-1]), n_kappa)
    new = Grid.regular(theta_step_deg=theta_step_deg, phi_step_deg=phi_step_deg,
                       theta_max_deg=min(th_max, 89.999), kappa=kappa, symmetry=g.symmetry)
    m = new.mesh()
    values = table.evaluate(m["theta_v"], m["phi_v"], m["theta_l"], m["phi_l"], m["kappa"]).astype(np.float32)
    attrs = dict(table.attrs)
    attrs["resampled_from"] = "x".join(str(n) for n in g.shape)
    return CDBRDF(values, new, attrs=attrs)


def _precision(lookup: NDArray[np.floating], precision: str) -> str:
    if precision not in PRECISIONS:
        raise OptionError(f"precision: {precision!r} is not one of {', '.join(PRECISIONS)}")
    if precision != "auto":
        if precision == "float16" and float(np.max(np.abs(lookup), initial=0.0)) > _FLOAT16_MAX:
            raise OptionError(f"precision: float16 cannot hold this table's peak {float(np.max(lookup)):g}")
        return precision
    big = lookup.shape[0] * lookup.shape[1] * lookup.shape[2] * lookup.shape[3] * lookup.shape[4] * 16
    if big > FLOAT16_ABOVE_BYTES and float(np.max(np.abs(lookup), initial=0.0)) <= _FLOAT16_MAX:
        return "float16"
    return "float32"


def _exposure_ev(values: NDArray[np.floating]) -> float:
    """The page's first exposure, stops: the 99.5th percentile of a lit sample (pi f cos 45) to 0.9, at most +2.

    As the demo's renders (at most +2 EV, so that dark fabrics stay dark);
    0 EV shows a white Lambertian surface facing the light as white.
    """
    v = np.asarray(values, dtype=np.float64)
    lum = v[..., :3] @ np.array([0.2126, 0.7152, 0.0722]) if v.shape[-1] == 3 else v[..., 0]
    p = float(np.percentile(lum, 99.5)) * math.pi * math.sqrt(0.5)
    if not (p > 0 and math.isfinite(p)):
        return 0.0
    return float(np.clip(math.log2(0.9 / p), -6.0, 2.0))


def table_asset(table: Any, *, name: str = "table", precision: str = "auto") -> Asset:
    """Pack a table for the viewer (see the module docstring for the layout).

    Parameters
    ----------
    table
        A :class:`~cdbrdf.table.CDBRDF` with 1 (grey) or 3 (RGB) channels.
    name
        Its label in the viewer (the file name).
    precision
        One of :data:`PRECISIONS`: the texture's float type.

    Returns
    -------
    Asset
        The packed table.

    Raises
    ------
    OptionError
        For a table of other channel counts, an unknown precision.
    LimitError
        When the texture exceeds WebGL2's guaranteed limits (:func:`check_texture`).
    """
    from ..schema import FILL_METHOD_CODES

    nc = int(table.n_channels)
    if nc not in (1, 3):
        raise OptionError(f"{name}: the viewer shows RGB or grey tables; this one has {nc} channels "
                          f"({', '.join(table.channels)})")
    check_texture(table, name=name)
    lg = table.lookup_grid()
    k, pl, tl, pv, tv, _ = lg.shape
    rgba = np.zeros((k, pl, tl, pv, tv, 4), dtype=np.float32)
    vals = np.asarray(lg.values, dtype=np.float32)
    rgba[..., :3] = vals if nc == 3 else vals[..., :1]
    rgba[..., 3] = 1.0
    prec = _precision(rgba, precision)
    blob = _Blob()
    # (kappa, phi_l, theta_l, phi_v, theta_v, 4) in C order is each layer's Fig. 7 image row by row:
    # folded into rows of the texture's width, the last row padded
    width, height, _ = texture_shape(table)
    flat = rgba.reshape(k, -1, 4)
    folded = np.zeros((k, width * height, 4), dtype=np.float32)
    folded[:, : flat.shape[1]] = flat
    blob.add("lookup", folded.reshape(k, height, width, 4), "float16" if prec == "float16" else "float32")
    blob.add("samples", np.asarray(table.values, dtype=np.float32), "float32")
    blob.add("measured", np.asarray(table.measured, dtype=np.uint8), "uint8")
    blob.add("fill_method", np.asarray(table.fill_method, dtype=np.uint8), "uint8")
    blob.add("fill_source", np.asarray(table.fill_source, dtype=np.int32), "int32")
    g = table.grid
    attrs = table.attrs
    header: dict[str, Any] = {
        "format": ASSET_FORMAT,
        "version": ASSET_VERSION,
        "kind": "table",
        "name": name,
        "material": str(attrs.get("material", "")),
        "quantity": table.quantity,
        "symmetry": table.symmetry,
        "channels": list(table.channels),
        "n_channels": nc,
        "resampled_from": attrs.get("resampled_from"),
        "axes": {"kappa": g.kappa.tolist(), "theta_l": g.theta_l.tolist(), "phi_l": g.phi_l.tolist(),
                 "theta_v": g.theta_v.tolist(), "phi_v": g.phi_v.tolist()},
        "units": {"kappa": "1/mm", "theta_l": "degree", "phi_l": "degree", "theta_v": "degree",
                  "phi_v": "degree"},
        "lookup": {
            "shape": [k, pl, tl, pv, tv],
            "kappa": lg.kappa.tolist(),
            "theta_l": lg.theta_l.tolist(),
            "theta_v": lg.theta_v.tolist(),
            "phi_l0": lg.phi_l0, "phi_l_step": lg.phi_l_step,
            "phi_v0": lg.phi_v0, "phi_v_step": lg.phi_v_step,
            "isotropic": bool(lg.isotropic),
            # 1 / step of evenly spaced elevations of >= 3 nodes, else 0 (the shader indexes those by
            # multiplication, as the RGB kernel; the curvature axis is searched)
            "theta_l_inv_step": lg.theta_l_inv_step,
            "theta_v_inv_step": lg.theta_v_inv_step,
            "snap_tolerance": 1e-6,  # cdbrdf.interp.SNAP_TOLERANCE["float32"]
            "texture": {"width": width, "height": height, "layers": k, "columns": pv * tv, "rows": pl * tl,
                        "format": "RGBA", "type": prec},
        },
        "fill_methods": {str(c): n for n, c in FILL_METHOD_CODES.items()},
        "exposure_ev": _exposure_ev(vals),
        "blocks": blob.blocks,
    }
    return Asset(header, blob.bytes())


def mesh_asset(mesh: Any, *, name: str, uv_scale_mm: float | tuple[float, float] = 1.0,
               precision: str = "auto") -> Asset:
    """Pack a mesh with per-vertex curvature (mm^-1) for the viewer: one draw call.

    Positions are centred (mm); the tangent is the material's x axis (dP/du
    of the UV map projected into the tangent plane, as in the renderer); a
    vertex without one gets any unit vector perpendicular to its normal.
    A mesh with its own UVs (all finite; not those :func:`cdbrdf.mesh.prepare_mesh`
    generates per face for the frames ``"tangent"`` and ``"principal"``)
    carries them as the block ``uv`` (float32,
    per vertex) and the header's ``uv_scale_mm`` (mm of fabric per UV unit,
    u and v): a CD-BTF is decoded at ``(u, v) = uv * uv_scale_mm`` mm, as
    the renderer's ``uv_scale``. Without UVs the header's ``uv`` is false and
    the viewer shows a CD-BTF's tile mean there.

    A mesh with a curvature map (``metadata["curvature_map"]``, baked per
    texel by :func:`cdbrdf.mesh.apply_maps`) also carries the block ``shape``
    (float32 ``(n, 4)``: its shape operator ``sxx, sxy, syy`` in 1/mm in the
    frame x = dP/du, y = n x x, and the UV layout's handedness, +1 or -1 where
    it is mirrored), the block ``map`` and the header's ``map``
    (:func:`cdbrdf.view.map_asset.map_atlas`), the map's levels at the mesh's UV scale
    (``metadata["uv_scale"]``) and neighbourhood.

    Parameters
    ----------
    mesh
        A :class:`~cdbrdf.mesh.Mesh` prepared by
        :func:`cdbrdf.mesh.prepare_mesh` (normals, UVs and the
        attribute ``"curvature"`` in mm^-1, lengths in mm).
    name
        Its label in the viewer.
    uv_scale_mm
        Millimetres of fabric per UV unit of a CD-BTF: one number for both,
        or ``(su, sv)`` (default 1: the UVs are in mm).
    precision
        The map's texture: one of :data:`PRECISIONS` (``"auto"``: float32).

    Returns
    -------
    Asset
        The packed mesh.

    Raises
    ------
    OptionError
        For a ``uv_scale_mm`` that is not one or two positive finite numbers,
        an unknown precision.
    """
    from ..mesh import SHAPE_ATTRIBUTES
    from ..mesh.prepare import has_own_uv
    from ..mesh.units import parse_units

    su, sv = _uv_scale_pair(uv_scale_mm)
    if precision not in PRECISIONS:
        raise OptionError(f"precision: {precision!r} is not one of {', '.join(PRECISIONS)}")
    scale = float(parse_units(mesh.metadata.get("units", "mm")).mm_per_unit)
    v = np.asarray(mesh.vertices, dtype=np.float64) * scale
    f = np.asarray(mesh.faces, dtype=np.int64)
    n = np.asarray(mesh.normals, dtype=np.float64)
    t = _vertex_frame_tangents(mesh, v, f, n)
    lo, hi = v.min(axis=0), v.max(axis=0)
    centre = (lo + hi) / 2
    kappa = np.asarray(mesh.attributes["curvature"], dtype=np.float64)
    blob = _Blob()
    blob.add("position", v - centre, "float32")
    blob.add("normal", n, "float32")
    blob.add("tangent", t, "float32")
    blob.add("curvature", kappa, "float32")
    own = has_own_uv(mesh)  # not the per-face UVs prepare_mesh makes without
    uv = np.asarray(mesh.uv, dtype=np.float64) if own else None
    if uv is not None and not np.isfinite(uv).all():
        _LOG.warning("%s: the UVs are not all finite; the viewer shows a CD-BTF's tile mean on it", name)
        uv = None
    if uv is not None:
        blob.add("uv", uv, "float32")
    blob.add("index", f, "uint32")
    header = {
        "format": ASSET_FORMAT, "version": ASSET_VERSION, "kind": "mesh", "name": name,
        "n_vertices": int(v.shape[0]), "n_faces": int(f.shape[0]),
        "uv": uv is not None, "uv_scale_mm": [su, sv],
        "size_mm": (hi - lo).tolist(), "units": "mm",
        "curvature_range": [float(kappa.min()), float(kappa.max())],
        "frame": _framing(v - centre),
    }
    cmap = mesh.metadata.get("curvature_map")
    if cmap is not None and uv is None:
        _LOG.warning("%s: its curvature map needs its own finite UVs; the viewer shows the mesh's own curvature",
                     name)
    elif cmap is not None and uv is not None:
        shape = np.stack([np.asarray(mesh.attributes[k], dtype=np.float64) for k in SHAPE_ATTRIBUTES]
                         + [uv_handedness(v, f, uv, n)], axis=1)
        blob.add("shape", shape, "float32")
        header["map"], atlas = map_atlas(cmap, uv_scale=mesh.metadata["uv_scale"],
                                         neighbourhood_mm=float(mesh.metadata.get("neighbourhood_mm", 5.0)),
                                         max_width=WEBGL2_MIN_LIMITS["MAX_TEXTURE_SIZE"],
                                         max_texels=WEBGL2_MIN_LIMITS["MAX_TEXTURE_SIZE"] ** 2)
        half = precision == "float16"
        if half and float(np.max(np.abs(atlas), initial=0.0)) > _FLOAT16_MAX:
            raise OptionError(f"precision: float16 cannot hold {cmap.name}'s values (up to "
                              f"{float(np.max(np.abs(atlas))):g})")
        header["map"]["atlas"]["type"] = "float16" if half else "float32"
        blob.add("map", atlas, "float16" if half else "float32")
    header["blocks"] = blob.blocks
    return Asset(header, blob.bytes())


def _vertex_frame_tangents(mesh: Any, v: NDArray[np.float64], f: NDArray[np.int64],
                           n: NDArray[np.float64]) -> NDArray[np.float64]:
    """Unit tangents per vertex: dP/du projected (the renderer's frame), else any unit vector perpendicular to n."""
    from ..mesh.frames import face_uv_tangents, vertex_tangents

    if mesh.uv is not None:
        ft, ok = face_uv_tangents(v, f, np.asarray(mesh.uv, dtype=np.float64))
        t = vertex_tangents(f, ft, ok.astype(np.float64), n)
    else:
        t = np.full_like(n, np.nan)
    bad = ~np.isfinite(t).all(axis=1)
    if bad.any():
        a = np.where(np.abs(n[bad, 0:1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
        p = a - np.einsum("ij,ij->i", a, n[bad])[:, None] * n[bad]
        t[bad] = p / np.linalg.norm(p, axis=1, keepdims=True)
    return t


def _framing(points: NDArray[np.float64]) -> dict[str, float]:
    """The page's first view of a mesh (centred points, mm): ``cdbrdf render``'s view, framed by its rule."""
    from ..render.camera import DEFAULT_MESH_VIEW, frame_camera

    el, az = DEFAULT_MESH_VIEW
    w, h = VIEWER_CANVAS
    _, target, dist = frame_camera(points, width=w, height=h, elevation_deg=el, azimuth_deg=az,
                                   fov_deg=VIEWER_FOV_DEG)
    # the page orbits the box's centre (the origin): the distance there that frames what frame_camera framed
    return {"elevation_deg": el, "azimuth_deg": az, "distance_mm": float(dist + np.linalg.norm(target))}


def _uv_scale_pair(uv_scale_mm: Any) -> tuple[float, float]:
    """``uv_scale_mm`` as ``(su, sv)``: one or two positive finite numbers."""
    try:
        vals = [uv_scale_mm] if isinstance(uv_scale_mm, (int, float, np.number, str)) else list(uv_scale_mm)
        pair = [float(x) for x in vals if isinstance(x, (int, float, np.number)) and not isinstance(x, bool)]
    except (TypeError, ValueError):
        vals, pair = [uv_scale_mm], []
    if len(pair) != len(vals) or len(pair) not in (1, 2) or not all(math.isfinite(x) and x > 0 for x in pair):
        raise OptionError(f"uv_scale_mm: expected one or two positive numbers (mm per UV unit), got {uv_scale_mm!r}")
    return (pair[0], pair[-1])
