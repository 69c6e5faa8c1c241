"""numba's ``njit`` with an on-disk cache only where one can be written, and kernels run in threads.

``@numba.njit(cache=True)`` raises ``RuntimeError: cannot cache function``
when it is *applied* (at import) if no cache location is writable: the
``__pycache__`` folder next to the source (a read-only install), then
``NUMBA_CACHE_DIR`` or the user's cache folder (no writable home: another
user, a container). :func:`njit` asks numba the same question for each
function when it is decorated and, when the answer is no, compiles that
function in memory (``cache=False``) instead: the program works, it only
compiles again in the next process. numba's global configuration is not
touched, so other packages in the process are unaffected.

:func:`run_split` runs a kernel over contiguous ranges of its items in
threads, one per CPU. The package's kernels are compiled serial (``nogil``,
taking ``start, stop``) and parallelised this way instead of with numba's
``parallel=True``, which takes about four times as long to compile (13 s
instead of 3.5 s for the lookup kernel on 2 cores), a cost every fresh
install pays.
"""

from __future__ import annotations

import logging
import os
from collections.abc import Callable
from typing import Any

import numba

__all__ = ["njit", "run_split", "cpu_count"]

_log = logging.getLogger(__name__)


def njit(*args: Any, **options: Any) -> Any:
    """:func:`numba.njit` that falls back to ``cache=False`` when caching is impossible.

    Parameters
    ----------
    *args
        Either nothing (``@njit(...)``) or the function itself (``@njit``).
    **options
        Passed to :func:`numba.njit` unchanged; only ``cache=True`` is
        dropped, per function, when numba finds no writable cache location.

    Returns
    -------
    numba dispatcher or decorator
        As :func:`numba.njit`.
    """
    if args and callable(args[0]) and len(args) == 1:
        return njit(**options)(args[0])
    if args:
        raise TypeError("njit: give the options as keywords (signatures are not supported here)")

    def decorate(func: Callable[..., Any]) -> Any:
        if not options.get("cache"):
            return numba.njit(**options)(func)
        try:
            dispatcher = numba.njit(**options)(func)
        except RuntimeError as exc:
            if "cannot cache function" not in str(exc):
                raise
            _log.debug("%s: no writable numba cache location, compiling in memory", func.__qualname__)
            return numba.njit(**dict(options, cache=False))(func)
        _tolerate_failed_saves(dispatcher, func.__qualname__)
        return dispatcher

    return decorate


def _tolerate_failed_saves(dispatcher: Any, name: str) -> None:
    """Make a failed write of the on-disk cache (a full disk, a file size limit) cost a recompile, not the run.

    numba raises the ``OSError`` of the write from the call that compiled;
    the compiled code is fine, only the cache copy is missing.
    """
    cache: Any = getattr(dispatcher, "_cache", None)
    save = getattr(cache, "save_overload", None)
    if save is None:  # pragma: no cover - a numba without this internal: its own behaviour
        return

    def save_overload(sig: Any, data: Any) -> None:
        try:
            save(sig, data)
        except OSError as exc:
            _log.debug("%s: compiled code not cached (%s)", name, exc)

    cache.save_overload = save_overload


def cpu_count() -> int:
    """The CPUs this process may run on (its affinity mask where the system has one)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - no sched_getaffinity (macOS, Windows)
        return max(1, os.cpu_count() or 1)


def run_split(kernel: Callable[..., Any], n: int, *args: Any, grain: int = 1) -> list[Any]:
    """Run ``kernel(*args, start, stop)`` over ``range(n)`` split into contiguous ranges, one thread each.

    Parameters
    ----------
    kernel
        A compiled kernel that releases the GIL (``nogil=True``) and treats
        the items of ``range(start, stop)`` independently of the others.
    n
        Number of items.
    *args
        The kernel's arguments before ``start, stop``.
    grain
        Fewest items worth a thread of their own: at most ``n // grain``
        threads, and one (this thread, no pool) when ``n < 2 * grain``.

    Returns
    -------
    list
        The kernel's results, one per range, in order.
    """
    parts = max(1, min(cpu_count(), n // max(1, grain)))
    if parts == 1:
        return [kernel(*args, 0, n)]
    from concurrent.futures import ThreadPoolExecutor

    edges = [n * i // parts for i in range(parts + 1)]
    with ThreadPoolExecutor(max_workers=parts) as pool:
        return list(pool.map(lambda i: kernel(*args, edges[i], edges[i + 1]), range(parts)))
