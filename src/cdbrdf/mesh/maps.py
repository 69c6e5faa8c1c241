"""A mesh's detail maps: which ones, at what UV scale, baked per texel (or per vertex), and checked.

:class:`SurfaceMaps` is the one record of everything laid on a mesh by its
UVs: a tangent-space normal map, a height map with its height scale, a
high-resolution mesh to bake onto its UVs, the UV scale (mm per UV unit,
shared with a CD-BTF's texels), the maps' physical size, and how to bake
them (:data:`BAKES`). :func:`apply_maps` applies it to a prepared mesh
(:func:`cdbrdf.mesh.prepare_mesh` calls it):

- the maps are those given, else those the mesh file names (an OBJ's MTL
  ``norm``, ``bump``/``map_Bump`` or ``disp`` with its ``-bm``, ``-s`` and
  ``-o``; a glTF's ``normalTexture`` with ``KHR_texture_transform``); an MTL
  bump map that is an RGB normal map (bluish, R and G around 0.5) is used as
  the normal map it is, and the user is told;
- the UV scale (:func:`detect_uv_scale`) is the one given, else the unit of
  UVs that are lengths (CAD panels: the UV and 3-D lengths of the edges
  agree in some length unit), else the median 3-D length per UV length of
  the edges; the rule that chose it is reported;
- ``bake="texel"`` (the default) bakes a
  :class:`~cdbrdf.mesh.curvature_map.CurvatureMap`
  (:mod:`cdbrdf.mesh.bake`) that the renderer looks up per shading point
  (``metadata["curvature_map"]``); ``bake="vertex"`` samples it at the
  vertices, filtered to the neighbourhood, and adds it to the vertices'
  curvature (the detail is then only as fine as the mesh; the map does not
  shade);
- a map that does nothing at the chosen scale (its folds average out within
  the curvature's neighbourhood: a map repeating every millimetre) is
  *one* warning that says what to change (the map's size, or the UV scale);
  every map gets one note of what it adds.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from os import PathLike
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..errors import MeshError
from ..ranges import Range
from .attributes import CURVATURE_MODES, SHAPE_ATTRIBUTES
from .bake import HeightMap, bake_height_map, bake_mesh, bake_normal_map, read_height_map
from .core import Mesh
from .curvature_map import (
    CurvatureMap,
    averaged_share,
    lookup,
    neighbourhood_level,
    principal,
    shape_operator,
)
from .normalmap import NORMAL_MAP_CONVENTIONS, NormalMap, normal_map_from_normals, read_normal_map
from .units import UNITS_MM, parse_units

__all__ = ["BAKES", "UV_SCALE_RANGE_MM", "MAP_SIZE_RANGE_MM", "HEIGHT_SCALE_RANGE_MM", "MESH_TEXELS_RANGE",
           "SurfaceMaps", "UVScale", "detect_uv_scale", "mesh_uv_scale", "as_uv_scale", "apply_maps",
           "NOTHING_LEFT_SHARE", "SAMPLES_PER_FOLD", "UV_UNIT_TOLERANCE"]

_LOG = logging.getLogger(__name__)

#: How maps are baked: per texel and looked up per shading point, or sampled at the vertices.
BAKES: tuple[str, ...] = ("texel", "vertex")

#: A map does nothing when the rms curvature left after the neighbourhood's filter is below this share of the
#: table's largest |kappa| over 2 (0.011 / mm for the paper's 0.22; 0.01 / mm without a table); the reason
#: given is that its folds average out when they keep less than this share of their own curvature.
NOTHING_LEFT_SHARE = 0.1

#: Vertices per fold length at least for a map baked per vertex (else a note).
SAMPLES_PER_FOLD = 4.0

#: UV and 3-D lengths "agree" in a unit within this relative difference (median over the edges).
UV_UNIT_TOLERANCE = 0.03

#: Accepted UV scales (each of u and v), mm per UV unit.
UV_SCALE_RANGE_MM = Range(0.0, 1e9, lo_open=True, unit="mm per UV unit")

#: Accepted sizes of one repeat of a map (each of u and v), mm.
MAP_SIZE_RANGE_MM = Range(0.0, 1e9, lo_open=True, unit="mm")

#: Accepted height scales of a height map, mm per unit of its values.
HEIGHT_SCALE_RANGE_MM = Range(0.0, 1e6, lo_open=True, unit="mm")

#: Accepted texels along the longer side of a mesh bake.
MESH_TEXELS_RANGE = Range(2, 8192, integer=True)


def _pair(name: str, value: Any, rng: Range = MAP_SIZE_RANGE_MM) -> tuple[float, float] | None:
    """One or two numbers of ``rng`` as ``(u, v)``, or None."""
    if value is None:
        return None
    try:
        parts = [float(value)] if isinstance(value, (int, float)) else [float(x) for x in value]
    except (TypeError, ValueError):
        parts = []
    if len(parts) == 1:
        parts *= 2
    if len(parts) != 2 or not all(x in rng for x in parts):
        raise MeshError(f"{name}: expected one or two numbers {rng.text()}, got {value!r:.60}")
    return parts[0], parts[1]


def as_uv_scale(value: Any, *, name: str = "uv_scale") -> tuple[float, float]:
    """A UV scale as two numbers (mm per UV unit along u and v): a number for both, or two.

    Parameters
    ----------
    value
        One positive number or two.
    name
        What to call it in the message.

    Returns
    -------
    tuple of float
        ``(su, sv)``.

    Raises
    ------
    MeshError
        For anything but one or two positive finite numbers.
    """
    pair = _pair(name, value, UV_SCALE_RANGE_MM)
    if pair is None:
        raise MeshError(f"{name}: expected one or two positive numbers of mm per UV unit, got None")
    return pair


@dataclass(frozen=True)
class SurfaceMaps:
    """What is laid on a mesh by its UVs, and how (see the module's description).

    Attributes
    ----------
    normal_map
        A tangent-space normal map (a file or a :class:`~cdbrdf.mesh.NormalMap`).
    normal_map_convention
        ``"opengl"`` (green up: Blender, glTF) or ``"directx"``.
    height_map
        A height (bump, displacement) map (a file or a :class:`~cdbrdf.mesh.bake.HeightMap`).
    height_scale_mm
        Millimetres per unit of the height map's values (8/16-bit codes are
        0 to 1); default: the MTL's ``-bm`` in the mesh's unit, else an error.
    hires_mesh
        A high-resolution mesh (a file or a :class:`~cdbrdf.mesh.Mesh`, in
        the mesh's unit and place) whose curvature is baked onto the mesh's UVs.
    uv_scale
        Mm per UV unit (one number or ``(u, v)``) of the maps and a CD-BTF;
        default: detected (:func:`detect_uv_scale`).
    map_size_mm
        The size (mm) one repeat of a normal or height map covers (one
        number or ``(u, v)``); default: the file's texture transform, else
        one repeat per UV unit.
    bake
        ``"texel"`` (default) or ``"vertex"`` (:data:`BAKES`).
    from_file
        Use the maps the mesh file names when none is given.
    mesh_texels
        Texels along the longer side of a mesh bake (default: from the high mesh's edges).
    """

    normal_map: str | PathLike[str] | NormalMap | None = None
    normal_map_convention: str = "opengl"
    height_map: str | PathLike[str] | HeightMap | None = None
    height_scale_mm: float | None = None
    hires_mesh: str | PathLike[str] | Mesh | None = None
    uv_scale: float | tuple[float, float] | None = None
    map_size_mm: float | tuple[float, float] | None = None
    bake: str = "texel"
    from_file: bool = True
    mesh_texels: int | None = None

    def __post_init__(self) -> None:
        if self.bake not in BAKES:
            raise MeshError(f"bake: {self.bake!r:.40} is not one of {', '.join(BAKES)}")
        if self.normal_map_convention not in NORMAL_MAP_CONVENTIONS:
            raise MeshError(f"normal map convention: {self.normal_map_convention!r:.40} is not one of "
                            f"{', '.join(NORMAL_MAP_CONVENTIONS)}")
        _pair("uv_scale", self.uv_scale, UV_SCALE_RANGE_MM)
        _pair("map_size_mm", self.map_size_mm, MAP_SIZE_RANGE_MM)
        if self.height_scale_mm is not None and self.height_scale_mm not in HEIGHT_SCALE_RANGE_MM:
            raise MeshError(f"height scale: expected {HEIGHT_SCALE_RANGE_MM.expect()}, got {self.height_scale_mm!r}")
        if self.mesh_texels is not None and self.mesh_texels not in MESH_TEXELS_RANGE:
            raise MeshError(f"mesh_texels: expected {MESH_TEXELS_RANGE.expect()}, got {self.mesh_texels!r}")
        if self.normal_map is not None and self.height_map is not None:
            raise MeshError("maps: give a normal map or a height map, not both (they draw the same detail)")
        if self.hires_mesh is not None and (self.normal_map is not None or self.height_map is not None):
            raise MeshError("maps: a high-resolution mesh is baked into the map itself; give it without a "
                            "normal or height map")
        if self.hires_mesh is not None and self.bake == "vertex":
            raise MeshError("bake 'vertex': takes a normal or height map; a high-resolution mesh is baked per texel")


@dataclass(frozen=True)
class UVScale:
    """A UV scale and the rule that chose it.

    Attributes
    ----------
    su, sv
        Mm per UV unit along u and v.
    rule
        Why, in words.
    spread
        ``(p10, p90)`` of the edges' mm per UV unit (NaN when given).
    """

    su: float
    sv: float
    rule: str
    spread: tuple[float, float] = (math.nan, math.nan)

    @property
    def pair(self) -> tuple[float, float]:
        """``(su, sv)``."""
        return self.su, self.sv

    def __str__(self) -> str:
        amount = f"{self.su:.4g}" if math.isclose(self.su, self.sv, rel_tol=1e-3) else f"{self.su:.4g} x {self.sv:.4g}"
        return f"{amount} mm per UV unit ({self.rule})"


def detect_uv_scale(vertices: NDArray[np.float64], faces: NDArray[np.int64], uv: NDArray[np.float64], *,
                    units: Any = "mm") -> UVScale:
    """The UV scale of a mesh's own UVs: a length unit they are in, else their edges' median stretch.

    UVs that are lengths (a CAD tool's sewing pattern, a simulator's panels):
    the median ratio of 3-D to UV edge length, in mm, is a unit of
    :data:`cdbrdf.mesh.UNITS_MM` (the mesh's own first) within
    :data:`UV_UNIT_TOLERANCE`; the scale is then that unit exactly. Else
    (UVs normalised to a texture) it is the median ratio along u (of the
    edges running mostly along u) and along v.

    Parameters
    ----------
    vertices, faces, uv
        The mesh (positions in ``units``).
    units
        The mesh's unit.

    Returns
    -------
    UVScale
        The scale and its rule.
    """
    u = parse_units(units)
    e = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    d3 = np.linalg.norm(vertices[e[:, 1]] - vertices[e[:, 0]], axis=1) * u.mm_per_unit
    duv = uv[e[:, 1]] - uv[e[:, 0]]
    luv = np.linalg.norm(duv, axis=1)
    ok = (luv > 1e-12) & np.isfinite(luv) & (d3 > 0)
    if ok.sum() < 3:
        raise MeshError("UV scale: the mesh's UVs give no scale (degenerate UVs); give the UV scale")
    ratio = d3[ok] / luv[ok]
    along_u = np.abs(duv[ok, 0]) >= 0.9 * luv[ok]
    along_v = np.abs(duv[ok, 1]) >= 0.9 * luv[ok]
    med = float(np.median(ratio))
    su = float(np.median(ratio[along_u])) if along_u.sum() >= 3 else med
    sv = float(np.median(ratio[along_v])) if along_v.sum() >= 3 else med
    spread = (float(np.percentile(ratio, 10)), float(np.percentile(ratio, 90)))
    names = [u.name] + [k for k in UNITS_MM if k != u.name] if u.name in UNITS_MM else list(UNITS_MM)
    for name in names:
        mm = UNITS_MM[name]
        if all(abs(s / mm - 1.0) <= UV_UNIT_TOLERANCE for s in (su, sv, med)):
            own = " (the mesh's unit)" if name == u.name else ""
            return UVScale(mm, mm, f"the UVs are lengths in {name}{own}: the UV and 3-D lengths of the edges "
                                   f"agree (median {med / mm:.3f} {name} per UV unit)", spread)
    return UVScale(su, sv, "from the mesh's edges: their median 3-D length per UV length", spread)


def mesh_uv_scale(mesh: Mesh) -> UVScale:
    """The UV scale of a prepared mesh's UVs: the one its maps were laid at, else detected (:func:`detect_uv_scale`).

    Parameters
    ----------
    mesh
        A mesh with UVs, as :func:`cdbrdf.mesh.prepare_mesh` made it (its
        ``metadata["uv_scale"]`` and ``"uv_scale_rule"`` when it has maps or
        was given a UV scale).

    Returns
    -------
    UVScale
        The scale and its rule.

    Raises
    ------
    MeshError
        For a mesh without UVs, or UVs that give no scale.
    """
    meta = mesh.metadata
    if meta.get("uv_scale") is not None:
        su, sv = as_uv_scale(meta["uv_scale"])
        return UVScale(su, sv, str(meta.get("uv_scale_rule", "given")))
    if mesh.uv is None:
        raise MeshError("UV scale: the mesh has no UV coordinates")
    return detect_uv_scale(mesh.vertices, mesh.faces, mesh.uv, units=meta.get("units", "mm"))


def _file_maps(maps: SurfaceMaps, meta: dict[str, Any], notes: list[str], name: str) -> dict[str, Any]:
    """The maps to use (given, else the file's) with their transform, height scale and what they are.

    A map the mesh file names is read here: one that cannot be used (damaged, not an image, beyond the image
    limits) is a warning naming the mesh, the map and why (:func:`~cdbrdf.mesh.normalmap.unusable_map`), and the
    mesh is shaded without it. A map given by the user is read later and its errors raised.
    """
    got: dict[str, Any] = {"transform": None}
    if maps.normal_map is not None:
        got["normal"] = maps.normal_map
    elif maps.height_map is not None:
        got["height"] = maps.height_map
    elif maps.hires_mesh is not None:
        got["mesh"] = maps.hires_mesh
    if maps.from_file and not any(k in got for k in ("normal", "height", "mesh")):
        if meta.get("normal_map") is not None:
            got["normal"] = meta["normal_map"]
        elif meta.get("height_map") is not None:
            got["height"] = meta["height_map"]
        got["transform"] = meta.get("map_transform")
        got["bm"] = meta.get("height_scale")
        for key in ("normal", "height"):
            if isinstance(got.get(key), (str, PathLike)):
                _read_file_map(maps, got, key, notes, name)
    elif isinstance(got.get("height"), (str, PathLike)):  # the user's: an RGB normal map is said; errors raised
        _read_file_map(maps, got, "height", notes, name, given=True)
    return got


def _read_file_map(maps: SurfaceMaps, got: dict[str, Any], key: str, notes: list[str], name: str, *,
                   given: bool = False) -> None:
    """Read the map a mesh file names (or the user's height map, ``given``) into ``got`` (a bump map that is an
    RGB normal map becomes the normal map it is, said); one the mesh names that cannot be used is dropped with a
    warning, the user's raises."""
    from ..errors import CDBRDFError
    from ..images import read_image
    from .bake import height_map_from_values
    from .normalmap import normal_map_from_image, unusable_map

    path = str(got[key])
    try:
        px, info = read_image(path)
        if key == "normal":
            got["normal"] = normal_map_from_image(px, info, convention=maps.normal_map_convention, name=path)
            return
        v = px.astype(np.float64) / float(info.max_code or 1.0)
        if v.ndim == 3 and v.shape[2] >= 3:
            mean = v[..., :3].reshape(-1, 3).mean(axis=0)
            if abs(mean[0] - 0.5) < 0.1 and abs(mean[1] - 0.5) < 0.1 and mean[2] > 0.75:  # an MTL bump that is RGB
                notes.append(f"{path}: named as a bump map, it is an RGB normal map (mean "
                             f"{mean[0]:.2f}, {mean[1]:.2f}, {mean[2]:.2f}): used as a normal map")
                got["normal"] = normal_map_from_normals(2.0 * v[..., :3] - 1.0, convention=maps.normal_map_convention,
                                                        name=path)
                del got["height"]
                return
        got["height"] = height_map_from_values(v, name=path)
    except (CDBRDFError, OSError) as exc:
        if given:
            raise
        why = " ".join(str(exc).removeprefix(f"{path}: ").split())
        what = "normal map" if key == "normal" else "height map"
        unusable_map(notes, f"{name}: the {what} {path} its material names cannot be used ({why})")
        del got[key]


def _size_transform(maps: SurfaceMaps, uvs: UVScale, transform: Any) -> tuple[float, float, float, float] | None:
    size = _pair("map_size_mm", maps.map_size_mm)
    if size is None:
        return None if transform is None else tuple(float(x) for x in transform)  # type: ignore[return-value]
    return uvs.su / size[0], uvs.sv / size[1], 0.0, 0.0


def _bake(maps: SurfaceMaps, got: dict[str, Any], mesh: Mesh, uvs: UVScale, nb: float, name: str) -> CurvatureMap:
    """The curvature map of the chosen source."""
    tr = _size_transform(maps, uvs, got.get("transform"))
    if "normal" in got:
        nm = got["normal"]
        nm = nm if isinstance(nm, NormalMap) else read_normal_map(nm, convention=maps.normal_map_convention)
        return bake_normal_map(nm, transform=tr)
    if "height" in got:
        hm = got["height"]
        hm = hm if isinstance(hm, HeightMap) else read_height_map(hm)
        scale = maps.height_scale_mm
        if scale is None and got.get("bm") is not None:
            scale = float(got["bm"]) * parse_units(mesh.metadata.get("units", "mm")).mm_per_unit
        if scale is None:
            raise MeshError(f"{hm.name}: a height map needs its height scale (mm per unit of its values): give "
                            "--height-scale MM, or -bm in the MTL")
        return bake_height_map(hm, height_scale_mm=scale, uv_scale=uvs.pair, transform=tr)
    from .io import read_mesh

    high = got["mesh"] if isinstance(got["mesh"], Mesh) else read_mesh(got["mesh"])
    label = str(high.metadata.get("source", got["mesh"] if not isinstance(got["mesh"], Mesh) else "high mesh"))
    return bake_mesh(high, mesh, uv_scale=uvs.pair, neighbourhood_mm=nb, texels=maps.mesh_texels, name=label)


def _check(cmap: CurvatureMap, uvs: UVScale, nb: float, kappa_range: tuple[float, float] | None,
           notes: list[str]) -> float:
    """One note of what the map adds, or one warning that it does nothing and what to change; its finest level."""
    lv = neighbourhood_level(cmap, uvs.pair, nb)
    tu, tv = cmap.tile_mm(uvs.pair)
    vals = cmap.levels[min(int(math.ceil(lv)), cmap.n_levels - 1)]
    _, _, kxx, kxy, kyy = shape_operator(vals, uvs.pair)
    k = np.abs(principal(kxx, kxy, kyy))
    kmax, krms = float(k.max()), float(np.sqrt(np.mean(k * k)))
    w, h = cmap.texels
    notes.append(f"{cmap.name}: {cmap.source}, {w} x {h} texels, one repeat per {tu:.4g} x {tv:.4g} mm; its curvature "
                 f"at the {nb:g} mm neighbourhood: up to {kmax:.3g} 1/mm (rms {krms:.3g})")
    top = max(abs(kappa_range[0]), abs(kappa_range[1])) if kappa_range is not None else None
    least = NOTHING_LEFT_SHARE * 0.5 * top if top else 0.01
    share = averaged_share(cmap, lv)
    msg = None
    if krms < least:
        if share < NOTHING_LEFT_SHARE:
            why = (f"it repeats every {tu:.3g} x {tv:.3g} mm and {1 - share:.0%} of its curvature averages out within "
                   f"the curvature's {nb:g} mm neighbourhood, the scale the table describes (finer detail is in the "
                   "table already)")
            fix = ("if one repeat of the map covers more, give its size (--map-size MM, SurfaceMaps(map_size_mm=...))"
                   if "lengths" in uvs.rule else
                   "if the map covers more, give its size (--map-size MM) or the UV scale (--uv-scale)")
        else:
            why = f"its folds are shallow: their curvature is at most {kmax:.3g} 1/mm"
            fix = "check " + ("its height scale and " if cmap.source == "height map" else "") + "the UV scale"
        msg = f"{cmap.name}: does nothing at {uvs}: {why} (rms {krms:.2g} 1/mm, under {least:.2g}); {fix}"
    elif top and krms > 5 * top:
        msg = (f"{cmap.name}: its curvature (rms {krms:.3g} 1/mm) is far beyond the table's range "
               f"[{kappa_range[0]:g}, {kappa_range[1]:g}] 1/mm and is clamped there: check "  # type: ignore[index]
               + ("its height scale and " if cmap.source == "height map" else "") + f"the UV scale ({uvs})")
    if msg is not None:
        _LOG.warning("%s", msg)
        notes.append(msg)
    return lv


def _vertex_bake(cmap: CurvatureMap, mesh: Mesh, uvs: UVScale, level: float, notes: list[str]) -> dict[str, Any]:
    """The map sampled at the vertices (at the neighbourhood's level), added to their shape operator."""
    assert mesh.uv is not None
    g = lookup(cmap, mesh.uv[:, 0], mesh.uv[:, 1], level)
    _, _, kxx, kxy, kyy = shape_operator(g, uvs.pair)
    sxx = mesh.attributes[SHAPE_ATTRIBUTES[0]] + kxx
    sxy = mesh.attributes[SHAPE_ATTRIBUTES[1]] + kxy
    syy = mesh.attributes[SHAPE_ATTRIBUTES[2]] + kyy
    s = cmap.stats()
    i = min(int(round(level)), cmap.n_levels - 1)
    k_rms = math.hypot(s[f"du{i}"] / uvs.su, s[f"dv{i}"] / uvs.sv)
    fold = 2 * math.pi * s[f"slope{i}"] / k_rms if k_rms > 0 else math.inf
    f = mesh.faces
    scale = parse_units(mesh.metadata.get("units", "mm")).mm_per_unit
    edge = float(np.median(np.linalg.norm(mesh.vertices[f[:, [1, 2, 0]]] - mesh.vertices[f], axis=2))) * scale
    if edge > fold / SAMPLES_PER_FOLD:
        notes.append(f"the mesh (median edge {edge:.3g} mm) is coarse for {cmap.name}'s folds (about {fold:.3g} mm "
                     f"long): baked per vertex, they are sampled sparsely; bake per texel (the default) or "
                     f"subdivide the mesh to {fold / SAMPLES_PER_FOLD:.2g} mm edges")
    return {CURVATURE_MODES["max"].attribute: principal(sxx, sxy, syy), CURVATURE_MODES["directional"].attribute: sxx,
            **dict(zip(SHAPE_ATTRIBUTES, (sxx, sxy, syy), strict=True))}


def apply_maps(mesh: Mesh, maps: SurfaceMaps | None, *, name: str = "mesh",
               kappa_range: tuple[float, float] | None = None) -> Mesh:
    """A prepared mesh with its maps: baked per texel (``metadata["curvature_map"]``) or added per vertex.

    Parameters
    ----------
    mesh
        A mesh as :func:`cdbrdf.mesh.prepare_mesh` made it (its own UVs, the
        shape-operator attributes, ``metadata["neighbourhood_mm"]``).
    maps
        What to apply (None: the maps the file names, baked per texel).
    name
        The mesh, for messages.
    kappa_range
        The table's, for the check of a map's curvature.

    Returns
    -------
    Mesh
        ``mesh`` itself when there is no map; else a copy with
        ``metadata["uv_scale"]`` (``(su, sv)``), ``"uv_scale_rule"``, and
        ``"curvature_map"`` (texel) or changed curvature attributes (vertex),
        and notes.
    """
    maps = maps if maps is not None else SurfaceMaps()
    notes: list[str] = list(mesh.metadata.get("notes", []))
    got = _file_maps(maps, mesh.metadata, notes, name)
    if not any(k in got for k in ("normal", "height", "mesh")):
        if maps.uv_scale is None:
            if len(notes) == len(mesh.metadata.get("notes", [])):
                return mesh
            out = mesh.copy()  # a map the file names could not be used: said
            out.metadata["notes"] = notes
            return out
    if mesh.uv is None or mesh.metadata.get("frame", "uv") != "uv":
        what = "a UV scale" if not any(k in got for k in ("normal", "height", "mesh")) else "a map"
        raise MeshError(f"{name}: {what} needs the mesh's own UV coordinates (frame 'uv')")
    if any(k not in mesh.attributes for k in SHAPE_ATTRIBUTES):
        raise MeshError(f"{name}: maps need the mesh's shape operator (prepare it with cdbrdf.mesh.prepare_mesh)")
    given = _pair("uv_scale", maps.uv_scale)
    uvs = UVScale(*given, "given") if given is not None else detect_uv_scale(
        mesh.vertices, mesh.faces, mesh.uv, units=mesh.metadata.get("units", "mm"))
    out = mesh.copy()
    notes.append(f"UV scale: {uvs}")
    if not math.isnan(uvs.spread[0]) and uvs.spread[1] > 1.5 * uvs.spread[0]:
        notes.append(f"the UV layout stretches ({uvs.spread[0]:.3g} to {uvs.spread[1]:.3g} mm per UV unit over 80 % "
                     "of the edges): the maps are laid at one scale")
    out.metadata.update({"uv_scale": uvs.pair, "uv_scale_rule": uvs.rule})
    if any(k in got for k in ("normal", "height", "mesh")):
        nb = float(mesh.metadata.get("neighbourhood_mm", 5.0))
        cmap = _bake(maps, got, mesh, uvs, nb, name)
        if cmap.uv_scale is not None and not np.allclose(cmap.uv_scale, uvs.pair, rtol=1e-6):
            raise MeshError(f"{cmap.name}: baked at {cmap.uv_scale} mm per UV unit, not the mesh's {uvs.pair}")
        level = _check(cmap, uvs, nb, kappa_range, notes)
        cmap = cmap.coarser(int(level))  # the levels finer than the neighbourhood's are never read
        level -= int(level)
        if maps.bake == "vertex":
            out.attributes.update(_vertex_bake(cmap, mesh, uvs, level, notes))
            notes.append(f"{cmap.name}: baked per vertex (its curvature added at the vertices; it does not shade)")
        else:
            out.metadata["curvature_map"] = cmap
    out.metadata["notes"] = notes
    return out
