"""A table on a surface as one glTF 2.0 asset: ``cdbrdf export TABLE -o OUT.glb``.

:func:`export_gltf` writes a ``.glb`` (or a self-contained ``.gltf``) holding

- the surface as one indexed triangle mesh, as the renderer sees it
  (:func:`cdbrdf.mesh.prepare_mesh`: repaired, welded, its curvature fitted;
  turned upright by :func:`cdbrdf.mesh.z_up_mesh`), in glTF's frame: metres,
  +Y up (the z-up world's ``(x, y, z)`` is glTF's ``(x, z, -y)``), with
  ``NORMAL``, ``TANGENT`` (MikkTSpace where the mesh has UVs of its own,
  :mod:`cdbrdf.export.tangents`; else the material's x axis the renderer
  uses, ``w = 1``), ``TEXCOORD_0`` (glTF's v runs down: ``1 - v``) and the
  custom attribute ``_CURVATURE``: the signed curvature the lookup reads,
  1/mm (> 0 convex), one value per vertex; with ``curvature_mode =
  "directional"`` also ``_CURVATURE_DIRECTION``, the unit direction it was
  measured along (the material's x axis);
- a material whose standard part is the flat BRDF's fit
  (:mod:`cdbrdf.export.fallback`: base colour, roughness,
  ``KHR_materials_sheen``, ``KHR_materials_anisotropy`` where it helps) and
  whose extension ``CDBRDF_materials_curvature_brdf`` holds the table
  (:mod:`cdbrdf.gltf_table`: a 16-bit lookup texture, the measured mask, the
  axes, the encoding and its error, the fallback's error).

The asset is written atomically (:func:`cdbrdf.fsutil.atomic_path`).
``docs/export.md`` specifies the extension and what engines need to adopt it.
"""

from __future__ import annotations

import base64
import json
import logging
import warnings
from collections.abc import Mapping
from dataclasses import dataclass, field
from os import PathLike
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..errors import OptionError
from ..gltf_table import EXTENSION, encode_curvature_map, encode_table
from ..mesh.attributes import SHAPE_ATTRIBUTES
from ..mesh.curvature_map import neighbourhood_level
from .fallback import FallbackFit, fit_fallback
from .tangents import any_tangent, mikktspace_tangents

__all__ = ["GLTF_SUFFIXES", "CURVATURE_ATTRIBUTE", "DIRECTION_ATTRIBUTE", "SHAPE_ATTRIBUTE", "ExportedMesh",
           "GltfAsset", "export_mesh", "build_gltf", "write_gltf", "export_gltf"]

_LOG = logging.getLogger(__name__)

#: Output suffixes: binary glTF, or JSON glTF with its buffer as a data URI.
GLTF_SUFFIXES: tuple[str, ...] = (".glb", ".gltf")

#: The custom vertex attribute of the signed curvature (1/mm).
CURVATURE_ATTRIBUTE = "_CURVATURE"

#: The custom vertex attribute of the direction the directional curvature is measured along.
DIRECTION_ATTRIBUTE = "_CURVATURE_DIRECTION"

#: The custom vertex attribute of the mesh's shape operator (with a curvature map): xx, xy, yy in 1/mm.
SHAPE_ATTRIBUTE = "_CURVATURE_SHAPE"

# z-up world (mm) -> glTF (+Y up): (x, y, z) -> (x, z, -y), a rotation
_TO_GLTF = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])

_FLOAT, _UINT16, _UINT32 = 5126, 5123, 5125
_ARRAY_BUFFER, _ELEMENT_ARRAY_BUFFER = 34962, 34963
_NEAREST, _CLAMP = 9728, 33071


