"""The measurement pipeline: a capture folder in, a :class:`~cdbrdf.CDBRDF` out.

Stages (``docs/capture.md`` describes the folder):

1. :func:`read_capture` parses ``capture.csv`` (and ``stands.json``), derives
   the grid from the sample rows and which samples the stands hide.
2. Every photograph that is needed (sample rows not hidden, white references,
   dark frames) becomes one Dask task that reads and decodes its N x N patch
   (:func:`cdbrdf.measure.patch.read_patch`). Tasks run on Dask's local
   threaded scheduler by default, or on a cluster (``scheduler="tcp://..."``,
   or a :class:`distributed.Client`); the files must be visible to the
   workers under the same path.
3. Results are checkpointed batch by batch (``checkpoint_dir``); a later run
   with the same capture table, stand file and options reuses every image
   whose size and modification time are unchanged, so an interrupted run
   resumes and gives a bit-identical table.
4. The driver merges brackets, subtracts dark frames, divides by
   ``cos(theta_l)``, scales by the white reference, and fills invalid samples
   (:func:`cdbrdf.measure.fill.fill_nearest`).

The result is built in memory and written with :meth:`CDBRDF.save`
(atomic), so no half file is ever left under the output name.
"""

from __future__ import annotations

import csv
import hashlib
import io
import json
import logging
import math
import os
import re
import stat as statmod
import struct
import zlib
from collections.abc import Callable
from dataclasses import dataclass, field
from os import PathLike
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .. import limits
from ..errors import CaptureError, CDBRDFError, TableError
from ..frames import direction_from_angles
from ..table import CDBRDF, Grid
from .fill import angle_between_deg, fill_nearest
from ..fsutil import OWNER_MARK, atomic_path, is_owned, mark_owned, remove_owned, same_file, sweep_stale
from .images import FORMATS, ImageError, ImageInfo, image_format, read_window
from .patch import merge_exposures, patch_statistics, patch_window, read_patch
from .plan import CAPTURE_FILE, STAND_FILE, Stand, hidden_mask, load_json_object, parse_stands

__all__ = [
    "CaptureError",
    "CaptureRow",
    "Capture",
    "MeasureReport",
    "MeasurementInterrupted",
    "KINDS",
    "LOCAL_SCHEDULERS",
    "read_capture",
    "measure",
    "checkpoint_path",
    "bad_list_path",
    "UnusablePhotographs",
]

_LOG = logging.getLogger(__name__)

#: Valid values of the ``kind`` column.
KINDS: tuple[str, ...] = ("sample", "white", "dark")
#: ``scheduler`` values that select one of Dask's local schedulers.
LOCAL_SCHEDULERS: tuple[str, ...] = ("threads", "processes", "synchronous")
_REQUIRED = ("file", "kappa", "theta_v", "phi_v", "theta_l", "phi_l")
_KNOWN = _REQUIRED + ("exposure", "cx", "cy", "kind", "hidden", "encoding")
_AXES = ("kappa", "theta_l", "phi_l", "theta_v", "phi_v")
_ANGLE_DECIMALS = 6
_CKPT_VERSION = 1
#: An axis value used by fewer sample conditions than this fraction of the axis's median is stray.
_STRAY_FRACTION = 0.1
#: Largest ``pixel_mm`` accepted in ``stands.json`` (a 10 mm pixel covers a whole stand).
_MAX_PIXEL_MM = 10.0
#: Largest ``cx``/``cy`` accepted (far beyond any camera; keeps the arithmetic in int64).
_MAX_PIXEL_INDEX = 10_000_000


class MeasurementInterrupted(RuntimeError):
    """Raised by the test hook ``_interrupt_after`` (simulates a killed run)."""


@dataclass(frozen=True)
class CaptureRow:
    """One row of ``capture.csv`` (angles in degrees, kappa in mm^-1; NaN where blank)."""

    line: int
    file: str
    kind: str
    kappa: float
    theta_v: float
    phi_v: float
    theta_l: float
    phi_l: float
    exposure: float
    cx: int | None
    cy: int | None
    linear: bool | None
    hidden: bool
    extra: dict[str, str]


@dataclass
class Capture:
    """A parsed capture folder.

    Attributes
    ----------
    folder
        The folder.
    rows
        All rows, in file order.
    grid
        The sample axes the sample rows cover.
    stands
        Stand geometry by curvature, or None without ``stands.json``.
    hidden
        ``grid.shape`` booleans: samples the stands (or the ``hidden`` column) hide.
    settings
        Other keys of ``stands.json`` (``white_albedo``, ``encoding``, ``material``).
    digest
        SHA-256 of ``capture.csv`` and ``stands.json`` (identifies the capture).
    extra_columns
        Columns beyond the documented ones (kept as provenance).
    """

    folder: Path
    rows: list[CaptureRow]
    grid: Grid
    stands: dict[float, Stand] | None
    hidden: NDArray[np.bool_]
    settings: dict[str, Any]
    digest: str
    extra_columns: list[str]
    sample_index: dict[int, tuple[int, int, int, int, int]] = field(default_factory=dict)


@dataclass
class MeasureReport:
    """What a measurement did (printed by ``cdbrdf measure``)."""

    n_samples: int = 0
    n_measured: int = 0
    n_filled: int = 0
    n_hidden: int = 0
    n_saturated: int = 0
    n_not_photographed: int = 0
    n_skipped_samples: int = 0
    n_images: int = 0
    n_images_resumed: int = 0
    n_white: int = 0
    n_dark: int = 0
    quantity: str = "relative"
    skipped_files: list[tuple[str, str]] = field(default_factory=list)

    def summary(self) -> str:
        """A few human-readable lines."""
        lines = [
            f"{self.n_images} photographs used ({self.n_images_resumed} from the checkpoint), "
            f"{self.n_white} white reference(s), {self.n_dark} dark frame(s); quantity {self.quantity}",
            f"{self.n_samples} samples: {self.n_measured} measured, {self.n_filled} filled "
            f"({self.n_hidden} hidden by the stand, {self.n_saturated} saturated, "
            f"{self.n_skipped_samples} unreadable, {self.n_not_photographed} not photographed)",
        ]
        if self.skipped_files:
            lines.append(f"{len(self.skipped_files)} file(s) skipped:")
            lines += [f"  {f}: {why}" for f, why in self.skipped_files[:20]]
            if len(self.skipped_files) > 20:
                lines.append(f"  ... and {len(self.skipped_files) - 20} more")
        return "\n".join(lines)


