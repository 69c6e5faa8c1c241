"""Mesh files in and out: PLY, OBJ, glTF/GLB, STL and OFF in; PLY (what Mitsuba reads) out.

Reading (:func:`read_mesh`, chosen by the file's suffix):

- **PLY** with cdbrdf's reader (:mod:`cdbrdf.mesh._ply`): ASCII and binary,
  any scalar types, polygons of any size, triangle strips, per-corner
  ``texcoord`` lists, and the header's ``comment cdbrdf ...`` lines in which
  :func:`write_ply` records the mesh's unit, up axis and how its curvature
  was computed (:func:`ply_metadata` reads them from the header alone);
- **OBJ, glTF/GLB, STL, OFF** through trimesh (``process=False``: nothing
  merged or reordered): every object, group and glTF node (its transform
  applied), polygons triangulated, OBJ's separate ``vt``/``vn`` indices
  resolved into vertices, UVs (glTF: ``TEXCOORD_0`` of primitives with a
  material, v flipped to OBJ's convention by trimesh; the frame uses dP/du,
  which the flip leaves alone) and the file's own normals (not computed
  ones).

Every failure, of any kind, is one :class:`~cdbrdf.errors.MeshError` naming
the file (no warning, no foreign exception); counts a header declares are
checked against the file's size and the ``mesh_faces`` limit before anything
is allocated.

Writing (:func:`write_ply`): binary little-endian PLY, float32 positions,
normals ``nx ny nz``, UVs ``u v``, tangents ``tangent_x ...`` and each
attribute by the names of :mod:`cdbrdf.mesh.attributes` (``NAME`` as the
property ``NAME_x``, which Mitsuba's PLY loader turns into the mesh
attribute ``vertex_NAME``: the curvature ``curvature`` -> ``curvature_x`` ->
``vertex_curvature``).
"""

from __future__ import annotations

import logging
import math
import re
import warnings
from os import PathLike
from pathlib import Path
from typing import Any
from urllib.parse import unquote

import numpy as np
from numpy.typing import NDArray

from ..errors import CDBRDFError, MeshError
from ..limits import check
from .attributes import SHAPE_ATTRIBUTES, SHAPE_PLY_PROPERTIES, attribute_of_ply, ply_property
from .core import Mesh
from .statements import file_statements, header_comments

__all__ = [
    "MESH_FORMATS",
    "Mesh",
    "read_mesh",
    "read_ply",
    "ply_metadata",
    "read_obj",
    "write_ply",
]

_LOG = logging.getLogger(__name__)

#: Mesh file suffixes read by :func:`read_mesh`, and their format.
MESH_FORMATS: dict[str, str] = {
    ".ply": "ply", ".obj": "obj", ".gltf": "gltf", ".glb": "glb", ".stl": "stl", ".off": "off",
}

_UV_NAMES = (("u", "v"), ("s", "t"), ("texture_u", "texture_v"), ("texture_s", "texture_t"))
_TANGENT_NAMES = (("tangent_x", "tangent_y", "tangent_z"), ("tx", "ty", "tz"))
_KNOWN = {"x", "y", "z", "nx", "ny", "nz"} | {n for pair in _UV_NAMES for n in pair} | {
    n for tri in _TANGENT_NAMES for n in tri}


def read_mesh(path: str | PathLike[str]) -> Mesh:
    """Read a mesh file chosen by its suffix (:data:`MESH_FORMATS`).

    Parameters
    ----------
    path
        The file.

    Returns
    -------
    Mesh
        The mesh; its metadata give the format and the file it came from.

    Raises
    ------
    MeshError
        For an unknown suffix or a file that cannot be read as a mesh (the
        message names the file).
    LimitError
        For more faces than the ``mesh_faces`` limit.
    """
    p = Path(path)
    fmt = MESH_FORMATS.get(p.suffix.lower())
    if fmt is None:
        raise MeshError(f"{p}: unknown mesh format {p.suffix.lower()!r}; expected {', '.join(MESH_FORMATS)}")
    mesh = read_ply(p) if fmt == "ply" else _read_trimesh(p, fmt)
    mesh.metadata.setdefault("source", str(p))
    return mesh


def _read_bytes(p: Path) -> bytes:
    from ..fsutil import check_regular

    try:
        check_regular(p)  # a FIFO would block the read, /dev/zero never end it
    except OSError as exc:
        detail = str(exc).removeprefix(f"{p}: ")
        raise MeshError(f"{p}: cannot be read ({detail})") from None
    try:
        return p.read_bytes()
    except OSError as exc:
        raise MeshError(f"{p}: cannot be read ({exc.strerror or exc})") from None


