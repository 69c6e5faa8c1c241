"""Checks made before a measurement decodes anything: photographs and outputs.

- :func:`preflight` reads only the headers of the photographs a measurement
  needs and lists every one that cannot be used (missing, not a regular
  file, unreadable, a corrupt header, a patch outside the image, a size or
  channel count different from the others);
- :func:`refuse_bad` turns such a list (or the failures of the full decode)
  into one :class:`UnusablePhotographs` error and writes the whole list to
  ``<output>.bad.txt`` (:func:`bad_list_path`);
- :func:`refuse_overlap` refuses outputs that would replace an input of the
  capture.

The one-line descriptions of a photograph's problem (:func:`problem`,
:func:`describe`, :func:`first_line`) are shared with the decoding tasks and
the checkpoint.
"""

from __future__ import annotations

import logging
import os
import stat as statmod
import struct
import zlib
from os import PathLike
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..errors import CaptureError
from ..fsutil import atomic_path
from ..images import ImageError, ImageInfo, image_format, read_window
from ..outputs import find_overlap
from .capture import CAPTURE_FILE, STAND_FILE, Capture
from .patch import patch_window, read_patch

__all__ = [
    "UnusablePhotographs",
    "preflight",
    "refuse_bad",
    "refuse_overlap",
    "bad_list_path",
    "remove_bad_list",
    "first_line",
    "describe",
    "problem",
    "read_patch_status",
]

_LOG = logging.getLogger(__name__)


# --------------------------------------------------------------------------- messages
def first_line(exc: BaseException) -> str:
    """The first line of an exception's message, at most 300 characters."""
    text = str(exc).strip()
    return (text.splitlines() or [""])[0][:300]


def describe(exc: BaseException) -> str:
    """``"Type: first line"`` (just the type when the message is empty)."""
    text = first_line(exc)
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__


def problem(path: str | Path, exc: BaseException) -> str:
    """The message of ``exc`` without the leading ``"<path>: "``."""
    text = first_line(exc)
    prefix = f"{path}: "
    return text[len(prefix):] if text.startswith(prefix) else text


#: PNG colour type -> channels the reader returns (alpha dropped); palette images: unknown.
_PNG_CHANNELS = {0: 1, 2: 3, 4: 1, 6: 3}
_PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


class _HeaderRead(BaseException):
    """Stops :func:`read_window` once the header is known (a BaseException so no reader swallows it)."""

    def __init__(self, info: ImageInfo) -> None:
        super().__init__()
        self.info = info


def read_patch_status(path: str | Path, n: int, cx: int | None, cy: int | None, linear: bool
                      ) -> tuple[int, NDArray[np.float64] | None, NDArray[np.bool_] | None, str]:
    """One photograph's N x N patch: ``(status, values, saturated, message)``.

    status 0 = read, 1 = missing, 2 = unusable. Every failure to read the
    photograph is that photograph's problem, whatever its type (the message
    is :func:`problem`'s).
    """
    try:
        v, s = read_patch(path, n=n, cx=cx, cy=cy, linear=linear)
    except FileNotFoundError:
        return 1, None, None, "missing"
    except ImageError as exc:
        return 2, None, None, problem(path, exc)
    except OSError as exc:
        return 2, None, None, f"cannot be read ({exc.strerror or exc})"
    except Exception as exc:  # noqa: BLE001 - a decoder failing on this file
        return 2, None, None, f"cannot be decoded ({describe(exc)})"
    return 0, v, s, ""


