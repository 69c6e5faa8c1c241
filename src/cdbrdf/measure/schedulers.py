"""Where the measurement's Dask tasks run: one owner for both measurements (CDBRDF and CD-BTF).

``scheduler`` is ``None`` (Dask's local threads), one of
:data:`LOCAL_SCHEDULERS`, a scheduler address ``"tcp://host:port"`` or a
:class:`distributed.Client`. :func:`check_scheduler` refuses anything else
before any work, :func:`open_client` connects to an address (a one-line
``OSError`` when it cannot), and :func:`compute` runs a task function over
chunks of jobs on the chosen scheduler, results in the jobs' order. The task
function must be importable by name (a module-level function) so that the
``processes`` scheduler and a cluster's workers can run it.
"""

from __future__ import annotations

from collections.abc import Callable
from functools import partial
from typing import Any

from ..errors import OptionError
from .preflight import first_line

__all__ = ["LOCAL_SCHEDULERS", "MeasurementInterrupted", "is_client", "check_scheduler", "open_client",
           "compute"]

#: ``scheduler`` values that select one of Dask's local schedulers.
LOCAL_SCHEDULERS: tuple[str, ...] = ("threads", "processes", "synchronous")


class MeasurementInterrupted(RuntimeError):
    """Raised by the test hook ``_interrupt_after`` (simulates a killed run)."""


def is_client(scheduler: Any) -> bool:
    """Whether ``scheduler`` looks like a :class:`distributed.Client` (it maps and gathers).

    Parameters
    ----------
    scheduler
        Any ``scheduler`` option.

    Returns
    -------
    bool
        It has callable ``map`` and ``gather``.
    """
    return callable(getattr(scheduler, "map", None)) and callable(getattr(scheduler, "gather", None))


def check_scheduler(scheduler: Any) -> None:
    """Refuse a ``scheduler`` that is none of the accepted kinds (before any work).

    Parameters
    ----------
    scheduler
        ``None``, one of :data:`LOCAL_SCHEDULERS`, an address ``"tcp://host:port"`` or a client.

    Raises
    ------
    OptionError
        One line.
    """
    if scheduler is None or is_client(scheduler):
        return
    if isinstance(scheduler, str):
        if scheduler in LOCAL_SCHEDULERS:
            return
        addr = scheduler.strip()
        if addr and addr == scheduler and addr.isprintable() and " " not in addr \
                and ("://" in addr or ":" in addr) and not addr.endswith((":", "://")):
            return
    raise OptionError(
        f"scheduler: {scheduler!r:.60} is neither a scheduler address (tcp://host:port), "
        f"a distributed.Client nor one of {', '.join(LOCAL_SCHEDULERS)}"
    )


def open_client(scheduler: Any) -> tuple[Any, bool]:
    """A distributed client for an address or a Client; none for a local scheduler.

    Parameters
    ----------
    scheduler
        A ``scheduler`` that :func:`check_scheduler` accepts.

    Returns
    -------
    client : distributed.Client or None
        The client (None for a local scheduler).
    owned : bool
        The client was opened here (the caller closes it).

    Raises
    ------
    OSError
        An address that cannot be reached (one line).
    """
    if scheduler is None or (isinstance(scheduler, str) and scheduler in LOCAL_SCHEDULERS):
        return None, False
    if isinstance(scheduler, str):
        from distributed import Client

        try:
            return Client(scheduler, timeout="10s", set_as_default=False), True
        except (OSError, ValueError, TypeError) as exc:  # unreachable, or an address distributed refuses
            raise OSError(f"scheduler {scheduler}: cannot connect ({first_line(exc) or type(exc).__name__})"
                          ) from None
    return scheduler, False


def compute(jobs: list[Any], scheduler: Any, client: Any, num_workers: int | None, *,
            task: Callable[[list[Any]], list[Any]], per_task: int) -> list[Any]:
    """``task`` over chunks of ``per_task`` jobs, on ``client`` or a local scheduler; one result per job, in order.

    Parameters
    ----------
    jobs
        The jobs (picklable for the ``processes`` scheduler and a cluster).
    scheduler
        The ``scheduler`` option (used when ``client`` is None; None: threads).
    client
        A client from :func:`open_client`, or None.
    num_workers
        Threads or processes of a local scheduler (None: Dask's default).
    task
        A module-level function: a list of jobs in, one result per job out.
    per_task
        Jobs per Dask task.

    Returns
    -------
    list
        The results, in the jobs' order.
    """
    chunks = [jobs[c:c + per_task] for c in range(0, len(jobs), per_task)]
    if client is not None:
        futures = client.map(task, chunks, pure=False)
        return [r for part in client.gather(futures) for r in part]
    import dask
    from dask import delayed

    # the chunk bound to the task, not an argument: Dask would walk every job's contents looking for its
    # collections (a fifth of a CD-BTF's time)
    tasks = [delayed(partial(task, c), pure=False)() for c in chunks]
    kw: dict[str, Any] = {"scheduler": scheduler or "threads"}
    if num_workers and kw["scheduler"] != "synchronous":
        kw["num_workers"] = num_workers
    return [r for part in dask.compute(*tasks, **kw) for r in part]
