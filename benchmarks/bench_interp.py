"""Benchmark: the 5-D lookup against scipy's RegularGridInterpolator.

Run: ``.venv/bin/python benchmarks/bench_interp.py [--queries 1000000] [--repeat 5]``

Both interpolators run in the same process on the paper's grid (5 x 12 x 6 x
12 x 6 x RGB, float32 table) with the same random queries. The reference is
``RegularGridInterpolator(method="linear")`` with both azimuth axes padded by
one period so that it wraps like ours. Reports the best-of-N time of each,
lookups/s, the speed-up (target >= 50x) and the extra memory of a 10^7-query
lookup beyond its output array (target: a few tens of MiB). Exits 1 when a
target is missed.
"""

from __future__ import annotations

import argparse
import sys
import tracemalloc

import numpy as np
from scipy.interpolate import RegularGridInterpolator

import cdbrdf
from cdbrdf._jit import cpu_count

from _common import best_seconds

TARGET_RATIO = 50.0
TARGET_EXTRA_MIB = 64.0



def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--queries", type=int, default=1_000_000)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--memory-queries", type=int, default=10_000_000)
    args = ap.parse_args(argv)


    g = cdbrdf.Grid.paper()
    rng = np.random.default_rng(0)
    values = (0.05 + rng.random(g.shape + (3,))).astype(np.float32)
    table = cdbrdf.CDBRDF(values, g)
    n = args.queries
    tv, tl = rng.uniform(0, 90, (2, n))
    pv, pl = rng.uniform(0, 360, (2, n))
    k = rng.uniform(-0.25, 0.25, n)

    # reference: scipy, azimuths padded for periodicity
    v = np.concatenate([values, values[:, :1]], axis=1)
    v = np.concatenate([v, v[:, :, :, :1]], axis=3).astype(np.float64)
    ph = np.append(g.phi_l, 360.0)
    rgi = RegularGridInterpolator((g.kappa, ph, g.theta_l, ph, g.theta_v), v, method="linear",
                                  bounds_error=False, fill_value=None)
    pts = np.stack([np.clip(k, -0.22, 0.22), pl, np.minimum(tl, 75.0), pv, np.minimum(tv, 75.0)], axis=-1)

    table.evaluate(tv[:10], pv[:10], tl[:10], pl[:10], k[:10])  # compile / load cache
    t_ours = best_seconds(lambda: table.evaluate(tv, pv, tl, pl, k), args.repeat, warmup=False)
    t_ref = best_seconds(lambda: rgi(pts), max(1, args.repeat // 2), warmup=False)
    ours = table.evaluate(tv, pv, tl, pl, k)
    off_pole = (tv >= 15) & (tl >= 15)
    err = float(np.abs(ours - rgi(pts))[off_pole].max())
    ratio = t_ref / t_ours

    # memory: extra beyond the output for a large query
    m = args.memory_queries
    qs = [rng.uniform(0, 90, m), rng.uniform(0, 360, m), rng.uniform(0, 90, m), rng.uniform(0, 360, m),
          rng.uniform(-0.25, 0.25, m)]
    tracemalloc.start()
    out = table.evaluate(*qs)
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    extra_mib = (peak - out.nbytes) / 2**20
    del out, qs

    rows = [
        ("threads", f"{cpu_count()}"),
        ("queries", f"{n:,}"),
        ("cdbrdf lookup", f"{t_ours * 1e3:.1f} ms  ({n / t_ours / 1e6:.1f} M lookups/s)"),
        ("scipy RegularGridInterpolator", f"{t_ref * 1e3:.1f} ms  ({n / t_ref / 1e6:.2f} M lookups/s)"),
        ("speed-up", f"{ratio:.1f}x  (target >= {TARGET_RATIO:.0f}x)"),
        ("max |difference| off the pole", f"{err:.2e}"),
        (f"extra memory, {m:,} queries", f"{extra_mib:.1f} MiB beyond the output  (target <= {TARGET_EXTRA_MIB:.0f})"),
    ]
    w = max(len(r[0]) for r in rows)
    for name, val in rows:
        print(f"{name:<{w}}  {val}")
    ok = ratio >= TARGET_RATIO and extra_mib <= TARGET_EXTRA_MIB and err < 1e-9
    print("PASS" if ok else "FAIL")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
