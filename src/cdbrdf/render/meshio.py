"""Small PLY / OBJ reader and PLY writer for triangle meshes with UVs and attributes.

Only what the renderer needs: positions, optional normals and UVs, per-vertex
scalar attributes, polygon faces (triangulated as fans). The PLY writer uses
``binary_little_endian`` and names the curvature property so that Mitsuba's
PLY loader turns it into the mesh attribute ``vertex_curvature``: Mitsuba keeps
an unknown vertex property only when its name ends in a channel suffix
(``curvature_x`` -> ``vertex_curvature`` with one channel; ``curvature_k`` is
refused and a bare ``curvature`` dropped, each with a warning).
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from os import PathLike
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

__all__ = ["Mesh", "read_mesh", "read_ply", "read_obj", "write_ply", "CURVATURE_PLY_PROPERTY"]


#: PLY vertex property written for the curvature (Mitsuba: attribute ``vertex_curvature``).
CURVATURE_PLY_PROPERTY = "curvature_x"

_PLY_TYPES = {
    "char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1",
    "short": "i2", "int16": "i2", "ushort": "u2", "uint16": "u2",
    "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4",
    "float": "f4", "float32": "f4", "double": "f8", "float64": "f8",
}


@dataclass
class Mesh:
    """A triangle mesh.

    Attributes
    ----------
    vertices
        ``(n, 3)`` float64 positions.
    faces
        ``(m, 3)`` int64 vertex indices (counter-clockwise = front).
    normals, uv
        Optional ``(n, 3)`` vertex normals and ``(n, 2)`` texture coordinates.
    attributes
        Extra per-vertex scalar arrays by name (e.g. ``"curvature"`` in mm^-1).
    """

    vertices: NDArray[np.float64]
    faces: NDArray[np.int64]
    normals: NDArray[np.float64] | None = None
    uv: NDArray[np.float64] | None = None
    attributes: dict[str, NDArray[np.float64]] = field(default_factory=dict)

    @property
    def n_vertices(self) -> int:
        return int(self.vertices.shape[0])


def read_mesh(path: str | PathLike[str]) -> Mesh:
    """Read a ``.ply`` or ``.obj`` file (chosen by extension)."""
    p = Path(path)
    ext = p.suffix.lower()
    if ext == ".ply":
        return read_ply(p)
    if ext == ".obj":
        return read_obj(p)
    raise ValueError(f"{p}: unknown mesh format {ext!r}; expected .ply or .obj")


def _fan(polys: list[list[int]]) -> NDArray[np.int64]:
    tris = []
    for poly in polys:
        for k in range(1, len(poly) - 1):
            tris.append((poly[0], poly[k], poly[k + 1]))
    return np.asarray(tris, dtype=np.int64).reshape(-1, 3)


def read_ply(path: str | PathLike[str]) -> Mesh:
    """Read a PLY file (ASCII or binary) with a vertex and a face element."""
    p = Path(path)
    with open(p, "rb") as fh:
        if fh.readline().strip() != b"ply":
            raise ValueError(f"{p}: not a PLY file (no 'ply' magic line)")
        fmt = None
        elements: list[tuple[str, int, list[tuple]]] = []
        while True:
            line = fh.readline()
            if not line:
                raise ValueError(f"{p}: PLY header has no end_header")
            words = line.decode("ascii", "replace").split()
            if not words or words[0] in ("comment", "obj_info"):
                continue
            if words[0] == "end_header":
                break
            if words[0] == "format":
                fmt = words[1]
            elif words[0] == "element":
                elements.append((words[1], int(words[2]), []))
            elif words[0] == "property":
                if not elements:
                    raise ValueError(f"{p}: PLY property before any element")
                if words[1] == "list":
                    elements[-1][2].append(("list", words[4], _PLY_TYPES[words[2]], _PLY_TYPES[words[3]]))
                else:
                    if words[1] not in _PLY_TYPES:
                        raise ValueError(f"{p}: unknown PLY type {words[1]!r}")
                    elements[-1][2].append(("scalar", words[2], _PLY_TYPES[words[1]]))
        if fmt not in ("ascii", "binary_little_endian", "binary_big_endian"):
            raise ValueError(f"{p}: unsupported PLY format {fmt!r}")
        data = fh.read()
    end = "<" if fmt == "binary_little_endian" else ">"
    vert = None
    faces = None
    pos = 0
    tokens = data.split() if fmt == "ascii" else None
    for name, count, props in elements:
        if fmt == "ascii":
            if all(pr[0] == "scalar" for pr in props):
                n = len(props)
                arr = np.asarray(tokens[pos:pos + n * count], dtype=np.float64).reshape(count, n)
                pos += n * count
                rec = {pr[1]: arr[:, i] for i, pr in enumerate(props)}
            else:
                rec = {}
                polys = []
                for _ in range(count):
                    for pr in props:
                        if pr[0] == "list":
                            k = int(tokens[pos])
                            vals = [int(t) for t in tokens[pos + 1:pos + 1 + k]]
                            pos += 1 + k
                            if pr[1] in ("vertex_indices", "vertex_index"):
                                polys.append(vals)
                        else:
                            pos += 1
                rec["__polys"] = polys
        else:
            if all(pr[0] == "scalar" for pr in props):
                dt = np.dtype([(pr[1], end + pr[2]) for pr in props])
                arr = np.frombuffer(data, dtype=dt, count=count, offset=pos)
                pos += dt.itemsize * count
                rec = {pr[1]: arr[pr[1]].astype(np.float64) for pr in props}
            else:
                rec = {}
                polys = []
                # Fast path: one list property of triangles.
                if len(props) == 1 and props[0][0] == "list":
                    _, pname, ct, it = props[0]
                    dt = np.dtype([("n", end + ct), ("i", end + it, (3,))])
                    if count and int(np.frombuffer(data, dtype=end + ct, count=1, offset=pos)[0]) == 3:
                        arr = np.frombuffer(data, dtype=dt, count=count, offset=pos)
                        if np.all(arr["n"] == 3):
                            pos += dt.itemsize * count
                            rec["__tris"] = arr["i"].astype(np.int64)
                if "__tris" not in rec:
                    for _ in range(count):
                        for pr in props:
                            if pr[0] == "list":
                                cdt = np.dtype(end + pr[2])
                                k = int(np.frombuffer(data, dtype=cdt, count=1, offset=pos)[0])
                                pos += cdt.itemsize
                                idt = np.dtype(end + pr[3])
                                vals = np.frombuffer(data, dtype=idt, count=k, offset=pos).tolist()
                                pos += idt.itemsize * k
                                if pr[1] in ("vertex_indices", "vertex_index"):
                                    polys.append(vals)
                            else:
                                pos += np.dtype(pr[2]).itemsize
                    rec["__polys"] = polys
        if name == "vertex":
            vert = rec
        elif name == "face":
            faces = rec["__tris"] if "__tris" in rec else _fan(rec.get("__polys", []))
    if vert is None or not all(k in vert for k in "xyz"):
        raise ValueError(f"{p}: PLY file has no vertex element with x, y, z")
    if faces is None:
        raise ValueError(f"{p}: PLY file has no face element")
    v = np.stack([vert["x"], vert["y"], vert["z"]], axis=1)
    normals = np.stack([vert[k] for k in ("nx", "ny", "nz")], axis=1) if all(k in vert for k in ("nx", "ny", "nz")) else None
    uv = None
    for a, b in (("u", "v"), ("s", "t"), ("texture_u", "texture_v"), ("texture_s", "texture_t")):
        if a in vert and b in vert:
            uv = np.stack([vert[a], vert[b]], axis=1)
            break
    known = {"x", "y", "z", "nx", "ny", "nz", "u", "v", "s", "t", "texture_u", "texture_v", "texture_s", "texture_t"}
    attrs = {}
    for k, a in vert.items():
        if k in known:
            continue
        m = re.fullmatch(r"(.+)_[a-z]", k)
        attrs[m.group(1) if m else k] = np.asarray(a, dtype=np.float64)
    return Mesh(v, faces, normals, uv, attrs)


def read_obj(path: str | PathLike[str]) -> Mesh:
    """Read a Wavefront OBJ (v, vt, vn, f); corners with distinct (v, vt, vn) become vertices."""
    p = Path(path)
    pos, tex, nor, polys = [], [], [], []
    with open(p, encoding="utf-8", errors="replace") as fh:
        for line in fh:
            if not line or line[0] == "#":
                continue
            w = line.split()
            if not w:
                continue
            if w[0] == "v":
                pos.append([float(x) for x in w[1:4]])
            elif w[0] == "vt":
                tex.append([float(x) for x in w[1:3]])
            elif w[0] == "vn":
                nor.append([float(x) for x in w[1:4]])
            elif w[0] == "f":
                corners = []
                for c in w[1:]:
                    parts = (c.split("/") + ["", ""])[:3]
                    idx = []
                    for part, n in zip(parts, (len(pos), len(tex), len(nor))):
                        if part == "":
                            idx.append(-1)
                        else:
                            i = int(part)
                            idx.append(i - 1 if i > 0 else n + i)
                    corners.append(tuple(idx))
                polys.append(corners)
    if not pos:
        raise ValueError(f"{p}: OBJ file has no vertices")
    if not polys:
        raise ValueError(f"{p}: OBJ file has no faces")
    key: dict[tuple, int] = {}
    out_polys = []
    for poly in polys:
        out_polys.append([key.setdefault(c, len(key)) for c in poly])
    corners = np.asarray(list(key.keys()), dtype=np.int64).reshape(-1, 3)
    P = np.asarray(pos, dtype=np.float64)
    try:
        v = P[corners[:, 0]]
        has_t = tex and np.all(corners[:, 1] >= 0)
        has_n = nor and np.all(corners[:, 2] >= 0)
        uv = np.asarray(tex, dtype=np.float64)[corners[:, 1]] if has_t else None
        normals = np.asarray(nor, dtype=np.float64)[corners[:, 2]] if has_n else None
    except IndexError:
        raise ValueError(f"{p}: a face refers to a vertex, UV or normal that does not exist") from None
    return Mesh(v, _fan(out_polys), normals, uv, {})


def write_ply(path: str | PathLike[str], mesh: Mesh) -> None:
    """Write ``mesh`` as binary little-endian PLY (float32 vertex data), atomically.

    Attributes are written as ``NAME_x`` float properties (Mitsuba loads them
    as ``vertex_NAME``); the attribute ``curvature`` becomes ``curvature_x``.
    """
    from ..io import atomic_path

    n = mesh.n_vertices
    cols = [("x", mesh.vertices[:, 0]), ("y", mesh.vertices[:, 1]), ("z", mesh.vertices[:, 2])]
    if mesh.normals is not None:
        cols += [("nx", mesh.normals[:, 0]), ("ny", mesh.normals[:, 1]), ("nz", mesh.normals[:, 2])]
    if mesh.uv is not None:
        cols += [("u", mesh.uv[:, 0]), ("v", mesh.uv[:, 1])]
    for name, a in mesh.attributes.items():
        a = np.asarray(a, dtype=np.float64)
        if a.shape != (n,):
            raise ValueError(f"attribute {name!r}: expected shape ({n},), got {a.shape}")
        cols.append((f"{name}_x", a))
    dt = np.dtype([(c, "<f4") for c, _ in cols])
    vrec = np.empty(n, dtype=dt)
    for c, a in cols:
        vrec[c] = a
    f = np.asarray(mesh.faces, dtype=np.int64)
    frec = np.empty(f.shape[0], dtype=np.dtype([("n", "u1"), ("i", "<i4", (3,))]))
    frec["n"] = 3
    frec["i"] = f
    header = ["ply", "format binary_little_endian 1.0", "comment written by cdbrdf",
              f"element vertex {n}"]
    header += [f"property float {c}" for c, _ in cols]
    header += [f"element face {f.shape[0]}", "property list uchar int vertex_indices", "end_header"]
    with atomic_path(path) as tmp:
        with open(tmp, "wb") as fh:
            fh.write(("\n".join(header) + "\n").encode("ascii"))
            fh.write(vrec.tobytes())
            fh.write(frec.tobytes())
