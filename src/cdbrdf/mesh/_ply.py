"""The PLY reader and writer of :mod:`cdbrdf.mesh` (private).

cdbrdf reads PLY itself rather than through trimesh, whose reader keeps extra
vertex properties (the curvature ``curvature_x``, tangents) only in its
private metadata, drops the header's comments (where cdbrdf records the unit
of a mesh and of its curvature) and cannot read binary files with polygons of
mixed sizes or triangle strips; plyfile would read them but is GPL-3.0
(``docs/rendering.md``, "Files"). The reader:

- parses the header (``ascii``, ``binary_little_endian``,
  ``binary_big_endian``; every scalar type; ``comment`` and ``obj_info``
  lines; any elements) and checks every declared count against the bytes
  that follow *before* reading anything, so a header declaring 10^12 faces
  is one error line, not an allocation;
- reads binary elements without lists with one structured ``frombuffer``;
  elements with lists at a fixed length (the usual all-triangle face
  element) the same way, and others (mixed triangles and quads, strips)
  with one numba pass that finds each record's offset;
- reads ASCII data line by line, as PLY defines it (one record a line): one
  numba pass over the bytes finds every non-blank line and its values (and
  the first byte that cannot be part of a number), a second converts the
  values (exactly, through Clinger's fast path, for up to 15 significant
  digits and decimal exponents within +-22; Python's ``float`` for the
  rest), and each element's records are checked to be one line each with
  exactly the values their properties need (a list: its count, then that
  many items). A record merged onto another's line, split over two lines,
  short of a value or with one too many is an error naming the line (from
  1, counting the header), the element and the record, never values read
  shifted. Blank lines, trailing whitespace, CRLF line endings and a last
  line without a newline are accepted; data after the last declared record
  and comments in the data (PLY has them in the header only) are errors;
- triangulates polygons as fans, triangle strips (element ``tristrips``,
  restart index -1) with alternating winding, and takes per-corner UVs
  (``texcoord`` lists of faces, as MeshLab writes them).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .._jit import njit
from ..errors import MeshError
from ..limits import check
from ._ply_ascii import _ascii_body, _AsciiBody, _read_ascii_element
from ._ply_format import _INDEX_NAMES, HEADER_MAX_BYTES, _Element, _list_items, ply_header

__all__ = ["PlyData", "parse_ply", "ply_header", "write_ply_bytes", "HEADER_MAX_BYTES"]


@dataclass
class PlyData:
    """What a PLY file holds, as arrays.

    Attributes
    ----------
    vertex
        Every scalar vertex property by name (float64).
    faces
        ``(m, 3)`` triangles (polygons as fans, strips unrolled).
    corner_uv
        ``(m, 3, 2)`` per-corner UVs of faces with ``texcoord`` lists, else None.
    comments
        The header's comment lines (without ``comment``).
    """

    vertex: dict[str, NDArray[np.float64]]
    faces: NDArray[np.int64]
    corner_uv: NDArray[np.float64] | None
    comments: list[str]


# -- scanning records with lists -------------------------------------------------------
@njit(cache=True)
def _read_uint(buf, pos, size, big):  # noqa: ANN001, ANN202 - numba
    v = 0
    for i in range(size):
        b = buf[pos + (i if big else size - 1 - i)]
        v = (v << 8) | b
    return v


@njit(cache=True)
def _scan_binary(buf, start, count, sizes, csizes, csigned, big):  # noqa: ANN001, ANN202 - numba
    """Offsets (count, nprops) of every property of every record, and list lengths; -1 on overrun."""
    npr = sizes.shape[0]
    offs = np.empty((count, npr), np.int64)
    lens = np.zeros((count, npr), np.int64)
    pos = start
    n = buf.shape[0]
    for r in range(count):
        for p in range(npr):
            offs[r, p] = pos
            if csizes[p] == 0:
                pos += sizes[p]
            else:
                if pos + csizes[p] > n:
                    return offs, lens, -1
                c = _read_uint(buf, pos, csizes[p], big)
                if csigned[p] and c >= (1 << (8 * csizes[p] - 1)):
                    return offs, lens, -1
                lens[r, p] = c
                pos += csizes[p] + c * sizes[p]
            if pos > n:
                return offs, lens, -1
    return offs, lens, pos


def _gather(buf: NDArray[np.uint8], offsets: NDArray[np.int64], dtype: np.dtype) -> NDArray[Any]:
    """Values of ``dtype`` at byte ``offsets`` of ``buf``."""
    size = dtype.itemsize
    idx = offsets[:, None] + np.arange(size)
    return np.ascontiguousarray(buf[idx]).view(dtype).reshape(-1)


def _read_element(el: _Element, fmt: str, body: bytes, pos: int, name: str) -> tuple[dict[str, Any], int]:
    """Read one binary element at byte ``pos``: scalars as arrays, lists as (flat values, lengths)."""
    out: dict[str, Any] = {}
    assert isinstance(body, bytes | bytearray | memoryview)
    big = fmt == "binary_big_endian"
    bo = ">" if big else "<"
    buf = np.frombuffer(body, dtype=np.uint8)
    if not el.has_lists:
        dt = np.dtype([(f"p{i}", bo + p.dtype) for i, p in enumerate(el.props)])
        if pos + dt.itemsize * el.count > buf.size:
            raise MeshError(f"{name}: element {el.name!r} needs {dt.itemsize * el.count} bytes, the file has "
                            f"{buf.size - pos}")
        rec = np.frombuffer(body, dtype=dt, count=el.count, offset=pos)
        for i, p in enumerate(el.props):
            out[p.name] = rec[f"p{i}"]
        return out, pos + dt.itemsize * el.count
    sizes = np.array([np.dtype(p.dtype).itemsize for p in el.props], np.int64)
    csizes = np.array([np.dtype(p.count_dtype).itemsize if p.count_dtype else 0 for p in el.props], np.int64)
    csigned = np.array([bool(p.count_dtype and p.count_dtype[0] == "i") for p in el.props])
    # fast path: every list as long as the first record's
    fixed = _fixed_layout(buf, pos, el, sizes, csizes, bo)
    if fixed is not None:
        dt = fixed
        rec = np.frombuffer(body, dtype=dt, count=el.count, offset=pos)
        for i, p in enumerate(el.props):
            if p.count_dtype is None:
                out[p.name] = rec[f"p{i}"]
            else:
                vals = rec[f"p{i}"].reshape(el.count, -1)
                out[p.name] = (vals.reshape(-1), np.full(el.count, vals.shape[1], np.int64))
        return out, pos + dt.itemsize * el.count
    offs, lens, end = _scan_binary(buf, pos, el.count, sizes, csizes, csigned, big)
    if end < 0:
        raise MeshError(f"{name}: element {el.name!r}: the data ends early or has a bad list length")
    for i, p in enumerate(el.props):
        dt = np.dtype(bo + p.dtype)
        if p.count_dtype is None:
            out[p.name] = _gather(buf, offs[:, i], dt)
        else:
            items = _list_items(offs[:, i] + csizes[i], lens[:, i], dt.itemsize)
            out[p.name] = (_gather(buf, items, dt), lens[:, i])
    return out, end


def _fixed_layout(buf: NDArray[np.uint8], pos: int, el: _Element, sizes: NDArray[np.int64],
                  csizes: NDArray[np.int64], bo: str) -> np.dtype | None:
    """The record dtype when every list of the element has its first record's length, else None."""
    if el.count == 0:
        return None
    fields: list[Any] = []
    lens: dict[int, int] = {}
    off = pos
    for i, p in enumerate(el.props):
        if p.count_dtype is None:
            fields.append((f"p{i}", bo + p.dtype))
            off += int(sizes[i])
        else:
            if off + csizes[i] > buf.size:
                return None
            c = int(np.frombuffer(buf[off:off + csizes[i]].tobytes(), dtype=bo + p.count_dtype)[0])
            if not 0 < c <= 64:
                return None
            lens[i] = c
            fields.append((f"n{i}", bo + p.count_dtype))
            fields.append((f"p{i}", bo + p.dtype, (c,)))
            off += int(csizes[i]) + c * int(sizes[i])
    dt = np.dtype(fields)
    if pos + dt.itemsize * el.count > buf.size:
        return None
    rec = np.frombuffer(buf, dtype=dt, count=el.count, offset=pos)
    for i, c in lens.items():
        if not np.all(rec[f"n{i}"] == c):
            return None
    return dt


