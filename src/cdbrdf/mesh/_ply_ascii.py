"""ASCII PLY bodies for :mod:`cdbrdf.mesh._ply` (private): one record a line, as PLY defines it.

One numba pass over the bytes finds every non-blank line and its values (and
the first byte that cannot be part of a number), a second converts the
values (exactly, through Clinger's fast path, for up to 15 significant
digits and decimal exponents within +-22; Python's ``float`` for the rest),
and each element's records are checked to be one line each with exactly the
values their properties need (a list: its count, then that many items).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .._jit import njit
from ..errors import MeshError
from ._ply_format import _Element, _list_items

__all__: list[str] = []


#: Bytes an ASCII PLY body may hold: number characters (``nan``, ``inf``, ``infinity``) and whitespace.
_ASCII_OK = np.zeros(256, np.bool_)
_ASCII_OK[np.frombuffer(b"0123456789eE+-.nNaAiIfFtTyY \t\r\n", np.uint8)] = True

#: The powers of ten a double holds exactly (10^0 .. 10^22): the exact fast path of :func:`_ascii_values`.
_POW10 = np.array([10.0**k for k in range(23)])


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