@dataclass(frozen=True)
class ExportedMesh:
    """A surface ready for the asset: welded, z-up world, mm (:func:`export_mesh`).

    Attributes
    ----------
    positions, normals
        ``(n, 3)`` float64, mm and unit vectors, z up.
    tangents
        ``(n, 4)``: unit material x axis (``xyz``) and handedness ``w``.
    uv
        ``(n, 2)`` the mesh's own UVs (v up), or None.
    faces
        ``(m, 3)`` triangles.
    attributes
        Per-vertex arrays by the mesh's names (``"curvature"``, ``"curvature_dir"``, 1/mm).
    direction
        ``(n, 3)`` the unit direction the directional curvature is measured along.
    name
        The surface's name.
    info
        What was done (units, up axis, neighbourhood), for the asset's ``extras``.
    metadata
        The prepared mesh's metadata (repairs, notes, units and neighbourhood notes, frame), for the report.
    curvature_map
        The maps' curvature baked per texel (:class:`cdbrdf.mesh.CurvatureMap`), or None.
    uv_scale
        Mm per UV unit of the map, ``(su, sv)``, or None.
    """

    positions: NDArray[np.float64]
    normals: NDArray[np.float64]
    tangents: NDArray[np.float64]
    uv: NDArray[np.float64] | None
    faces: NDArray[np.int64]
    attributes: Mapping[str, NDArray[np.float64]]
    direction: NDArray[np.float64]
    name: str
    info: Mapping[str, Any] = field(default_factory=dict)
    metadata: Mapping[str, Any] = field(default_factory=dict)
    curvature_map: Any = None
    uv_scale: tuple[float, float] | None = None

    @property
    def n_vertices(self) -> int:
        """Number of vertices."""
        return int(self.positions.shape[0])


def _unit_rows(a: NDArray[np.float64]) -> NDArray[np.float64]:
    n = np.linalg.norm(a, axis=1, keepdims=True)
    return a / np.where(n > 0, n, 1.0)


def _weld(mesh: Any) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """The vertices identical in position and normal merged: ``(first vertex of each, new faces)``."""
    key = np.concatenate([mesh.vertices, mesh.normals], axis=1)
    _, first, inverse = np.unique(key, axis=0, return_index=True, return_inverse=True)
    return first, inverse.reshape(-1)[mesh.faces]


def _builtin(surface: Any) -> Any:
    """The built-in surface's mesh (the sine sheet or the swatch), or None."""
    from ..mesh import SineSheet, Swatch, sine_sheet_mesh, swatch_mesh

    if isinstance(surface, SineSheet) or (isinstance(surface, str) and surface == "sine"):
        m = sine_sheet_mesh(surface if isinstance(surface, SineSheet) else SineSheet())
        m.metadata["source"] = "sine sheet"
        return m
    if isinstance(surface, Swatch) or (isinstance(surface, str) and surface == "swatch"):
        return swatch_mesh(surface if isinstance(surface, Swatch) else Swatch())
    return None


