"""Checks of HDF5 structures that the HDF5 library itself would trust (used by :mod:`cdbrdf.io`).

HDF5 loops forever, or allocates without bound, on some damaged structures
that carry no checksum: global heaps (variable-length strings, dimension
lists), the raw references of variable-length strings, and chunk addresses
beyond the end of a truncated file. The functions here look at those
structures in the file's bytes, without trusting them, before h5py reads
anything; each problem is a :class:`~cdbrdf.errors.FormatError` naming the
file (:func:`fail`).
"""

from __future__ import annotations

import math
import mmap
from dataclasses import dataclass, field
from os import PathLike
from pathlib import Path
from typing import Any

from .errors import FormatError

__all__ = [
    "Heaps",
    "UnsureError",
    "fail",
    "one_line",
    "superblock_version",
    "check_global_heaps",
    "walk_global_heaps",
    "check_vlen_refs",
    "check_storage",
]

_HDF5_SIGNATURE = b"\x89HDF\r\n\x1a\n"


def fail(path: Path, msg: str) -> FormatError:
    """The :class:`FormatError` for ``path``: its message starts with the path."""
    return FormatError(f"{path}: {msg}")


def one_line(exc: BaseException) -> str:
    """``exc`` as one line of at most about 200 characters, with its class name (for messages)."""
    text = " ".join(str(exc).split())
    return f"{type(exc).__name__}: {text[:200]}" if text else type(exc).__name__


def superblock_version(path: str | PathLike[str]) -> int | None:
    """The HDF5 superblock version of ``path``, or None when it is not HDF5.

    The superblock is searched where HDF5 searches it: at byte 0, 512, 1024,
    2048... Versions 2 and 3 carry checksums of all file metadata; 0 and 1
    (HDF5 < 1.8 layout, the default of most writers) do not.

    Parameters
    ----------
    path
        The file.

    Returns
    -------
    int or None
        The version, None when no superblock is found.
    """
    with open(path, "rb") as fh:
        size = fh.seek(0, 2)
        offset = 0
        while offset + 9 <= size:
            fh.seek(offset)
            head = fh.read(9)
            if head[:8] == _HDF5_SIGNATURE:
                return head[8]
            offset = 512 if offset == 0 else offset * 2
    return None


class UnsureError(Exception):
    """The in-process reader met something only the time-limited child may read."""


@dataclass
class Heaps:
    """Result of :func:`check_global_heaps`."""

    #: "ok", "unsure" or a description of the damage
    status: str
    #: heap address -> {object index: object size}
    objects: dict[int, dict[int, int]] = field(default_factory=dict)
    #: size of file addresses (superblock)
    n_off: int = 8


def check_global_heaps(path: Path) -> Heaps:
    """Whether every HDF5 global heap collection in the file parses to its end.

    Global heaps (which hold variable-length strings and the dimension lists of
    NetCDF-4 files) have no checksum even in the newest HDF5 format, and HDF5
    loops forever on a collection whose object sizes do not advance (e.g. a
    zeroed block). This walks every ``GCOL`` block as HDF5 does, in Python,
    without trusting it.

    Returns
    -------
    Heaps
        ``status`` ``"ok"`` (with every heap object's size); ``"unsure"``
        when something may or may not be a damaged heap (or the superblock is
        not v2/v3); otherwise a description of the damage, for the message.
    """
    with open(path, "rb") as fh, mmap.mmap(fh.fileno(), 0, access=mmap.ACCESS_READ) as buf:
        return walk_global_heaps(buf)


