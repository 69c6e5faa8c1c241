"""measure --btf's sample conditions run in Dask tasks and checkpointed batch by batch (resume).

The unit of work is a *sample condition* (its brackets, and its fabric
positions in a scan): its photographs' footprints are merged pixel by pixel
before the rectification, so a photograph alone gives no texels. A task
function (:func:`cdbrdf.measure.btf._condition_tasks`, given by the caller)
reads and rectifies the conditions of one Dask task and returns only their
texels, so a worker holds one condition's footprints at a time and the
driver the texels. Tasks run wherever the CDBRDF path's do
(:func:`cdbrdf.measure.schedulers.compute`).

The texels go to the same checkpoint as the CDBRDF path's patches
(:class:`~cdbrdf.measure.checkpoint.Checkpoint`, shape ``(n_v, n_u)``), one
entry per condition under its first row's index: the pair is
``(fingerprint, used)`` (:func:`fingerprint` of its photographs' sizes and
modification times; the photographs used), the status 0 (texels), 1
(saturated) or 2 (no readable photograph). A condition reused only when its
fingerprint is unchanged; one with a photograph that failed to read is not
kept (it is tried again, as the CDBRDF path tries a failed photograph
again).
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .checkpoint import Checkpoint
from .schedulers import MeasurementInterrupted, compute

__all__ = ["fingerprint", "run_conditions", "STATUS_CODES"]

#: A condition's status and its code in the checkpoint.
STATUS_CODES: dict[str, int] = {"ok": 0, "saturated": 1, "skipped": 2}
_STATUS_OF = {v: k for k, v in STATUS_CODES.items()}

#: One condition's result: ``(first row, status, texels (n_texels, C) or None, photographs used)``.
Result = tuple[int, str, NDArray | None, int]


def fingerprint(idx: list[int], stats: dict[int, tuple[int, int]]) -> int:
    """63 bits of the SHA-256 of a condition's rows and their photographs' sizes and modification times.

    Parameters
    ----------
    idx
        The condition's row indices.
    stats
        ``(size, mtime_ns)`` per usable photograph (the others count as ``(-1, -1)``).

    Returns
    -------
    int
        In ``[0, 2**63)`` (an int64 of the checkpoint).
    """
    doc = [[i, *stats.get(i, (-1, -1))] for i in sorted(idx)]
    return int.from_bytes(hashlib.sha256(json.dumps(doc).encode()).digest()[:8], "big") >> 1


def run_conditions(conds: list[list[int]], job: Callable[[list[int]], Any], stats: dict[int, tuple[int, int]],
                   ck: Checkpoint, *, task: Callable[[list[Any]], list[Any]], per_task: int, batch_size: int,
                   scheduler: Any, client: Any, num_workers: int | None, failed: dict[int, tuple[int, str]],
                   progress: Callable[[int], None] | None = None, interrupt_after: int | None = None,
                   ) -> Iterator[list[Result]]:
    """Every condition's texels, a batch at a time: the checkpoint's first, then the rest in Dask tasks.

    Parameters
    ----------
    conds
        Each condition's row indices.
    job
        The task's job for a condition (what ``task`` is given for it).
    stats
        ``(size, mtime_ns)`` per usable photograph (the pre-flight's).
    ck
        The checkpoint (with a folder or none).
    task, per_task
        The task function over a list of jobs (per job ``(status, texels,
        used, failed)``, ``failed`` mapping a row to ``(status, message)``),
        and conditions per task.
    batch_size
        Photographs per checkpointed batch (at least one condition).
    scheduler, client, num_workers
        As :func:`cdbrdf.measure.schedulers.compute`.
    failed
        Filled with the photographs that failed to read.
    progress
        Called with the number of photographs done so far in this call.
    interrupt_after
        For the tests: raise :class:`MeasurementInterrupted` once this many
        photographs are read (a killed run).

    Yields
    ------
    list
        One batch of results ``(first row, status, texels, used)``; the
        first holds the conditions resumed from the checkpoint (maybe none).
    """
    fps = {idx[0]: fingerprint(idx, stats) for idx in conds}
    resumed: list[Result] = []
    for idx in conds:
        got = ck.done.get(idx[0])
        if got is not None and got[0][0] == fps[idx[0]]:
            tex = None if got[2] is None else got[2].reshape(-1, got[2].shape[-1])
            resumed.append((idx[0], _STATUS_OF[got[1]], tex, got[0][1]))
    ck.done.clear()  # the driver keeps what it yields: the texels are held once
    reused = {r[0] for r in resumed}
    done = sum(len(idx) for idx in conds if idx[0] in reused)
    if progress is not None:
        progress(done)
    yield resumed
    todo = [idx for idx in conds if idx[0] not in reused]
    read_now = 0
    start = 0
    while start < len(todo):
        stop, n = start, 0
        while stop < len(todo) and (n == 0 or n + len(todo[stop]) <= batch_size):
            n += len(todo[stop])
            stop += 1
        batch = todo[start:stop]
        start = stop
        out = compute([job(idx) for idx in batch], scheduler, client, num_workers, task=task, per_task=per_task)
        new: dict[int, tuple] = {}
        part: list[Result] = []
        for idx, (status, tex, used, fails) in zip(batch, out):
            part.append((idx[0], status, tex, used))
            failed.update(fails)
            if not fails:
                vals = None if tex is None else np.asarray(tex, dtype=np.float64).reshape(*ck.shape, -1)
                sat = None if tex is None else np.zeros(ck.shape, dtype=bool)
                new[idx[0]] = ((fps[idx[0]], int(used)), STATUS_CODES[status], vals, sat, "")
        ck.add(new)
        ck.done.clear()
        read_now += n
        done += n
        if progress is not None:
            progress(done)
        yield part
        if interrupt_after is not None and read_now >= interrupt_after:
            raise MeasurementInterrupted(f"test hook: interrupted after {read_now} photographs")
