"""The PLY format for :mod:`cdbrdf.mesh._ply` (private): scalar types, the header, list items.

:func:`ply_header` parses the header (``ascii``, ``binary_little_endian``,
``binary_big_endian``; every scalar type; ``comment`` and ``obj_info``
lines; any elements) into :class:`_Element` s of :class:`_Prop` s.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from ..errors import MeshError

__all__ = ["HEADER_MAX_BYTES", "ply_header"]


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


def _list_items(starts: NDArray[np.int64], lens: NDArray[np.int64], step: int) -> NDArray[np.int64]:
    """Flat positions of every item of lists starting at ``starts`` (first item) with ``lens`` items."""
    total = int(lens.sum())
    rec = np.repeat(np.arange(lens.size), lens)
    first = np.r_[0, np.cumsum(lens)[:-1]]
    j = np.arange(total) - first[rec]
    return starts[rec] + j * step
