"""Image files: PNG, TIFF (8/16 bit, float) and OpenEXR, read whole or as a window, and written.

The one owner of image files in cdbrdf: the measurement reads photographs
with it, the simulated rig writes them, the renderer writes its pictures.

Two entry points:

- :func:`read_image` decodes a whole image;
- :func:`read_window` returns a rectangle of pixels. It decodes the whole
  image through the same path as :func:`read_image` and slices it, so that it
  never returns pixels of a file that :func:`read_image` rejects; the one
  exception to the whole decode is an uncompressed TIFF whose data lie in one
  contiguous block, which is memory-mapped (:func:`tifffile.memmap`) once
  the same checks have passed, so only the window's rows are read.

Both return the raw code values (``uint8``, ``uint16`` or ``float32``) with
shape ``(rows, cols, channels)``: grey images have one channel, an alpha
channel is dropped. :class:`ImageInfo` says how to interpret them: the
largest code (``255``/``65535``; ``None`` for float data) and whether the
format is linear by nature (float TIFF, EXR) or display-encoded (integer
data: sRGB unless the capture says linear).

The formats are decoded by libraries: PNG by libpng through
:func:`imagecodecs.png_decode` (all 16 bits kept; common readers such as
Pillow reduce 16-bit RGB PNG to 8 bit), TIFF by :mod:`tifffile`, OpenEXR by
the ``OpenEXR`` bindings. Before any decoding the declared size is checked
against the ``image_pixels`` limit (:mod:`cdbrdf.limits`); a PNG's chunk
structure and CRCs are checked first too, so that libpng mostly sees
well-formed files (its error path in :mod:`imagecodecs` needs a repair; see
:func:`_png_decode`).

Every problem with a file raises :class:`ImageError` (a :class:`ValueError`)
naming the file - :class:`~cdbrdf.errors.LimitError` when it declares a size
above the limit - or :class:`FileNotFoundError` when it does not exist; no
other exception escapes the readers.
"""

from __future__ import annotations

import contextlib
import ctypes
import logging
import math
import os
import stat
import struct
import sys
import threading
import zlib
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from os import PathLike
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from . import limits
from .errors import CDBRDFError, ImageError, OptionError
from .fsutil import atomic_path

__all__ = [
    "ImageError",
    "ImageInfo",
    "FORMATS",
    "image_format",
    "decode_image",
    "read_image",
    "read_window",
    "write_png",
    "write_tiff",
    "write_exr",
]

#: File extensions (lower case) and the format they select.
FORMATS: dict[str, str] = {
    ".png": "png",
    ".tif": "tiff",
    ".tiff": "tiff",
    ".exr": "exr",
}

_PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
_FORMAT_NAMES = {"png": "PNG", "tiff": "TIFF", "exr": "OpenEXR"}


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
    """The image format chosen by a file's extension.

    Parameters
    ----------
    path
        The file's name.

    Returns
    -------
    str
        ``"png"``, ``"tiff"`` or ``"exr"``.

    Raises
    ------
    ImageError
        For another extension (the message lists the valid ones).
    """
    ext = Path(path).suffix.lower()
    try:
        return FORMATS[ext]
    except KeyError:
        raise ImageError(
            f"{path}: unsupported image type {ext!r}; valid extensions: {', '.join(FORMATS)}"
        ) from None


# --------------------------------------------------------------------------- common
def _window_values(window: Any) -> tuple[int, int, int, int]:
    """``(x0, y0, nx, ny)`` as integers; :class:`OptionError` for anything else (NaN, 1.5, 3 values...)."""
    try:
        vals = tuple(window)
    except TypeError:
        vals = ()
    ok = len(vals) == 4 and all(
        not isinstance(v, bool) and isinstance(v, (int, float, np.integer, np.floating))
        and math.isfinite(float(v)) and float(v).is_integer() and abs(float(v)) < 2**62 for v in vals)
    if not ok:
        raise OptionError(
            f"window: expected four whole numbers (x0, y0, nx, ny) or a function returning them, "
            f"got {window!r:.60}"
        )
    x0, y0, nx, ny = (int(v) for v in vals)
    return x0, y0, nx, ny


