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

import math
import re
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .._jit import njit
from ..errors import MeshError
from ..limits import check

__all__ = ["PlyData", "parse_ply", "ply_header", "write_ply_bytes", "HEADER_MAX_BYTES"]

#: Largest header accepted (bytes).
HEADER_MAX_BYTES = 1 << 20

_TYPES = {
    "char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1",
    "short": "i2", "int16": "i2", "ushort": "u2", "uint16": "u2",
    "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4",
    "float": "f4", "float32": "f4", "double": "f8", "float64": "f8",
}

_INDEX_NAMES = ("vertex_indices", "vertex_index")


@dataclass
class _Prop:
    name: str
    dtype: str  # numpy code without byte order ("f4", ...)
    count_dtype: str | None = None  # for lists


@dataclass
class _Element:
    name: str
    count: int
    props: list[_Prop] = field(default_factory=list)

    @property
    def has_lists(self) -> bool:
        return any(p.count_dtype is not None for p in self.props)


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


def ply_header(data: bytes, name: str) -> tuple[str, list[_Element], list[str], int]:
    """The format, elements, comments and the offset of the body of a PLY file's bytes."""
    if not data.startswith(b"ply"):
        raise MeshError(f"{name}: not a PLY file (no 'ply' magic line)")
    m = re.search(rb"end_header[ \t]*\r?\n", data[:HEADER_MAX_BYTES])
    if m is None:
        raise MeshError(f"{name}: PLY header has no end_header within {HEADER_MAX_BYTES} bytes")
    try:
        text = data[: m.start()].decode("ascii")
    except UnicodeDecodeError:
        raise MeshError(f"{name}: PLY header is not ASCII text") from None
    fmt = None
    elements: list[_Element] = []
    comments: list[str] = []
    for lineno, line in enumerate(text.splitlines()[1:], start=2):
        w = line.split()
        if not w:
            continue
        if w[0] == "comment" or w[0] == "obj_info":
            comments.append(line.strip()[len(w[0]):].strip())
        elif w[0] == "format":
            if len(w) < 2 or w[1] not in ("ascii", "binary_little_endian", "binary_big_endian"):
                raise MeshError(f"{name}: line {lineno}: unsupported PLY format {' '.join(w[1:2])!r}")
            fmt = w[1]
        elif w[0] == "element":
            if len(w) != 3 or not w[2].isdigit():
                raise MeshError(f"{name}: line {lineno}: expected 'element NAME COUNT', got {line.strip()!r:.80}")
            elements.append(_Element(w[1], int(w[2])))
        elif w[0] == "property":
            if not elements:
                raise MeshError(f"{name}: line {lineno}: a property before any element")
            if len(w) == 5 and w[1] == "list":
                if w[2] not in _TYPES or w[3] not in _TYPES or _TYPES[w[2]][0] == "f":
                    raise MeshError(f"{name}: line {lineno}: bad list property types {w[2]!r} {w[3]!r}")
                elements[-1].props.append(_Prop(w[4], _TYPES[w[3]], _TYPES[w[2]]))
            elif len(w) == 3 and w[1] in _TYPES:
                elements[-1].props.append(_Prop(w[2], _TYPES[w[1]]))
            else:
                raise MeshError(f"{name}: line {lineno}: bad property line {line.strip()!r:.80}")
        else:
            raise MeshError(f"{name}: line {lineno}: unknown PLY header keyword {w[0]!r:.40}")
    if fmt is None:
        raise MeshError(f"{name}: PLY header has no format line")
    return fmt, elements, comments, m.end()


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


#: Bytes an ASCII PLY body may hold: number characters (``nan``, ``inf``, ``infinity``) and whitespace.
_ASCII_OK = np.zeros(256, np.bool_)
_ASCII_OK[np.frombuffer(b"0123456789eE+-.nNaAiIfFtTyY \t\r\n", np.uint8)] = True


