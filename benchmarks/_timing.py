"""Timing helper shared by the benchmarks (run as ``python benchmarks/bench_*.py``)."""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from typing import Any

__all__ = ["best_seconds"]


def best_seconds(fn: Callable[[], Any], repeat: int, *, warmup: bool = True) -> float:
    """The shortest wall time of ``repeat`` calls of ``fn`` in seconds (after one untimed call if ``warmup``)."""
    if warmup:
        fn()
    best = math.inf
    for _ in range(max(int(repeat), 1)):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best
