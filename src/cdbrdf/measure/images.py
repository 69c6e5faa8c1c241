"""Reading photographs: PNG, TIFF (8/16 bit, float) and OpenEXR, whole or a window.

Two entry points:

- :func:`read_image` decodes a whole image;
- :func:`read_window` returns only a rectangle of pixels and reads as little
  of the file as the format allows: the rows of an uncompressed TIFF (strips
  or tiles) are read with a few small ``pread`` calls, only the strips or
  tiles holding the window of a compressed TIFF are decoded (:mod:`tifffile`'s
  codecs), an OpenEXR file's scanlines are read for the window's rows only,
  and a PNG stream is inflated and unfiltered only down to the window's last
  row.

Both return the raw code values (``uint8``, ``uint16`` or ``float32``) with
shape ``(rows, cols, channels)``: grey images have one channel, an alpha
channel is dropped. :class:`ImageInfo` says how to interpret them: the
largest code (``255``/``65535``; ``None`` for float data) and whether the
format is linear by nature (float TIFF, EXR) or display-encoded (integer
data: sRGB unless the capture says linear).

PNG is decoded by this module itself (:mod:`zlib` + a compiled unfilter
kernel), because common readers silently reduce 16-bit RGB PNG to 8 bit; the
same decoder writes PNG (:func:`write_png`) with all 16 bits.

Every problem with a file raises :class:`ImageError` (a :class:`ValueError`)
naming the file, or :class:`FileNotFoundError` when it does not exist.
"""

from __future__ import annotations

import os
import struct
import zlib
from collections.abc import Callable
from dataclasses import dataclass
from os import PathLike
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._jit import njit
from ..errors import CDBRDFError, ImageError

__all__ = [
    "ImageError",
    "ImageInfo",
    "FORMATS",
    "image_format",
    "read_image",
    "read_window",
    "write_png",
    "write_tiff",
    "write_exr",
    "srgb_to_linear",
    "linear_to_srgb",
]

#: File extensions (lower case) and the format they select.
FORMATS: dict[str, str] = {
    ".png": "png",
    ".tif": "tiff",
    ".tiff": "tiff",
    ".exr": "exr",
}

_PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


@dataclass(frozen=True)
class ImageInfo:
    """How to interpret the code values of an image.

    Attributes
    ----------
    width, height
        Size in pixels.
    channels
        Channels returned (alpha dropped).
    max_code
        The largest code value (255 or 65535) of integer data; ``None`` for
        floating-point data (no saturation level).
    linear
        True when the format stores linear values by nature (float TIFF,
        OpenEXR); integer data is display-encoded unless the capture says
        otherwise.
    """

    width: int
    height: int
    channels: int
    max_code: int | None
    linear: bool


def image_format(path: str | PathLike[str]) -> str:
    """The format (``png``, ``tiff``, ``exr``) chosen by a file's extension."""
    ext = Path(path).suffix.lower()
    try:
        return FORMATS[ext]
    except KeyError:
        raise ImageError(
            f"{path}: unsupported image type {ext!r}; valid extensions: {', '.join(FORMATS)}"
        ) from None


# --------------------------------------------------------------------------- sRGB
def srgb_to_linear(x: ArrayLike) -> NDArray[np.float64]:
    """Decode sRGB-encoded values in [0, 1] to linear (IEC 61966-2-1)."""
    x = np.asarray(x, dtype=np.float64)
    return np.where(x <= 0.04045, x / 12.92, ((np.maximum(x, 0.04045) + 0.055) / 1.055) ** 2.4)


def linear_to_srgb(x: ArrayLike) -> NDArray[np.float64]:
    """Encode linear values in [0, 1] to sRGB (IEC 61966-2-1)."""
    x = np.asarray(x, dtype=np.float64)
    return np.where(
        x <= 0.0031308, 12.92 * x, 1.055 * np.maximum(x, 0.0031308) ** (1.0 / 2.4) - 0.055
    )