def _resolve(path: object, info: ImageInfo, window: Any) -> tuple[int, int, int, int]:
    """The window ``(x0, y0, nx, ny)`` (called with ``info`` if callable), checked to fit."""
    x0, y0, nx, ny = _window_values(window(info) if callable(window) else window)
    if nx < 1 or ny < 1 or x0 < 0 or y0 < 0 or x0 + nx > info.width or y0 + ny > info.height:
        raise ImageError(
            f"{path}: the window x {x0}..{x0 + nx - 1}, y {y0}..{y0 + ny - 1} does not lie "
            f"inside the {info.width} x {info.height} image"
        )
    return x0, y0, nx, ny


def _channels_kept(samples: int) -> int:
    # grey, grey+alpha -> 1; RGB, RGBA -> 3
    return 1 if samples <= 2 else 3


def _one_line(exc: BaseException) -> str:
    text = " ".join(str(exc).split())
    text = text.encode("ascii", "backslashreplace").decode("ascii")
    return f"{type(exc).__name__}: {text[:200]}" if text else type(exc).__name__


@contextlib.contextmanager
def _reading(path: Path, fmt: str) -> Iterator[None]:
    """Turn every failure while reading ``path`` into :class:`ImageError` naming it.

    The libraries raise all sorts (``PngError``, ``TiffFileError``,
    ``ValueError``, ``struct.error``, ``OSError``, ``IndexError``,
    ``KeyError``, ``MemoryError``...); this is the one place that wraps them.
    :class:`FileNotFoundError` and the project's own errors pass through.
    """
    try:
        yield
    except (CDBRDFError, FileNotFoundError):
        raise
    except IsADirectoryError:
        raise ImageError(f"{path}: is a folder, not an image file") from None
    except PermissionError:
        raise ImageError(f"{path}: cannot read {_FORMAT_NAMES[fmt]} file (permission denied)") from None
    except Exception as exc:  # noqa: BLE001 - any library failure is an unreadable file
        raise ImageError(f"{path}: corrupt or unsupported {_FORMAT_NAMES[fmt]} file "
                         f"({_one_line(exc)})") from None


def _check_file(path: Path) -> None:
    """Refuse anything but an existing regular file (after symlinks) before a library opens it."""
    try:
        st = os.stat(path)
    except FileNotFoundError:
        raise FileNotFoundError(f"{path}: no such image file") from None
    except OSError as exc:  # symlink loop, name too long, permission on a folder...
        raise ImageError(f"{path}: cannot open image file ({_one_line(exc)})") from None
    if stat.S_ISDIR(st.st_mode):
        raise ImageError(f"{path}: is a folder, not an image file")
    if not stat.S_ISREG(st.st_mode):
        raise ImageError(f"{path}: not a regular file")


def _check_size(path: Path, width: int, height: int, fmt: str) -> None:
    """Refuse a declared size of 0 or above the ``image_pixels`` limit, before decoding."""
    if width < 1 or height < 1:
        raise ImageError(f"{path}: {_FORMAT_NAMES[fmt]} declares an empty image ({width} x {height})")
    limits.check("image_pixels", width * height, what=f"{path}: {width} x {height} image")


# --------------------------------------------------------------------------- PNG
# bit depths allowed for each colour type (PNG specification, 11.2.2)
_PNG_DEPTHS = {0: (1, 2, 4, 8, 16), 2: (8, 16), 3: (1, 2, 4, 8), 4: (8, 16), 6: (8, 16)}