def _metadata(comments: list[str]) -> dict[str, Any]:
    """What the header's ``cdbrdf KEY VALUE`` comments record (the one reader of them)."""
    meta: dict[str, Any] = {}
    for c in comments:
        w = c.split(None, 2)
        if len(w) == 3 and w[0] == "cdbrdf":
            meta[w[1]] = w[2].strip()
    return meta


def ply_metadata(path: str | PathLike[str]) -> dict[str, str]:
    """What a PLY file's header records in its ``comment cdbrdf KEY VALUE`` lines, reading the header only.

    The same header parser and rule as :func:`read_ply` (``units``, ``up``,
    ``curvature_units``, ``neighbourhood_mm``, ``frame``: what
    :func:`write_ply` writes).

    Parameters
    ----------
    path
        The file (never a FIFO or a device: refused before it is opened).

    Returns
    -------
    dict
        The recorded values, as text, by key.

    Raises
    ------
    MeshError
        For a file that is not PLY or whose header is damaged.
    OSError
        For a file that cannot be read (missing, not a regular file).
    """
    from ..fsutil import read_regular
    from ._ply_format import HEADER_MAX_BYTES, ply_header

    head = read_regular(path, max_bytes=HEADER_MAX_BYTES)
    return _metadata(ply_header(head, str(path))[2])


def read_ply(path: str | PathLike[str]) -> Mesh:
    """Read a PLY file (see the module's description).

    Parameters
    ----------
    path
        The file.

    Returns
    -------
    Mesh
        The mesh, with the file's vertex attributes and cdbrdf metadata.
    """
    from ._ply import parse_ply

    p = Path(path)
    data = _read_bytes(p)
    with np.errstate(all="ignore"):
        ply = parse_ply(data, str(p))
    vert = ply.vertex
    v = np.stack([vert["x"], vert["y"], vert["z"]], axis=1)
    n = v.shape[0]
    normals = np.stack([vert[k] for k in ("nx", "ny", "nz")], axis=1) if all(
        k in vert for k in ("nx", "ny", "nz")) else None
    uv = next((np.stack([vert[a], vert[b]], axis=1) for a, b in _UV_NAMES if a in vert and b in vert), None)
    tangents = next((np.stack([vert[a] for a in tri], axis=1) for tri in _TANGENT_NAMES
                     if all(a in vert for a in tri)), None)
    attrs = {}
    shape = all(k in vert for k in SHAPE_PLY_PROPERTIES)  # the shape operator's three (Mitsuba: one attribute)
    for k, a in sorted(vert.items(), key=lambda kv: shape and kv[0] in SHAPE_PLY_PROPERTIES):  # the three last
        name = None if k in _KNOWN else attribute_of_ply(k, shape=shape)
        if name is not None:
            attrs[name] = a
    faces = ply.faces
    if faces.size and int(faces.max()) >= n:
        raise MeshError(f"{p}: faces refer to vertex {int(faces.max())} but there are {n}")
    meta: dict[str, Any] = {"format": "ply", **_metadata(ply.comments)}
    stated = file_statements(p, "ply", [c for c in ply.comments if not c.startswith("cdbrdf ")])
    for key in ("units", "up"):  # a unit or up axis cdbrdf recorded is the file's own
        if key in stated and key not in meta:
            meta[key], meta[f"{key}_source"] = stated[key], stated[f"{key}_source"]
    if "notes" in stated:
        meta["notes"] = stated["notes"]
    mesh = Mesh(v, faces, normals, uv, attrs, tangents, meta)
    if ply.corner_uv is not None:
        mesh = _split_corner_uv(mesh, ply.corner_uv)
    return mesh


def _split_corner_uv(mesh: Mesh, corner_uv: NDArray[np.float64]) -> Mesh:
    """One vertex per distinct (vertex, UV) of the faces' corners (per-corner UVs -> per-vertex)."""
    corners = mesh.faces.reshape(-1)
    key = np.c_[corners.astype(np.float64), corner_uv.reshape(-1, 2)]
    _, first, inv = np.unique(key, axis=0, return_index=True, return_inverse=True)
    src = corners[first]
    pick = (lambda a: None if a is None else a[src])  # noqa: E731 - tiny local helper
    return Mesh(mesh.vertices[src], inv.reshape(-1, 3).astype(np.int64), pick(mesh.normals),
                corner_uv.reshape(-1, 2)[first], {k: a[src] for k, a in mesh.attributes.items()},
                pick(mesh.tangents), mesh.metadata)


