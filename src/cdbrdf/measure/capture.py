"""The capture folder: ``capture.csv``, the settings of ``stands.json``, plans and brackets.

This module owns the folder's format (``docs/capture.md``); the planner
(``cdbrdf plan``), the measurement (:func:`cdbrdf.measure.measure`) and the
simulated rig (:mod:`cdbrdf.rig`) all read and write it through here:

- reading: :func:`read_capture` parses ``capture.csv`` into
  :class:`CaptureRow` s (one rule per column), derives the grid (refusing
  stray rows, or checking the rows against the ``grid`` of ``stands.json``),
  validates the settings of ``stands.json`` and marks the samples the stands
  hide; the result is a :class:`Capture`. :func:`read_rows` reads the rows
  as text, unparsed, for a tool that re-writes them (the rig);
- writing: :func:`plan_rows` / :func:`write_plan` write a plan (one row per
  photograph, :data:`PLAN_COLUMNS`), :func:`bracket_rows` repeats rows per
  exposure, :func:`write_rows` writes rows as ``capture.csv``;
- brackets: rows of one kind with the same curvature, view and light are the
  brackets of one sample (:meth:`Capture.brackets`).

The stand geometry and the ``stands`` list of ``stands.json`` live in
:mod:`cdbrdf.measure.stands`.
"""

from __future__ import annotations

import csv
import hashlib
import io
import math
import posixpath
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from os import PathLike
from pathlib import Path, PurePosixPath, PureWindowsPath
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .. import limits
from ..errors import CaptureError, TableError
from ..images import FORMATS
from ..ranges import Range
from ..table import Grid
from .registration import ROW_COLUMNS, parse_registration, row_origin
from .stands import (
    KAPPA_TOL_PER_MM,
    Stand,
    hidden_mask,
    json_number,
    load_json_object,
    parse_stands,
    read_input,
    read_json_object,
)

__all__ = [
    "CAPTURE_FILE",
    "STAND_FILE",
    "PLAN_COLUMNS",
    "REQUIRED_COLUMNS",
    "KINDS",
    "HIDDEN_NAMES",
    "ENCODINGS",
    "STAND_FILE_KEYS",
    "WHITE_ALBEDO_RANGE",
    "CaptureRow",
    "Capture",
    "read_capture",
    "read_plan",
    "Plan",
    "file_key",
    "check_file_name",
    "check_duplicates",
    "read_rows",
    "row_kind",
]

#: Name of the capture table in a capture folder.
CAPTURE_FILE = "capture.csv"
#: Name of the optional stand geometry and settings file beside it.
STAND_FILE = "stands.json"
#: Columns written by :func:`write_plan`.
PLAN_COLUMNS = ("file", "kappa", "theta_v", "phi_v", "theta_l", "phi_l", "exposure", "kind", "hidden")
#: Columns every ``capture.csv`` must have.
REQUIRED_COLUMNS = ("file", "kappa", "theta_v", "phi_v", "theta_l", "phi_l")
#: Valid values of the ``kind`` column.
KINDS: tuple[str, ...] = ("sample", "white", "dark")
#: The ``hidden`` column's words for the codes of :func:`~cdbrdf.measure.stands.hidden_mask`.
HIDDEN_NAMES: Mapping[int, str] = {0: "", 1: "view", 2: "light", 3: "view+light"}
#: Values of the ``encoding`` column and setting.
ENCODINGS: tuple[str, ...] = ("srgb", "linear")
#: The top-level keys ``stands.json`` may have (``docs/capture.md``); any other is refused.
STAND_FILE_KEYS: tuple[str, ...] = ("stands", "grid", "white_albedo", "pixel_mm", "encoding", "material",
                                    "simulated", "registration")
