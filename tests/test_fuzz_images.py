"""Fuzzing the photograph readers (:mod:`cdbrdf.images`) with :mod:`fuzzing`.

Mutated PNG (8/16 bit; grey, grey+alpha, RGB, RGBA; one image over several
IDAT chunks), TIFF (uncompressed strips, deflate strips and tiles, float32)
and OpenEXR (float RGB, half grey) files go through :func:`read_image` and
:func:`read_window`. Targets:

- only :mod:`cdbrdf.errors` classes (and :class:`FileNotFoundError`) raised;
- no crash and no hang (10 s per input);
- :func:`read_window` rejects every file :func:`read_image` rejects, and
  returns the same pixels as a slice of the whole image otherwise;
- PNG: no silently changed value (chunk CRCs and zlib's Adler-32 protect the
  data: a PNG that decodes must equal its seed). TIFF and OpenEXR carry no
  checksums, so changed values there are a limitation of the format: they
  are counted, not refused.

The default run tries a few hundred inputs per format; ``-m slow`` tries
100,000 in all (print the figures with ``-s``).
"""

from __future__ import annotations

import functools
import logging
import struct
import tempfile
import zlib
from pathlib import Path

import numpy as np
import pytest

from cdbrdf.errors import CDBRDFError
from cdbrdf.images import read_image, read_window, write_exr, write_png, write_tiff
from tests.fuzzing import fuzz

__all__ = ["target_png", "target_png_crafted", "target_tiff", "target_exr"]

_ALLOWED = (CDBRDFError, FileNotFoundError)
logging.getLogger("tifffile").setLevel(logging.CRITICAL)  # its warnings about every broken tag
_WINDOW = (1, 2, 3, 4)  # x0, y0, nx, ny


@functools.cache
def _seeds(fmt: str) -> tuple[tuple[np.ndarray, bytes], ...]:
    """``(image, file bytes)`` of the seed files of a format; shapes differ between seeds."""
    rng = np.random.default_rng(7)

    def img(shape, dtype):
        if np.dtype(dtype).kind == "f":
            return (rng.random(shape) * 4).astype(dtype)
        return rng.integers(0, np.iinfo(dtype).max + 1, shape).astype(dtype)

    out = []
    with tempfile.TemporaryDirectory() as tmp:
        p = Path(tmp) / f"seed.{'tif' if fmt == 'tiff' else fmt}"
        if fmt == "png":
            specs = [((9, 11), np.uint8), ((10, 12), np.uint16), ((11, 9, 2), np.uint16),
                     ((12, 10, 3), np.uint8), ((13, 11, 3), np.uint16), ((8, 14, 4), np.uint8),
                     ((9, 13, 4), np.uint16), ((48, 40, 3), np.uint16)]  # the last: 2 IDAT chunks
            for shape, dtype in specs:
                a = img(shape, dtype)
                if shape == (12, 10, 3):
                    a[:6] = 17  # compressible rows
                write_png(p, a)
                out.append((a, p.read_bytes()))
        elif fmt == "tiff":
            specs = [((9, 11, 3), np.uint16, {"compression": None}),
                     ((10, 12), np.uint8, {"compression": "zlib"}),
                     ((11, 9, 3), np.float32, {"compression": None}),
                     ((32, 32, 3), np.uint16, {"compression": "zlib", "tile": (16, 16)})]
            for shape, dtype, kw in specs:
                a = img(shape, dtype)
                write_tiff(p, a, **kw)
                out.append((a, p.read_bytes()))
        else:
            for shape in [(9, 11, 3), (12, 10)]:
                a = img(shape, np.float32)
                write_exr(p, a)
                out.append((a, p.read_bytes()))
    return tuple(out)


def _target(fmt: str, data: bytes, work: Path) -> str:
    p = work / f"in.{'tif' if fmt == 'tiff' else fmt}"
    p.write_bytes(data)
    try:
        full, info = read_image(p)
    except _ALLOWED:
        try:
            read_window(p, _WINDOW)
        except _ALLOWED:
            raise
        raise AssertionError("read_window accepted a file that read_image rejects") from None
    try:
        win, _ = read_window(p, _WINDOW)
    except _ALLOWED as exc:
        if (info.width, info.height) >= (4, 6):  # the window fits: no reason to refuse
            raise AssertionError(f"read_window rejects a file that read_image accepts ({exc})") from None
        return "ok"
    x0, y0, nx, ny = _WINDOW
    if not np.array_equal(win, full[y0 : y0 + ny, x0 : x0 + nx], equal_nan=full.dtype.kind == "f"):
        raise AssertionError("read_window differs from read_image")
    for a, _ in _seeds(fmt):
        ref = a[..., None] if a.ndim == 2 else a
        ref = ref[..., : 1 if ref.shape[-1] <= 2 else 3]
        if ref.shape == full.shape and ref.dtype == full.dtype:
            return "ok" if np.array_equal(ref, full) else "changed"
    return "changed"


def target_png(data: bytes, work: Path) -> str:
    """Fuzz target: one mutated PNG."""
    return _target("png", data, work)


def _fix_idat_crcs(data: bytes) -> bytes:
    """``data`` with the CRC of every IDAT chunk recomputed (as a crafted file would have)."""
    b = bytearray(data)
    pos = 8
    while pos + 12 <= len(b):
        (n,) = struct.unpack(">I", b[pos : pos + 4])
        end = pos + 8 + n
        if end + 4 > len(b):
            break
        if b[pos + 4 : pos + 8] == b"IDAT":
            b[end : end + 4] = struct.pack(">I", zlib.crc32(bytes(b[pos + 4 : end])))
        pos = end + 4
    return bytes(b)


def target_png_crafted(data: bytes, work: Path) -> str:
    """Fuzz target: one mutated PNG whose IDAT CRCs were recomputed, so that the
    mutations reach libpng's inflate and unfilter (the zlib Adler-32 still guards the data)."""
    return _target("png", _fix_idat_crcs(data), work)


def target_tiff(data: bytes, work: Path) -> str:
    """Fuzz target: one mutated TIFF."""
    return _target("tiff", data, work)


def target_exr(data: bytes, work: Path) -> str:
    """Fuzz target: one mutated OpenEXR file."""
    return _target("exr", data, work)


def _run(fmt: str, n: int, seed: int):
    seeds = [b for _, b in _seeds(fmt.split("_")[0])]
    report = fuzz(f"tests.test_fuzz_images:target_{fmt}", seeds, n=n, seed=seed,
                  per_input_s=10.0, allowed=_ALLOWED)
    print(f"\n{fmt}: {report.summary()}")
    for i, outcome, detail in report.bad:
        if outcome != "changed":
            print(f"  #{i} {outcome}: {detail}")
    assert report.n == n
    bad = [b for b in report.bad if fmt.startswith("png") or b[1] != "changed"]
    assert not bad, report.summary()
    return report


def test_seeds_read_back():
    for fmt in ("png", "tiff", "exr"):
        for _, data in _seeds(fmt):
            with tempfile.TemporaryDirectory() as tmp:
                assert _target(fmt, data, Path(tmp)) == "ok"


@pytest.mark.parametrize("fmt, n", [("png", 150), ("png_crafted", 150), ("tiff", 200), ("exr", 150)])
def test_fuzz_images_quick(fmt, n):
    _run(fmt, n, seed=1)


@pytest.mark.slow
@pytest.mark.parametrize("fmt, n", [("png", 25_000), ("png_crafted", 25_000), ("tiff", 30_000),
                                    ("exr", 20_000)])
def test_fuzz_images_long(fmt, n):
    _run(fmt, n, seed=2)