# --------------------------------------------------------------------------- parsing
def _num(where: str, col: str, text: str, *, blank_ok: bool) -> float:
    t = (text or "").strip()
    if not t:
        if blank_ok:
            return math.nan
        raise CaptureError(f"{where}: column {col!r} is empty")
    try:
        v = float(t)
    except ValueError:
        raise CaptureError(f"{where}: column {col!r}: {t!r} is not a number") from None
    if not math.isfinite(v):
        raise CaptureError(f"{where}: column {col!r}: {t!r} is not finite")
    return v


def _bool(where: str, col: str, text: str) -> bool:
    t = (text or "").strip().lower()
    if t in ("", "0", "no", "false", "visible"):
        return False
    if t in ("1", "yes", "true", "view", "light", "view+light", "both", "hidden"):
        return True
    raise CaptureError(f"{where}: column {col!r}: {text!r} is not a yes/no value")


def _round_angle(x: float) -> float:
    return round(x, _ANGLE_DECIMALS) + 0.0


def _decode_csv(csv_path: Path, data: bytes) -> str:
    """``capture.csv``'s bytes as text; one-line :class:`CaptureError` naming the line otherwise."""
    if data.startswith((b"\xff\xfe", b"\xfe\xff")):
        raise CaptureError(f"{csv_path}: UTF-16 text (byte-order mark); save it as UTF-8")
    nul = data.find(b"\0")
    if nul >= 0:
        line = data[:nul].count(b"\n") + 1
        raise CaptureError(f"{csv_path}: line {line}: NUL byte; not a text file")
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = data[: exc.start].count(b"\n") + 1
        raise CaptureError(
            f"{csv_path}: line {line}: not UTF-8 text (byte 0x{data[exc.start]:02x}); save it as UTF-8"
        ) from None


def _check_rows_limit(csv_path: Path, text: str) -> None:
    """Refuse a table of more rows than the ``capture_rows`` limit (before parsing it)."""
    cap = limits.limit("capture_rows").value()
    if text.count("\n") <= cap:  # an upper bound of the data rows: nothing to count
        return
    try:
        n = sum(1 for _ in csv.reader(io.StringIO(text))) - 1
    except csv.Error:
        n = text.count("\n")
    limits.check("capture_rows", n, what=f"{csv_path}: a table of")


def _settings(doc: dict[str, Any], stand_path: Path) -> dict[str, Any]:
    """Validate the settings of ``stands.json`` (every key but ``stands`` and ``grid``)."""
    out = {k: v for k, v in doc.items() if k not in ("stands", "grid")}
    if "white_albedo" in out:
        a = out["white_albedo"]
        if isinstance(a, bool) or not isinstance(a, (int, float)) or not 0 < a <= 1.5:
            raise CaptureError(f"{stand_path}: white_albedo: expected a number in (0, 1.5], got {a!r:.40}")
        out["white_albedo"] = float(a)
    if "pixel_mm" in out:
        v = out["pixel_mm"]
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not 0 <= v <= _MAX_PIXEL_MM:
            raise CaptureError(
                f"{stand_path}: pixel_mm: expected a number in [0, {_MAX_PIXEL_MM:g}] mm, got {v!r:.40}"
            )
        out["pixel_mm"] = float(v)
    if "encoding" in out and out["encoding"] not in ("srgb", "linear"):
        raise CaptureError(f"{stand_path}: encoding: {out['encoding']!r:.40} is not one of srgb, linear")
    if "material" in out:
        m = out["material"]
        if not isinstance(m, str) or not m.strip() or len(m) > 200 or not m.isprintable():
            raise CaptureError(f"{stand_path}: material: expected a printable name (1 to 200 characters)")
    return out


def _explicit_grid(doc: dict[str, Any], stand_path: Path) -> dict[str, NDArray[np.float64]] | None:
    """The ``grid`` of ``stands.json`` (each axis a list of numbers), normalised like the rows."""
    g = doc.get("grid")
    if g is None:
        return None
    if not isinstance(g, dict) or set(g) != set(_AXES):
        raise CaptureError(f"{stand_path}: grid: expected an object with the lists {', '.join(_AXES)}")
    out: dict[str, NDArray[np.float64]] = {}
    for name in _AXES:
        vals = g[name]
        if not isinstance(vals, list) or not vals:
            raise CaptureError(f"{stand_path}: grid: {name}: expected a non-empty list of numbers")
        xs = []
        for v in vals:
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(float(v)):
                raise CaptureError(f"{stand_path}: grid: {name}: {v!r:.40} is not a finite number")
            v = float(v)
            if name.startswith("phi"):
                v = v % 360.0
            v = _round_angle(v)
            xs.append(0.0 if name.startswith("phi") and v >= 360.0 else v)
        out[name] = np.unique(np.array(xs))
    return out


def _stray_values(csv_path: Path, samples: list[CaptureRow]) -> None:
    """Refuse an axis value that a stray row adds to a derived grid (see :func:`read_capture`)."""
    conds = {tuple(getattr(r, a) for a in _AXES): r for r in reversed(samples)}  # first row per condition
    for ax, name in enumerate(_AXES):
        count: dict[float, int] = {}
        for c in conds:
            count[c[ax]] = count.get(c[ax], 0) + 1
        if len(count) < 2:
            continue
        med = float(np.median(list(count.values())))
        for v, n in count.items():
            if n < _STRAY_FRACTION * med:
                line = min(r.line for c, r in conds.items() if c[ax] == v)
                raise CaptureError(
                    f"{csv_path}: line {line}: {name} = {v:g} is used by {n} sample condition(s) only, "
                    f"the other {name} values by {med:g} (median); a stray row? Fix it, or list the "
                    f"grid in {STAND_FILE} ('grid') to keep it"
                )


