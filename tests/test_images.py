"""Readers and writers of cdbrdf.images: bit depth kept, windows, corrupt files."""

from __future__ import annotations

import struct
import zlib

import numpy as np
import pytest
from PIL import Image

from cdbrdf.errors import LimitError
from cdbrdf.images import (
    ImageError,
    image_format,
    read_image,
    read_window,
    write_exr,
    write_png,
    write_tiff,
)


@pytest.fixture
def rgb16():
    rng = np.random.default_rng(1)
    return rng.integers(0, 65536, (37, 29, 3), dtype=np.uint16)


def test_png16_keeps_16_bits(tmp_path, rgb16):
    p = tmp_path / "a.png"
    write_png(p, rgb16)
    a, info = read_image(p)
    assert a.dtype == np.uint16 and info.max_code == 65535
    np.testing.assert_array_equal(a, rgb16)
    # a reader that reduced to 8 bits would give multiples of 257 only
    assert np.any(a % 257 != 0)


@pytest.mark.parametrize("channels", [1, 2, 3, 4])
@pytest.mark.parametrize("dtype", [np.uint8, np.uint16])
def test_png_round_trip_channels(tmp_path, channels, dtype):
    rng = np.random.default_rng(channels)
    img = rng.integers(0, np.iinfo(dtype).max + 1, (9, 11, channels)).astype(dtype)
    p = tmp_path / "c.png"
    write_png(p, img)
    a, info = read_image(p)
    keep = 1 if channels <= 2 else 3
    assert info.channels == keep
    np.testing.assert_array_equal(a, img[..., :keep])


def test_png_all_filter_types(tmp_path):
    """A PNG written by Pillow with optimisation uses Sub/Up/Average/Paeth filters."""
    rng = np.random.default_rng(3)
    img = (np.add.outer(np.arange(40), np.arange(30))[..., None] * [1, 2, 3] % 256).astype(np.uint8)
    img = (img + rng.integers(0, 3, img.shape)).astype(np.uint8)
    p = tmp_path / "f.png"
    Image.fromarray(img).save(p, optimize=True)
    a, _ = read_image(p)
    np.testing.assert_array_equal(a, img)


def test_png_window(tmp_path, rgb16):
    p = tmp_path / "w.png"
    write_png(p, rgb16)
    a, info = read_window(p, (4, 6, 5, 3))
    np.testing.assert_array_equal(a, rgb16[6:9, 4:9])
    a, _ = read_window(p, lambda inf: (inf.width - 2, inf.height - 2, 2, 2))
    np.testing.assert_array_equal(a, rgb16[-2:, -2:])


@pytest.mark.parametrize("window", [(0, 0, 1), (0, 0, 1, 1, 1), (float("nan"), 0, 1, 1), (0.5, 0, 1, 1),
                                    (True, 0, 1, 1), ("0", 0, 1, 1), None, 5, (0, 0, 1e300, 1)])
def test_malformed_window_is_an_option_error(tmp_path, rgb16, window):
    from cdbrdf.errors import OptionError

    p = tmp_path / "w.png"
    write_png(p, rgb16)
    with pytest.raises(OptionError, match=r"^window: expected four whole numbers \(x0, y0, nx, ny\)"):
        read_window(p, window)
    with pytest.raises(OptionError, match="^window: expected four whole numbers"):
        read_window(p, lambda info: window)  # a function returning a bad window
    a, _ = read_window(p, (np.int64(1), 2.0, 3, np.uint8(2)))  # any whole numbers
    np.testing.assert_array_equal(a, rgb16[2:4, 1:4])


def test_writers_refuse_bad_arrays_with_an_option_error(tmp_path):
    from cdbrdf.errors import OptionError

    for bad, match in ((np.zeros((4, 4, 3)), "image: expected uint8 or uint16, got float64"),
                       (np.zeros(4, np.uint8), r"image: expected \(h, w\[, 1-4\]\) pixels, got shape \(4,\)")):
        with pytest.raises(OptionError, match=match):
            write_png(tmp_path / "a.png", bad)
    with pytest.raises(OptionError, match="level: expected 0 to 9"):
        write_png(tmp_path / "a.png", np.zeros((4, 4), np.uint8), level=11)
    with pytest.raises(OptionError, match="image: expected 1 or 3 channels"):
        write_exr(tmp_path / "a.exr", np.zeros((4, 4, 2)))
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("tile", [None, (16, 16)])
@pytest.mark.parametrize("compression", [None, "zlib"])
def test_tiff_window(tmp_path, rgb16, tile, compression):
    p = tmp_path / "t.tif"
    write_tiff(p, rgb16, tile=tile, compression=compression)
    for win in [(0, 0, 29, 37), (3, 5, 7, 7), (20, 30, 9, 7), (15, 14, 3, 4)]:
        x0, y0, nx, ny = win
        a, info = read_window(p, win)
        assert info.max_code == 65535 and not info.linear
        np.testing.assert_array_equal(a, rgb16[y0 : y0 + ny, x0 : x0 + nx])
    full, _ = read_image(p)
    np.testing.assert_array_equal(full, rgb16)


