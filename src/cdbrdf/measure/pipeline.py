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
import shutil
import tempfile
from collections.abc import Callable
from dataclasses import dataclass, field
from os import PathLike
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..errors import CaptureError, CDBRDFError, TableError
from ..frames import direction_from_angles
from ..table import CDBRDF, Grid
from .fill import angle_between_deg, fill_nearest
from .images import FORMATS, ImageError
from .patch import merge_exposures, patch_statistics, read_patch
from .plan import CAPTURE_FILE, STAND_FILE, Stand, hidden_mask, read_stands

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
]

_LOG = logging.getLogger(__name__)

#: Valid values of the ``kind`` column.
KINDS: tuple[str, ...] = ("sample", "white", "dark")
#: ``scheduler`` values that select one of Dask's local schedulers.
LOCAL_SCHEDULERS: tuple[str, ...] = ("threads", "processes", "synchronous")
_REQUIRED = ("file", "kappa", "theta_v", "phi_v", "theta_l", "phi_l")
_KNOWN = _REQUIRED + ("exposure", "cx", "cy", "kind", "hidden", "encoding")
_ANGLE_DECIMALS = 6
_CKPT_VERSION = 1


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


def read_capture(folder: str | PathLike[str], *, csv_name: str = CAPTURE_FILE, patch: int = 7) -> Capture:
    """Parse a capture folder (``docs/capture.md``).

    ``patch`` (N) sizes the patch whose footprint the stand geometry must
    leave clear when ``stands.json`` gives ``pixel_mm``.

    Raises
    ------
    FileNotFoundError
        When the folder or its ``capture.csv`` does not exist.
    CaptureError
        When a row is malformed (names the file and line), or the sample
        rows do not form a grid.
    """
    root = Path(folder)
    if not root.is_dir():
        raise FileNotFoundError(f"{root}: no such capture folder")
    csv_path = root / csv_name
    if not csv_path.is_file():
        raise FileNotFoundError(f"{csv_path}: the capture folder has no {csv_name}")
    csv_bytes = csv_path.read_bytes()
    try:
        text = csv_bytes.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise CaptureError(f"{csv_path}: not UTF-8 text ({exc})") from None
    reader = csv.DictReader(io.StringIO(text))
    cols = [c.strip() for c in (reader.fieldnames or [])]
    reader.fieldnames = cols
    missing = [c for c in _REQUIRED if c not in cols]
    if missing:
        raise CaptureError(f"{csv_path}: missing column(s) {', '.join(missing)} (have: {', '.join(cols)})")
    extra_cols = [c for c in cols if c not in _KNOWN]
    rows: list[CaptureRow] = []
    for i, rec in enumerate(reader):
        line = i + 2
        where = f"{csv_path}: line {line}"
        if None in rec:
            raise CaptureError(f"{where}: more fields than columns")
        kind = (rec.get("kind") or "sample").strip().lower() or "sample"
        if kind not in KINDS:
            raise CaptureError(f"{where}: kind {kind!r} is not one of {', '.join(KINDS)}")
        fname = (rec.get("file") or "").strip()
        if not fname:
            raise CaptureError(f"{where}: column 'file' is empty")
        if Path(fname).suffix.lower() not in FORMATS:
            raise CaptureError(
                f"{where}: {fname!r} has an unsupported extension; valid: {', '.join(FORMATS)}"
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
        cxy = []
        for c in ("cx", "cy"):
            v = _num(where, c, rec.get(c, ""), blank_ok=True)
            if not math.isnan(v) and (v != int(v) or v < 0):
                raise CaptureError(f"{where}: {c} must be a non-negative pixel index, got {v:g}")
            cxy.append(None if math.isnan(v) else int(v))
        enc = (rec.get("encoding") or "").strip().lower()
        if enc not in ("", "srgb", "linear"):
            raise CaptureError(f"{where}: encoding {enc!r} is not one of srgb, linear")
        rows.append(CaptureRow(
            line=line, file=fname, kind=kind,
            kappa=_round_angle(kappa) if not math.isnan(kappa) else math.nan,
            exposure=exposure, cx=cxy[0], cy=cxy[1],
            linear=None if not enc else enc == "linear",
            hidden=_bool(where, "hidden", rec.get("hidden", "")),
            extra={c: rec.get(c, "") or "" for c in extra_cols},
            **ang,
        ))
    samples = [r for r in rows if r.kind == "sample"]
    if not samples:
        raise CaptureError(f"{csv_path}: no sample rows")

    def axis(name: str) -> NDArray[np.float64]:
        return np.unique(np.array([getattr(r, name) for r in samples]))

    try:
        grid = Grid(kappa=axis("kappa"), theta_l=axis("theta_l"), phi_l=axis("phi_l"),
                    theta_v=axis("theta_v"), phi_v=axis("phi_v"))
    except TableError as exc:
        raise CaptureError(f"{csv_path}: the sample rows do not form a table grid: {exc}") from None

    stands = None
    settings: dict[str, Any] = {}
    stand_bytes = b""
    stand_path = root / STAND_FILE
    if stand_path.is_file():
        stand_bytes = stand_path.read_bytes()
        try:
            doc = json.loads(stand_bytes.decode("utf-8"))
        except (UnicodeDecodeError, json.JSONDecodeError) as exc:
            raise CaptureError(f"{stand_path}: not valid JSON ({exc})") from None
        if not isinstance(doc, dict):
            raise CaptureError(f"{stand_path}: expected a JSON object")
        settings = {k: v for k, v in doc.items() if k != "stands"}
        if "stands" in doc:
            stands = read_stands(stand_path)
    if stands is not None:
        missing_k = [k for k in grid.kappa if not any(abs(k - s) <= 1e-9 for s in stands)]
        if missing_k:
            raise CaptureError(
                f"{stand_path}: no stand for kappa {', '.join(f'{k:g}' for k in missing_k)}"
            )
        pixel_mm = settings.get("pixel_mm", 0.0)
        if not isinstance(pixel_mm, (int, float)) or pixel_mm < 0 or not math.isfinite(pixel_mm):
            raise CaptureError(f"{stand_path}: pixel_mm must be a non-negative number, got {pixel_mm!r}")
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


# --------------------------------------------------------------------------- tasks
def _read_task(path: str, n: int, cx: int | None, cy: int | None, linear: bool
               ) -> tuple[int, NDArray | None, NDArray | None, str]:
    """One photograph's patch: ``(status, values, saturated, message)``.

    status 0 = read, 1 = missing, 2 = unreadable.
    """
    try:
        v, s = read_patch(path, n=n, cx=cx, cy=cy, linear=linear)
    except FileNotFoundError:
        return 1, None, None, "missing"
    except ImageError as exc:
        return 2, None, None, str(exc)
    return 0, v, s, ""


def _stat(path: Path) -> tuple[int, int]:
    try:
        st = path.stat()
    except OSError:
        return -1, -1
    return int(st.st_size), int(st.st_mtime_ns)


def checkpoint_path(output: str | PathLike[str]) -> Path:
    """The checkpoint folder used for an output file: ``<output>.ckpt``."""
    return Path(str(output) + ".ckpt")


class _Checkpoint:
    """Results of finished images, one ``.npz`` file per batch (each written atomically)."""

    def __init__(self, folder: Path | None, key: str) -> None:
        self.folder = folder
        self.key = key
        self.done: dict[int, tuple[tuple[int, int], int, NDArray | None, NDArray | None, str]] = {}
        if folder is None:
            return
        key_file = folder / "key.json"
        if folder.is_dir():
            try:
                old = json.loads(key_file.read_text())
            except (OSError, ValueError):
                old = None
            if old != {"key": key, "version": _CKPT_VERSION}:
                _LOG.warning("%s: checkpoint of a different run; starting afresh", folder)
                shutil.rmtree(folder)
        if folder.is_dir():
            for f in sorted(folder.glob("batch-*.npz")):
                try:
                    self._load(f)
                except (OSError, ValueError, KeyError) as exc:
                    _LOG.warning("%s: unreadable checkpoint batch ignored (%s)", f, exc)
        else:
            folder.mkdir(parents=True)
            key_file.write_text(json.dumps({"key": key, "version": _CKPT_VERSION}))

    def _load(self, f: Path) -> None:
        with np.load(f, allow_pickle=False) as z:
            rows = z["rows"]
            stats = z["stats"]
            status = z["status"]
            msgs = z["messages"]
            for j, r in enumerate(rows.tolist()):
                v = z[f"v{r}"] if status[j] == 0 else None
                s = z[f"s{r}"] if status[j] == 0 else None
                self.done[r] = ((int(stats[j, 0]), int(stats[j, 1])), int(status[j]), v, s, str(msgs[j]))

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
        fd, tmp = tempfile.mkstemp(prefix=".batch-", suffix=".npz", dir=self.folder)
        with os.fdopen(fd, "wb") as fh:
            np.savez(fh, **arrays)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, self.folder / f"batch-{rows[0]:08d}.npz")

    def remove(self) -> None:
        if self.folder is not None and self.folder.is_dir():
            shutil.rmtree(self.folder)


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
        Treat missing and unreadable photographs as invalid samples (filled)
        instead of stopping.
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

    Returns
    -------
    table : CDBRDF
        ``quantity="brdf"`` with a white reference, else ``"relative"``.
    report : MeasureReport

    Raises
    ------
    FileNotFoundError
        A needed photograph is missing (without ``skip_bad``); names it.
    ImageError
        A photograph is unreadable (without ``skip_bad``); names it.
    CaptureError
        The capture table is malformed.
    """
    if int(patch) != patch or patch < 1:
        raise ValueError(f"patch: expected a positive integer, got {patch!r}")
    if batch_size < 1:
        raise ValueError(f"batch_size: must be positive, got {batch_size!r}")
    if output is not None:
        out_dir = Path(output).parent
        if not out_dir.is_dir():
            raise FileNotFoundError(f"{output}: the folder {out_dir} does not exist")
    cap = read_capture(folder, patch=int(patch))
    grid = cap.grid
    enc = cap.settings.get("encoding")
    if enc not in (None, "srgb", "linear"):
        raise CaptureError(f"{cap.folder / STAND_FILE}: encoding {enc!r} is not one of srgb, linear")
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
    paths = {i: (cap.folder / cap.rows[i].file) for i in needed}
    stats = {i: _stat(paths[i]) for i in needed}
    if not skip_bad:
        for i in needed:
            if stats[i][0] < 0:
                r = cap.rows[i]
                raise FileNotFoundError(
                    f"{paths[i]}: photograph missing (capture.csv line {r.line}); "
                    "use --skip-bad to fill its sample instead"
                )

    def lin(r: CaptureRow) -> bool:
        if r.linear is not None:
            return r.linear
        if enc is not None:
            return enc == "linear"
        return bool(linear)

    key_doc = {
        "capture": cap.digest, "patch": int(patch), "linear": bool(linear),
        "skip_bad": bool(skip_bad), "needed": len(needed),
    }
    key = hashlib.sha256(json.dumps(key_doc, sort_keys=True).encode()).hexdigest()
    ck = _Checkpoint(checkpoint_path(output) if (output is not None and checkpoint) else None, key)
    results: dict[int, tuple[int, NDArray | None, NDArray | None, str]] = {}
    resumed = 0
    for i in needed:
        got = ck.done.get(i)
        if got is not None and got[0] == stats[i] and got[1] != 1:
            results[i] = got[1:]
            resumed += 1
    todo = [i for i in needed if i not in results]
    total = len(needed)
    if progress is not None:
        progress(len(results), total)
    client, own_client = _open_client(scheduler)
    try:
        done_now = 0
        for b in range(0, len(todo), batch_size):
            batch = todo[b : b + batch_size]
            jobs = [
                (str(paths[i].resolve()), int(patch), cap.rows[i].cx, cap.rows[i].cy, lin(cap.rows[i]))
                for i in batch
            ]
            out = _compute(jobs, scheduler, client, num_workers)
            new = {}
            for i, (status, v, s, msg) in zip(batch, out):
                if status != 0 and not skip_bad:
                    if status == 1:
                        raise FileNotFoundError(f"{paths[i]}: photograph missing")
                    raise ImageError(f"{msg} (capture.csv line {cap.rows[i].line}); "
                                     "use --skip-bad to fill its sample instead")
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

    table, report = _assemble(cap, results, albedo=albedo, patch=int(patch), linear=bool(linear),
                              material=material)
    report.n_images_resumed = resumed
    if output is not None:
        table.save(output)
        ck.remove()
    return table, report


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
    filled, fill_src, filled_std = fill_nearest(values, valid, grid, std=std)

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