def read_capture(folder: str | PathLike[str], *, csv_name: str = CAPTURE_FILE, patch: int = 7) -> Capture:
    """Parse a capture folder (``docs/capture.md``).

    ``patch`` (N) sizes the patch whose footprint the stand geometry must
    leave clear when ``stands.json`` gives ``pixel_mm``.

    The grid is, by default, derived from the sample rows: the sorted
    distinct values of each axis. A value that only a few rows use - fewer
    sample conditions than a tenth of the median of that axis's values - is
    taken for a stray row (a typo would otherwise silently add a whole
    not-photographed slice to the table) and refused, naming its line.
    ``stands.json`` may instead list the grid (``"grid": {"kappa": [...],
    "theta_l": [...], "phi_l": [...], "theta_v": [...], "phi_v": [...]}``):
    then every sample row must lie on it and any value is accepted.

    Raises
    ------
    FileNotFoundError
        When the folder or its ``capture.csv`` does not exist.
    CaptureError
        When a row is malformed (names the file and line), the sample rows
        do not form a grid, or ``stands.json`` is malformed (names the key).
    LimitError
        When ``capture.csv`` has more rows than the ``capture_rows`` limit or
        ``stands.json`` is larger than ``json_bytes``.
    """
    root = Path(folder)
    if not root.is_dir():
        raise FileNotFoundError(f"{root}: no such capture folder")
    csv_path = root / csv_name
    if not csv_path.is_file():
        raise FileNotFoundError(f"{csv_path}: the capture folder has no {csv_name}")
    try:
        csv_bytes = csv_path.read_bytes()
    except OSError as exc:
        raise CaptureError(f"{csv_path}: cannot be read ({exc.strerror or exc})") from None
    text = _decode_csv(csv_path, csv_bytes)
    _check_rows_limit(csv_path, text)

    # stands.json first: its grid decides how the rows are checked
    stands = None
    settings: dict[str, Any] = {}
    stand_bytes = b""
    stand_path = root / STAND_FILE
    given_grid = None
    if stand_path.exists() or stand_path.is_symlink():
        doc = load_json_object(stand_path)
        stand_bytes = stand_path.read_bytes()
        settings = _settings(doc, stand_path)
        given_grid = _explicit_grid(doc, stand_path)
        if "stands" in doc:
            stands = parse_stands(doc, stand_path)

    reader = csv.DictReader(io.StringIO(text))
    try:
        cols = [c.strip() for c in (reader.fieldnames or [])]
    except csv.Error as exc:
        raise CaptureError(f"{csv_path}: line 1: not a CSV header ({exc})") from None
    reader.fieldnames = cols
    missing = [c for c in _REQUIRED if c not in cols]
    if missing:
        have = ", ".join(cols)
        raise CaptureError(
            f"{csv_path}: missing column(s) {', '.join(missing)} (have: {have[:200]})"
        )
    extra_cols = [c for c in cols if c not in _KNOWN]
    rows: list[CaptureRow] = []
    try:
        for rec in reader:
            rows.append(_parse_row(csv_path, reader.line_num, rec, extra_cols))
    except csv.Error as exc:
        # the reader counts a line once parsed: the faulty one is the next
        raise CaptureError(f"{csv_path}: line {reader.line_num + 1}: not valid CSV ({exc})") from None
    samples = [r for r in rows if r.kind == "sample"]
    if not samples:
        raise CaptureError(f"{csv_path}: no sample rows")

    if given_grid is not None:
        for r in samples:
            for name in _AXES:
                v = getattr(r, name)
                if not np.any(given_grid[name] == v):
                    raise CaptureError(
                        f"{csv_path}: line {r.line}: {name} = {v:g} is not on the grid of {STAND_FILE}"
                    )
        axes = given_grid
        where = f"{stand_path}: grid"
    else:
        _stray_values(csv_path, samples)
        axes = {name: np.unique(np.array([getattr(r, name) for r in samples])) for name in _AXES}
        where = f"{csv_path}: the sample rows"
    limits.check("table_samples", math.prod(len(v) for v in axes.values()), what=f"{where}: a grid of")
    try:
        grid = Grid(**axes)
    except TableError as exc:
        raise CaptureError(f"{where} do not form a table grid: {exc}") from None

    if stands is not None:
        missing_k = [k for k in grid.kappa if not any(abs(k - s) <= 1e-9 for s in stands)]
        if missing_k:
            raise CaptureError(
                f"{stand_path}: no stand for kappa {', '.join(f'{k:g}' for k in missing_k[:10])}"
            )
        pixel_mm = settings.get("pixel_mm", 0.0)
        hidden = hidden_mask(grid, list(stands.values()), pixel_mm=float(pixel_mm), patch_px=patch) > 0
    else:
        hidden = np.zeros(grid.shape, dtype=bool)
    index: dict[int, tuple[int, int, int, int, int]] = {}
    for i, r in enumerate(rows):
        if r.kind != "sample":
            continue
        idx = (
            int(np.searchsorted(grid.kappa, r.kappa)),
            int(np.searchsorted(grid.phi_l, r.phi_l)),
            int(np.searchsorted(grid.theta_l, r.theta_l)),
            int(np.searchsorted(grid.phi_v, r.phi_v)),
            int(np.searchsorted(grid.theta_v, r.theta_v)),
        )
        index[i] = idx
        if stands is None and r.hidden:
            hidden[idx] = True
    digest = hashlib.sha256(csv_bytes + b"\0" + stand_bytes).hexdigest()
    return Capture(root, rows, grid, stands, hidden, settings, digest, extra_cols, index)


