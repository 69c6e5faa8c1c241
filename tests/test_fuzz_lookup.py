"""Fuzzing the 5-D lookup through every kernel, in a child process.

Each input (bytes, mutated by :mod:`tests.fuzzing`) picks a table (one per
kernel path: RGB, RGB float32, generic 1-channel, > 8 curvatures, uneven
elevations, a single curvature, 720 azimuths), a query dtype and a
broadcasting pattern, and holds raw float64 query values: bit flips reach
every exponent, NaN, infinities and subnormals. On top of them a
generator seeded by the input adds queries drawn across all float
exponents, special values and uniform angles. Checked for every query:

- the process does not crash or hang (the harness runs the target in a child);
- shapes broadcast as documented;
- a finite query with both elevations in [0, 90] gives a finite value inside
  [min, max] of the table (the pole rule's ring mean is inside too), equal to
  the readable reference at the exactly wrapped azimuths for a sample of rows;
- any other query gives a NaN row with ``on_invalid="nan"``, and with the
  default a :class:`~cdbrdf.QueryError` exactly when a finite elevation lies
  outside [0, 90].
"""

from __future__ import annotations

import functools
from pathlib import Path

import numpy as np
import pytest

from cdbrdf import QueryError
from cdbrdf.interp import evaluate, evaluate_reference

from .fuzzing import fuzz

#: Extra random queries per input (default and slow budgets).
_EXTRA = 1000
_SPECIALS = np.array([np.nan, np.inf, -np.inf, 0.0, -0.0, 5e-324, -5e-324, 1e-300, 90.0, 90.0 + 1e-13,
                      90.0 - 1e-13, 360.0 - 1e-13, 360.0, 3.4028235e38, -3.4028235e38, 1e308, -1e308,
                      1.7976931348623157e308, 2.0**53, 2.0**63])


@functools.cache
def _tables():
    from .lookup_cases import kernel_tables

    ts = list(kernel_tables().values())
    return [(t, float(t.values.min()), float(t.values.max())) for t in ts]


def _random_queries(rng: np.random.Generator, n: int) -> np.ndarray:
    """``(n, 5)`` queries mixing uniform angles, all float exponents and special values."""
    q = np.empty((n, 5))
    kind = rng.integers(0, 4, (n, 5))
    uniform = np.stack([rng.uniform(0, 90, n), rng.uniform(-360, 720, n), rng.uniform(0, 90, n),
                        rng.uniform(-360, 720, n), rng.uniform(-0.5, 0.5, n)], axis=1)
    expo = rng.choice([-1.0, 1.0], (n, 5)) * np.ldexp(rng.random((n, 5)) + 0.5, rng.integers(-1075, 1024, (n, 5)))
    special = rng.choice(_SPECIALS, (n, 5))
    near = uniform + rng.choice([-1, 1], (n, 5)) * np.ldexp(1.0, rng.integers(-60, 0, (n, 5)))
    for k, src in enumerate((uniform, expo, special, near)):
        q[kind == k] = src[kind == k]
    return q


def _shaped(cols: list[np.ndarray], pattern: int) -> list[np.ndarray]:
    """The five query columns arranged in one of a few broadcasting patterns."""
    n = cols[0].size
    if pattern == 0 or n < 4:
        return cols
    if pattern == 1:  # scalar light direction and curvature
        return [cols[0], cols[1], cols[2][:1].reshape(()), cols[3][:1].reshape(()), cols[4][:1].reshape(())]
    a = int(np.sqrt(n))
    if pattern == 2:  # (a, 1) x (1, a) grid of view directions
        return [cols[0][:a, None], cols[1][None, :a], cols[2][:a * a].reshape(a, a), cols[3][:1], cols[4][:a, None]]
    # non-contiguous views (chunked path)
    return [c[::2] for c in cols]