def test_tiff_grey_and_float(tmp_path):
    g = np.arange(12 * 10, dtype=np.uint8).reshape(12, 10)
    write_tiff(tmp_path / "g.tif", g)
    a, info = read_window(tmp_path / "g.tif", (2, 3, 4, 5))
    assert info.channels == 1 and info.max_code == 255
    np.testing.assert_array_equal(a[..., 0], g[3:8, 2:6])
    f = np.random.default_rng(0).random((8, 9, 3)).astype(np.float32)
    write_tiff(tmp_path / "f.tif", f)
    a, info = read_window(tmp_path / "f.tif", (1, 2, 3, 4))
    assert info.linear and info.max_code is None
    np.testing.assert_array_equal(a, f[2:6, 1:4])


def test_exr_window(tmp_path):
    f = np.random.default_rng(2).random((21, 17, 3)).astype(np.float32) * 40
    p = tmp_path / "e.exr"
    write_exr(p, f)
    a, info = read_window(p, (3, 4, 5, 6))
    assert info.linear and info.max_code is None and (info.width, info.height) == (17, 21)
    np.testing.assert_array_equal(a, f[4:10, 3:8])
    full, _ = read_image(p)
    np.testing.assert_array_equal(full, f)


def test_missing_file(tmp_path):
    for ext in ("png", "tif", "exr"):
        with pytest.raises(FileNotFoundError, match=f"nope.{ext}"):
            read_window(tmp_path / f"nope.{ext}", (0, 0, 1, 1))


def test_unsupported_extension(tmp_path):
    with pytest.raises(ImageError, match="unsupported image type '.jpg'"):
        image_format(tmp_path / "x.jpg")


def _corrupt(tmp_path, rgb16):
    p = tmp_path / "c.png"
    write_png(p, rgb16)
    data = bytearray(p.read_bytes())
    return p, data


def test_corrupt_png_crc(tmp_path, rgb16):
    p, data = _corrupt(tmp_path, rgb16)
    data[60] ^= 0xFF  # inside the IDAT body
    p.write_bytes(bytes(data))
    with pytest.raises(ImageError, match=r"c\.png: corrupt"):
        read_image(p)