@njit(cache=True)
def _ascii_lines(buf, start, n_lines, ok):  # noqa: ANN001, ANN202 - numba
    """The non-blank lines of an ASCII PLY body: body line index, first token, token count; bad byte or -1.

    Tokens are runs of bytes other than space, tab, CR and LF; a line ends at LF
    (a CR before it is whitespace) or at the end of the data. At most
    ``n_lines`` lines are found (the scan stops there).
    """
    line_no = np.empty(n_lines, np.int64)
    first = np.empty(n_lines, np.int64)
    ntok = np.empty(n_lines, np.int64)
    k = 0
    line = 0
    tokens = 0
    cnt = 0
    in_tok = False
    for i in range(start, buf.shape[0]):
        b = buf[i]
        if b == 10:
            if cnt > 0:
                line_no[k] = line
                first[k] = tokens - cnt
                ntok[k] = cnt
                k += 1
                if k == n_lines:
                    return line_no, first, ntok, -1
            line += 1
            cnt = 0
            in_tok = False
        elif b == 32 or b == 9 or b == 13:
            in_tok = False
        elif not ok[b]:
            return line_no[:k], first[:k], ntok[:k], i
        elif not in_tok:
            in_tok = True
            cnt += 1
            tokens += 1
    if cnt > 0:
        line_no[k] = line
        first[k] = tokens - cnt
        ntok[k] = cnt
        k += 1
    return line_no[:k], first[:k], ntok[:k], -1


#: The powers of ten a double holds exactly (10^0 .. 10^22): the exact fast path of :func:`_ascii_values`.
_POW10 = np.array([10.0**k for k in range(23)])


@njit(cache=True)
def _push(a, n, v):  # noqa: ANN001, ANN202 - numba
    """``a`` with ``v`` stored at ``n`` (grown by doubling when full)."""
    if n == a.shape[0]:
        b = np.empty(2 * a.shape[0], a.dtype)
        b[:n] = a
        a = b
    a[n] = v
    return a


@njit(cache=True)
def _ascii_values(buf, start, n_tok, pow10):  # noqa: ANN001, ANN202 - numba
    """The ``n_tok`` tokens of an ASCII PLY body as numbers, where an exact fast path applies.

    A token ``[+-]digits[.digits][(e|E)[+-]digits]`` whose digits make an
    integer ``m < 2^53`` and whose decimal exponent ``k`` has ``|k| <= 22`` is
    ``m * 10^k`` or ``m / 10^-k``: one correctly rounded operation on two
    exact doubles, so the value is the correctly rounded one (Clinger's fast
    path), as a C library's ``strtod`` gives. Every other token (more
    digits, larger exponents, ``nan``, ``inf``, anything malformed) is left
    to the caller: its index, first and last byte are returned.
    """
    out = np.empty(n_tok, np.float64)
    fb_tok = np.empty(16, np.int64)
    fb_a = np.empty(16, np.int64)
    fb_b = np.empty(16, np.int64)
    n_fb = 0
    limit = 9007199254740992  # 2^53
    k = 0
    i = start
    n = buf.shape[0]
    while k < n_tok:
        while i < n and (buf[i] == 32 or buf[i] == 9 or buf[i] == 13 or buf[i] == 10):
            i += 1
        a = i
        while i < n and not (buf[i] == 32 or buf[i] == 9 or buf[i] == 13 or buf[i] == 10):
            i += 1
        b = i
        j = a
        neg = False
        if j < b and (buf[j] == 43 or buf[j] == 45):
            neg = buf[j] == 45
            j += 1
        m = 0
        ex = 0
        digits = 0
        ok = True
        while j < b and 48 <= buf[j] <= 57:
            m = m * 10 + (buf[j] - 48)
            digits += 1
            j += 1
            if m >= limit:
                ok = False
                break
        if ok and j < b and buf[j] == 46:
            j += 1
            while j < b and 48 <= buf[j] <= 57:
                m = m * 10 + (buf[j] - 48)
                digits += 1
                ex -= 1
                j += 1
                if m >= limit:
                    ok = False
                    break
        if ok and digits > 0 and j < b and (buf[j] == 101 or buf[j] == 69):
            j += 1
            eneg = False
            if j < b and (buf[j] == 43 or buf[j] == 45):
                eneg = buf[j] == 45
                j += 1
            e = 0
            ed = 0
            while j < b and 48 <= buf[j] <= 57 and e < 100000:
                e = e * 10 + (buf[j] - 48)
                ed += 1
                j += 1
            if ed == 0:
                ok = False
            ex += -e if eneg else e
        if ok and digits > 0 and j == b and -22 <= ex <= 22:
            v = float(m)
            if ex > 0:
                v = v * pow10[ex]
            elif ex < 0:
                v = v / pow10[-ex]
            out[k] = -v if neg else v
        else:
            out[k] = np.nan
            fb_tok = _push(fb_tok, n_fb, k)
            fb_a = _push(fb_a, n_fb, a)
            fb_b = _push(fb_b, n_fb, b)
            n_fb += 1
        k += 1
    return out, fb_tok[:n_fb], fb_a[:n_fb], fb_b[:n_fb]