def walk_global_heaps(buf: Any) -> Heaps:
    """:func:`check_global_heaps` on the file's bytes (``bytes`` or ``mmap``)."""
    sb = buf.find(_HDF5_SIGNATURE)
    if sb < 0 or sb + 11 > len(buf) or buf[sb + 8] not in (2, 3):
        return Heaps("unsure")
    n_off, n_len = buf[sb + 9], buf[sb + 10]  # sizes of addresses and lengths (v2/v3 superblock)
    if n_len not in (2, 4, 8) or n_off not in (2, 4, 8):
        return Heaps("unsure")
    heaps = Heaps("ok", n_off=n_off)
    obj_hdr = 8 + n_len
    pos = buf.find(b"GCOL\x01")
    while pos >= 0:
        # HDF5 takes any "GCOL", version 1 as a heap; with the zero reserved
        # bytes too it is certainly one (and not a chance match in the data)
        certain = buf[pos + 5 : pos + 8] == b"\0\0\0"
        bad = ""
        size = int.from_bytes(buf[pos + 8 : pos + 8 + n_len], "little")
        end = pos + size
        if pos + 8 + n_len > len(buf) or end > len(buf):
            bad = f"the global heap at byte {pos} runs past the end of the file"
        elif size < 4096:
            bad = f"the global heap at byte {pos} declares an impossible size {size}"
        p = pos + 8 + n_len
        objects: dict[int, int] = {}
        while not bad and p < end:
            if p + obj_hdr > end:
                break  # a tail too small for an object header is free space
            idx = int.from_bytes(buf[p : p + 2], "little")
            osize = int.from_bytes(buf[p + 8 : p + 8 + n_len], "little")
            need = osize if idx == 0 else obj_hdr + ((osize + 7) & ~7)
            if need <= 0 or p + need > end:
                bad = f"the global heap at byte {pos} has a damaged object at byte {p}"
            elif idx:
                objects[idx] = osize
            p += need
        if bad:
            return Heaps(bad if certain else "unsure")
        heaps.objects[pos - sb] = objects  # heap addresses are relative to the superblock
        pos = buf.find(b"GCOL\x01", pos + 1)
    return heaps


def check_vlen_refs(path: Path, ds: Any, name: str, heaps: Heaps) -> None:
    """Check the global-heap references of a variable-length string dataset before HDF5 follows them.

    Its raw data (length, heap address, object index per element) has no
    checksum; a damaged length or address makes HDF5 allocate gigabytes or
    read a heap that was never checked.
    """
    offset = ds.id.get_offset()
    if offset is None or ds.id.get_storage_size() != ds.size * (8 + heaps.n_off):
        raise UnsureError(name)  # not contiguous as save() writes it: let the child read it
    with open(path, "rb") as fh:
        fh.seek(offset)
        raw = fh.read(ds.size * (8 + heaps.n_off))
    step = 8 + heaps.n_off
    if len(raw) != ds.size * step:
        raise fail(path, f"{name!r} has data stored beyond the end of the file: the file is truncated or damaged")
    for i in range(ds.size):
        e = raw[i * step : (i + 1) * step]
        length = int.from_bytes(e[:4], "little")
        addr = int.from_bytes(e[4 : 4 + heaps.n_off], "little")
        idx = int.from_bytes(e[4 + heaps.n_off :], "little")
        size = heaps.objects.get(addr, {}).get(idx)
        if size is None or length > size:
            raise fail(path, f"{name!r} entry {i} points at no stored string: the file is damaged")


def check_storage(path: Path, ds: Any, name: str, file_size: int) -> None:
    """Refuse a dataset whose stored pieces lie outside the file (before reading them)."""
    dsid = ds.id
    if ds.chunks is not None:
        expected = math.prod(-(-n // c) for n, c in zip(ds.shape, ds.chunks, strict=True))
        pieces: list[tuple[int, int]] = []
        if hasattr(dsid, "chunk_iter"):
            dsid.chunk_iter(lambda info: pieces.append((info.byte_offset, info.size)))
        else:  # pragma: no cover - old HDF5
            n = dsid.get_num_chunks()
            if n > expected:
                raise fail(path, f"{name!r} has {n} chunks stored, at most {expected} fit its shape")
            for i in range(n):
                info = dsid.get_chunk_info(i)
                pieces.append((info.byte_offset, info.size))
        if len(pieces) > expected:
            raise fail(path, f"{name!r} has {len(pieces)} chunks stored, at most {expected} fit its shape")
    else:
        offset = dsid.get_offset()
        pieces = [] if offset is None else [(offset, dsid.get_storage_size())]
    for offset, size in pieces:
        if offset is None or offset < 0 or size < 0 or offset + size > file_size:
            raise fail(path, f"{name!r} has data stored beyond the end of the file: the file is truncated or damaged")