def test_truncated_png(tmp_path, rgb16):
    p, data = _corrupt(tmp_path, rgb16)
    p.write_bytes(bytes(data[: len(data) // 2]))
    with pytest.raises(ImageError, match=r"c\.png.*truncated"):
        read_window(p, (0, 0, 2, 2))


def test_png_bad_stream(tmp_path):
    """Valid chunks around a zlib stream that is not one."""
    import struct

    def chunk(t, b):
        return struct.pack(">I", len(b)) + t + b + struct.pack(">I", zlib.crc32(b, zlib.crc32(t)))

    body = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", 4, 4, 8, 2, 0, 0, 0))
    body += chunk(b"IDAT", b"not zlib at all") + chunk(b"IEND", b"")
    p = tmp_path / "z.png"
    p.write_bytes(body)
    with pytest.raises(ImageError, match=r"z\.png: corrupt or unsupported PNG file \(PngError"):
        read_image(p)


def test_garbage_files(tmp_path):
    for ext in ("png", "tif", "exr"):
        p = tmp_path / f"g.{ext}"
        p.write_bytes(b"this is not an image" * 10)
        with pytest.raises(ImageError, match=f"g.{ext}"):
            read_window(p, (0, 0, 1, 1))


def test_window_outside_image(tmp_path, rgb16):
    p = tmp_path / "o.png"
    write_png(p, rgb16)
    with pytest.raises(ImageError, match="does not lie inside the 29 x 37 image"):
        read_window(p, (25, 0, 7, 7))


@pytest.mark.parametrize("byteorder", ["<", ">"])
@pytest.mark.parametrize("rowsperstrip", [1, 4, None])
def test_tiff_strips_and_byte_order(tmp_path, rgb16, byteorder, rowsperstrip, monkeypatch):
    """Uncompressed contiguous TIFF: the window is memory-mapped, either byte order, 8 and 16 bit."""
    import tifffile


    for img in (rgb16, (rgb16 >> 8).astype(np.uint8)):
        p = tmp_path / "s.tif"
        tifffile.imwrite(p, img, photometric="rgb", byteorder=byteorder, rowsperstrip=rowsperstrip)
        with monkeypatch.context() as m:
            m.setattr(tifffile.TiffPage, "asarray", lambda *a, **k: pytest.fail("decoded the whole TIFF"))
            a, info = read_window(p, (2, 3, 11, 13))
        np.testing.assert_array_equal(a, img[3:16, 2:13])
        assert a.dtype.isnative and info.max_code == np.iinfo(img.dtype).max


def test_tiff_planar_separate(tmp_path, rgb16):
    import tifffile

    p = tmp_path / "p.tif"
    tifffile.imwrite(p, np.moveaxis(rgb16, -1, 0), photometric="rgb", planarconfig="separate")
    np.testing.assert_array_equal(read_image(p)[0], rgb16)
    np.testing.assert_array_equal(read_window(p, (3, 4, 5, 6))[0], rgb16[4:10, 3:8])


def test_palette_png_falls_back(tmp_path):
    img = (np.arange(12 * 10).reshape(12, 10) % 7).astype(np.uint8)
    im = Image.fromarray(img, mode="L").convert("P")
    p = tmp_path / "p.png"
    im.save(p)
    a, info = read_window(p, (1, 2, 3, 4))
    ref = np.asarray(Image.open(p).convert("RGB"))
    assert info.max_code == 255
    np.testing.assert_array_equal(a, ref[2:6, 1:4, : a.shape[-1]] if a.shape[-1] == 3 else ref[2:6, 1:4, :1])


@pytest.mark.parametrize("compression", ["zlib", "lzw", "zstd"])
@pytest.mark.parametrize("layout", [{"tile": (16, 16)}, {"rowsperstrip": 8}])
def test_compressed_tiff_window(tmp_path, rgb16, compression, layout):
    import tifffile

    p = tmp_path / "c.tif"
    # imagecodecs (a dependency) provides every codec here: a missing one is a failure
    tifffile.imwrite(p, rgb16, photometric="rgb", compression=compression, predictor=True, **layout)
    for win in [(3, 5, 7, 7), (14, 14, 5, 6), (0, 30, 29, 7)]:
        x0, y0, nx, ny = win
        a, _ = read_window(p, win)
        np.testing.assert_array_equal(a, rgb16[y0 : y0 + ny, x0 : x0 + nx])


def test_truncated_tiff_and_exr(tmp_path):
    a = np.random.default_rng(5).random((64, 64, 3)).astype(np.float32)
    write_exr(tmp_path / "t.exr", a)
    write_tiff(tmp_path / "t.tif", (a * 60000).astype(np.uint16))
    for name in ("t.exr", "t.tif"):
        p = tmp_path / name
        data = p.read_bytes()
        p.write_bytes(data[: len(data) // 3])
        with pytest.raises(ImageError, match=name):
            read_window(p, (30, 30, 7, 7))


# --------------------------------------------------------------------------- hardening
def _chunk(kind: bytes, body: bytes) -> bytes:
    return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body))


def _png_with_size(w: int, h: int) -> bytes:
    """A valid-looking PNG declaring ``w x h`` (8-bit grey) with a tiny IDAT."""
    return (b"\x89PNG\r\n\x1a\n" + _chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 0, 0, 0, 0))
            + _chunk(b"IDAT", zlib.compress(b"\x00" * 64)) + _chunk(b"IEND", b""))


@pytest.mark.parametrize("size", [(0, 10), (10, 0), (2**32 - 1, 1), (1, 2**32 - 1), (2**31, 2**31)])
def test_png_impossible_sizes_refused(tmp_path, size):
    p = tmp_path / "s.png"
    p.write_bytes(_png_with_size(*size))
    with pytest.raises(ImageError, match=r"s\.png"):
        read_image(p)
    with pytest.raises(ImageError, match=r"s\.png"):
        read_window(p, (0, 0, 1, 1))


def test_png_bomb_refused_before_decoding(tmp_path, monkeypatch):
    """12000 x 12000 in a few hundred bytes: refused by the limit, libpng never called."""
    from cdbrdf import images

    p = tmp_path / "bomb.png"
    p.write_bytes(_png_with_size(12000, 12000))
    monkeypatch.setattr(images, "_png_decode", lambda d: pytest.fail("decoded"))
    with pytest.raises(LimitError, match=r"bomb\.png: 12000 x 12000 image: 144,000,000 pixels .*CDBRDF_MAX_IMAGE_PIXELS"):
        read_image(p)
    monkeypatch.setenv("CDBRDF_MAX_IMAGE_PIXELS", "100")
    q = tmp_path / "small.png"
    write_png(q, np.zeros((11, 10), np.uint8))
    with pytest.raises(LimitError, match=r"small\.png: 10 x 11 image"):
        read_window(q, (0, 0, 1, 1))


def test_tiff_and_exr_sizes_refused(tmp_path, monkeypatch):
    write_tiff(tmp_path / "a.tif", np.zeros((20, 30, 3), np.uint16))
    write_exr(tmp_path / "a.exr", np.zeros((20, 30, 3), np.float32))
    monkeypatch.setenv("CDBRDF_MAX_IMAGE_PIXELS", "599")
    for name in ("a.tif", "a.exr"):
        with pytest.raises(LimitError, match=rf"{name}: 30 x 20 image: 600 pixels"):
            read_image(tmp_path / name)
    monkeypatch.setenv("CDBRDF_MAX_IMAGE_PIXELS", "600")
    for name in ("a.tif", "a.exr"):
        assert read_image(tmp_path / name)[0].shape == (20, 30, 3)


def test_tiff_declared_huge_size_refused(tmp_path):
    """Width and length tags rewritten to 65535 x 65535 (a 4-billion-pixel page)."""
    import tifffile

    p = tmp_path / "h.tif"
    tifffile.imwrite(p, np.zeros((4, 4), np.uint8))
    data = bytearray(p.read_bytes())
    with tifffile.TiffFile(p) as tf:
        tags = tf.pages.first.tags
        offs = [tags[256].valueoffset, tags[257].valueoffset]
    for o in offs:
        data[o : o + 2] = b"\xff\xff"
    p.write_bytes(bytes(data))
    with pytest.raises((LimitError, ImageError), match=r"h\.tif"):
        read_image(p)


def test_png_idat_bit_flip_with_recomputed_crc(tmp_path, rgb16):
    """A flipped bit in the zlib stream whose chunk CRC was recomputed: the Adler-32 catches it,
    and read_window rejects the file exactly as read_image does."""
    p = tmp_path / "f.png"
    write_png(p, rgb16)
    data = p.read_bytes()
    pos = data.index(b"IDAT") - 4
    (n,) = struct.unpack(">I", data[pos : pos + 4])
    rng = np.random.default_rng(0)
    for k in rng.integers(16, 8 * n, 40):
        b = bytearray(data)
        b[pos + 8 + k // 8] ^= 1 << int(k % 8)
        b[pos + 8 + n : pos + 12 + n] = struct.pack(">I", zlib.crc32(bytes(b[pos + 4 : pos + 8 + n])))
        p.write_bytes(bytes(b))
        outcomes = []
        for read in (read_image, lambda q: read_window(q, (10, 10, 7, 7))):
            try:
                a, _ = read(p)
                outcomes.append("ok")
                np.testing.assert_array_equal(a, rgb16 if a.shape == rgb16.shape else rgb16[10:17, 10:17])
            except ImageError:
                outcomes.append("error")
        assert outcomes[0] == outcomes[1]


def test_libpng_errors_do_not_leak_none(tmp_path, rgb16):
    """imagecodecs' png_decode drops a reference to None on each error; the reader gives it back."""
    import sys

    p = tmp_path / "f.png"
    write_png(p, rgb16)
    data = bytearray(p.read_bytes())
    pos = data.index(b"IDAT") - 4
    (n,) = struct.unpack(">I", data[pos : pos + 4])
    data[pos + 8 + n // 2] ^= 0x55
    data[pos + 8 + n : pos + 12 + n] = struct.pack(">I", zlib.crc32(bytes(data[pos + 4 : pos + 8 + n])))
    p.write_bytes(bytes(data))
    import gc

    gc.collect()
    before = sys.getrefcount(None)
    for _ in range(2000):
        try:
            read_image(p)
        except ImageError as exc:
            assert "PngError" in str(exc)
    gc.collect()
    assert sys.getrefcount(None) >= before - 500  # without the repair: before - 2000


def test_every_failure_is_image_error(tmp_path, rgb16):
    import os

    folder = tmp_path / "dir.png"
    folder.mkdir()
    loop = tmp_path / "loop.tif"
    loop.symlink_to(tmp_path / "loop2.tif")
    (tmp_path / "loop2.tif").symlink_to(loop)
    cases = {folder: "is a folder", loop: "cannot open image file"}
    for ext in ("png", "tif", "exr"):
        empty = tmp_path / f"empty.{ext}"
        empty.write_bytes(b"")
        cases[empty] = f"empty.{ext}"
        foreign = tmp_path / f"foreign.{ext}"
        write_png(tmp_path / "x.png", rgb16) if ext != "png" else write_tiff(tmp_path / "x.tif", rgb16)
        foreign.write_bytes((tmp_path / ("x.png" if ext != "png" else "x.tif")).read_bytes())
        cases[foreign] = f"foreign.{ext}"
    if os.geteuid() != 0:  # root reads anything
        locked = tmp_path / "locked.png"
        write_png(locked, rgb16)
        locked.chmod(0)
        cases[locked] = "permission denied"
    for path, msg in cases.items():
        for read in (read_image, lambda q: read_window(q, (0, 0, 1, 1))):
            with pytest.raises(ImageError, match=msg) as info:
                read(path)
            assert "\n" not in str(info.value)


def test_unsupported_png_kinds(tmp_path):
    """Palette, low bit depth and interlaced PNG decode through libpng; 16-bit grey too."""
    img = (np.arange(12 * 10).reshape(12, 10) % 7 * 30).astype(np.uint8)
    p = tmp_path / "i.png"
    Image.fromarray(img).save(p, interlace=1)
    assert np.array_equal(read_image(p)[0][..., 0], img)
    Image.fromarray(img > 100).save(p)  # 1 bit
    a, info = read_image(p)
    assert info.max_code == 255 and set(np.unique(a)) <= {0, 255}


def test_window_errors_keep_their_type(tmp_path, rgb16):
    p = tmp_path / "w.png"
    write_png(p, rgb16)

    def bad(info):
        raise KeyError("mine")

    with pytest.raises(KeyError, match="mine"):
        read_window(p, bad)


def test_writers_are_atomic(tmp_path, rgb16):
    p = tmp_path / "a.png"
    write_png(p, rgb16)
    with pytest.raises(ValueError, match="expected uint8 or uint16"):
        write_png(p, rgb16.astype(np.float32))
    np.testing.assert_array_equal(read_image(p)[0], rgb16)
    assert sorted(f.name for f in tmp_path.iterdir()) == ["a.png"]


def test_png_adler_mismatch_refused(tmp_path, rgb16):
    """libpng only warns about a wrong Adler-32 once the rows are complete; the reader refuses it."""
    p = tmp_path / "a.png"
    write_png(p, rgb16)
    data = bytearray(p.read_bytes())
    pos = data.index(b"IEND") - 4 - 4  # the last IDAT's CRC
    data[pos - 1] ^= 0x01  # last byte of the zlib stream: the Adler-32
    start = data.rindex(b"IDAT")
    data[pos : pos + 4] = struct.pack(">I", zlib.crc32(bytes(data[start:pos])))
    p.write_bytes(bytes(data))
    for read in (read_image, lambda q: read_window(q, (0, 0, 2, 2))):
        with pytest.raises(ImageError, match=r"a\.png: .*IDAT: incorrect data check"):
            read(p)


def test_tiff_missing_strips_refused(tmp_path):
    """A TIFF declaring more rows than its strips hold: tifffile would pad with zeros; refused."""
    import tifffile

    p = tmp_path / "m.tif"
    tifffile.imwrite(p, np.ones((10, 12), np.uint8), compression="zlib")
    data = bytearray(p.read_bytes())
    with tifffile.TiffFile(p) as tf:
        o = tf.pages.first.tags[257].valueoffset  # ImageLength
    data[o : o + 2] = struct.pack("<H", 40)
    p.write_bytes(bytes(data))
    for read in (read_image, lambda q: read_window(q, (0, 0, 2, 2))):
        with pytest.raises(ImageError, match=r"m\.tif: truncated TIFF \(1 of 4 strips"):
            read(p)
