"""The measurement pipeline: a capture folder in, a :class:`~cdbrdf.CDBRDF` out.

Stages (``docs/capture.md`` describes the folder), one module each:

1. :func:`cdbrdf.measure.capture.read_capture` parses ``capture.csv`` (and
   ``stands.json``), derives the grid from the sample rows and which samples
   the stands hide (:mod:`cdbrdf.measure.stands`).
2. A pre-flight pass (:mod:`cdbrdf.measure.preflight`) reads the header of
   every photograph that is needed and lists every one that cannot be used
   before any work; outputs that would replace an input are refused.
3. Every photograph that is needed (sample rows not hidden, white references,
   dark frames) is read and its N x N patch decoded
   (:func:`cdbrdf.measure.patch.read_patch`) in Dask tasks of
   :data:`PHOTOS_PER_TASK` photographs. Tasks run on Dask's local
   threaded scheduler by default, or on a cluster (``scheduler="tcp://..."``,
   or a :class:`distributed.Client`); the files must be visible to the
   workers under the same path. This module runs them.
4. Results are checkpointed batch by batch (:mod:`cdbrdf.measure.checkpoint`);
   a later run with the same capture table, stand file and options reuses
   every image whose size and modification time are unchanged, so an
   interrupted run resumes and gives a bit-identical table.
5. The driver merges brackets, subtracts dark frames, divides by
   ``cos(theta_l)``, scales by the white reference, and fills invalid samples
   (:func:`cdbrdf.measure.calibrate.assemble`).

The result is built in memory and written with :meth:`CDBRDF.save`
(atomic), so no half file is ever left under the output name.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
from collections.abc import Callable
from os import PathLike
from pathlib import Path
from typing import TYPE_CHECKING, Any, overload

from numpy.typing import NDArray

from ..btf import CDBTF
from ..errors import OptionError
from ..fsutil import check_output_file
from ..outputs import output_lock
from ..table import CDBRDF
from .calibrate import MeasureReport, assemble
from .capture import CaptureRow, read_capture
from .checkpoint import Checkpoint, checkpoint_path
from .fill import DEFAULT_FILL, check_fill_method
from .options import MeasureOptions
from .preflight import (
    bad_list_path,
    preflight,
    read_patch_status,
    refuse_bad,
    refuse_overlap,
    remove_bad_list,
)
from .schedulers import LOCAL_SCHEDULERS, MeasurementInterrupted, check_scheduler, compute, open_client

if TYPE_CHECKING:
    from ..btf import CDBTF
    from .btf import BTFReport

__all__ = [
    "measure",
    "MeasurementInterrupted",
    "LOCAL_SCHEDULERS",
    "PHOTOS_PER_TASK",
]

# --------------------------------------------------------------------------- tasks
# (the scheduler's handling has one owner, :mod:`cdbrdf.measure.schedulers`, shared with measure --btf)
def _check_runner(*, scheduler: Any, progress: Any) -> None:
    """Refuse a bad scheduler or progress callback of :func:`measure` before anything is read or created."""
    check_scheduler(scheduler)
    if progress is not None and not callable(progress):
        raise OptionError(f"progress: expected a callable progress(done, total) or None, got {progress!r:.40}")


def _read_tasks(jobs: list[tuple]) -> list[tuple[int, NDArray | None, NDArray | None, str]]:
    """:func:`~cdbrdf.measure.preflight.read_patch_status` for each of several photographs (one Dask task)."""
    return [read_patch_status(*j) for j in jobs]


#: Photographs one Dask task reads: enough to make the scheduler's cost per task
#: (about 0.3 ms) small beside the reading (about 0.1 ms a photograph of 32 x 32 pixels).
PHOTOS_PER_TASK = 64


def _compute(jobs: list[tuple], scheduler: Any, client: Any, num_workers: int | None) -> list:
    """:func:`_read_tasks` over the jobs, :data:`PHOTOS_PER_TASK` a task (:func:`.schedulers.compute`)."""
    return compute(jobs, scheduler, client, num_workers, task=_read_tasks, per_task=PHOTOS_PER_TASK)


def _run(cap: Any, needed: list[int], bad: dict[int, tuple[int, str]], stats: dict[int, tuple[int, int]],
         paths: dict[int, Path], ck: Checkpoint, lin: Callable[[CaptureRow], bool], *, patch: int,
         batch_size: int, scheduler: Any, client: Any, num_workers: int | None,
         progress: Callable[[int, int], None] | None, interrupt_after: int | None,
         ) -> tuple[dict[int, tuple[int, NDArray | None, NDArray | None, str]], dict[int, tuple[int, str]], int]:
    """Read every needed photograph not in the checkpoint; ``(results, failed, resumed)``."""
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
    done_now = 0
    for b in range(0, len(todo), batch_size):
        batch = todo[b : b + batch_size]
        jobs = [
            (str(paths[i]), patch, cap.rows[i].cx, cap.rows[i].cy, lin(cap.rows[i]))
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
        if interrupt_after is not None and done_now >= interrupt_after:
            raise MeasurementInterrupted(f"test hook: interrupted after {done_now} photographs")
    return results, failed, resumed


@overload
def measure(folder: str | PathLike[str], output: str | PathLike[str] | None = None, *, btf: None = None,
            **options: Any) -> tuple[CDBRDF, MeasureReport]: ...


@overload
def measure(folder: str | PathLike[str], output: str | PathLike[str] | None = None, *,
            btf: int | tuple[int, int], **options: Any) -> tuple[CDBTF, BTFReport]: ...


def measure(  # type: ignore[misc]  # the overloads give the options as **options
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
    batch_size: int = 1024,
    num_workers: int | None = None,
    progress: Callable[[int, int], None] | None = None,
    overwrite: bool = True,
    fill: str | None = None,
    btf: int | tuple[int, int] | None = None,
    _interrupt_after: int | None = None,
) -> tuple[CDBRDF, MeasureReport] | tuple[CDBTF, BTFReport]:
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
        Photographs per checkpointed batch (an interrupted run loses at most
        one batch of work).
    num_workers
        Threads/processes of a local scheduler (default: Dask's).
    progress
        Called as ``progress(done, total)`` after each batch.
    overwrite
        Replace an existing ``output`` (the command line's ``--force``).
        An output, its checkpoint folder or its list of unusable photographs
        that is one of the run's inputs (``capture.csv``, ``stands.json``, a
        photograph, found also through links) is always refused.
    fill
        How invalid samples are filled, one of
        :data:`cdbrdf.measure.fill.FILL_METHODS`: ``"auto"`` (the default,
        :data:`cdbrdf.measure.fill.DEFAULT_FILL`: per hidden stand the method
        whose check errs least), ``"model"`` (the fabric model fitted to the
        measured samples), ``"kappa-fit"`` (the same direction on the other
        stands, fitted along the curvature), ``"nearest-stand"``, or
        ``"nearest"`` (the paper's rule: the nearest measured direction at the
        same curvature); with ``btf`` one of
        :data:`cdbrdf.measure.fill.BTF_FILLS`, default ``"kappa-fit"``. It
        does not change what is read, so a checkpoint serves every method.
    btf
        Texels per repeat side (``n`` or ``(n_u, n_v)``): measure a CD-BTF
        instead (:func:`cdbrdf.measure.btf.measure_btf`; the capture's
        ``stands.json`` must have a ``registration``). Every photograph is
        rectified onto the fabric's texels instead of averaged; the same
        calibration, hidden samples and fill; the same schedulers, and a
        checkpoint of each sample condition's texels (its key has the texels).
    _interrupt_after
        For the tests: stop as a killed run would once this many photographs are read.

    Returns
    -------
    table : CDBRDF
        ``quantity="brdf"`` with a white reference, else ``"relative"``
        (a :class:`~cdbrdf.CDBTF` with ``btf``).
    report : MeasureReport
        What was read, skipped, saturated and filled (a
        :class:`~cdbrdf.measure.btf.BTFReport` with ``btf``).

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
    OptionError
        An option has an invalid value (``patch``, ``batch_size``,
        ``num_workers``, ``scheduler``, ``white_albedo``, ``material``,
        ``progress``); checked before anything is read or created.
    IsADirectoryError, FileNotFoundError
        ``output`` is empty or a folder, or its folder does not exist
        (before any work).
    FileExistsError
        ``output`` exists and ``overwrite`` is False, exists and is not a
        regular file (a device, a FIFO: never replaced), or ``<output>.ckpt``
        exists and is not a checkpoint cdbrdf made (all before any work).
    OutputError
        Another run is measuring into ``output`` (its lock,
        :func:`cdbrdf.outputs.output_lock`, is held while the run works).
    OSError
        A scheduler address that cannot be reached (before the checkpoint
        is created).
    """
    opts = MeasureOptions(patch=patch, linear=linear, skip_bad=skip_bad, white_albedo=white_albedo,
                          material=material, fill=fill, checkpoint=checkpoint, batch_size=batch_size,
                          num_workers=num_workers, overwrite=overwrite)  # checked once, for both paths
    _check_runner(scheduler=scheduler, progress=progress)
    if btf is not None:
        from .btf import measure_btf

        return measure_btf(folder, output, texels=btf, options=opts, scheduler=scheduler, progress=progress,
                           _interrupt_after=_interrupt_after)
    patch, white_albedo = opts.patch, opts.white_albedo
    out_path = None if output is None else check_output_file(output)  # a folder, a device: refused now
    fill = check_fill_method(DEFAULT_FILL if fill is None else fill)
    if out_path is not None:
        check_output_file(bad_list_path(out_path))
        if not overwrite and (out_path.exists() or out_path.is_symlink()):
            raise FileExistsError(f"{out_path}: already exists (use --force to overwrite)")
    # one run at a time on an output: a second one would delete this one's checkpoint
    with output_lock(out_path) if out_path is not None else contextlib.nullcontext():
        cap = read_capture(folder, patch=patch)
        ck_path = checkpoint_path(out_path) if (out_path is not None and checkpoint) else None
        if out_path is not None:
            refuse_overlap(cap, [ck_path] if ck_path is not None else [],
                           [out_path, bad_list_path(out_path)])
        enc = cap.settings.get("encoding")
        albedo = float(white_albedo if white_albedo is not None else cap.settings.get("white_albedo", 1.0))

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
        stats, bad = preflight(cap, needed, paths, patch)
        if bad and not skip_bad:
            refuse_bad(cap, bad, paths, out_path, during=False)

        def lin(r: CaptureRow) -> bool:
            if r.linear is not None:
                return r.linear
            if enc is not None:
                return enc == "linear"
            return bool(linear)

        key_doc: dict[str, Any] = {"capture": cap.digest, "patch": patch, "linear": bool(linear),
                                   "needed": len(needed)}
        key = hashlib.sha256(json.dumps(key_doc, sort_keys=True).encode()).hexdigest()
        # checkpoints of earlier versions also hashed skip_bad (which does not change what is read)
        legacy = hashlib.sha256(json.dumps({**key_doc, "skip_bad": bool(skip_bad)}, sort_keys=True).encode()
                                ).hexdigest()
        client, own_client = open_client(scheduler)  # an unreachable scheduler: before the checkpoint exists
        try:
            ck = Checkpoint(ck_path, key, legacy_keys=(legacy,), patch=patch)
        except BaseException:
            if own_client:
                client.close()
            raise
        try:
            results, failed, resumed = _run(cap, needed, bad, stats, paths, ck, lin, patch=patch,
                                            batch_size=batch_size, scheduler=scheduler, client=client,
                                            num_workers=num_workers, progress=progress,
                                            interrupt_after=_interrupt_after)
        except BaseException:
            ck.discard_if_empty()  # made by this run and nothing saved: leave nothing behind
            raise
        finally:
            if own_client:
                client.close()
        if failed and not skip_bad:
            refuse_bad(cap, failed, paths, out_path, during=True)

        table, report = assemble(cap, results, albedo=albedo, patch=int(patch), linear=bool(linear),
                                 material=material, fill_method=fill)
        report.n_images_resumed = resumed
        if out_path is not None:
            table.save(out_path)
            ck.remove()
            remove_bad_list(out_path)
        return table, report