def _parse_row(csv_path: Path, line: int, rec: dict, extra_cols: list[str]) -> CaptureRow:
    """One record of ``capture.csv`` (``line``: its last physical line)."""
    where = f"{csv_path}: line {line}"
    if None in rec:
        raise CaptureError(f"{where}: more fields than columns")
    kind = (rec.get("kind") or "sample").strip().lower() or "sample"
    if kind not in KINDS:
        raise CaptureError(f"{where}: kind {kind!r:.40} is not one of {', '.join(KINDS)}")
    fname = (rec.get("file") or "").strip()
    if not fname:
        raise CaptureError(f"{where}: column 'file' is empty")
    if not fname.isprintable():
        raise CaptureError(f"{where}: file {fname!r:.60} contains control characters")
    if Path(fname).suffix.lower() not in FORMATS:
        raise CaptureError(
            f"{where}: {fname!r:.60} has an unsupported extension; valid: {', '.join(FORMATS)}"
        )
    blank_dirs = kind == "dark"
    kappa = _num(where, "kappa", rec.get("kappa", ""), blank_ok=kind != "sample")
    ang = {
        c: _num(where, c, rec.get(c, ""), blank_ok=blank_dirs)
        for c in ("theta_v", "phi_v", "theta_l", "phi_l")
    }
    for c in ("theta_v", "theta_l"):
        if not math.isnan(ang[c]) and not 0 <= ang[c] < 90:
            raise CaptureError(f"{where}: {c} = {ang[c]:g} is outside [0, 90) degrees")
    for c in ("phi_v", "phi_l"):
        if not math.isnan(ang[c]):
            ang[c] = ang[c] % 360.0
    for c in ang:
        if not math.isnan(ang[c]):
            ang[c] = _round_angle(ang[c])
            if c.startswith("phi") and ang[c] >= 360.0:
                ang[c] = 0.0
    exposure = _num(where, "exposure", rec.get("exposure", ""), blank_ok=True)
    if math.isnan(exposure):
        exposure = 1.0
    if exposure <= 0:
        raise CaptureError(f"{where}: exposure must be positive, got {exposure:g}")
    if not 1e-9 <= exposure <= 1e9:  # a denormal exposure overflows the bracket merge
        raise CaptureError(f"{where}: exposure {exposure:g} is outside [1e-9, 1e9]")
    cxy = []
    for c in ("cx", "cy"):
        v = _num(where, c, rec.get(c, ""), blank_ok=True)
        if not math.isnan(v) and (v != int(v) or not 0 <= v <= _MAX_PIXEL_INDEX):
            raise CaptureError(f"{where}: {c} must be a pixel index in [0, {_MAX_PIXEL_INDEX}], got {v:g}")
        cxy.append(None if math.isnan(v) else int(v))
    enc = (rec.get("encoding") or "").strip().lower()
    if enc not in ("", "srgb", "linear"):
        raise CaptureError(f"{where}: encoding {enc!r:.40} is not one of srgb, linear")
    return CaptureRow(
        line=line, file=fname, kind=kind,
        kappa=_round_angle(kappa) if not math.isnan(kappa) else math.nan,
        exposure=exposure, cx=cxy[0], cy=cxy[1],
        linear=None if not enc else enc == "linear",
        hidden=_bool(where, "hidden", rec.get("hidden", "")),
        extra={c: rec.get(c, "") or "" for c in extra_cols},
        **ang,
    )


# --------------------------------------------------------------------------- tasks
def _read_task(path: str, n: int, cx: int | None, cy: int | None, linear: bool
               ) -> tuple[int, NDArray | None, NDArray | None, str]:
    """One photograph's patch: ``(status, values, saturated, message)``.

    status 0 = read, 1 = missing, 2 = unusable. Every failure to read the
    photograph is that photograph's problem, whatever its type.
    """
    try:
        v, s = read_patch(path, n=n, cx=cx, cy=cy, linear=linear)
    except FileNotFoundError:
        return 1, None, None, "missing"
    except ImageError as exc:
        return 2, None, None, _problem(path, exc)
    except OSError as exc:
        return 2, None, None, f"cannot be read ({exc.strerror or exc})"
    except Exception as exc:  # noqa: BLE001 - a decoder failing on this file
        return 2, None, None, f"cannot be decoded ({_describe(exc)})"
    return 0, v, s, ""


def _first_line(exc: BaseException) -> str:
    text = str(exc).strip()
    return (text.splitlines() or [""])[0][:300]


def _describe(exc: BaseException) -> str:
    """``"Type: first line"`` (just the type when the message is empty)."""
    text = _first_line(exc)
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__


def _problem(path: str | Path, exc: BaseException) -> str:
    """The message of ``exc`` without the leading ``"<path>: "``."""
    text = _first_line(exc)
    prefix = f"{path}: "
    return text[len(prefix):] if text.startswith(prefix) else text


def _stat(path: Path) -> tuple[int, int]:
    try:
        st = path.stat()
    except (OSError, ValueError):
        return -1, -1
    return int(st.st_size), int(st.st_mtime_ns)


# --------------------------------------------------------------------------- pre-flight
#: PNG colour type -> channels the reader returns (alpha dropped); palette images: unknown.
_PNG_CHANNELS = {0: 1, 2: 3, 4: 1, 6: 3}
_PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


class _HeaderRead(BaseException):
    """Stops :func:`read_window` once the header is known (a BaseException so no reader swallows it)."""

    def __init__(self, info: ImageInfo) -> None:
        super().__init__()
        self.info = info


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