def read_obj(path: str | PathLike[str]) -> Mesh:
    """Read a Wavefront OBJ (every object and group; see the module's description).

    Parameters
    ----------
    path
        The file.

    Returns
    -------
    Mesh
        The mesh.
    """
    return _read_trimesh(Path(path), "obj")


def _file_normals(geom: Any) -> NDArray[np.float64] | None:
    """The normals a trimesh geometry was given by its file (not ones it would compute)."""
    cache = getattr(getattr(geom, "_cache", None), "cache", None)
    if isinstance(cache, dict) and "vertex_normals" in cache:
        nn = np.asarray(cache["vertex_normals"], dtype=np.float64)
        if nn.shape == geom.vertices.shape:
            return nn
    return None


def _count_obj_faces(data: bytes) -> int:
    return data.count(b"\nf ") + data.count(b"\nf\t") + int(data.startswith(b"f "))


_OBJ_ZERO = re.compile(rb"(?m)^[ \t]*f[ \t][^\n]*?(?<=[ \t/])-?0+(?=[/ \t\r\n]|$)")


def _check_obj_indices(p: Path, data: bytes) -> None:
    """Refuse an OBJ face with index 0: OBJ indices count from 1 (negative ones from the end); 0 names nothing.

    Readers disagree on it (trimesh took it as the last vertex): a file
    that means nothing in OBJ is refused, with its line.
    """
    m = _OBJ_ZERO.search(data)
    if m is not None:
        line = data.count(b"\n", 0, m.start()) + 1
        raise MeshError(f"{p}: line {line}: a face refers to index 0, which names no vertex (OBJ indices count "
                        "from 1, negative ones from the end)")


def _read_trimesh(p: Path, fmt: str) -> Mesh:
    import trimesh

    from .references import check_references

    data = _read_bytes(p)
    refs = check_references(p, data)  # a FIFO or device named by the file would hang trimesh's reader
    if fmt == "obj":
        check("mesh_faces", _count_obj_faces(data), what=f"{p}: OBJ faces")
        _check_obj_indices(p, data)
    elif fmt == "stl" and len(data) >= 84 and not data[:5].lower() == b"solid":
        check("mesh_faces", int.from_bytes(data[80:84], "little"), what=f"{p}: STL triangles")
    try:
        with warnings.catch_warnings(), np.errstate(all="ignore"):
            warnings.simplefilter("ignore")
            scene = trimesh.load_scene(str(p), file_type=fmt, process=False)
            parts = _scene_parts(scene)
    except CDBRDFError:
        raise
    except (MemoryError, RecursionError):
        raise MeshError(f"{p}: the file asks for more memory or nesting than it can hold (corrupt?)") from None
    except Exception as exc:  # noqa: BLE001 - any failure of the foreign reader is the file's fault
        msg = " ".join(str(exc).split())[:200] or type(exc).__name__
        raise MeshError(f"{p}: cannot be read as {fmt.upper()} ({msg})") from None
    if not parts:
        raise MeshError(f"{p}: the file holds no triangle mesh")
    vs, fs, uvs, ns = [], [], [], []
    offset = 0
    for v, f, uv, nn in parts:
        vs.append(v)
        fs.append(f + offset)
        uvs.append(uv)
        ns.append(nn)
        offset += v.shape[0]
    v_all = np.concatenate(vs)
    f_all = np.concatenate(fs).astype(np.int64)
    check("mesh_faces", f_all.shape[0], what=f"{p}: faces")
    meta: dict[str, Any] = {"format": fmt}
    # what the file says of its unit and up axis (glTF: metres, +Y up; a header's comments; MakeHuman)
    meta.update(file_statements(p, fmt, header_comments(data) if fmt in ("obj", "off") else []))
    uv_all = np.concatenate(uvs) if all(u is not None for u in uvs) else None
    if uv_all is None and any(u is not None for u in uvs):
        meta["notes"] = [*meta.get("notes", []),
                         f"{sum(u is None for u in uvs)} of {len(uvs)} parts have no UVs: the UVs are not used"]
    n_all = np.concatenate(ns) if all(n is not None for n in ns) else None
    notes: list[str] = list(meta.get("notes", []))
    if fmt == "obj":
        meta.update(_obj_maps(refs, notes))
    elif fmt in ("gltf", "glb"):
        meta.update(_gltf_maps(p, data, notes))
    if notes:
        meta["notes"] = notes
    return Mesh(v_all, f_all, n_all, uv_all, {}, None, meta)