# --------------------------------------------------------------------------- window
_WindowArg = "tuple[int, int, int, int] | Callable[[ImageInfo], tuple[int, int, int, int]]"


def _resolve(path: object, info: ImageInfo, window) -> tuple[int, int, int, int]:  # noqa: ANN001
    x0, y0, nx, ny = (int(v) for v in (window(info) if callable(window) else window))
    _check_window(path, info, x0, y0, nx, ny)
    return x0, y0, nx, ny


def _check_window(path: object, info: ImageInfo, x0: int, y0: int, nx: int, ny: int) -> None:
    if nx < 1 or ny < 1 or x0 < 0 or y0 < 0 or x0 + nx > info.width or y0 + ny > info.height:
        raise ImageError(
            f"{path}: the window x {x0}..{x0 + nx - 1}, y {y0}..{y0 + ny - 1} does not lie "
            f"inside the {info.width} x {info.height} image"
        )


def _channels_kept(samples: int) -> int:
    # grey, grey+alpha -> 1; RGB, RGBA (and more) -> 3
    return 1 if samples <= 2 else 3


# --------------------------------------------------------------------------- PNG
@njit(cache=True, nogil=True)
def _png_unfilter(raw: NDArray[np.uint8], stride: int, bpp: int, nrows: int,
                  out: NDArray[np.uint8]) -> int:  # pragma: no cover - compiled
    """Undo PNG row filters for the first ``nrows`` rows; -1-row on a bad filter byte."""
    for r in range(nrows):
        base = r * (stride + 1)
        ft = raw[base]
        src = base + 1
        if ft == 0:
            for i in range(stride):
                out[r, i] = raw[src + i]
        elif ft == 1:
            for i in range(stride):
                left = out[r, i - bpp] if i >= bpp else 0
                out[r, i] = (raw[src + i] + left) & 0xFF
        elif ft == 2:
            if r == 0:
                for i in range(stride):
                    out[r, i] = raw[src + i]
            else:
                for i in range(stride):
                    out[r, i] = (raw[src + i] + out[r - 1, i]) & 0xFF
        elif ft == 3:
            for i in range(stride):
                left = np.int32(out[r, i - bpp]) if i >= bpp else 0
                up = np.int32(out[r - 1, i]) if r > 0 else 0
                out[r, i] = (raw[src + i] + ((left + up) >> 1)) & 0xFF
        elif ft == 4:
            for i in range(stride):
                a = np.int32(out[r, i - bpp]) if i >= bpp else 0
                b = np.int32(out[r - 1, i]) if r > 0 else 0
                c = np.int32(out[r - 1, i - bpp]) if (r > 0 and i >= bpp) else 0
                p = a + b - c
                pa = abs(p - a)
                pb = abs(p - b)
                pc = abs(p - c)
                if pa <= pb and pa <= pc:
                    pred = a
                elif pb <= pc:
                    pred = b
                else:
                    pred = c
                out[r, i] = (raw[src + i] + pred) & 0xFF
        else:
            return r
    return -1


_PNG_SAMPLES = {0: 1, 2: 3, 4: 2, 6: 4}


def _png_parse(path: Path, data: bytes) -> tuple[dict, list[memoryview]]:
    if data[:8] != _PNG_SIGNATURE:
        raise ImageError(f"{path}: not a PNG file (bad signature)")
    pos = 8
    header: dict | None = None
    idat: list[memoryview] = []
    mv = memoryview(data)
    end_seen = False
    while pos + 8 <= len(data):
        (length,) = struct.unpack(">I", data[pos : pos + 4])
        ctype = data[pos + 4 : pos + 8]
        body_end = pos + 8 + length
        if body_end + 4 > len(data):
            raise ImageError(f"{path}: truncated PNG (chunk {ctype!r} runs past the end)")
        body = mv[pos + 8 : body_end]
        if ctype in (b"IHDR", b"IDAT", b"IEND"):
            (crc,) = struct.unpack(">I", data[body_end : body_end + 4])
            if zlib.crc32(body, zlib.crc32(ctype)) != crc:
                raise ImageError(f"{path}: corrupt PNG (CRC mismatch in chunk {ctype.decode()})")
        if ctype == b"IHDR":
            if length != 13:
                raise ImageError(f"{path}: corrupt PNG (IHDR length {length})")
            w, h, depth, ctype_, comp, filt, interlace = struct.unpack(">IIBBBBB", body)
            header = dict(width=w, height=h, depth=depth, color=ctype_, interlace=interlace,
                          comp=comp, filt=filt)
        elif ctype == b"IDAT":
            idat.append(body)
        elif ctype == b"IEND":
            end_seen = True
            break
        pos = body_end + 4
    if header is None:
        raise ImageError(f"{path}: corrupt PNG (no IHDR chunk)")
    if not idat:
        raise ImageError(f"{path}: corrupt PNG (no image data)")
    if not end_seen:
        raise ImageError(f"{path}: truncated PNG (no IEND chunk)")
    return header, idat