def _fan(values: NDArray[np.int64], lens: NDArray[np.int64]) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Triangles of polygons (fans) and for each its three positions in ``values``."""
    if lens.size and np.all(lens == 3):
        return values.reshape(-1, 3), np.arange(values.size).reshape(-1, 3)
    starts = np.r_[0, np.cumsum(lens)[:-1]]
    ntri = np.maximum(lens - 2, 0)
    rec = np.repeat(np.arange(lens.size), ntri)
    j = np.arange(int(ntri.sum())) - np.r_[0, np.cumsum(ntri)[:-1]][rec]
    s = starts[rec]
    corners = np.stack([s, s + j + 1, s + j + 2], axis=1)
    return values[corners], corners


def _strips(values: NDArray[np.int64], lens: NDArray[np.int64]) -> NDArray[np.int64]:
    """Triangles of triangle strips (restart index -1, alternating winding), degenerate ones dropped."""
    n = values.size
    if n < 3:
        return np.zeros((0, 3), np.int64)
    rec = np.repeat(np.arange(lens.size), lens)
    brk = values < 0
    seg_start = np.r_[True, (rec[1:] != rec[:-1]) | brk[:-1]]
    start_idx = np.maximum.accumulate(np.where(seg_start, np.arange(n), 0))
    p = np.arange(n - 2)
    ok = (rec[p] == rec[p + 2]) & ~brk[p] & ~brk[p + 1] & ~brk[p + 2]
    ok &= start_idx[p + 2] == start_idx[p]
    p = p[ok]
    odd = ((p - start_idx[p]) % 2).astype(bool)
    a, b, c = values[p], values[p + 1], values[p + 2]
    tri = np.stack([np.where(odd, b, a), np.where(odd, a, b), c], axis=1)
    keep = (tri[:, 0] != tri[:, 1]) & (tri[:, 1] != tri[:, 2]) & (tri[:, 0] != tri[:, 2])
    return tri[keep]


def parse_ply(data: bytes, name: str) -> PlyData:
    """Parse a PLY file's bytes; :class:`MeshError` naming ``name`` for anything wrong.

    Raises
    ------
    MeshError
        Not PLY, a bad header, counts the file cannot hold, lists running
        past the end, no vertex element with x, y, z, no faces.
    LimitError
        More faces than the ``mesh_faces`` limit.
    """
    fmt, elements, comments, start = ply_header(data, name)
    for el in elements:
        if el.name in ("face", "tristrips"):
            check("mesh_faces", el.count, what=f"{name}: PLY element {el.name!r}")
    ascii_body: _AsciiBody | None = None
    if fmt == "ascii":
        ascii_body = _ascii_body(data, start, name, sum(el.count for el in elements if el.props))
    else:
        avail = len(data) - start
        total_min = 0
        for el in elements:
            rec_min = sum((np.dtype(p.count_dtype).itemsize if p.count_dtype else np.dtype(p.dtype).itemsize)
                          for p in el.props)
            total_min += el.count * rec_min
        if total_min > avail:
            raise MeshError(f"{name}: the header declares at least {total_min} bytes of data, the file has {avail}")
    pos = 0 if fmt == "ascii" else start
    vertex: dict[str, NDArray[np.float64]] | None = None
    tris: list[NDArray[np.int64]] = []
    corner_uv: list[NDArray[np.float64] | None] = []
    have_faces = False
    for el in elements:
        if ascii_body is not None:
            rec, pos = _read_ascii_element(el, ascii_body, pos)
        else:
            rec, pos = _read_element(el, fmt, data, pos, name)
        if el.name == "vertex":
            vertex = {}
            for k, val in rec.items():
                if not isinstance(val, tuple):
                    vertex[k] = np.asarray(val, dtype=np.float64)
        elif el.name == "face":
            key = next((k for k in _INDEX_NAMES if k in rec and isinstance(rec[k], tuple)), None)
            if key is None:
                raise MeshError(f"{name}: the face element has no vertex_indices list")
            have_faces = True
            vals, lens = rec[key]
            vi = _as_index(vals, name)
            t, corners = _fan(vi, lens)
            tris.append(t)
            cuv = None
            tc = rec.get("texcoord")
            if isinstance(tc, tuple) and np.array_equal(tc[1], 2 * lens):
                uvals = np.asarray(tc[0], dtype=np.float64).reshape(-1, 2)
                cuv = uvals[corners]
            corner_uv.append(cuv)
        elif el.name == "tristrips":
            key = next((k for k in _INDEX_NAMES if k in rec and isinstance(rec[k], tuple)), None)
            if key is None:
                raise MeshError(f"{name}: the tristrips element has no vertex_indices list")
            have_faces = True
            vals, lens = rec[key]
            t = _strips(_as_index(vals, name, allow_restart=True), lens)
            tris.append(t)
            corner_uv.append(None)
    if ascii_body is not None and pos < ascii_body.first.size:
        declared = ", ".join(f"{el.count} {el.name!r}" for el in elements)
        raise MeshError(f"{name}: line {ascii_body.line(pos)}: data after the last record the header declares "
                        f"({declared})")
    if vertex is None or not all(k in vertex for k in "xyz"):
        raise MeshError(f"{name}: the PLY file has no vertex element with x, y, z")
    if not have_faces:
        raise MeshError(f"{name}: the PLY file has no face or tristrips element (a point cloud?)")
    faces = np.concatenate(tris) if tris else np.zeros((0, 3), np.int64)
    cu = None
    if any(c is not None for c in corner_uv) and all(c is not None or t.shape[0] == 0
                                                    for c, t in zip(corner_uv, tris, strict=True)):
        cu = np.concatenate([c for c in corner_uv if c is not None])
    return PlyData(vertex, faces, cu, comments)


def _as_index(vals: NDArray[Any], name: str, *, allow_restart: bool = False) -> NDArray[np.int64]:
    """List items as int64 vertex indices (ASCII ones must be integers)."""
    a = np.asarray(vals)
    if a.dtype.kind == "f":
        if not np.all(np.isfinite(a)) or not np.all(a == np.floor(a)):
            raise MeshError(f"{name}: vertex indices that are not integers")
        if a.size and (a.max() > 2**62 or a.min() < -(2**62)):
            raise MeshError(f"{name}: vertex indices out of range")
    a = a.astype(np.int64)
    if not allow_restart and a.size and a.min() < 0:
        raise MeshError(f"{name}: negative vertex indices")
    return a


def write_ply_bytes(
    columns: list[tuple[str, NDArray[np.float64]]], faces: NDArray[np.int64], comments: list[str]
) -> bytes:
    """A binary little-endian PLY: float32 vertex columns, triangles as ``uchar int`` lists."""
    n = columns[0][1].shape[0] if columns else 0
    dt = np.dtype([(c, "<f4") for c, _ in columns])
    vrec = np.empty(n, dtype=dt)
    for c, a in columns:
        vrec[c] = a
    frec = np.empty(faces.shape[0], dtype=np.dtype([("n", "u1"), ("i", "<i4", (3,))]))
    frec["n"] = 3
    frec["i"] = faces
    header = ["ply", "format binary_little_endian 1.0"]
    header += [f"comment {c}" for c in comments]
    header.append(f"element vertex {n}")
    header += [f"property float {c}" for c, _ in columns]
    header += [f"element face {faces.shape[0]}", "property list uchar int vertex_indices", "end_header"]
    return ("\n".join(header) + "\n").encode("ascii") + vrec.tobytes() + frec.tobytes()