#: MTL map statements read as detail maps, in order of preference: a normal map, then height maps.
_MTL_MAPS: tuple[tuple[str, str, str], ...] = (("norm", "normal_map", "normal map"),
                                               ("map_bump", "height_map", "bump map"),
                                               ("bump", "height_map", "bump map"),
                                               ("disp", "height_map", "displacement map"))


def _mtl_transform(options: tuple[str, ...]) -> tuple[tuple[float, float, float, float] | None, float | None]:
    """An MTL map's texture transform ``(ru, rv, ou, ov)`` from ``-s`` and ``-o``, and its ``-bm``."""
    rep, off, bm = [1.0, 1.0], [0.0, 0.0], None
    words = [w.lower() for w in options]
    for i, w in enumerate(words):
        nums = []
        for x in words[i + 1 : i + 4]:
            try:
                nums.append(float(x))
            except ValueError:
                break
        if w == "-s" and nums:
            rep = [nums[0], nums[1] if len(nums) > 1 else nums[0]]
        elif w == "-o" and nums:
            off = [nums[0], nums[1] if len(nums) > 1 else 0.0]
        elif w == "-bm" and nums:
            bm = nums[0]
    ok = all(np.isfinite(rep + off)) and rep[0] != 0 and rep[1] != 0
    t = (rep[0], rep[1], off[0], off[1]) if ok and (rep != [1.0, 1.0] or off != [0.0, 0.0]) else None
    return t, bm


def _obj_maps(refs: list[Any], notes: list[str]) -> dict[str, Any]:
    """The detail map an OBJ's material library names (``norm``, else ``map_Bump``/``bump``/``disp``), if readable."""
    from .normalmap import unusable_map

    for role, key, what in _MTL_MAPS:
        for r in refs:
            if r.role.lower() != role:
                continue
            if not r.path.is_file():
                unusable_map(notes, f"{r.named_by}: names the {what} {r.path}, which does not exist")
                continue
            t, bm = _mtl_transform(r.options)
            out: dict[str, Any] = {key: str(r.path)}
            if t is not None:
                out["map_transform"] = t
            if bm is not None and key == "height_map":
                out["height_scale"] = bm
            return out
    return {}


def _data_uri(uri: str, what: str) -> bytes:
    """The bytes of a ``data:`` URI (base64 or percent-encoded; RFC 2397)."""
    import base64
    import binascii

    head, sep, payload = uri.partition(",")
    if not sep:
        raise MeshError(f"{what}: a data: URI without a comma")
    if head.endswith(";base64"):
        try:
            return base64.b64decode(payload, validate=True)
        except (binascii.Error, ValueError) as exc:
            raise MeshError(f"{what}: its data: URI is not valid base64 ({exc})") from None
    return unquote(payload).encode("latin-1", "replace")


def _glb_binary(p: Path, data: bytes) -> bytes:
    """A GLB's binary chunk (the one that follows the JSON chunk)."""
    import struct

    (json_len,) = struct.unpack_from("<I", data, 12)
    start = 20 + json_len
    if start + 8 > len(data):
        raise MeshError(f"{p}: the GLB has no binary chunk (truncated?)")
    length, kind = struct.unpack_from("<I4s", data, start)
    if kind != b"BIN\x00" or start + 8 + length > len(data):
        raise MeshError(f"{p}: the GLB's binary chunk is truncated or missing")
    return data[start + 8 : start + 8 + length]


def _gltf_image_bytes(doc: dict[str, Any], p: Path, data: bytes, img: dict[str, Any], what: str) -> bytes:
    """An image's encoded bytes: a data: URI, or a buffer view (of a GLB's binary chunk, a data: URI or a file
    beside the glTF, read within the image size of the JSON limit's files)."""
    from ..fsutil import read_regular

    if isinstance(img.get("uri"), str):
        return _data_uri(img["uri"], what)
    try:
        bv = doc["bufferViews"][int(img["bufferView"])]
        buf = doc["buffers"][int(bv["buffer"])]
        off, length = int(bv.get("byteOffset", 0)), int(bv["byteLength"])
    except (KeyError, IndexError, TypeError, ValueError):
        raise MeshError(f"{what}: neither a uri nor a valid bufferView") from None
    uri = buf.get("uri") if isinstance(buf, dict) else None
    if uri is None:
        blob = _glb_binary(p, data) if data[:4] == b"glTF" else b""
    elif isinstance(uri, str) and uri.startswith("data:"):
        blob = _data_uri(uri, what)
    else:
        try:
            blob = read_regular(p.parent / unquote(str(uri)), max_bytes=1 << 31)
        except OSError as exc:
            raise MeshError(f"{what}: its buffer {uri!s:.80} cannot be read ({exc})") from None
    if off < 0 or length < 1 or off + length > len(blob):
        raise MeshError(f"{what}: its bufferView (bytes {off} to {off + length}) runs past the end of its buffer "
                        f"({len(blob)} bytes): the file is truncated")
    return blob[off : off + length]