def _png_check(path: Path, data: bytes) -> tuple[int, int]:
    """Check a PNG's structure before libpng sees it; its ``(width, height)``.

    The signature, that every chunk lies inside the file, the CRC of every
    chunk but IDAT (critical and ancillary alike; libpng checks IDAT's as it
    reads, and so refuses it too), that IHDR comes first and is valid, that
    there is image data and an IEND chunk, and the size against the limit.
    This is not a decoder: libpng inflates and unfilters (and checks the
    zlib stream's Adler-32).
    """
    if data[:8] != _PNG_SIGNATURE:
        raise ImageError(f"{path}: not a PNG file (bad signature)")
    if len(data) < 33 or data[12:16] != b"IHDR" or data[8:12] != b"\x00\x00\x00\x0d":
        raise ImageError(f"{path}: corrupt PNG (no IHDR chunk first)")
    width, height, depth, color, comp, filt, interlace = struct.unpack(">IIBBBBB", data[16:29])
    if zlib.crc32(data[12:29]) != struct.unpack(">I", data[29:33])[0]:
        raise ImageError(f"{path}: corrupt PNG (CRC mismatch in chunk IHDR)")
    if width < 1 or height < 1 or width > 2**31 - 1 or height > 2**31 - 1:
        raise ImageError(f"{path}: corrupt PNG (size {width} x {height})")
    if depth not in _PNG_DEPTHS.get(color, ()) or comp != 0 or filt != 0 or interlace > 1:
        raise ImageError(
            f"{path}: unsupported PNG (bit depth {depth}, colour type {color}, compression "
            f"{comp}, filter {filt}, interlace {interlace})"
        )
    _check_size(path, width, height, "png")
    pos, n, idat, end = 33, len(data), False, False
    mv = memoryview(data)
    while pos + 12 <= n:
        (length,) = struct.unpack(">I", data[pos : pos + 4])
        body_end = pos + 8 + length
        if length > 2**31 - 1 or body_end + 4 > n:
            break
        kind = bytes(data[pos + 4 : pos + 8])
        # libpng checks the IDAT CRCs as it inflates (an error, as for every critical chunk)
        crc = struct.unpack(">I", data[body_end : body_end + 4])[0]
        if kind != b"IDAT" and zlib.crc32(mv[pos + 4 : body_end]) != crc:
            raise ImageError(f"{path}: corrupt PNG (CRC mismatch in chunk {kind!r})")
        if kind == b"IHDR":
            raise ImageError(f"{path}: corrupt PNG (second IHDR chunk)")
        idat |= kind == b"IDAT"
        pos = body_end + 4
        if kind == b"IEND":
            end = True
            break
    if not end:
        raise ImageError(f"{path}: truncated PNG (a chunk runs past the end, or no IEND chunk)")
    if not idat:
        raise ImageError(f"{path}: corrupt PNG (no image data)")
    return width, height


if sys.version_info < (3, 12):  # pragma: no branch - None became immortal in 3.12

    def _restore_none() -> None:
        ctypes.pythonapi.Py_IncRef(ctypes.py_object(None))

else:  # pragma: no cover

    def _restore_none() -> None:
        pass


class _PngWarnings(logging.Filter):
    """Collects, per thread, the libpng warnings that imagecodecs logs during a decode."""

    def __init__(self) -> None:
        super().__init__()
        self.local = threading.local()

    def filter(self, record: logging.LogRecord) -> bool:
        seen = getattr(self.local, "seen", None)
        if seen is None:
            return True
        seen.append(record.getMessage())
        return False  # reported as the ImageError instead


_PNG_WARNINGS = _PngWarnings()
logging.getLogger("imagecodecs").addFilter(_PNG_WARNINGS)