_KNOWN = REQUIRED_COLUMNS + ("exposure", "cx", "cy", "kind", "hidden", "encoding") + ROW_COLUMNS
_AXES = ("kappa", "theta_l", "phi_l", "theta_v", "phi_v")
_ANGLE_DECIMALS = 6
#: An axis value used by fewer sample conditions than this fraction of the axis's median is stray.
_STRAY_FRACTION = 0.1
#: Largest ``pixel_mm`` accepted in ``stands.json`` (a 10 mm pixel covers a whole stand).
_MAX_PIXEL_MM = 10.0

#: Accepted albedos of the white reference (``stands.json``'s ``white_albedo``): a white standard's
#: reflectance factor, which a fluorescent or retro-reflective standard may lift above 1.
WHITE_ALBEDO_RANGE = Range(0.0, 1.5, lo_open=True)
#: Largest ``cx``/``cy`` accepted (far beyond any camera; keeps the arithmetic in int64).
_MAX_PIXEL_INDEX = 10_000_000


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
    uv_mm: tuple[float, float] | None = None  # the fabric's (u, v) at the stand's centre (registration)


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

    def brackets(self, kind: str) -> dict[tuple[float, ...], list[int]]:
        """Row indices of one ``kind`` grouped by condition, in first-row order.

        Rows with the same ``(kappa, theta_v, phi_v, theta_l, phi_l)`` are the
        exposure brackets of one sample (or white reference); blank values
        (NaN) compare equal.
        """
        out: dict[tuple[float, ...], list[int]] = {}
        for i, r in enumerate(self.rows):
            if r.kind == kind:
                cond = (r.kappa, r.theta_v, r.phi_v, r.theta_l, r.phi_l)
                out.setdefault(tuple(-1e300 if math.isnan(x) else x for x in cond), []).append(i)
        return out


# --------------------------------------------------------------------------- reading
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
    if t in ("1", "yes", "true", "both", "hidden") or t in HIDDEN_NAMES.values():
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


def _load_table(csv_path: Path) -> tuple[bytes, str]:
    """``capture.csv``'s bytes and text: a regular file within the ``csv_bytes`` and ``capture_rows`` limits."""
    data = read_input(csv_path, "csv_bytes", what=f"{csv_path}: CSV file")
    text = _decode_csv(csv_path, data)
    _check_rows_limit(csv_path, text)
    return data, text


def _open_reader(csv_path: Path, text: str) -> csv.DictReader:
    """A reader of the table's records whose header (names stripped) has the required columns."""
    reader = csv.DictReader(io.StringIO(text))
    try:
        cols = [c.strip() for c in (reader.fieldnames or [])]
    except csv.Error as exc:
        raise CaptureError(f"{csv_path}: line 1: not a CSV header ({exc})") from None
    reader.fieldnames = cols
    missing = [c for c in REQUIRED_COLUMNS if c not in cols]
    if missing:
        have = ", ".join(cols)
        raise CaptureError(
            f"{csv_path}: missing column(s) {', '.join(missing)} (have: {have[:200]})"
        )
    return reader


def _csv_error(csv_path: Path, reader: csv.DictReader, exc: csv.Error) -> CaptureError:
    # the reader counts a line once parsed: the faulty one is the next
    return CaptureError(f"{csv_path}: line {reader.line_num + 1}: not valid CSV ({exc})")


def row_kind(rec: Mapping[str, str | None]) -> str:
    """The ``kind`` of a record of ``capture.csv`` (blank: ``"sample"``), lower case, not validated."""
    return (rec.get("kind") or "sample").strip().lower() or "sample"