def _preflight(cap: Capture, needed: list[int], paths: dict[int, Path], patch: int
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
            problems[i] = (2, _problem(p, exc))
            continue
        except OSError as exc:
            problems[i] = (2, f"cannot be read ({exc.strerror or exc})")
            continue
        except Exception as exc:  # noqa: BLE001 - a header parser failing on this file
            problems[i] = (2, f"corrupt header ({_describe(exc)})")
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
        first = {}
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


def _refuse_bad(cap: Capture, problems: dict[int, tuple[int, str]], paths: dict[int, Path],
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


def _refuse_overlap(cap: Capture, folders: list[Path], files: list[Path]) -> None:
    """Refuse outputs that are (or, for folders, contain) an input of the run.

    ``files`` are written, ``folders`` created and deleted. Inputs: ``capture.csv``,
    ``stands.json`` and the file of every row (hidden rows too). The same
    file is recognised through symbolic and hard links (device and inode),
    and by resolved path for inputs that do not exist yet.
    """
    inputs = [cap.folder / CAPTURE_FILE, cap.folder / STAND_FILE] + [cap.folder / r.file for r in cap.rows]
    line_of: dict[Path, str] = {cap.folder / CAPTURE_FILE: "the capture table",
                                cap.folder / STAND_FILE: "the stand file"}
    for r in cap.rows:
        line_of.setdefault(cap.folder / r.file, f"a photograph (capture.csv line {r.line})")
    parents: dict[Path, Path] = {}

    def resolved(p: Path) -> Path:
        if p.parent not in parents:
            try:
                parents[p.parent] = p.parent.resolve()
            except (OSError, RuntimeError):
                parents[p.parent] = p.parent.absolute()
        return parents[p.parent] / p.name

    by_inode: dict[tuple[int, int], Path] = {}
    by_path: dict[Path, Path] = {}
    for p in inputs:
        by_path.setdefault(resolved(p), p)
        try:
            st = os.stat(p)
        except (OSError, ValueError):
            continue
        by_inode.setdefault((st.st_dev, st.st_ino), p)
    input_dirs = set(parents.values())

    def clash(target: Path, folder: bool) -> Path | None:
        t = resolved(target)
        if t in by_path:
            return by_path[t]
        try:
            st = os.stat(target)
        except (OSError, ValueError):
            st = None
        if st is not None and (st.st_dev, st.st_ino) in by_inode:
            return by_inode[(st.st_dev, st.st_ino)]
        if folder:
            for d in input_dirs:
                if d == t or t in d.parents:
                    return next(p for p in inputs if resolved(p).parent == d)
        return None

    for target, folder in [(t, False) for t in files] + [(t, True) for t in folders]:
        hit = clash(target, folder)
        if hit is not None:
            what = line_of.get(hit, "an input")
            rel = "holds" if folder and not same_file(target, hit) else "is"
            raise CaptureError(
                f"{target}: {rel} {hit}, {what} of the capture; the output must not replace an input "
                f"(--force does not change that); choose another output name"
            )


def checkpoint_path(output: str | PathLike[str]) -> Path:
    """The checkpoint folder used for an output file: ``<output>.ckpt``."""
    return Path(str(output) + ".ckpt")


_CKPT_KIND = "checkpoint"
_KEY_FILE = "key.json"
_BATCH_RE = re.compile(r"^batch-\d{8}\.npz$")
#: names in a checkpoint written by cdbrdf before folders carried the owner mark
_LEGACY_RE = re.compile(r"^(key\.json|batch-\d{8}\.npz|\.batch-[A-Za-z0-9_]+\.npz)$")
#: temporaries of :func:`cdbrdf.fsutil.atomic_path` inside a checkpoint: ``.<dest>.<pid>.<host>.<rand>.tmp``
_TEMP_DEST_RE = re.compile(r"^\.(key\.json|batch-\d{8}\.npz)\.\d+\.[0-9a-f]{8}\.[0-9a-f]{8}\.tmp$")


def _checkpoint_layout(folder: Path) -> bool:
    """True when ``folder`` holds nothing but what cdbrdf's checkpoints hold."""
    try:
        names = [p.name for p in folder.iterdir()]
    except OSError:
        return False
    return all(n == OWNER_MARK or _LEGACY_RE.match(n) or _TEMP_DEST_RE.match(n) for n in names)


def _read_key(folder: Path) -> object:
    try:
        return json.loads((folder / _KEY_FILE).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None


class _Checkpoint:
    """Results of finished images, one ``.npz`` file per batch (each written atomically).

    The folder carries cdbrdf's owner mark (:func:`cdbrdf.fsutil.mark_owned`);
    a folder of that name that cdbrdf did not make is never touched. A folder
    of the layout written by earlier versions (``key.json`` and
    ``batch-*.npz`` only) is adopted. An unreadable batch is ignored (its
    photographs are read again) with a warning.
    """

    def __init__(self, folder: Path | None, key: str, *, legacy_keys: tuple[str, ...] = (),
                 patch: int = 7) -> None:
        self.folder = folder
        self.key = key
        self.patch = patch
        self.done: dict[int, tuple[tuple[int, int], int, NDArray | None, NDArray | None, str]] = {}
        if folder is None:
            return
        self._sweep_leftovers()
        accepted = [{"key": k, "version": _CKPT_VERSION} for k in (key, *legacy_keys)]
        if folder.exists() or folder.is_symlink():
            if not is_owned(folder, _CKPT_KIND):
                legacy = folder.is_dir() and not folder.is_symlink() and not (folder / OWNER_MARK).exists() \
                    and _checkpoint_layout(folder)
                if not legacy:
                    raise FileExistsError(
                        f"{folder}: exists and is not a checkpoint made by cdbrdf measure; "
                        "move it away or choose another output name"
                    )
                for p in folder.glob(".batch-*.npz"):  # temporaries of earlier versions
                    p.unlink(missing_ok=True)
                mark_owned(folder, _CKPT_KIND)
            if _read_key(folder) not in accepted:
                _LOG.warning("%s: checkpoint of a different run; starting afresh", folder)
                remove_owned(folder, _CKPT_KIND)
        if folder.is_dir():
            for f in sorted(folder.iterdir()):
                if _BATCH_RE.match(f.name):
                    self._load(f)
            if _read_key(folder) != accepted[0]:
                self._write_key()
        else:
            folder.mkdir()
            mark_owned(folder, _CKPT_KIND)
            self._write_key()

    def _sweep_leftovers(self) -> None:
        """Remove what killed runs left: temporaries inside, half-removed checkpoints beside.

        :func:`cdbrdf.fsutil.remove_owned` renames the folder to a temporary
        name before deleting it; a run killed then leaves that folder, maybe
        without its marker. One that holds only checkpoint files gets the
        marker back so that :func:`cdbrdf.fsutil.sweep_stale` (which checks
        that its process is gone) removes it.
        """
        assert self.folder is not None
        folder = self.folder
        prefix = f".{folder.name}."
        try:
            siblings = [p for p in folder.parent.iterdir() if p.name.startswith(prefix) and p.name.endswith(".old")]
        except OSError:
            siblings = []
        for p in siblings:
            try:
                if p.is_dir() and not p.is_symlink() and not (p / OWNER_MARK).exists() and _checkpoint_layout(p):
                    mark_owned(p, _CKPT_KIND)
            except OSError:  # pragma: no cover - removed meanwhile
                pass
        sweep_stale(folder)
        if is_owned(folder, _CKPT_KIND):
            dests = set()
            for p in folder.iterdir():
                m = _TEMP_DEST_RE.match(p.name)
                if m:
                    dests.add(m[1])
            for d in sorted(dests):
                sweep_stale(folder / d)

    def _write_key(self) -> None:
        assert self.folder is not None
        with atomic_path(self.folder / _KEY_FILE) as tmp:
            tmp.write_text(json.dumps({"key": self.key, "version": _CKPT_VERSION}), encoding="utf-8")

    def _load(self, f: Path) -> None:
        """Add one batch; an unreadable or inconsistent batch is ignored (and deleted)."""
        n = self.patch
        got = {}
        try:
            with open(f, "rb") as fh, np.load(fh, allow_pickle=False) as z:
                rows, stats, status, msgs = z["rows"], z["stats"], z["status"], z["messages"]
                k = rows.shape[0] if rows.ndim == 1 else -1
                if k < 1 or stats.shape != (k, 2) or status.shape != (k,) or msgs.shape != (k,) \
                        or rows.dtype.kind != "i" or stats.dtype.kind != "i" or status.dtype.kind != "i":
                    raise ValueError("arrays of inconsistent shapes or types")
                for j, r in enumerate(rows.tolist()):
                    st = int(status[j])
                    if st not in (0, 1, 2):
                        raise ValueError(f"status {st} of row {r}")
                    v = s = None
                    if st == 0:
                        v, s = z[f"v{r}"], z[f"s{r}"]
                        if v.ndim != 3 or v.shape[:2] != (n, n) or v.shape[2] < 1 or v.dtype != np.float64 \
                                or s.shape != (n, n) or s.dtype != np.bool_:
                            raise ValueError(f"patch of row {r} has shape {v.shape} {v.dtype}")
                    got[r] = ((int(stats[j, 0]), int(stats[j, 1])), st, v, s, str(msgs[j]))
        except Exception as exc:  # noqa: BLE001 - any damage: read the photographs again
            _LOG.warning("%s: unreadable checkpoint batch ignored, its photographs are read again (%s: %s)",
                         f, type(exc).__name__, _first_line(exc))
            f.unlink(missing_ok=True)
            return
        self.done.update(got)

    def add(self, results: dict[int, tuple[tuple[int, int], int, NDArray | None, NDArray | None, str]]) -> None:
        self.done.update(results)
        if self.folder is None or not results:
            return
        rows = sorted(results)
        arrays: dict[str, NDArray] = {
            "rows": np.array(rows, dtype=np.int64),
            "stats": np.array([results[r][0] for r in rows], dtype=np.int64).reshape(-1, 2),
            "status": np.array([results[r][1] for r in rows], dtype=np.int8),
            "messages": np.array([results[r][4] for r in rows], dtype=str),
        }
        for r in rows:
            if results[r][1] == 0:
                arrays[f"v{r}"] = results[r][2]
                arrays[f"s{r}"] = results[r][3]
        with atomic_path(self.folder / f"batch-{rows[0]:08d}.npz") as tmp:
            with open(tmp, "wb") as fh:
                np.savez(fh, **arrays)

    def remove(self) -> None:
        if self.folder is not None:
            remove_owned(self.folder, _CKPT_KIND)


def _open_client(scheduler: Any):  # noqa: ANN202
    """A distributed client for an address or a Client; None for local schedulers."""
    if scheduler is None or (isinstance(scheduler, str) and scheduler in LOCAL_SCHEDULERS):
        return None, False
    if isinstance(scheduler, str):
        if "://" not in scheduler and ":" not in scheduler:
            raise ValueError(
                f"scheduler: {scheduler!r} is neither a scheduler address (tcp://host:port) "
                f"nor one of {', '.join(LOCAL_SCHEDULERS)}"
            )
        from distributed import Client

        try:
            return Client(scheduler, timeout="10s", set_as_default=False), True
        except OSError as exc:
            raise OSError(f"scheduler {scheduler}: cannot connect ({exc})") from None
    return scheduler, False


def _compute(jobs: list[tuple], scheduler: Any, client: Any, num_workers: int | None) -> list:
    if client is not None:
        futures = client.map(_read_task, *zip(*jobs), pure=False)
        return client.gather(futures)
    import dask
    from dask import delayed

    tasks = [delayed(_read_task, pure=True)(*j) for j in jobs]
    kw = {"scheduler": scheduler or "threads"}
    if num_workers and kw["scheduler"] != "synchronous":
        kw["num_workers"] = num_workers
    return list(dask.compute(*tasks, **kw))


# --------------------------------------------------------------------------- measure
def _dirs_distance(tv1, pv1, tl1, pl1, tv2, pv2, tl2, pl2) -> NDArray[np.float64]:  # noqa: ANN001
    """angle(view) + angle(light) in degrees (the fill distance)."""
    return angle_between_deg(direction_from_angles(tv1, pv1), direction_from_angles(tv2, pv2)) + \
        angle_between_deg(direction_from_angles(tl1, pl1), direction_from_angles(tl2, pl2))


def measure(
    folder: str | PathLike[str],
    output: str | PathLike[str] | None = None,
    *,
    patch: int = 7,
    linear: bool = False,
    skip_bad: bool = False,
    scheduler: Any = None,
    white_albedo: float | None = None,
    material: str | None = None,
    checkpoint: bool = True,
    batch_size: int = 32,
    num_workers: int | None = None,
    progress: Callable[[int, int], None] | None = None,
    overwrite: bool = True,
    _interrupt_after: int | None = None,
) -> tuple[CDBRDF, MeasureReport]:
    """Measure a capture folder into a CDBRDF.

    Parameters
    ----------
    folder
        The capture folder (``capture.csv``, optional ``stands.json``, images).
    output
        When given, the table is written there (atomically) and a checkpoint
        folder ``<output>.ckpt`` makes an interrupted run resumable; it is
        removed once the output is written.
    patch
        Patch size N (N x N pixels).
    linear
        Integer images hold linear values (not sRGB). A row's ``encoding``
        column, then ``stands.json``'s ``encoding``, take precedence.
    skip_bad
        Treat photographs that cannot be used (missing, not a regular file,
        unreadable, corrupt, of another size) as invalid samples (filled,
        listed in the report) instead of stopping.
    scheduler
        None (Dask's local threads), ``"threads"``, ``"processes"``,
        ``"synchronous"``, a scheduler address ``"tcp://host:port"``, or a
        :class:`distributed.Client`.
    white_albedo
        Albedo of the white reference (default: ``stands.json``'s
        ``white_albedo``, else 1.0). The reference is taken as Lambertian.
    material
        Material name written to the file (default ``stands.json``'s
        ``material``, else the folder's name).
    checkpoint
        Keep a checkpoint beside ``output`` (only with ``output``).
    batch_size
        Photographs per checkpointed batch.
    num_workers
        Threads/processes of a local scheduler (default: Dask's).
    progress
        Called as ``progress(done, total)`` after each batch.
    overwrite
        Replace an existing ``output`` (the command line's ``--force``).
        An output, its checkpoint folder or its list of unusable photographs
        that is one of the run's inputs (``capture.csv``, ``stands.json``, a
        photograph, found also through links) is always refused.

    Returns
    -------
    table : CDBRDF
        ``quantity="brdf"`` with a white reference, else ``"relative"``.
    report : MeasureReport

    Raises
    ------
    UnusablePhotographs
        (an :class:`ImageError`) without ``skip_bad``, when photographs
        cannot be used. A pre-flight pass (file type, header, size; no
        decoding) lists every such photograph before any work; photographs
        that fail to decode later are collected over the whole pass. The
        message gives the count and the first; with ``output`` the full list
        is written to ``<output>.bad.txt``, else logged.
    CaptureError
        The capture table or stand file is malformed, or an output would
        replace an input.
    FileExistsError
        ``output`` exists and ``overwrite`` is False, or ``<output>.ckpt``
        exists and is not a checkpoint cdbrdf made.
    """
    if int(patch) != patch or patch < 1:
        raise ValueError(f"patch: expected a positive integer, got {patch!r}")
    if batch_size < 1:
        raise ValueError(f"batch_size: must be positive, got {batch_size!r}")
    out_path = None if output is None else Path(output)
    if out_path is not None:
        out_dir = out_path.parent
        if not out_dir.is_dir():
            raise FileNotFoundError(f"{output}: the folder {out_dir} does not exist")
    cap = read_capture(folder, patch=int(patch))
    ck_path = checkpoint_path(out_path) if (out_path is not None and checkpoint) else None
    if out_path is not None:
        _refuse_overlap(cap, [ck_path] if ck_path is not None else [],
                        [out_path, bad_list_path(out_path)])
        if not overwrite and (out_path.exists() or out_path.is_symlink()):
            raise FileExistsError(f"{out_path}: already exists (use --force to overwrite)")
    enc = cap.settings.get("encoding")
    albedo = white_albedo if white_albedo is not None else cap.settings.get("white_albedo", 1.0)
    try:
        albedo = float(albedo)
    except (TypeError, ValueError):
        raise ValueError(f"white_albedo: expected a number, got {albedo!r}") from None
    if not 0 < albedo <= 1.5:
        raise ValueError(f"white_albedo: expected a value in (0, 1.5], got {albedo:g}")

    # which rows are read
    needed: list[int] = []
    for i, r in enumerate(cap.rows):
        if r.kind == "sample" and cap.hidden[cap.sample_index[i]]:
            continue
        needed.append(i)
    try:
        root = cap.folder.resolve()
    except (OSError, RuntimeError):
        root = cap.folder.absolute()
    paths = {i: root / cap.rows[i].file for i in needed}
    stats, bad = _preflight(cap, needed, paths, int(patch))
    if bad and not skip_bad:
        _refuse_bad(cap, bad, paths, out_path, during=False)

    def lin(r: CaptureRow) -> bool:
        if r.linear is not None:
            return r.linear
        if enc is not None:
            return enc == "linear"
        return bool(linear)

    key_doc: dict[str, Any] = {"capture": cap.digest, "patch": int(patch), "linear": bool(linear),
                               "needed": len(needed)}
    key = hashlib.sha256(json.dumps(key_doc, sort_keys=True).encode()).hexdigest()
    # checkpoints of earlier versions also hashed skip_bad (which does not change what is read)
    legacy = hashlib.sha256(json.dumps({**key_doc, "skip_bad": bool(skip_bad)}, sort_keys=True).encode()
                            ).hexdigest()
    ck = _Checkpoint(ck_path, key, legacy_keys=(legacy,), patch=int(patch))
    results: dict[int, tuple[int, NDArray | None, NDArray | None, str]] = {}
    for i, (status, why) in bad.items():
        results[i] = (status, None, None, why)
    resumed = 0
    for i in needed:
        if i in results:
            continue
        got = ck.done.get(i)
        if got is not None and got[0] == stats[i] and got[1] == 0:  # failures are tried again
            results[i] = got[1:]
            resumed += 1
    todo = [i for i in needed if i not in results]
    total = len(needed)
    if progress is not None:
        progress(len(results), total)
    failed: dict[int, tuple[int, str]] = {i: (r[0], r[3]) for i, r in results.items() if r[0] != 0 and i not in bad}
    client, own_client = _open_client(scheduler)
    try:
        done_now = 0
        for b in range(0, len(todo), batch_size):
            batch = todo[b : b + batch_size]
            jobs = [
                (str(paths[i]), int(patch), cap.rows[i].cx, cap.rows[i].cy, lin(cap.rows[i]))
                for i in batch
            ]
            out = _compute(jobs, scheduler, client, num_workers)
            new = {}
            for i, (status, v, s, msg) in zip(batch, out):
                if status != 0:
                    failed[i] = (status, msg)
                new[i] = (stats[i], status, v, s, msg)
            ck.add(new)
            for i, val in new.items():
                results[i] = val[1:]
            done_now += len(batch)
            if progress is not None:
                progress(len(results), total)
            if _interrupt_after is not None and done_now >= _interrupt_after:
                raise MeasurementInterrupted(f"test hook: interrupted after {done_now} photographs")
    finally:
        if own_client:
            client.close()
    if failed and not skip_bad:
        _refuse_bad(cap, failed, paths, out_path, during=True)

    table, report = _assemble(cap, results, albedo=albedo, patch=int(patch), linear=bool(linear),
                              material=material)
    report.n_images_resumed = resumed
    if out_path is not None:
        table.save(out_path)
        ck.remove()
        _remove_bad_list(out_path)
    return table, report


def _remove_bad_list(output: Path) -> None:
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


def _merged(cap: Capture, idx: list[int], results: dict, darks: dict[float, NDArray] | None
            ) -> tuple[NDArray, NDArray, bool, list[int]] | None:
    """Merge the readable rows ``idx``; None when none is readable."""
    ok = [i for i in idx if results.get(i, (1,))[0] == 0]
    if not ok:
        return None
    vals = [results[i][1] for i in ok]
    sats = [results[i][2] for i in ok]
    exps = [cap.rows[i].exposure for i in ok]
    dk = None
    if darks:
        keys = np.array(sorted(darks))
        dk = [darks[float(keys[np.argmin(np.abs(np.log(keys / e)))])] for e in exps]
    rad, valid = merge_exposures(vals, sats, exps, dk)
    mean, std, good = patch_statistics(rad, valid)
    return mean, std, good, ok


def _assemble(cap: Capture, results: dict, *, albedo: float, patch: int, linear: bool,
              material: str | None) -> tuple[CDBRDF, MeasureReport]:
    grid = cap.grid
    rep = MeasureReport()
    rows = cap.rows
    for i, (status, _v, _s, msg) in sorted(results.items()):
        if status != 0:
            rep.skipped_files.append((rows[i].file, msg))
    chans = {results[i][1].shape[-1] for i in results if results[i][0] == 0}
    if len(chans) > 1:
        raise CaptureError(f"{cap.folder}: photographs have different channel counts {sorted(chans)}")
    nc = chans.pop() if chans else 3

    # dark frames by exposure (mean of the frames of one exposure)
    dark_groups: dict[float, list[int]] = {}
    for i, r in enumerate(rows):
        if r.kind == "dark" and results.get(i, (1,))[0] == 0:
            dark_groups.setdefault(r.exposure, []).append(i)
    darks = {e: np.mean([results[i][1] for i in g], axis=0) for e, g in dark_groups.items()}
    rep.n_dark = sum(len(g) for g in dark_groups.values())

    # groups of rows per condition, in first-row order
    def groups(kind: str) -> dict[tuple, list[int]]:
        out: dict[tuple, list[int]] = {}
        for i, r in enumerate(rows):
            if r.kind == kind:
                k = (r.kappa, r.theta_v, r.phi_v, r.theta_l, r.phi_l)
                k = tuple(-1e300 if math.isnan(x) else x for x in k)
                out.setdefault(k, []).append(i)
        return out

    # white references: W = mean / cos(theta_l) per geometry
    whites = []
    for key, idx in groups("white").items():
        m = _merged(cap, idx, results, darks)
        if m is None:
            continue
        mean, _std, good, ok = m
        r = rows[idx[0]]
        if not good:
            _LOG.warning("white reference %s is saturated; not used", r.file)
            continue
        w = mean / math.cos(math.radians(r.theta_l))
        if np.any(w <= 0):
            raise CaptureError(f"{cap.folder / r.file}: white reference is black (after dark subtraction)")
        whites.append((r, w))
        rep.n_white += len(ok)
    if whites:
        w_k = np.array([-1e300 if math.isnan(r.kappa) else r.kappa for r, _ in whites])
        w_dirs = np.array([(r.theta_v, r.phi_v, r.theta_l, r.phi_l) for r, _ in whites])
        w_vals = np.array([w for _, w in whites])
        rep.quantity = "brdf"

    values = np.full(grid.shape + (nc,), np.nan)
    std = np.full(grid.shape + (nc,), np.nan)
    valid = np.zeros(grid.shape, dtype=bool)
    photographed = np.zeros(grid.shape, dtype=bool)
    skipped = np.zeros(grid.shape, dtype=bool)
    saturated = np.zeros(grid.shape, dtype=bool)
    n_used = 0
    for _key, idx in groups("sample").items():
        sidx = cap.sample_index[idx[0]]
        photographed[sidx] = True
        if cap.hidden[sidx]:
            continue
        m = _merged(cap, idx, results, darks)
        if m is None:
            skipped[sidx] = True
            continue
        mean, sd, good, ok = m
        n_used += len(ok)
        if not good:
            saturated[sidx] = True
            continue
        r = rows[idx[0]]
        c = math.cos(math.radians(r.theta_l))
        scale = np.full(nc, 1.0 / c)
        if whites:
            d = _dirs_distance(r.theta_v, r.phi_v, r.theta_l, r.phi_l,
                               w_dirs[:, 0], w_dirs[:, 1], w_dirs[:, 2], w_dirs[:, 3])
            d = np.where((w_k == -1e300) | (np.abs(w_k - r.kappa) <= 1e-9), d, np.inf)
            if not np.isfinite(d).any():
                raise CaptureError(f"{cap.folder}: no white reference applies to kappa {r.kappa:g}")
            j = int(np.flatnonzero(d <= d.min() + 1e-9)[0])
            scale = scale / w_vals[j] * (albedo / math.pi)
        values[sidx] = mean * scale
        std[sidx] = sd * scale
        valid[sidx] = True

    rep.n_samples = int(np.prod(grid.shape))
    rep.n_measured = int(valid.sum())
    rep.n_filled = rep.n_samples - rep.n_measured
    rep.n_hidden = int(cap.hidden.sum())
    rep.n_saturated = int(saturated.sum())
    rep.n_skipped_samples = int(skipped.sum())
    rep.n_not_photographed = int((~photographed).sum())
    rep.n_images = n_used + rep.n_white + rep.n_dark
    try:
        filled, fill_src, filled_std = fill_nearest(values, valid, grid, std=std)
    except TableError as exc:
        raise CaptureError(f"{cap.folder}: {exc}") from None

    provenance: dict[str, Any] = {
        "method": "measured",
        "capture": cap.folder.resolve().name,
        "capture_sha256": cap.digest,
        "patch_px": patch,
        "encoding": "linear" if linear else "srgb (unless the capture says linear)",
        "white_reference": bool(whites),
        "white_albedo": albedo if whites else None,
        "dark_frames": rep.n_dark,
        "stand_geometry": [s.to_dict() for s in cap.stands.values()] if cap.stands else None,
        "fill": "nearest measured direction at the same curvature "
                "(angle(view) + angle(light); ties: lowest flat index)",
        "n_hidden": rep.n_hidden,
        "n_saturated": rep.n_saturated,
        "skipped_files": [f for f, _ in rep.skipped_files[:100]],
    }
    if cap.extra_columns:
        prov_cols = {}
        for c in cap.extra_columns:
            uniq = sorted({r.extra.get(c, "") for r in rows})
            prov_cols[c] = uniq if len(uniq) <= 20 else f"{len(uniq)} distinct values"
        provenance["extra_columns"] = prov_cols
    mat = material or cap.settings.get("material") or cap.folder.resolve().name
    table = CDBRDF(
        filled, **grid.axes(), measured=valid, fill_source=fill_src, std=filled_std,
        attrs={"quantity": rep.quantity, "material": str(mat), "provenance": provenance,
               "channels": ["R", "G", "B"] if nc == 3 else ["Y"]},
    )
    return table, rep