def export_mesh(surface: Any, *, table: Any = None, maps: Any = None) -> ExportedMesh:
    """A surface made ready for the asset (see the module's description).

    The maps laid on the mesh (:class:`cdbrdf.mesh.SurfaceMaps`: given, or
    those the file names) are baked as the renderer bakes them: per texel
    (the default), carried as the curvature map's texture with the mesh's
    shape operator (``_CURVATURE_SHAPE``), or per vertex (``bake="vertex"``),
    added into ``_CURVATURE`` at the mesh's resolution.

    Parameters
    ----------
    surface
        ``"sine"`` or ``"swatch"`` (the built-in scenes, :data:`cdbrdf.render.spec.SCENES`),
        a :class:`~cdbrdf.mesh.SineSheet` or :class:`~cdbrdf.mesh.Swatch`, a
        :class:`~cdbrdf.mesh.MeshSurface` (a mesh with its unit, neighbourhood,
        frame and up axis, as :func:`cdbrdf.render.render_table` takes it), or
        a :class:`~cdbrdf.mesh.Mesh` or mesh file (``MeshSurface(mesh)``).
    table
        The table: its kappa range checks the curvature, its provenance gives
        the default neighbourhood (:func:`cdbrdf.mesh.prepare_mesh`).
    maps
        A :class:`cdbrdf.mesh.SurfaceMaps` of the mesh.

    Returns
    -------
    ExportedMesh
        The mesh.

    Raises
    ------
    OptionError
        For maps given with a built-in surface.
    MeshError
        For a mesh that cannot be used.
    """
    from ..mesh import MeshSurface, has_own_uv, z_up_mesh
    from ..mesh.frames import face_uv_tangents, vertex_tangents
    from ..mesh.units import parse_units

    built = _builtin(surface)
    if built is not None:
        if maps is not None:
            raise OptionError(f"maps: only for a mesh (the {built.metadata.get('source', surface)} "
                              "is in mm, z up, with its analytic curvature)")
        world, name = built, str(built.metadata.get("source", surface))
        info: dict[str, Any] = {"units": "mm", "up": "z", "curvature": "analytic"}
    else:
        s = surface if isinstance(surface, MeshSurface) else MeshSurface(surface)
        name = Path(s.mesh).name if isinstance(s.mesh, str | PathLike) else s.name
        mesh = s.prepare(table=table, maps=maps)
        world, axis, why = z_up_mesh(mesh, s.up)
        info = {"units": mesh.metadata.get("units"), "up": axis, "up_reason": why,
                "neighbourhood_mm": mesh.metadata.get("neighbourhood_mm"), "frame": mesh.metadata.get("frame"),
                "repairs": list(mesh.metadata.get("repairs", []))}
        if "outside_share" in mesh.metadata:
            info["outside_share"] = float(mesh.metadata["outside_share"])
    mm = float(parse_units(world.metadata.get("units", "mm")).mm_per_unit)
    normals = _unit_rows(np.asarray(world.normals, dtype=np.float64))
    own = has_own_uv(world) and world.uv is not None
    if own:
        tang, src, faces = mikktspace_tangents(world.vertices, normals, world.uv, world.faces)
        uv = np.asarray(world.uv, dtype=np.float64)[src]
        # the direction the renderer measures the directional curvature along: dP/du of the UV map
        ft, ok = face_uv_tangents(world.vertices, world.faces, np.asarray(world.uv, dtype=np.float64))
        direction = vertex_tangents(world.faces, ft, ok.astype(np.float64), normals)[src]
    else:  # per-face UVs prepare_mesh made carry the frame (one vertex per corner): welded again
        first, faces = _weld(world)
        src, uv = first, None
        direction = np.full((first.size, 3), np.nan)
        if world.uv is not None:
            ft, ok = face_uv_tangents(world.vertices, world.faces, np.asarray(world.uv, dtype=np.float64))
            direction = vertex_tangents(faces, ft, ok.astype(np.float64), normals[first])
        tang = np.concatenate([direction, np.ones((first.size, 1))], axis=1)
    n_src = normals[src]
    bad = ~np.isfinite(direction).all(axis=1)
    direction[bad] = any_tangent(n_src[bad])
    bad = ~np.isfinite(tang[:, :3]).all(axis=1)
    tang[bad, :3] = any_tangent(n_src[bad])
    attrs = {k: np.asarray(a, dtype=np.float64)[src] for k, a in world.attributes.items()}
    return ExportedMesh(positions=np.asarray(world.vertices, dtype=np.float64)[src] * mm, normals=n_src,
                        tangents=tang, uv=uv, faces=np.asarray(faces, dtype=np.int64), attributes=attrs,
                        direction=_unit_rows(direction), name=name, info=info, metadata=dict(world.metadata),
                        curvature_map=world.metadata.get("curvature_map"),
                        uv_scale=_pair(world.metadata.get("uv_scale")))


def _pair(value: Any) -> tuple[float, float] | None:
    """Two numbers as a pair of floats, or None."""
    return None if value is None else (float(value[0]), float(value[1]))