def _png_fallback(path: Path) -> NDArray:
    """Palette, low bit depth or interlaced 8-bit PNG: decode with imageio/Pillow."""
    import imageio.v3 as iio

    try:
        a = np.asarray(iio.imread(path))
    except Exception as exc:  # noqa: BLE001 - any reader failure is a corrupt file
        raise ImageError(f"{path}: cannot decode PNG ({exc})") from None
    if a.ndim == 2:
        a = a[..., None]
    return a


def _png_read(path: Path, window: _WindowArg | None) -> tuple[NDArray, ImageInfo]:
    """Decode the whole image (``window`` None) or the window's rows and crop."""
    try:
        data = path.read_bytes()
    except FileNotFoundError:
        raise FileNotFoundError(f"{path}: no such image file") from None
    hd, idat = _png_parse(path, data)
    w, h, depth, color = hd["width"], hd["height"], hd["depth"], hd["color"]
    if color not in _PNG_SAMPLES or depth not in (8, 16) or hd["interlace"] != 0:
        if depth == 16:
            raise ImageError(f"{path}: interlaced or palette 16-bit PNG is not supported")
        a = _png_fallback(path)
        if a.dtype != np.uint8:
            raise ImageError(f"{path}: unsupported PNG sample type {a.dtype}")
        a = a[..., : _channels_kept(a.shape[-1])]
        info = ImageInfo(w, h, a.shape[-1], 255, False)
        if window is None:
            return a, info
        x0, y0, nx, ny = _resolve(path, info, window)
        return a[y0 : y0 + ny, x0 : x0 + nx], info
    samples = _PNG_SAMPLES[color]
    bpp = samples * depth // 8
    stride = w * bpp
    keep = _channels_kept(samples)
    info = ImageInfo(w, h, keep, 65535 if depth == 16 else 255, False)
    if window is None:
        nrows = h
    else:
        x0, y0, nx, ny = _resolve(path, info, window)
        nrows = y0 + ny
    need = nrows * (stride + 1)
    d = zlib.decompressobj()
    parts: list[bytes] = []
    got = 0
    try:
        for chunk in idat:
            if got >= need:
                break
            out = d.decompress(chunk, need - got)
            parts.append(out)
            got += len(out)
            while got < need and d.unconsumed_tail:
                out = d.decompress(d.unconsumed_tail, need - got)
                if not out:
                    break
                parts.append(out)
                got += len(out)
    except zlib.error as exc:
        raise ImageError(f"{path}: corrupt PNG data ({exc})") from None
    raw = np.frombuffer(b"".join(parts), dtype=np.uint8)
    if raw.size < need:
        raise ImageError(f"{path}: truncated PNG data ({raw.size} of {need} bytes)")
    buf = np.empty((nrows, stride), dtype=np.uint8)
    bad = _png_unfilter(raw, stride, bpp, nrows, buf)
    if bad >= 0:
        raise ImageError(f"{path}: corrupt PNG (bad filter type in row {bad})")
    if window is not None:
        buf = buf[y0:, x0 * bpp : (x0 + nx) * bpp]
    if depth == 16:
        a = buf.view(">u2").astype(np.uint16).reshape(buf.shape[0], -1, samples)
    else:
        a = buf.reshape(buf.shape[0], -1, samples)
    return a[..., :keep], info