def _png_decode(data: bytes) -> NDArray:
    """:func:`imagecodecs.png_decode`, made strict and repairing the damage of its error path.

    libpng treats a zlib stream whose Adler-32 does not match as a mere
    warning when the last row was complete before the check (imagecodecs
    never calls ``png_read_end``): a crafted IDAT with a recomputed CRC then
    decodes to changed pixels. imagecodecs logs that warning ("IDAT:
    incorrect data check") on its logger; any warning about IDAT during the
    decode makes it an error here.

    Each libpng error that ``png_decode`` raises as ``PngError`` (corrupt
    zlib stream, bad filter byte...) drops one reference to ``None`` too many
    (imagecodecs 2026.3, measured: exactly one per error); on Python < 3.12
    the interpreter aborts ("deallocating None") after some 7,700 such files
    in one process. The reference is given back here. Should a later
    imagecodecs fix the leak, the extra reference is harmless (``None`` is
    never freed).
    """
    import imagecodecs

    seen: list[str] = []
    _PNG_WARNINGS.local.seen = seen
    try:
        out = imagecodecs.png_decode(data)
    except imagecodecs.PngError:
        _restore_none()
        raise
    finally:
        _PNG_WARNINGS.local.seen = None
    bad = [m for m in seen if "IDAT" in m]
    if bad:
        raise ValueError(bad[0])
    return out


def _png_read(path: Path, data: bytes | None = None) -> tuple[NDArray, ImageInfo]:
    data = path.read_bytes() if data is None else data
    width, height = _png_check(path, data)
    return _integer_image(path, np.asarray(_png_decode(data)), width, height)


def _integer_image(path: Path, a: NDArray, width: int, height: int) -> tuple[NDArray, ImageInfo]:
    a = a[..., None] if a.ndim == 2 else a  # 8- or 16-bit codes of the declared size, alpha dropped
    if a.ndim != 3 or a.shape[:2] != (height, width) or a.dtype not in (np.uint8, np.uint16):
        raise ImageError(f"{path}: unsupported image layout (decoded {a.shape} {a.dtype})")
    keep = _channels_kept(a.shape[-1])
    return a[..., :keep], ImageInfo(width, height, keep, 65535 if a.dtype == np.uint16 else 255, False)


@contextmanager
def _destination(path: str | PathLike[str], suffix: str, atomic: bool) -> Iterator[Path]:
    """The path a writer writes to: a temporary renamed onto ``path`` (``atomic``), or ``path`` made new."""
    if atomic:
        with atomic_path(path, suffix=suffix) as tmp:
            yield tmp
    else:
        with open(path, "xb"):  # a new file: nothing is ever replaced
            pass
        yield Path(path)


def write_png(path: str | PathLike[str], image: ArrayLike, *, level: int = 6, atomic: bool = True) -> None:
    """Write a grey or RGB(A) ``uint8``/``uint16`` image as PNG, keeping all bits.

    Encoded by libpng (:func:`imagecodecs.png_encode`) and written atomically.

    Parameters
    ----------
    path
        Output file.
    image
        ``(h, w)`` or ``(h, w, c)`` pixels, ``c`` in 1..4 (grey, grey+alpha,
        RGB, RGBA), ``uint8`` or ``uint16``.
    level
        zlib compression level, 0 to 9.
    atomic
        Write a temporary beside ``path`` and rename it
        (:func:`cdbrdf.fsutil.atomic_path`). False only for the many files
        written into a partial folder of :func:`cdbrdf.outputs.output_folder`,
        which is published whole once complete: written in place, without
        a temporary, a sweep of the folder or an fsync each (an existing file
        is refused: ``FileExistsError``).
    """
    import imagecodecs

    a = np.asarray(image)
    if a.ndim == 3 and a.shape[-1] == 1:
        a = a[..., 0]
    if a.ndim not in (2, 3) or (a.ndim == 3 and a.shape[-1] not in (2, 3, 4)) or 0 in a.shape:
        raise OptionError(f"image: expected (h, w[, 1-4]) pixels, got shape {a.shape}")
    if a.dtype not in (np.uint8, np.uint16):
        raise OptionError(f"image: expected uint8 or uint16, got {a.dtype}")
    if not 0 <= int(level) <= 9:
        raise OptionError(f"level: expected 0 to 9, got {level!r}")
    encoded = imagecodecs.png_encode(np.ascontiguousarray(a), level=int(level))
    if atomic:
        with atomic_path(path, suffix=".png") as tmp:
            tmp.write_bytes(encoded)
    else:
        with open(path, "xb") as fh:  # a new file: nothing is ever replaced
            fh.write(encoded)


