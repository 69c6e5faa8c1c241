"""Helpers shared by the benchmarks (run as ``python benchmarks/bench_*.py``): timing, test surfaces."""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from typing import Any

import numpy as np

__all__ = ["best_seconds", "jittered_triangulation"]


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


def jittered_triangulation(n_vertices: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """About ``n_vertices`` jittered points of the unit square (UVs) and their Delaunay triangles.

    Irregular on purpose: regular grids flatter curvature estimators and parsers alike.
    """
    from scipy.spatial import Delaunay

    n = int(round(math.sqrt(n_vertices)))
    u, v = np.meshgrid(np.linspace(0, 1, n), np.linspace(0, 1, n), indexing="ij")
    uv = np.c_[u.ravel(), v.ravel()] + rng.uniform(-0.3 / n, 0.3 / n, (n * n, 2))
    return uv, Delaunay(uv).simplices.astype(np.int64)