@dataclass(frozen=True)
class GltfAsset:
    """The asset :func:`build_gltf` made.

    Attributes
    ----------
    document
        The glTF JSON (a dict) with one buffer (no URI: the GLB's binary chunk).
    blob
        The buffer's bytes.
    fallback
        The standard material's fit.
    encoding_error
        The lookup texture's quantisation errors (:func:`cdbrdf.gltf_table.encode_table`).
    """

    document: dict[str, Any]
    blob: bytes
    fallback: FallbackFit
    encoding_error: Mapping[str, float]

    def glb(self) -> bytes:
        """The asset as binary glTF (written by pygltflib).

        Returns
        -------
        bytes
            The ``.glb`` file.
        """
        from pygltflib import GLTF2

        with warnings.catch_warnings():  # dataclasses_json warns of the fields glTF leaves out (an image's uri)
            warnings.simplefilter("ignore")
            doc = GLTF2.from_dict(self.document)
        doc.set_binary_blob(self.blob)
        out = doc.save_to_bytes()
        return b"".join(out) if isinstance(out, list) else bytes(out)

    def gltf_json(self) -> bytes:
        """The asset as one JSON glTF file, its buffer a base64 data URI.

        Returns
        -------
        bytes
            The ``.gltf`` file.
        """
        doc = json.loads(json.dumps(self.document))
        doc["buffers"][0]["uri"] = "data:application/octet-stream;base64," + base64.b64encode(self.blob).decode("ascii")
        return (json.dumps(doc, separators=(",", ":"), allow_nan=False) + "\n").encode("utf-8")


class _Buffer:
    """The one buffer: views appended 4-byte aligned, accessors and views in glTF's JSON."""

    def __init__(self) -> None:
        self.parts: list[bytes] = []
        self.size = 0
        self.views: list[dict[str, Any]] = []
        self.accessors: list[dict[str, Any]] = []

    def view(self, data: bytes, target: int | None = None) -> int:
        pad = (-self.size) % 4
        if pad:
            self.parts.append(b"\0" * pad)
            self.size += pad
        v: dict[str, Any] = {"buffer": 0, "byteOffset": self.size, "byteLength": len(data)}
        if target is not None:
            v["target"] = target
        self.views.append(v)
        self.parts.append(data)
        self.size += len(data)
        return len(self.views) - 1

    def accessor(self, a: NDArray[Any], kind: str, *, index: bool = False, bounds: bool = False) -> int:
        if index:
            ctype, arr = (_UINT16, a.astype("<u2")) if a.max(initial=0) < 65535 else (_UINT32, a.astype("<u4"))
        else:
            ctype, arr = _FLOAT, np.ascontiguousarray(a, dtype="<f4")
        view = self.view(arr.tobytes(), _ELEMENT_ARRAY_BUFFER if index else _ARRAY_BUFFER)
        count = int(arr.shape[0] if arr.ndim > 1 else arr.size)
        acc: dict[str, Any] = {"bufferView": view, "componentType": ctype, "count": count, "type": kind}
        if bounds:
            flat = arr.reshape(acc["count"], -1).astype(np.float64)
            acc["min"] = [float(x) for x in flat.min(axis=0)]
            acc["max"] = [float(x) for x in flat.max(axis=0)]
        self.accessors.append(acc)
        return len(self.accessors) - 1

    def blob(self) -> bytes:
        out = b"".join(self.parts)
        return out + b"\0" * ((-len(out)) % 4)


def _material(table: Any, fit: FallbackFit, ext: dict[str, Any]) -> tuple[dict[str, Any], list[str]]:
    """The material (fallback + extension) and the extensions it uses."""
    used = ["KHR_materials_sheen", EXTENSION]
    exts: dict[str, Any] = {
        "KHR_materials_sheen": {"sheenColorFactor": [float(c) for c in fit.sheen_color],
                                "sheenRoughnessFactor": float(fit.sheen_roughness)},
    }
    if fit.anisotropy_strength > 0:
        used.insert(1, "KHR_materials_anisotropy")
        exts["KHR_materials_anisotropy"] = {"anisotropyStrength": float(fit.anisotropy_strength),
                                            "anisotropyRotation": float(fit.anisotropy_rotation)}
    exts[EXTENSION] = ext
    mat = {
        "name": str(table.attrs.get("material") or "cdbrdf"),
        "pbrMetallicRoughness": {"baseColorFactor": [*(float(c) for c in fit.base_color), 1.0],
                                 "metallicFactor": 0.0, "roughnessFactor": float(fit.roughness)},
        "doubleSided": True,
        "extensions": exts,
    }
    return mat, used