def _gltf_normal_map(doc: dict[str, Any], p: Path, data: bytes, index: Any) -> Any:
    """The normal map of texture ``index``: a file beside the glTF (read as data), or embedded (decoded by
    :func:`cdbrdf.images.decode_image`, under the image limits)."""
    from ..images import FORMATS, decode_image
    from .normalmap import normal_map_from_image, read_normal_map

    try:
        src = int(doc["textures"][int(index)]["source"])
        img = doc["images"][src]
    except (KeyError, IndexError, TypeError, ValueError):
        raise MeshError("its normalTexture names no image") from None
    if not isinstance(img, dict):
        raise MeshError(f"images[{src}] is not an object")
    uri = img.get("uri")
    what = f"{p}: images[{src}]"
    if isinstance(uri, str) and not uri.startswith("data:"):
        path = p.parent / unquote(uri)
        if not path.is_file():
            raise MeshError(f"{path} does not exist")
        if path.suffix.lower() in FORMATS:
            return read_normal_map(path)
        from ..fsutil import read_regular

        blob = read_regular(path, max_bytes=1 << 31)
        px, info = decode_image(blob, name=str(path))
        return normal_map_from_image(px, info, name=str(path))
    px, info = decode_image(_gltf_image_bytes(doc, p, data, img, what), name=what)
    return normal_map_from_image(px, info, name=f"{p}: normalTexture")


def _gltf_maps(p: Path, data: bytes, notes: list[str]) -> dict[str, Any]:
    """A glTF's first ``normalTexture`` (read as data by the project's image reader), with its texture transform.

    ``KHR_texture_transform`` (glTF's texture coordinates run down from the
    top) becomes the transform of UVs with v up: repeat ``(sx, sy)``, offset
    ``(ox, 1 - oy - sy)``; a rotation is not applied (said). A normal texture
    that cannot be used (missing, damaged, truncated, beyond the image limits)
    is a warning naming the file, the image and why; the mesh is read without it.
    """
    from .normalmap import unusable_map
    from .references import _gltf_json

    doc = _gltf_json(p, data)
    for mat in doc.get("materials", []) if isinstance(doc.get("materials"), list) else []:
        nt = mat.get("normalTexture") if isinstance(mat, dict) else None
        if not isinstance(nt, dict):
            continue
        out: dict[str, Any] = {}
        kt = (nt.get("extensions") or {}).get("KHR_texture_transform")
        if isinstance(kt, dict):
            try:
                sx, sy = (float(x) for x in kt.get("scale", (1.0, 1.0)))
                ox, oy = (float(x) for x in kt.get("offset", (0.0, 0.0)))
                if sx != 0 and sy != 0 and np.isfinite([sx, sy, ox, oy]).all():
                    out["map_transform"] = (sx, sy, ox, 1.0 - oy - sy)
                if float(kt.get("rotation", 0.0)) != 0.0:
                    notes.append(f"{p}: the normal texture's KHR_texture_transform rotation is not applied")
            except (TypeError, ValueError):
                notes.append(f"{p}: the normal texture's KHR_texture_transform cannot be read: not applied")
        try:
            out["normal_map"] = _gltf_normal_map(doc, p, data, nt.get("index"))
        except (CDBRDFError, OSError) as exc:
            msg = str(exc).removeprefix(f"{p}: ")
            unusable_map(notes, f"{p}: its normalTexture cannot be used ({msg})")
            return {}
        return out
    return {}