def _header(path: str) -> tuple[int, int, int | None]:
    """``(width, height, channels or None)`` of a photograph from its header alone.

    PNG: the signature and the IHDR chunk (33 bytes). TIFF and OpenEXR: the
    reader opens the file and parses its header; the window callback stops it
    before any pixel is read.
    """
    if image_format(path) == "png":
        with open(path, "rb") as fh:
            head = fh.read(33)
        if head[:8] != _PNG_SIGNATURE:
            raise ImageError(f"{path}: not a PNG file (bad signature)")
        if len(head) < 33:
            raise ImageError(f"{path}: truncated PNG (no complete IHDR chunk)")
        length, ctype = struct.unpack(">I4s", head[8:16])
        if ctype != b"IHDR" or length != 13:
            raise ImageError(f"{path}: corrupt PNG header (the first chunk is not a 13-byte IHDR)")
        if zlib.crc32(head[12:29]) != struct.unpack(">I", head[29:33])[0]:
            raise ImageError(f"{path}: corrupt PNG header (CRC mismatch in IHDR)")
        w, h, _depth, color = struct.unpack(">IIBB", head[16:26])
        if w == 0 or h == 0:
            raise ImageError(f"{path}: corrupt PNG header (size {w} x {h})")
        return w, h, _PNG_CHANNELS.get(color)

    def stop(info: ImageInfo) -> tuple[int, int, int, int]:
        raise _HeaderRead(info)

    try:
        read_window(path, stop)
    except _HeaderRead as got:
        return got.info.width, got.info.height, got.info.channels
    raise ImageError(f"{path}: the reader gave pixels without a header")  # pragma: no cover


def preflight(cap: Capture, needed: list[int], paths: dict[int, Path], patch: int
              ) -> tuple[dict[int, tuple[int, int]], dict[int, tuple[int, str]]]:
    """Cheap checks of every needed photograph before any is decoded.

    Returns ``(stats, problems)``: ``(size, mtime_ns)`` per row (``(-1, -1)``
    when it cannot be statted) and, per unusable row, ``(status, problem)``
    (status 1 missing, 2 otherwise). A photograph is unusable when it is
    missing, not a regular file (a folder, a FIFO, a link loop), cannot be
    opened, has a corrupt header, is too small for the patch at its centre,
    or differs in size (or channels) from the other photographs (the most
    common size; ties go to the earlier row).
    """
    stats: dict[int, tuple[int, int]] = {}
    problems: dict[int, tuple[int, str]] = {}
    sizes: dict[int, tuple[int, int, int | None]] = {}
    for i in needed:
        p = paths[i]
        stats[i] = (-1, -1)
        try:
            st = os.stat(p)
        except FileNotFoundError:
            problems[i] = (1, "missing (the link points nowhere)" if os.path.islink(p) else "missing")
            continue
        except (OSError, ValueError) as exc:
            problems[i] = (2, f"cannot be opened ({getattr(exc, 'strerror', None) or exc})")
            continue
        stats[i] = (int(st.st_size), int(st.st_mtime_ns))
        if not statmod.S_ISREG(st.st_mode):
            what = "a folder" if statmod.S_ISDIR(st.st_mode) else "a FIFO" if statmod.S_ISFIFO(st.st_mode) \
                else "a device or socket"
            problems[i] = (2, f"not a regular file ({what})")
            continue
        try:
            w, h, c = _header(str(p))
        except FileNotFoundError:
            problems[i] = (1, "missing")
            continue
        except ImageError as exc:
            problems[i] = (2, problem(p, exc))
            continue
        except OSError as exc:
            problems[i] = (2, f"cannot be read ({exc.strerror or exc})")
            continue
        except Exception as exc:  # noqa: BLE001 - a header parser failing on this file
            problems[i] = (2, f"corrupt header ({describe(exc)})")
            continue
        r = cap.rows[i]
        x0, y0, n, _ = patch_window((w, h), n=patch, cx=r.cx, cy=r.cy)
        if x0 < 0 or y0 < 0 or x0 + n > w or y0 + n > h:
            at = "" if r.cx is None and r.cy is None else f" at ({r.cx}, {r.cy})"
            problems[i] = (2, f"the {n} x {n} patch{at} does not fit in the {w} x {h} image")
            continue
        sizes[i] = (w, h, c)

    def majority(values: dict[int, Any]) -> Any:
        count: dict[Any, int] = {}
        for v in values.values():
            count[v] = count.get(v, 0) + 1
        first: dict[Any, int] = {}
        for i, v in values.items():
            first.setdefault(v, i)
        return max(count, key=lambda v: (count[v], -first[v]))

    if sizes:
        ref = majority({i: (w, h) for i, (w, h, _c) in sizes.items()})
        for i, (w, h, _c) in sizes.items():
            if (w, h) != ref:
                problems[i] = (2, f"{w} x {h} pixels where the other photographs have {ref[0]} x {ref[1]}")
        chans = {i: c for i, (_w, _h, c) in sizes.items() if c is not None and i not in problems}
        if chans:
            ref_c = majority(chans)
            for i, c in chans.items():
                if c != ref_c:
                    problems[i] = (2, f"{c} channel(s) where the other photographs have {ref_c}")
    return stats, problems