def build_gltf(table: Any, mesh: ExportedMesh, *, curvature_mode: str = "max",
               fallback: FallbackFit | None = None) -> GltfAsset:
    """The glTF asset of a table on a prepared surface (see the module's description).

    Parameters
    ----------
    table
        A :class:`~cdbrdf.CDBRDF` (RGB or grey).
    mesh
        The surface (:func:`export_mesh`).
    curvature_mode
        ``"max"`` (the paper's) or ``"directional"``: the curvature in ``_CURVATURE``.
    fallback
        The standard material; default: fitted (:func:`cdbrdf.export.fallback.fit_fallback`).

    Returns
    -------
    GltfAsset
        The asset.

    Raises
    ------
    OptionError
        For an unknown curvature mode.
    FormatError
        For a table the lookup texture cannot hold (:func:`cdbrdf.gltf_table.encode_table`).
    """
    from .._version import __version__
    from ..mesh import curvature_mode as _mode

    mode = _mode(curvature_mode)
    lut = encode_table(table)
    fit = fit_fallback(table) if fallback is None else fallback
    buf = _Buffer()
    pos = mesh.positions @ _TO_GLTF.T / 1000.0
    attrs: dict[str, int] = {
        "POSITION": buf.accessor(pos, "VEC3", bounds=True),
        "NORMAL": buf.accessor(_unit_rows(mesh.normals @ _TO_GLTF.T), "VEC3"),
        "TANGENT": buf.accessor(np.concatenate([_unit_rows(mesh.tangents[:, :3] @ _TO_GLTF.T),
                                                np.where(mesh.tangents[:, 3:] < 0, -1.0, 1.0)], axis=1), "VEC4"),
    }
    if mesh.uv is not None:
        attrs["TEXCOORD_0"] = buf.accessor(np.stack([mesh.uv[:, 0], 1.0 - mesh.uv[:, 1]], axis=1), "VEC2")
    kappa = np.asarray(mesh.attributes[mode.attribute], dtype=np.float64)
    attrs[CURVATURE_ATTRIBUTE] = buf.accessor(np.nan_to_num(kappa), "SCALAR", bounds=True)
    curv: dict[str, Any] = {"attribute": CURVATURE_ATTRIBUTE, "mode": mode.name, "units": "1/mm"}
    if mode.name == "directional":
        attrs[DIRECTION_ATTRIBUTE] = buf.accessor(_unit_rows(mesh.direction @ _TO_GLTF.T), "VEC3")
        curv["directionAttribute"] = DIRECTION_ATTRIBUTE
    if isinstance(mesh.info.get("neighbourhood_mm"), (int, float)):
        curv["neighbourhoodMm"] = float(mesh.info["neighbourhood_mm"])
    indices = buf.accessor(mesh.faces.reshape(-1), "SCALAR", index=True)
    images = [{"bufferView": buf.view(lut.png), "mimeType": "image/png", "name": "cdbrdf lookup"},
              {"bufferView": buf.view(lut.measured_png), "mimeType": "image/png", "name": "cdbrdf measured mask"}]
    textures = [{"sampler": 0, "source": 0, "name": "cdbrdf lookup"}]
    if mesh.curvature_map is not None and mesh.uv is not None and mesh.uv_scale is not None:
        attrs[SHAPE_ATTRIBUTE] = buf.accessor(np.stack([np.nan_to_num(mesh.attributes[k]) for k in SHAPE_ATTRIBUTES],
                                                       axis=1), "VEC3")
        curv["shapeAttribute"] = SHAPE_ATTRIBUTE
        cmap = mesh.curvature_map
        cm = encode_curvature_map(cmap.levels, transform=cmap.transform, uv_scale=mesh.uv_scale,
                                  min_level=neighbourhood_level(cmap, mesh.uv_scale,
                                                                float(mesh.info.get("neighbourhood_mm") or 5.0)))
        for j, png in enumerate(cm.pngs):
            images.append({"bufferView": buf.view(png), "mimeType": "image/png", "name": f"cdbrdf curvature map {j}"})
            textures.append({"sampler": 0, "source": len(images) - 1, "name": f"cdbrdf curvature map {j}"})
        curv["map"] = {"textures": [{"index": len(textures) - 2}, {"index": len(textures) - 1}], **cm.spec}
    ext = dict(lut.spec)
    ext["lookup"] = {"texture": {"index": 0}, **ext["lookup"]}
    ext["measuredImage"] = 1
    ext["curvature"] = curv
    ext["fallback"] = {"fittedTo": "the kappa = 0 slice (the flat fabric)",
                       "weighting": "f cos(theta_l), relative to its RMS over the stored directions",
                       **fit.as_json()}
    material, used = _material(table, fit, ext)
    doc: dict[str, Any] = {
        "asset": {"version": "2.0", "generator": f"cdbrdf {__version__}"},
        "extensionsUsed": used,
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0, "name": mesh.name,
                   "extras": {"cdbrdf": dict(mesh.info)}}],
        "meshes": [{"name": mesh.name, "primitives": [{"attributes": attrs, "indices": indices, "material": 0,
                                                       "mode": 4}]}],
        "materials": [material],
        "samplers": [{"magFilter": _NEAREST, "minFilter": _NEAREST, "wrapS": _CLAMP, "wrapT": _CLAMP}],
        "textures": textures,
        "images": images,
        "accessors": buf.accessors,
        "bufferViews": buf.views,
        "buffers": [{"byteLength": 0}],
    }
    blob = buf.blob()
    doc["buffers"][0]["byteLength"] = len(blob)
    json.dumps(doc, allow_nan=False)  # every number finite
    return GltfAsset(document=doc, blob=blob, fallback=fit, encoding_error=lut.spec["lookup"]["encoding"]["error"])