def read_rows(path: str | PathLike[str]) -> tuple[list[str], list[dict[str, str]]]:
    """The columns and rows of a ``capture.csv`` as text, unparsed (for a tool that re-writes them).

    The file is decoded and its header checked as by :func:`read_capture`;
    the values are not. Blank cells are empty strings.

    Raises
    ------
    CaptureError
        When the file is not UTF-8 CSV, lacks a required column or a row has
        more fields than the header (names the file and line).
    LimitError
        When it has more rows than the ``capture_rows`` limit.
    """
    csv_path = Path(path)
    _data, text = _load_table(csv_path)
    reader = _open_reader(csv_path, text)
    rows: list[dict[str, str]] = []
    try:
        for rec in reader:
            if None in rec:
                raise CaptureError(f"{csv_path}: line {reader.line_num}: more fields than columns")
            rows.append({k: v or "" for k, v in rec.items()})
    except csv.Error as exc:
        raise _csv_error(csv_path, reader, exc) from None
    return list(reader.fieldnames or ()), rows


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
    """Validate the settings of ``stands.json`` (every key but ``stands`` and ``grid``).

    An unknown key is refused, listing the valid ones (:data:`STAND_FILE_KEYS`):
    a typo such as ``white_albdeo`` would otherwise silently scale the table.
    """
    unknown = [k for k in doc if k not in STAND_FILE_KEYS]
    if unknown:
        raise CaptureError(
            f"{stand_path}: unknown key{'s' * (len(unknown) > 1)} {', '.join(repr(k[:40]) for k in unknown[:5])}; "
            f"valid keys are {', '.join(STAND_FILE_KEYS)}"
        )
    out = {k: v for k, v in doc.items() if k not in ("stands", "grid")}
    if "simulated" in out and not isinstance(out["simulated"], bool):
        raise CaptureError(f"{stand_path}: simulated: expected true or false, got {out['simulated']!r:.40}")
    if "white_albedo" in out:
        a = out["white_albedo"]
        if a not in WHITE_ALBEDO_RANGE:
            raise CaptureError(f"{stand_path}: white_albedo: expected {WHITE_ALBEDO_RANGE.expect()}, got {a!r:.40}")
        out["white_albedo"] = float(a)
    if "pixel_mm" in out:
        v = out["pixel_mm"]
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not 0 <= v <= _MAX_PIXEL_MM:
            raise CaptureError(
                f"{stand_path}: pixel_mm: expected a number in [0, {_MAX_PIXEL_MM:g}] mm, got {v!r:.40}"
            )
        out["pixel_mm"] = float(v)
    if "encoding" in out and out["encoding"] not in ENCODINGS:
        raise CaptureError(f"{stand_path}: encoding: {out['encoding']!r:.40} is not one of {', '.join(ENCODINGS)}")
    if "registration" in out:  # where the fabric's (u, v) lies: cdbrdf.measure.registration
        out["registration"] = parse_registration(out["registration"], str(stand_path))
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
            v = json_number(stand_path, f"grid: {name}", v)
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

    The grid is, by default, derived from the sample rows: the sorted
    distinct values of each axis. A value that only a few rows use - fewer
    sample conditions than a tenth of the median of that axis's values - is
    taken for a stray row (a typo would otherwise silently add a whole
    not-photographed slice to the table) and refused, naming its line.
    ``stands.json`` may instead list the grid (``"grid": {"kappa": [...],
    "theta_l": [...], "phi_l": [...], "theta_v": [...], "phi_v": [...]}``):
    then every sample row must lie on it and any value is accepted.

    Parameters
    ----------
    folder
        The capture folder.
    csv_name
        The name of its table of photographs.
    patch
        The patch's side N, pixels: it sizes the footprint the stand
        geometry must leave clear when ``stands.json`` gives ``pixel_mm``.

    Returns
    -------
    Capture
        The parsed folder.

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
    if not csv_path.exists() and not csv_path.is_symlink():
        raise FileNotFoundError(f"{csv_path}: the capture folder has no {csv_name}")
    csv_bytes, text = _load_table(csv_path)

    # stands.json first: its grid decides how the rows are checked
    stands = None
    settings: dict[str, Any] = {}
    stand_bytes = b""
    stand_path = root / STAND_FILE
    given_grid = None
    if stand_path.exists() or stand_path.is_symlink():
        doc, stand_bytes = read_json_object(stand_path)  # read once: what is checked is what is hashed
        settings = _settings(doc, stand_path)
        given_grid = _explicit_grid(doc, stand_path)
        if "stands" in doc:
            stands = parse_stands(doc, stand_path)

    rows, columns, _records = _parse_table(csv_path, text)
    extra_cols = [c for c in columns if c not in _KNOWN]
    grid = _table_grid(csv_path, rows, given_grid, stand_path)

    if stands is not None:
        missing_k = [k for k in grid.kappa if not any(abs(k - s) <= KAPPA_TOL_PER_MM for s in stands)]
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