# --------------------------------------------------------------------------- TIFF
def _tiff_page(path: Path, tf: Any) -> tuple[Any, ImageInfo]:
    """The first page and its :class:`ImageInfo`, after checking size, type and data extent."""
    page = tf.pages.first
    if page is None or not hasattr(page, "imagewidth"):
        raise ImageError(f"{path}: TIFF without images")
    width, height = int(page.imagewidth), int(page.imagelength)
    _check_size(path, width, height, "tiff")
    dtype = np.dtype(page.dtype) if page.dtype is not None else None
    samples = int(page.samplesperpixel)
    if dtype == np.uint8:
        max_code, linear = 255, False
    elif dtype == np.uint16:
        max_code, linear = 65535, False
    elif dtype in (np.float16, np.float32, np.float64):
        max_code, linear = None, True
    else:
        raise ImageError(f"{path}: unsupported TIFF sample type {dtype}")
    if not 1 <= samples <= 4 or int(getattr(page, "imagedepth", 1) or 1) != 1:
        raise ImageError(f"{path}: unsupported TIFF layout ({samples} samples per pixel, "
                         f"depth {getattr(page, 'imagedepth', 1)})")
    if tuple(page.shaped[2:4]) != (height, width):
        raise ImageError(f"{path}: unsupported TIFF layout (shape {page.shape})")
    size = os.path.getsize(path)
    for off, count in zip(page.dataoffsets, page.databytecounts):
        if count and (off < 0 or off + count > size):
            raise ImageError(f"{path}: truncated TIFF (image data {off}+{count} past the end "
                             f"of the {size}-byte file)")
    want = int(np.prod(page.chunked))
    if len(page.dataoffsets) != want or not all(page.databytecounts):
        # tifffile would fill missing strips or tiles with zeros
        raise ImageError(f"{path}: truncated TIFF ({sum(map(bool, page.databytecounts))} of "
                         f"{want} strips or tiles present)")
    return page, ImageInfo(width, height, _channels_kept(samples), max_code, linear)


def _tiff_pixels(page: Any, a: NDArray, info: ImageInfo) -> NDArray:
    """``(height, width, channels)`` from tifffile's array of the page (any planar layout)."""
    sep, _depth, h, w, contig = (int(v) for v in page.shaped)
    a = a.reshape(sep, h, w, contig)
    a = np.moveaxis(a, 0, -1).reshape(h, w, sep * contig) if sep > 1 else a[0]
    return a[..., : info.channels]


def _tiff_data(path: Path, page: Any, info: ImageInfo,
               box: tuple[int, int, int, int] | None) -> NDArray:
    """The page's pixels, or those of ``box``: memory-mapped when uncompressed and contiguous."""
    import tifffile

    if box is None:
        a = _tiff_pixels(page, np.asarray(page.asarray()), info)
    else:
        x0, y0, nx, ny = box
        if page.is_contiguous and page.is_memmappable:
            mm = tifffile.memmap(path, page=0, mode="r")
            a = _tiff_pixels(page, mm, info)[y0 : y0 + ny, x0 : x0 + nx]
        else:
            a = _tiff_pixels(page, np.asarray(page.asarray()), info)[y0 : y0 + ny, x0 : x0 + nx]
    return np.array(a, dtype=a.dtype.newbyteorder("="), order="C")