def write_gltf(asset: GltfAsset, path: str | PathLike[str]) -> Path:
    """Write the asset atomically: binary glTF for ``.glb``, one JSON file for ``.gltf``.

    Parameters
    ----------
    asset
        The asset.
    path
        The output file (suffix one of :data:`GLTF_SUFFIXES`).

    Returns
    -------
    pathlib.Path
        The file written.

    Raises
    ------
    OptionError
        For another suffix.
    """
    from ..fsutil import atomic_path

    p = Path(path)
    suffix = p.suffix.lower()
    if suffix not in GLTF_SUFFIXES:
        raise OptionError(f"{p}: the output must end in {' or '.join(GLTF_SUFFIXES)}")
    data = asset.glb() if suffix == ".glb" else asset.gltf_json()
    with atomic_path(p, suffix=suffix) as tmp:
        tmp.write_bytes(data)
    _LOG.info("wrote %s (%d bytes)", p, len(data))
    return p


def export_gltf(
    table: Any,
    surface: Any,
    path: str | PathLike[str],
    *,
    maps: Any = None,
    curvature_mode: str = "max",
) -> GltfAsset:
    """Export a table on a surface as a glTF asset (:func:`export_mesh`, :func:`build_gltf`, :func:`write_gltf`).

    Parameters
    ----------
    table
        A :class:`~cdbrdf.CDBRDF` or a CDBRDF file.
    surface
        As :func:`export_mesh` takes it (a mesh's options in a :class:`~cdbrdf.mesh.MeshSurface`).
    path
        ``OUT.glb`` or ``OUT.gltf``.
    maps
        For a mesh (:func:`export_mesh`).
    curvature_mode
        ``"max"`` or ``"directional"``.

    Returns
    -------
    GltfAsset
        What was written.
    """
    from ..sources import open_source

    if Path(path).suffix.lower() not in GLTF_SUFFIXES:
        raise OptionError(f"{path}: the output must end in {' or '.join(GLTF_SUFFIXES)}")
    tbl = open_source(table).flat
    mesh = export_mesh(surface, table=tbl, maps=maps)
    asset = build_gltf(tbl, mesh, curvature_mode=curvature_mode)
    write_gltf(asset, path)
    return asset