class UnusablePhotographs(ImageError):
    """Photographs that cannot be used, found before or during the measurement.

    One line: how many, the first one and where the whole list is.

    Attributes
    ----------
    problems
        ``(path, capture.csv line, problem)`` of every unusable photograph.
    listing
        The file that lists them (``<output>.bad.txt``), or None.
    """

    def __init__(self, message: str, problems: list[tuple[str, int, str]], listing: Path | None) -> None:
        super().__init__(message)
        self.problems = problems
        self.listing = listing


def bad_list_path(output: str | PathLike[str]) -> Path:
    """The file listing unusable photographs for an output file: ``<output>.bad.txt``."""
    return Path(str(output) + ".bad.txt")


_BAD_LIST_HEADER = "# cdbrdf measure: photographs that cannot be used (path, capture.csv line, problem)"


def refuse_bad(cap: Capture, problems: dict[int, tuple[int, str]], paths: dict[int, Path],
               output: Path | None, *, during: bool) -> None:
    """Raise :class:`UnusablePhotographs`; the full list goes to ``<output>.bad.txt`` (or the log)."""
    items = [(str(paths[i]), cap.rows[i].line, problems[i][1]) for i in sorted(problems)]
    listing = None
    if len(items) > 1:
        if output is not None:
            listing = bad_list_path(output)
            with atomic_path(listing) as tmp:
                tmp.write_text(_BAD_LIST_HEADER + "\n" + "".join(
                    f"{f}\tline {line}\t{why}\n" for f, line, why in items), encoding="utf-8")
        else:
            for f, line, why in items:
                _LOG.error("%s (capture.csv line %d): %s", f, line, why)
    f, line, why = items[0]
    kept = " (the photographs read are kept in the checkpoint)" if during and output is not None else ""
    if len(items) == 1:
        msg = f"{f} (capture.csv line {line}): {why}; use --skip-bad to fill its sample instead{kept}"
    else:
        where = f"all are listed in {listing}" if listing is not None else "all are listed in the log"
        msg = (f"{len(items)} photographs cannot be used (first: {f}, capture.csv line {line}: {why}); "
               f"{where}; use --skip-bad to fill their samples instead{kept}")
    raise UnusablePhotographs(msg, items, listing)


def refuse_overlap(cap: Capture, folders: list[Path], files: list[Path]) -> None:
    """Refuse outputs that are (or, for folders, contain) an input of the run.

    ``files`` are written, ``folders`` created and deleted. Inputs: ``capture.csv``,
    ``stands.json`` and the file of every row (hidden rows too). The rule is
    the one of every command (:func:`cdbrdf.outputs.find_overlap`: the same
    file is recognised through symbolic and hard links, and by resolved path
    for inputs that do not exist yet); the message names the capture's line.
    """
    inputs = [cap.folder / CAPTURE_FILE, cap.folder / STAND_FILE] + [cap.folder / r.file for r in cap.rows]
    hit = find_overlap([(t, False) for t in files] + [(t, True) for t in folders], inputs)
    if hit is None:
        return
    target, inp, relation = hit
    line_of: dict[Path, str] = {cap.folder / CAPTURE_FILE: "the capture table",
                                cap.folder / STAND_FILE: "the stand file"}
    for r in cap.rows:
        line_of.setdefault(cap.folder / r.file, f"a photograph (capture.csv line {r.line})")
    raise CaptureError(
        f"{target}: {relation} {inp}, {line_of.get(inp, 'an input')} of the capture; the output must not "
        "replace an input (--force does not change that); choose another output name"
    )


def remove_bad_list(output: str | PathLike[str]) -> None:
    """Delete a list of unusable photographs left by an earlier run (only one cdbrdf wrote)."""
    p = bad_list_path(output)
    try:
        if p.is_file() and not p.is_symlink():
            with open(p, encoding="utf-8", errors="replace") as fh:
                first = fh.readline().rstrip("\n")
            if first == _BAD_LIST_HEADER:
                p.unlink()
    except OSError as exc:  # pragma: no cover - a vanished or protected file
        _LOG.debug("could not remove %s: %s", p, exc)