def write_tiff(path: str | PathLike[str], image: ArrayLike, *, compression: str | None = None,
               tile: tuple[int, int] | None = None, atomic: bool = True) -> None:
    """Write an image as TIFF, atomically.

    Parameters
    ----------
    path
        Output file.
    image
        ``(h, w)`` or ``(h, w, c)`` pixels (``uint8``, ``uint16`` or float).
    compression
        A :func:`tifffile.imwrite` compression (``"zlib"``, ``"lzw"``...);
        None for uncompressed data.
    tile
        ``(rows, cols)`` of a tiled file; None for strips.
    atomic
        Write a temporary beside ``path`` and rename it
        (:func:`cdbrdf.fsutil.atomic_path`). False only for the many files
        written into a partial folder of :func:`cdbrdf.outputs.output_folder`,
        which is published whole once complete: written in place, without
        a temporary, a sweep of the folder or an fsync each (an existing file
        is refused: ``FileExistsError``).
    """
    import tifffile

    a = np.asarray(image)
    photometric = "rgb" if a.ndim == 3 and a.shape[-1] >= 3 else "minisblack"
    with _destination(path, ".tif", atomic) as tmp:
        tifffile.imwrite(tmp, a, photometric=photometric, compression=compression, tile=tile)


# --------------------------------------------------------------------------- EXR
def _exr_read(path: Path) -> tuple[NDArray, ImageInfo]:
    """Decode the first part of an OpenEXR file, after checking its header.

    Uses the ``OpenEXR.File`` API: the legacy ``InputFile.header()`` crashes
    the interpreter (segmentation fault) on an attribute name that is not
    UTF-8, where ``File`` raises.
    """
    import OpenEXR

    with OpenEXR.File(str(path), header_only=True) as f:  # the header is valid while open
        header = f.header()
        window = [np.array(v, dtype=np.int64) for v in header["dataWindow"]]
        names = [str(c.name) for c in header["channels"]]
    (xmin, ymin), (xmax, ymax) = window
    width, height = int(xmax - xmin + 1), int(ymax - ymin + 1)
    _check_size(path, width, height, "exr")
    if all(c in names for c in "RGB"):
        chans = ["R", "G", "B"]
    elif "Y" in names:
        chans = ["Y"]
    elif len(names) == 1:
        chans = names
    else:
        raise ImageError(f"{path}: OpenEXR channels {names} are neither R,G,B nor Y")
    with OpenEXR.File(str(path), separate_channels=True) as f:
        channels = f.channels()
        out = np.empty((height, width, len(chans)), dtype=np.float32)
        for i, c in enumerate(chans):
            px = np.asarray(channels[c].pixels)
            if px.shape != (height, width):
                raise ImageError(f"{path}: OpenEXR channel {c} has {px.shape} pixels, "
                                 f"not {height} x {width}")
            out[..., i] = px
    return out, ImageInfo(width, height, len(chans), None, True)


def write_exr(path: str | PathLike[str], image: ArrayLike, *, atomic: bool = True) -> None:
    """Write a linear grey or RGB image as a float32 OpenEXR file (ZIP compression), atomically.

    Parameters
    ----------
    path
        Output file.
    image
        ``(h, w)``, ``(h, w, 1)`` or ``(h, w, 3)`` linear values.
    atomic
        Write a temporary beside ``path`` and rename it
        (:func:`cdbrdf.fsutil.atomic_path`). False only for the many files
        written into a partial folder of :func:`cdbrdf.outputs.output_folder`,
        which is published whole once complete: written in place, without
        a temporary, a sweep of the folder or an fsync each (an existing file
        is refused: ``FileExistsError``).
    """
    import OpenEXR

    a = np.asarray(image, dtype=np.float32)
    if a.ndim == 2:
        a = a[..., None]
    if a.ndim != 3 or a.shape[-1] not in (1, 3):
        raise OptionError(f"image: expected 1 or 3 channels, got shape {a.shape}")
    if a.shape[-1] == 3:
        channels = {"RGB": np.ascontiguousarray(a)}
    else:
        channels = {"Y": np.ascontiguousarray(a[..., 0])}
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    with _destination(path, ".exr", atomic) as tmp, OpenEXR.File(header, channels) as f:
        f.write(str(tmp))