def check(data: bytes, rng: np.random.Generator, n_extra: int) -> None:
    """Run the queries encoded in ``data`` (plus ``n_extra`` random ones); raise AssertionError on a violation."""
    head = data[:3].ljust(3, b"\0")
    tables = _tables()
    t, lo, hi = tables[head[0] % len(tables)]
    dtype = (np.float64, np.float32)[head[1] % 2]
    body = data[3:]
    body = body[: len(body) // 8 * 8]
    raw = np.frombuffer(body, dtype=np.float64)
    raw = np.resize(raw, (raw.size // 5) * 5).reshape(-1, 5) if raw.size >= 5 else np.zeros((0, 5))
    q = np.concatenate([raw, _random_queries(rng, n_extra)])
    with np.errstate(all="ignore"):
        q = q.astype(dtype)
    cols = _shaped([np.ascontiguousarray(q[:, i]) for i in range(5)], head[2] % 4)
    shape = np.broadcast_shapes(*(c.shape for c in cols))
    got = evaluate(t, *cols, on_invalid="nan")
    assert got.shape == shape + (t.n_channels,), (got.shape, shape)
    b = [np.broadcast_to(c, shape).reshape(-1).astype(np.float64) for c in cols]
    tv, pv, tl, pl, k = b
    g = got.reshape(-1, t.n_channels)
    finite = np.isfinite(np.stack(b)).all(axis=0)
    valid = finite & (tv >= 0) & (tv <= 90) & (tl >= 0) & (tl <= 90)
    assert np.isnan(g[~valid]).all(), "a non-finite or impossible query gave a number"
    gv = g[valid]
    assert np.isfinite(gv).all(), f"a valid query gave NaN/inf: {np.stack(b)[:, valid][:, ~np.isfinite(gv).all(1)][:, :3].T}"
    assert ((gv >= lo) & (gv <= hi)).all(), f"value outside the table's range [{lo}, {hi}]: {gv.min()}..{gv.max()}"
    # a few rows against the readable reference at exactly wrapped azimuths
    idx = np.flatnonzero(valid)
    for i in idx[rng.integers(0, idx.size, min(3, idx.size))] if idx.size else ():
        ref = evaluate_reference(t, tv[i], np.fmod(pv[i], 360.0), tl[i], np.fmod(pl[i], 360.0), k[i])
        np.testing.assert_allclose(g[i], ref, rtol=1e-9, atol=1e-12 * hi)
    # the default mode raises exactly when a finite elevation is outside [0, 90]
    bad_elev = finite & ~valid
    try:
        again = evaluate(t, *cols)
    except QueryError as exc:
        assert bad_elev.any(), f"QueryError without an impossible elevation: {exc}"
        assert "elevation outside [0, 90]" in str(exc)
    else:
        assert not bad_elev.any(), "an elevation outside [0, 90] was not refused"
        np.testing.assert_array_equal(again, got)


def target(data: bytes, workdir: Path) -> str:
    """Fuzz target for :func:`tests.fuzzing.fuzz` (default budget)."""
    check(data, np.random.default_rng(list(data[:64])), _EXTRA)
    return "ok"


def target_large(data: bytes, workdir: Path) -> str:
    """Fuzz target with 20,000 extra queries per input (slow budget)."""
    check(data, np.random.default_rng(list(data[:64])), 20_000)
    return "ok"


def _seeds() -> list[bytes]:
    rng = np.random.default_rng(0)
    seeds = []
    for i in range(14):
        q = np.stack([rng.uniform(0, 90, 8), rng.uniform(0, 360, 8), rng.uniform(0, 90, 8), rng.uniform(0, 360, 8),
                      rng.uniform(-0.3, 0.3, 8)], axis=1)
        seeds.append(bytes([i % 7, i // 7, i % 4]) + q.tobytes())
    return seeds


@pytest.mark.slow
def test_seed_inputs_pass_in_process():
    rng = np.random.default_rng(1)
    for s in _seeds():
        check(s, rng, 200)


def test_fuzz_lookup_small_budget():
    report = fuzz("tests.test_fuzz_lookup:target", _seeds(), n=60, seed=1, per_input_s=60.0, max_ops=8)
    assert not report.bad, report.summary()
    assert report.outcomes["ok"] == 60, report.summary()


@pytest.mark.slow
def test_fuzz_lookup_large_budget():
    # 500 inputs x ~20,000 queries x 2 modes: about 10^7 lookups
    report = fuzz("tests.test_fuzz_lookup:target_large", _seeds(), n=500, seed=2, per_input_s=120.0, max_ops=8)
    assert not report.bad, report.summary()