def _name(fname: str) -> str:
    """A file name for a message: quoted, its middle elided beyond 80 characters."""
    return repr(fname if len(fname) <= 80 else f"{fname[:38]}...{fname[-38:]}")


def check_file_name(where: str, fname: str) -> None:
    """Refuse a ``file`` that is not a relative path inside the capture folder."""
    win = PureWindowsPath(fname)
    parts = re.split(r"[/\\]", fname)
    if PurePosixPath(fname).is_absolute() or win.is_absolute() or win.drive or win.root:
        why = "is an absolute path"
    elif ".." in parts:
        why = "has a '..' component"
    elif not parts[-1] or parts[-1] == ".":
        why = "names a folder, not a file"
    else:
        return
    raise CaptureError(
        f"{where}: file {_name(fname)} {why}; photographs must be named by a relative path "
        "inside the capture folder (e.g. k0/photo.png)"
    )


def file_key(fname: str) -> str:
    """The name two rows that name the same photograph share (``k0/./a.png`` and ``k0//a.png`` -> ``k0/a.png``)."""
    return posixpath.normpath(fname.strip())


def check_duplicates(csv_path: Path, names: Sequence[tuple[int, str]]) -> None:
    """Refuse two rows that name the same photograph (``names``: ``(line, file)`` in file order)."""
    seen: dict[str, int] = {}
    for line, fname in names:
        key = file_key(fname)
        first = seen.setdefault(key, line)
        if first != line:
            raise CaptureError(
                f"{csv_path}: line {line}: file {_name(fname.strip())} is also the file of line {first}; "
                "every row needs its own photograph"
            )


def _parse_table(csv_path: Path, text: str) -> tuple[list[CaptureRow], list[str], list[dict[str, str]]]:
    """Every row of a ``capture.csv``'s text: parsed rows, the columns, the records as text.

    One rule per column (:func:`_parse_row`), file names inside the folder
    and each photograph named by one row only; at least one sample row.
    """
    reader = _open_reader(csv_path, text)
    extra_cols = [c for c in reader.fieldnames or () if c not in _KNOWN]
    rows: list[CaptureRow] = []
    records: list[dict[str, str]] = []
    try:
        for rec in reader:
            rows.append(_parse_row(csv_path, reader.line_num, rec, extra_cols))
            records.append({k: v or "" for k, v in rec.items()})
    except csv.Error as exc:
        raise _csv_error(csv_path, reader, exc) from None
    check_duplicates(csv_path, [(r.line, r.file) for r in rows])
    if not any(r.kind == "sample" for r in rows):
        raise CaptureError(f"{csv_path}: no sample rows")
    return rows, list(reader.fieldnames or ()), records


def _table_grid(csv_path: Path, rows: list[CaptureRow], given_grid: dict[str, NDArray[np.float64]] | None,
                stand_path: Path) -> Grid:
    """The grid of the sample rows: ``stands.json``'s ``grid`` (rows must lie on it), else derived."""
    samples = [r for r in rows if r.kind == "sample"]
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
        return Grid(kappa=axes["kappa"], theta_l=axes["theta_l"], phi_l=axes["phi_l"],
                    theta_v=axes["theta_v"], phi_v=axes["phi_v"])
    except TableError as exc:
        raise CaptureError(f"{where} do not form a table grid: {exc}") from None