@njit(cache=True)
def _ascii_list_records(tok, first, ntok, lo, count, is_list):  # noqa: ANN001, ANN202 - numba
    """Token offsets and list lengths of ``count`` one-line records from non-blank line ``lo``.

    Returns offsets ``(count, nprops)``, lengths, and the first bad record with
    what was wrong: ``(record, kind, expected)``, kind 0 (none), 1 (``expected``
    values), 2 (at least ``expected`` values: the line ends before a list's
    count), 3 (a list count that is not a count; ``expected`` is the property).
    """
    npr = is_list.shape[0]
    offs = np.empty((count, npr), np.int64)
    lens = np.zeros((count, npr), np.int64)
    for r in range(count):
        pos = first[lo + r]
        end = pos + ntok[lo + r]
        need = 0  # values the record needs so far
        for p in range(npr):
            offs[r, p] = pos + need
            if is_list[p]:
                if pos + need >= end:
                    return offs, lens, r, 2, need + npr - p
                c = tok[pos + need]
                if not (c >= 0 and c <= 1e15 and c == math.floor(c)):
                    return offs, lens, r, 3, p
                lens[r, p] = int(c)
                need += 1 + int(c)
            else:
                need += 1
        if need != end - pos:
            return offs, lens, r, 1, need
    return offs, lens, -1, 0, 0


@dataclass
class _AsciiBody:
    """An ASCII PLY body: every value, and its non-blank lines (body line index, first value, count)."""

    values: NDArray[np.float64]
    line_no: NDArray[np.int64]
    first: NDArray[np.int64]
    ntok: NDArray[np.int64]
    header_lines: int
    name: str

    def line(self, k: int) -> int:
        """The file's line number (from 1, counting the header) of non-blank body line ``k``."""
        return self.header_lines + int(self.line_no[k]) + 1


def _ascii_body(data: bytes, start: int, name: str, max_records: int) -> _AsciiBody:
    """Split an ASCII PLY body into values and lines; a :class:`MeshError` with the line of anything not a number.

    Only the first ``max_records + 1`` non-blank lines are read (the records
    the header declares and one to tell that more follow), so memory follows
    the declared counts and the file's size, whichever is smaller.
    """
    buf = np.frombuffer(data, dtype=np.uint8)
    header_lines = data.count(b"\n", 0, start)
    # the lines the records need, and one more to tell data after the last record
    cap = min(data.count(b"\n", start) + 1, max_records + 1)
    line_no, first, ntok, bad = _ascii_lines(buf, start, cap, _ASCII_OK)
    if bad >= 0:
        lineno = header_lines + data.count(b"\n", start, bad) + 1
        ls = data.rfind(b"\n", 0, bad) + 1
        text = data[ls:ls + 80].split(b"\n")[0].decode("ascii", "replace").strip()
        if text.startswith("comment") or text.startswith("obj_info"):
            raise MeshError(f"{name}: line {lineno}: a comment in the data (PLY comments belong in the header)")
        raise MeshError(f"{name}: line {lineno}: {data[bad:bad + 1].decode('ascii', 'replace')!r} is not part "
                        f"of a number ({text!r:.60})")
    n_tok = int(first[-1] + ntok[-1]) if first.size else 0
    values, fb_tok, fb_a, fb_b = _ascii_values(buf, start, n_tok, _POW10)
    for t, a, b in zip(fb_tok.tolist(), fb_a.tolist(), fb_b.tolist(), strict=True):
        try:
            values[t] = float(data[a:b])
        except ValueError:
            k = int(np.searchsorted(first, t, side="right")) - 1
            raise MeshError(f"{name}: line {header_lines + int(line_no[k]) + 1}: "
                            f"{data[a:b].decode('ascii', 'replace')!r:.40} is not a number") from None
    return _AsciiBody(values, line_no, first, ntok, header_lines, name)