# --------------------------------------------------------------------------- API
def _read(path: Path, window: Any) -> tuple[NDArray, ImageInfo]:
    """Read ``path`` whole (``window`` None) or the window; every failure as :class:`ImageError`.

    The window (a function of the image's :class:`ImageInfo` possibly) is
    resolved outside the wrapping, so that its own errors keep their type.
    """
    fmt = image_format(path)
    _check_file(path)
    if fmt == "tiff":
        import tifffile

        with _reading(path, fmt):
            tf = tifffile.TiffFile(path)
        try:
            with _reading(path, fmt):
                page, info = _tiff_page(path, tf)
            box = None if window is None else _resolve(path, info, window)
            with _reading(path, fmt):
                return _tiff_data(path, page, info, box), info
        finally:
            tf.close()
    with _reading(path, fmt):
        a, info = _png_read(path) if fmt == "png" else _exr_read(path)
    if window is None:
        return a, info
    x0, y0, nx, ny = _resolve(path, info, window)
    return a[y0 : y0 + ny, x0 : x0 + nx].copy(), info


def _jpeg_size(name: str, data: bytes) -> tuple[int, int]:
    """A JPEG's ``(width, height)`` from its first frame header, before decoding (ITU T.81, B.2)."""
    pos = 2
    while pos + 9 <= len(data) and data[pos] == 0xFF:
        marker, (length,) = data[pos + 1], struct.unpack(">H", data[pos + 2 : pos + 4])
        if 0xC0 <= marker <= 0xCF and marker not in (0xC4, 0xC8, 0xCC):
            height, width = struct.unpack(">HH", data[pos + 5 : pos + 9])
            return int(width), int(height)
        pos += 1 if marker == 0xFF else 2 + max(length, 2)
    raise ImageError(f"{name}: corrupt or truncated JPEG (no frame header)")


def decode_image(data: bytes, *, name: str) -> tuple[NDArray, ImageInfo]:
    """A PNG (every check of :func:`read_image`) or JPEG (its size checked first) held in memory, as :func:`read_image`
    returns it; ``name`` for messages. Raises :class:`ImageError` (:class:`~cdbrdf.errors.LimitError`)."""
    if data[:8] == _PNG_SIGNATURE:
        with _reading(Path(name), "png"):
            return _png_read(Path(name), data)
    if data[:3] != b"\xff\xd8\xff":
        raise ImageError(f"{name}: neither a PNG nor a JPEG image (signature {data[:8]!r})")
    (width, height), label = _jpeg_size(name, data), Path(name)
    _check_size(label, width, height, "png")
    with _reading(label, "png"):
        import imagecodecs
        return _integer_image(label, np.asarray(imagecodecs.jpeg8_decode(data)), width, height)


def read_image(path: str | PathLike[str]) -> tuple[NDArray, ImageInfo]:
    """Decode a whole image.

    Parameters
    ----------
    path
        PNG, TIFF or OpenEXR file (the extension selects the format).

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
        When it is corrupt, truncated, unreadable, not a regular file or of
        an unsupported kind (:class:`~cdbrdf.errors.LimitError` when it
        declares more pixels than the ``image_pixels`` limit).
    """
    return _read(Path(path), None)


def read_window(
    path: str | PathLike[str],
    window: tuple[int, int, int, int] | Callable[[ImageInfo], tuple[int, int, int, int]],
) -> tuple[NDArray, ImageInfo]:
    """Read the pixels ``[y0:y0+ny, x0:x0+nx]`` of an image.

    The file passes exactly the checks of :func:`read_image` (the image is
    decoded whole and sliced), except that the rows of an uncompressed,
    contiguous TIFF are memory-mapped instead of read whole.

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
    OptionError
        When ``window`` is not four whole numbers (checked before the file
        is opened) or the function returns something else.
    """
    if not callable(window):
        _window_values(window)
    return _read(Path(path), window)
