"""numba's ``njit`` with an on-disk cache only where one can be written.

``@numba.njit(cache=True)`` raises ``RuntimeError: cannot cache function``
when it is *applied* (at import) if no cache location is writable: the
``__pycache__`` folder next to the source (a read-only install), then
``NUMBA_CACHE_DIR`` or the user's cache folder (no writable home: another
user, a container). :func:`njit` asks numba the same question for each
function when it is decorated and, when the answer is no, compiles that
function in memory (``cache=False``) instead: the program works, it only
compiles again in the next process. numba's global configuration is not
touched, so other packages in the process are unaffected.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from typing import Any

import numba

__all__ = ["njit"]

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
            return numba.njit(**options)(func)
        except RuntimeError as exc:
            if "cannot cache function" not in str(exc):
                raise
            _log.debug("%s: no writable numba cache location, compiling in memory", func.__qualname__)
            return numba.njit(**dict(options, cache=False))(func)

    return decorate