def _read_ascii_element(el: _Element, body: _AsciiBody, lo: int) -> tuple[dict[str, Any], int]:
    """Read ``el``'s records, one a non-blank line from line ``lo``; the next line's index.

    Every record must be one line with exactly the values its properties need
    (a list: its count, then that many items); a :class:`MeshError` names the
    file, line, element, record and what was wrong.
    """
    name = body.name
    n_lines = body.first.size
    avail = min(el.count, n_lines - lo)
    out: dict[str, Any] = {}
    where = f"element {el.name!r} record"
    if not el.props:
        return out, lo  # records of no values: nothing on any line
    if not el.has_lists:
        n_props = len(el.props)
        bad = np.flatnonzero(body.ntok[lo:lo + avail] != n_props)
        if bad.size:
            r = int(bad[0])
            raise MeshError(f"{name}: line {body.line(lo + r)}: {where} {r}: expected {n_props} values, found "
                            f"{int(body.ntok[lo + r])}")
        _check_complete(el, body, lo, avail)
        s = int(body.first[lo]) if el.count else 0
        a = body.values[s:s + n_props * el.count].reshape(el.count, n_props)
        for i, p in enumerate(el.props):
            out[p.name] = a[:, i]
        return out, lo + el.count
    is_list = np.array([p.count_dtype is not None for p in el.props])
    offs, lens, r, kind, exp = _ascii_list_records(body.values, body.first, body.ntok, lo, avail, is_list)
    if kind:
        found = int(body.ntok[lo + r])
        at = f"{name}: line {body.line(lo + r)}: {where} {r}"
        if kind == 3:
            c = body.values[int(offs[r, exp])]
            raise MeshError(f"{at}: the count of list {el.props[exp].name!r} is {c:g}, not a whole number >= 0")
        if kind == 2:
            raise MeshError(f"{at}: expected at least {exp} values, found {found}")
        lists = ", ".join(f"{p.name}: {int(lens[r, i])} items" for i, p in enumerate(el.props)
                          if p.count_dtype is not None)
        raise MeshError(f"{at}: expected {exp} values ({lists}), found {found}")
    _check_complete(el, body, lo, avail)
    if el.count and all(p.count_dtype is None or np.all(lens[:, i] == lens[0, i]) for i, p in enumerate(el.props)):
        # every record has the same layout (the usual all-triangle faces): one reshape
        s = int(body.first[lo])
        rel = offs[0] - s
        block = body.values[s:s + el.count * int(body.ntok[lo])].reshape(el.count, -1)
        for i, p in enumerate(el.props):
            if p.count_dtype is None:
                out[p.name] = block[:, rel[i]]
            else:
                c = int(lens[0, i])
                out[p.name] = (block[:, rel[i] + 1:rel[i] + 1 + c].reshape(-1), lens[:, i])
        return out, lo + el.count
    for i, p in enumerate(el.props):
        if p.count_dtype is None:
            out[p.name] = body.values[offs[:, i]]
        else:
            items = _list_items(offs[:, i] + 1, lens[:, i], 1)
            out[p.name] = (body.values[items], lens[:, i])
    return out, lo + el.count


def _check_complete(el: _Element, body: _AsciiBody, lo: int, avail: int) -> None:
    if avail < el.count:
        last = f" (line {body.line(body.first.size - 1)})" if body.first.size else ""
        raise MeshError(f"{body.name}: element {el.name!r} declares {el.count} records, the data ends after "
                        f"{max(avail, 0)} of them{last}")


def _gather(buf: NDArray[np.uint8], offsets: NDArray[np.int64], dtype: np.dtype) -> NDArray[Any]:
    """Values of ``dtype`` at byte ``offsets`` of ``buf``."""
    size = dtype.itemsize
    idx = offsets[:, None] + np.arange(size)
    return np.ascontiguousarray(buf[idx]).view(dtype).reshape(-1)


def _list_items(starts: NDArray[np.int64], lens: NDArray[np.int64], step: int) -> NDArray[np.int64]:
    """Flat positions of every item of lists starting at ``starts`` (first item) with ``lens`` items."""
    total = int(lens.sum())
    rec = np.repeat(np.arange(lens.size), lens)
    first = np.r_[0, np.cumsum(lens)[:-1]]
    j = np.arange(total) - first[rec]
    return starts[rec] + j * step


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