def write_png(path: str | PathLike[str], image: ArrayLike, *, level: int = 6) -> None:
    """Write a grey or RGB(A) ``uint8``/``uint16`` image as PNG, keeping all bits.

    Rows are stored with the "Up" filter. ``level`` is the zlib level (0-9).
    """
    a = np.asarray(image)
    if a.ndim == 2:
        a = a[..., None]
    if a.ndim != 3 or a.shape[-1] not in (1, 2, 3, 4):
        raise ValueError(f"image: expected (h, w[, 1-4]) pixels, got shape {a.shape}")
    if a.dtype == np.uint8:
        depth = 8
        raw = np.ascontiguousarray(a).reshape(a.shape[0], -1)
    elif a.dtype == np.uint16:
        depth = 16
        raw = np.ascontiguousarray(a.astype(">u2")).view(np.uint8).reshape(a.shape[0], -1)
    else:
        raise ValueError(f"image: expected uint8 or uint16, got {a.dtype}")
    h, w, c = a.shape
    color = {1: 0, 2: 4, 3: 2, 4: 6}[c]
    filtered = np.empty((h, raw.shape[1] + 1), dtype=np.uint8)
    filtered[:, 0] = 2
    filtered[0, 1:] = raw[0]
    filtered[1:, 1:] = raw[1:] - raw[:-1]  # uint8 wraps modulo 256, as PNG's Up filter
    comp = zlib.compress(filtered.tobytes(), level)

    def chunk(kind: bytes, body: bytes) -> bytes:
        return struct.pack(">I", len(body)) + kind + body + struct.pack(
            ">I", zlib.crc32(body, zlib.crc32(kind))
        )

    ihdr = struct.pack(">IIBBBBB", w, h, depth, color, 0, 0, 0)
    Path(path).write_bytes(
        _PNG_SIGNATURE + chunk(b"IHDR", ihdr) + chunk(b"IDAT", comp) + chunk(b"IEND", b"")
    )


# --------------------------------------------------------------------------- TIFF
def _tiff_info(path: Path, page) -> ImageInfo:  # noqa: ANN001
    dtype = np.dtype(page.dtype)
    samples = int(page.samplesperpixel)
    if dtype == np.uint8:
        max_code, linear = 255, False
    elif dtype == np.uint16:
        max_code, linear = 65535, False
    elif dtype in (np.float16, np.float32, np.float64):
        max_code, linear = None, True
    else:
        raise ImageError(f"{path}: unsupported TIFF sample type {dtype}")
    return ImageInfo(int(page.imagewidth), int(page.imagelength), _channels_kept(samples),
                     max_code, linear)


def _tiff_open(path: Path):  # noqa: ANN202
    import tifffile

    try:
        tf = tifffile.TiffFile(path)
    except FileNotFoundError:
        raise FileNotFoundError(f"{path}: no such image file") from None
    except Exception as exc:  # noqa: BLE001 - any parser failure is a corrupt file
        raise ImageError(f"{path}: corrupt TIFF ({exc})") from None
    if not tf.pages:
        tf.close()
        raise ImageError(f"{path}: TIFF without images")
    return tf


def _tiff_full(path: Path, tf) -> tuple[NDArray, ImageInfo]:  # noqa: ANN001
    page = tf.pages[0]
    info = _tiff_info(path, page)
    try:
        a = np.asarray(page.asarray())
    except Exception as exc:  # noqa: BLE001
        raise ImageError(f"{path}: corrupt TIFF data ({exc})") from None
    if a.ndim == 2:
        a = a[..., None]
    if a.shape[:2] != (info.height, info.width):
        raise ImageError(f"{path}: unsupported TIFF layout (decoded shape {a.shape})")
    return a[..., : info.channels], info