@dataclass
class Plan:
    """A capture plan (a ``capture.csv`` to photograph or render), checked like a capture.

    Attributes
    ----------
    path
        The plan's CSV file.
    columns
        Its header (names stripped).
    records
        Its rows as text, as in the file (for a tool that re-writes them).
    rows
        The same rows parsed by the rules of :func:`read_capture`.
    grid
        The grid the sample rows cover.
    stands
        The stands of the ``stands.json`` beside the plan (empty without one).
    settings
        That file's other settings (validated as by :func:`read_capture`).
    given_grid
        That file's ``grid``, as written, or None.
    """

    path: Path
    columns: list[str]
    records: list[dict[str, str]]
    rows: list[CaptureRow]
    grid: Grid
    stands: dict[float, Stand]
    settings: dict[str, Any]
    given_grid: dict[str, list[float]] | None


def read_plan(path: str | PathLike[str]) -> Plan:
    """Read a capture plan and check it with the rules of :func:`read_capture`, before any photograph exists.

    The rows are parsed by the same parser (every column's rule, file names
    that are relative paths inside the folder, no photograph named twice, no
    stray row); a ``stands.json`` beside the plan is read and checked as
    well (its ``stands`` need not cover every curvature: the rig gives the
    others a default stand).

    Raises
    ------
    FileNotFoundError
        When ``path`` does not exist.
    CaptureError
        The first problem, naming the file and line (or key).
    LimitError
        As :func:`read_capture`.
    """
    csv_path = Path(path)
    if not csv_path.exists() and not csv_path.is_symlink():
        raise FileNotFoundError(f"{csv_path}: no such capture plan")
    _csv_bytes, text = _load_table(csv_path)
    stand_path = csv_path.parent / STAND_FILE
    stands: dict[float, Stand] = {}
    settings: dict[str, Any] = {}
    given_grid = given_raw = None
    if stand_path.exists() or stand_path.is_symlink():
        doc = load_json_object(stand_path)
        settings = _settings(doc, stand_path)
        given_grid = _explicit_grid(doc, stand_path)
        given_raw = doc.get("grid") if given_grid is not None else None
        if "stands" in doc:
            stands = parse_stands(doc, stand_path)
    rows, columns, records = _parse_table(csv_path, text)
    grid = _table_grid(csv_path, rows, given_grid, stand_path)
    return Plan(csv_path, columns, records, rows, grid, stands, settings, given_raw)


def _parse_row(csv_path: Path, line: int, rec: dict, extra_cols: list[str]) -> CaptureRow:
    """One record of ``capture.csv`` (``line``: its last physical line)."""
    where = f"{csv_path}: line {line}"
    if None in rec:
        raise CaptureError(f"{where}: more fields than columns")
    kind = row_kind(rec)
    if kind not in KINDS:
        raise CaptureError(f"{where}: kind {kind!r:.40} is not one of {', '.join(KINDS)}")
    fname = (rec.get("file") or "").strip()
    if not fname:
        raise CaptureError(f"{where}: column 'file' is empty")
    if not fname.isprintable():
        raise CaptureError(f"{where}: file {fname!r:.60} contains control characters")
    check_file_name(where, fname)
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
    if enc and enc not in ENCODINGS:
        raise CaptureError(f"{where}: encoding {enc!r:.40} is not one of {', '.join(ENCODINGS)}")
    return CaptureRow(
        line=line, file=fname, kind=kind,
        kappa=_round_angle(kappa) if not math.isnan(kappa) else math.nan,
        exposure=exposure, cx=cxy[0], cy=cxy[1],
        linear=None if not enc else enc == "linear",
        hidden=_bool(where, "hidden", rec.get("hidden", "")),
        extra={c: rec.get(c, "") or "" for c in extra_cols}, uv_mm=row_origin(where, rec),
        **ang,
    )