def _scene_parts(scene: Any) -> list[tuple[NDArray[np.float64], NDArray[np.int64], Any, Any]]:
    """Vertices (transformed), faces, UVs and file normals of every triangle mesh of a trimesh scene."""
    import trimesh

    parts = []
    for node in scene.graph.nodes_geometry:
        transform, gname = scene.graph[node]
        geom = scene.geometry.get(gname)
        if not isinstance(geom, trimesh.Trimesh) or len(geom.faces) == 0:
            continue
        t = np.asarray(transform, dtype=np.float64)
        v = np.asarray(geom.vertices, dtype=np.float64)
        f = np.asarray(geom.faces, dtype=np.int64)
        if f.ndim != 2 or f.shape[1] != 3:
            raise MeshError("faces are not triangles")
        v = v @ t[:3, :3].T + t[:3, 3]
        uv = getattr(geom.visual, "uv", None) if geom.visual is not None else None
        uv = np.asarray(uv, dtype=np.float64) if uv is not None and len(uv) == len(v) else None
        nn = _file_normals(geom)
        if nn is not None:
            m = t[:3, :3]
            try:
                nn = nn @ np.linalg.inv(m)  # normals transform with the inverse transpose
            except np.linalg.LinAlgError:
                nn = None
        parts.append((v, f, uv, nn))
    return parts


def _check_column(name: str, a: NDArray[Any] | None, shape: tuple[int, ...]) -> None:
    if a is not None and np.shape(a) != shape:
        raise MeshError(f"mesh: {name}: expected shape {shape}, got {np.shape(a)}")


def write_ply(path: str | PathLike[str], mesh: Mesh) -> None:
    """Write ``mesh`` as binary little-endian PLY (float32 vertex data), atomically.

    Attributes are written as ``NAME_x`` float properties (Mitsuba loads them
    as ``vertex_NAME``), the shape operator's three as ``shape_x``,
    ``shape_y``, ``shape_z`` (Mitsuba: one attribute ``vertex_shape``); the
    metadata ``units``, ``up``, ``curvature_units``, ``neighbourhood_mm`` and
    ``frame`` as ``comment cdbrdf KEY VALUE`` lines.

    Parameters
    ----------
    path
        Destination.
    mesh
        The mesh.
    """
    from .._version import __version__
    from ..fsutil import atomic_path
    from ._ply import write_ply_bytes

    n = mesh.n_vertices
    _check_column("vertices", mesh.vertices, (n, 3))
    _check_column("normals", mesh.normals, (n, 3))
    _check_column("uv", mesh.uv, (n, 2))
    _check_column("tangents", mesh.tangents, (n, 3))
    f = np.asarray(mesh.faces, dtype=np.int64)
    if f.ndim != 2 or f.shape[1] != 3 or (f.size and (f.min() < 0 or f.max() >= n)):
        raise MeshError(f"mesh: faces: expected (m, 3) indices of the {n} vertices")
    cols: list[tuple[str, NDArray[Any]]] = [(c, mesh.vertices[:, i]) for i, c in enumerate("xyz")]
    if mesh.normals is not None:
        cols += [(c, mesh.normals[:, i]) for i, c in enumerate(("nx", "ny", "nz"))]
    if mesh.uv is not None:
        cols += [("u", mesh.uv[:, 0]), ("v", mesh.uv[:, 1])]
    if mesh.tangents is not None:
        cols += [(c, mesh.tangents[:, i]) for i, c in enumerate(_TANGENT_NAMES[0])]
    shape = all(k in mesh.attributes for k in SHAPE_ATTRIBUTES)  # then the three as one (last, consecutive)
    for name, a in sorted(mesh.attributes.items(), key=lambda kv: shape and kv[0] in SHAPE_ATTRIBUTES):
        a = np.asarray(a, dtype=np.float64)
        if a.shape != (n,):
            raise MeshError(f"mesh: attribute {name!r}: expected shape ({n},), got {a.shape}")
        if not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", name):
            raise MeshError(f"mesh: attribute {name!r}: not a valid PLY property name")
        cols.append((ply_property(name, shape=shape), a))
    comments = [f"written by cdbrdf {__version__}"]
    for key in ("units", "up", "curvature_units", "neighbourhood_mm", "frame"):
        val = mesh.metadata.get(key)
        if val is not None:
            text = f"{val:g}" if isinstance(val, float) and math.isfinite(val) else str(val)
            if "\n" in text or "\r" in text:
                raise MeshError(f"mesh: metadata {key!r}: one line expected")
            comments.append(f"cdbrdf {key} {text}")
    data = write_ply_bytes(cols, f, comments)
    with atomic_path(path, suffix=".ply") as tmp:
        Path(tmp).write_bytes(data)