_TIFF_TYPES = {1: "B", 3: "H", 4: "I", 16: "Q"}  # BYTE, SHORT, LONG, LONG8
_TIFF_SIZES = {1: 1, 3: 2, 4: 4, 16: 8}


def _tiff_fast_window(path: Path, window) -> tuple[NDArray, ImageInfo] | None:  # noqa: ANN001, C901
    """Window of an uncompressed, chunky, classic little/big-endian TIFF with ``os.pread``.

    Parses only the first IFD's few tags and reads only the window's bytes
    (plus the strip/tile offsets it needs). Returns None for any other
    layout (the caller then uses :mod:`tifffile`).
    """
    try:
        fd = os.open(path, os.O_RDONLY)
    except FileNotFoundError:
        raise FileNotFoundError(f"{path}: no such image file") from None
    try:
        head = os.pread(fd, 4096, 0)  # the header and, usually, the first IFD
        if len(head) < 8 or head[:2] not in (b"II", b"MM"):
            return None
        bo = "<" if head[:2] == b"II" else ">"
        magic, ifd = struct.unpack(bo + "HI", head[2:8])
        if magic != 42:
            return None  # BigTIFF or not a TIFF
        raw = head[ifd : ifd + 2] if ifd + 2 <= len(head) else os.pread(fd, 2, ifd)
        if len(raw) < 2:
            return None
        (n,) = struct.unpack(bo + "H", raw)
        if ifd + 2 + 12 * n <= len(head):
            body = head[ifd + 2 : ifd + 2 + 12 * n]
        else:
            body = os.pread(fd, 12 * n, ifd + 2)
        if len(body) < 12 * n:
            return None
        tags: dict[int, tuple[int, int, bytes]] = {}
        for i in range(n):
            tag, typ, count = struct.unpack(bo + "HHI", body[12 * i : 12 * i + 8])
            tags[tag] = (typ, count, body[12 * i + 8 : 12 * i + 12])

        def scalar(tag: int, default: int | None = None) -> int | None:
            if tag not in tags:
                return default
            typ, count, val = tags[tag]
            if typ not in (3, 4) or count < 1:
                return None
            return struct.unpack(bo + _TIFF_TYPES[typ], val[: _TIFF_SIZES[typ]])[0]

        def entry(tag: int, k: int) -> int | None:
            typ, count, val = tags[tag]
            if typ not in (3, 4) or k >= count:
                return None
            size = _TIFF_SIZES[typ]
            if count * size <= 4:
                data = val[k * size : (k + 1) * size]
            else:
                (off,) = struct.unpack(bo + "I", val)
                data = os.pread(fd, size, off + k * size)
                if len(data) < size:
                    return None
            return struct.unpack(bo + _TIFF_TYPES[typ], data)[0]

        width, height = scalar(256), scalar(257)
        spp = scalar(277, 1)
        comp, planar, pred = scalar(259, 1), scalar(284, 1), scalar(317, 1)
        fmt = scalar(339, 1)
        if None in (width, height, spp, comp, planar, pred, fmt) or comp != 1 or pred != 1:
            return None
        if spp > 1 and planar != 1:
            return None
        typ, count, val = tags.get(258, (3, 1, b"\x08\x00\x00\x00"))
        bps = entry(258, 0) if 258 in tags else 1
        if bps not in (8, 16) or fmt != 1:
            return None  # float or odd depths: tifffile
        dtype = np.dtype(f"{bo}u{bps // 8}")
        pix = spp * bps // 8
        info = ImageInfo(int(width), int(height), _channels_kept(spp), 255 if bps == 8 else 65535, False)
        x0, y0, nx, ny = _resolve(path, info, window)
        out = np.empty((ny, nx, spp), dtype=dtype)
        if 322 in tags:
            tw, th = scalar(322), scalar(323)
            if not tw or not th or 324 not in tags:
                return None
            tiles_x = -(-width // tw)
            for r in range(ny):
                ty, ry = divmod(y0 + r, th)
                x = x0
                while x < x0 + nx:
                    tx, rx = divmod(x, tw)
                    m = min(tw - rx, x0 + nx - x)
                    off = entry(324, ty * tiles_x + tx)
                    if off is None:
                        return None
                    buf = os.pread(fd, m * pix, off + (ry * tw + rx) * pix)
                    if len(buf) != m * pix:
                        raise ImageError(f"{path}: truncated TIFF data")
                    out[r, x - x0 : x - x0 + m] = np.frombuffer(buf, dtype).reshape(m, spp)
                    x += m
        else:
            if 273 not in tags:
                return None
            rps = min(scalar(278, height) or height, height)
            rowbytes = width * pix
            r = 0
            while r < ny:  # one read per strip: the window's rows in it are contiguous
                st, rs = divmod(y0 + r, rps)
                k = min(ny - r, rps - rs)
                off = entry(273, st)
                if off is None:
                    return None
                span = (k - 1) * rowbytes + nx * pix
                buf = os.pread(fd, span, off + rs * rowbytes + x0 * pix)
                if len(buf) != span:
                    raise ImageError(f"{path}: truncated TIFF data")
                rows = np.frombuffer(buf + bytes(rowbytes - nx * pix), dtype).reshape(k, rowbytes // dtype.itemsize)
                out[r : r + k] = rows[:, : nx * spp].reshape(k, nx, spp)
                r += k
        return out[..., : info.channels].astype(dtype.newbyteorder("=")), info
    except struct.error:
        return None
    finally:
        os.close(fd)


def _tiff_segments(path: Path, tf, page, info: ImageInfo, x0: int, y0: int, nx: int,  # noqa: ANN001
                   ny: int) -> NDArray | None:
    """Decode only the strips or tiles of a compressed chunky TIFF that hold the window.

    Returns None for layouts this does not handle (the caller decodes the whole image).
    """
    samples = int(page.samplesperpixel)
    if samples > 1 and int(page.planarconfig) != 1:
        return None
    if len(page.shape) not in (2, 3) or getattr(page, "imagedepth", 1) not in (1, None):
        return None
    if page.is_tiled:
        th, tw = (int(c) for c in page.chunks[:2])
        tiles_x = -(-info.width // tw)
        index = [ty * tiles_x + tx
                 for ty in range(y0 // th, (y0 + ny - 1) // th + 1)
                 for tx in range(x0 // tw, (x0 + nx - 1) // tw + 1)]
    else:
        rps = min(int(page.rowsperstrip or info.height), info.height)
        index = list(range(y0 // rps, (y0 + ny - 1) // rps + 1))
    out = np.empty((ny, nx, samples), dtype=np.dtype(page.dtype))
    fh = tf.filehandle
    jpegtables = getattr(page, "jpegtables", None)
    for k in index:
        if k >= len(page.dataoffsets):
            raise ImageError(f"{path}: truncated TIFF (segment {k} missing)")
        fh.seek(page.dataoffsets[k])
        data = fh.read(page.databytecounts[k])
        try:
            seg, where, _shape = page.decode(data, k, jpegtables=jpegtables)
        except Exception as exc:  # noqa: BLE001 - any codec failure is a corrupt file
            raise ImageError(f"{path}: corrupt TIFF data in segment {k} ({exc})") from None
        if seg is None:
            raise ImageError(f"{path}: TIFF segment {k} is empty")
        seg = np.asarray(seg).reshape(seg.shape[-3], seg.shape[-2], -1)
        sy, sx = int(where[-3]), int(where[-2])
        ya, yb = max(y0, sy), min(y0 + ny, sy + seg.shape[0])
        xa, xb = max(x0, sx), min(x0 + nx, sx + seg.shape[1])
        if ya < yb and xa < xb:
            out[ya - y0 : yb - y0, xa - x0 : xb - x0] = seg[ya - sy : yb - sy, xa - sx : xb - sx]
    return out[..., : info.channels]


def _tiff_window(path: Path, window) -> tuple[NDArray, ImageInfo]:  # noqa: ANN001
    tf = _tiff_open(path)
    try:
        page = tf.pages[0]
        info = _tiff_info(path, page)
        x0, y0, nx, ny = _resolve(path, info, window)
        samples = int(page.samplesperpixel)
        simple = (
            int(page.compression) == 1
            and (samples == 1 or int(page.planarconfig) == 1)
            and int(getattr(page, "predictor", 1) or 1) == 1
            and int(page.bitspersample) * samples % 8 == 0
            and len(page.shape) in (2, 3)
        )
        if not simple:
            got = _tiff_segments(path, tf, page, info, x0, y0, nx, ny)
            if got is not None:
                return got, info
            a, _ = _tiff_full(path, tf)
            return a[y0 : y0 + ny, x0 : x0 + nx], info
        dtype = np.dtype(page.dtype).newbyteorder(tf.byteorder)
        pix = dtype.itemsize * samples
        offsets = page.dataoffsets
        counts = page.databytecounts
        fh = tf.filehandle
        out = np.empty((ny, nx, samples), dtype=dtype)
        if page.is_tiled:
            tw, th = int(page.tilewidth), int(page.tilelength)
            tiles_x = -(-info.width // tw)
            for r in range(ny):
                y = y0 + r
                ty, ry = divmod(y, th)
                x = x0
                while x < x0 + nx:
                    tx, rx = divmod(x, tw)
                    n = min(tw - rx, x0 + nx - x)
                    k = ty * tiles_x + tx
                    start = (ry * tw + rx) * pix
                    if start + n * pix > counts[k]:
                        raise ImageError(f"{path}: truncated TIFF tile {k}")
                    fh.seek(offsets[k] + start)
                    buf = fh.read(n * pix)
                    if len(buf) != n * pix:
                        raise ImageError(f"{path}: truncated TIFF data")
                    out[r, x - x0 : x - x0 + n] = np.frombuffer(buf, dtype).reshape(n, samples)
                    x += n
        else:
            rps = int(page.rowsperstrip) if page.rowsperstrip else info.height
            rps = min(rps, info.height)
            rowbytes = info.width * pix
            for r in range(ny):
                s, rs = divmod(y0 + r, rps)
                start = rs * rowbytes + x0 * pix
                if s >= len(offsets) or start + nx * pix > counts[s]:
                    raise ImageError(f"{path}: truncated TIFF strip {s}")
                fh.seek(offsets[s] + start)
                buf = fh.read(nx * pix)
                if len(buf) != nx * pix:
                    raise ImageError(f"{path}: truncated TIFF data")
                out[r] = np.frombuffer(buf, dtype).reshape(nx, samples)
        return out[..., : info.channels].astype(dtype.newbyteorder("=")), info
    finally:
        tf.close()


def write_tiff(path: str | PathLike[str], image: ArrayLike, *, compression: str | None = None,
               tile: tuple[int, int] | None = None) -> None:
    """Write an image as TIFF (uncompressed by default; ``tile`` for a tiled file)."""
    import tifffile

    a = np.asarray(image)
    photometric = "rgb" if a.ndim == 3 and a.shape[-1] >= 3 else "minisblack"
    tifffile.imwrite(path, a, photometric=photometric, compression=compression, tile=tile)


# --------------------------------------------------------------------------- EXR
def _exr_open(path: Path):  # noqa: ANN202
    import OpenEXR

    if not path.exists():
        raise FileNotFoundError(f"{path}: no such image file")
    try:
        f = OpenEXR.InputFile(str(path))
        header = f.header()
    except Exception as exc:  # noqa: BLE001
        raise ImageError(f"{path}: corrupt OpenEXR file ({exc})") from None
    dw = header["dataWindow"]
    width = dw.max.x - dw.min.x + 1
    height = dw.max.y - dw.min.y + 1
    names = list(header["channels"].keys())
    if all(c in names for c in "RGB"):
        chans = ["R", "G", "B"]
    elif "Y" in names:
        chans = ["Y"]
    elif len(names) == 1:
        chans = names
    else:
        f.close()
        raise ImageError(f"{path}: OpenEXR channels {names} are neither R,G,B nor Y")
    return f, dw, width, height, chans


def _exr_window(path: Path, window) -> tuple[NDArray, ImageInfo]:  # noqa: ANN001
    import Imath

    f, dw, width, height, chans = _exr_open(path)
    try:
        info = ImageInfo(width, height, len(chans), None, True)
        if window is None:
            x0, y0, nx, ny = 0, 0, width, height
        else:
            x0, y0, nx, ny = _resolve(path, info, window)
        pt = Imath.PixelType(Imath.PixelType.FLOAT)
        out = np.empty((ny, nx, len(chans)), dtype=np.float32)
        for i, c in enumerate(chans):
            try:
                buf = f.channel(c, pt, dw.min.y + y0, dw.min.y + y0 + ny - 1)
            except Exception as exc:  # noqa: BLE001
                raise ImageError(f"{path}: corrupt OpenEXR data ({exc})") from None
            rows = np.frombuffer(buf, dtype=np.float32)
            if rows.size != ny * width:
                raise ImageError(f"{path}: truncated OpenEXR data")
            out[..., i] = rows.reshape(ny, width)[:, x0 : x0 + nx]
        return out, info
    finally:
        f.close()


def write_exr(path: str | PathLike[str], image: ArrayLike) -> None:
    """Write a linear grey or RGB image as a float32 OpenEXR file (ZIP compression)."""
    import OpenEXR

    a = np.asarray(image, dtype=np.float32)
    if a.ndim == 2:
        a = a[..., None]
    if a.shape[-1] == 3:
        channels = {"RGB": np.ascontiguousarray(a)}
    elif a.shape[-1] == 1:
        channels = {"Y": np.ascontiguousarray(a[..., 0])}
    else:
        raise ValueError(f"image: expected 1 or 3 channels, got shape {a.shape}")
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    with OpenEXR.File(header, channels) as f:
        f.write(str(path))


# --------------------------------------------------------------------------- API
def read_image(path: str | PathLike[str]) -> tuple[NDArray, ImageInfo]:
    """Decode a whole image.

    Returns
    -------
    pixels : numpy.ndarray
        Raw codes, ``(height, width, channels)``: ``uint8``, ``uint16`` or
        ``float32``.
    info : ImageInfo
        Size, saturation code and encoding.

    Raises
    ------
    FileNotFoundError
        When the file does not exist.
    ImageError
        When it is corrupt, truncated or of an unsupported kind.
    """
    p = Path(path)
    fmt = image_format(p)
    if fmt == "png":
        return _png_read(p, None)
    if fmt == "tiff":
        tf = _tiff_open(p)
        try:
            return _tiff_full(p, tf)
        finally:
            tf.close()
    return _exr_window(p, None)


def read_window(
    path: str | PathLike[str],
    window: tuple[int, int, int, int] | Callable[[ImageInfo], tuple[int, int, int, int]],
) -> tuple[NDArray, ImageInfo]:
    """Read the pixels ``[y0:y0+ny, x0:x0+nx]`` reading as little as the format allows.

    Parameters
    ----------
    path
        PNG, TIFF or OpenEXR file.
    window
        ``(x0, y0, nx, ny)``: column and row of the window's top-left pixel
        (0-based, rows from the top) and its size; or a function of the
        image's :class:`ImageInfo` returning them (to centre a window on an
        image whose size is known only once the file is opened).

    Returns
    -------
    pixels : numpy.ndarray
        ``(ny, nx, channels)`` raw codes.
    info : ImageInfo
        The whole image's size, saturation code and encoding.

    Raises
    ------
    FileNotFoundError, ImageError
        As :func:`read_image`; :class:`ImageError` also when the window does
        not lie inside the image.
    """
    p = Path(path)
    fmt = image_format(p)
    if fmt == "png":
        return _png_read(p, window)
    if fmt == "tiff":
        got = _tiff_fast_window(p, window)
        return got if got is not None else _tiff_window(p, window)
    return _exr_window(p, window)
