"""Benchmark: tabulating the cloth presets on the paper's grid.

Run: ``.venv/bin/python benchmarks/bench_synth.py``

For each preset (``denim``, ``shot``) times ``ClothModel.tabulate`` on
:meth:`cdbrdf.Grid.paper` (72 x 72 directions x 5 curvatures, each sample an
integral over the weave repeat: ``points`` points on the micro-surface, each
with a visibility ray towards the viewer and one towards the light,
``tilt_samples`` footprint patches on a bent cloth), after a warm-up that
compiles the kernels. Target: <= 60 s per preset.
As a reference measured in the same run, the kappa = +0.22 slice is also
computed in one thread; the ratio is the parallel speed-up (the values
are checked to be identical: no reductions across threads). Exits 1 when a
target is missed.
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np

import cdbrdf
import cdbrdf._jit
from cdbrdf.synth import presets

TARGET_S = 60.0


cpu_count = cdbrdf._jit.cpu_count


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--presets", nargs="*", default=["denim", "shot"])
    args = ap.parse_args(argv)
    g = cdbrdf.Grid.paper()
    one = cdbrdf.Grid.paper(kappa=[0.22])
    tiny = cdbrdf.Grid(kappa=[0.0, 0.1], theta_l=[10.0], phi_l=[0.0], theta_v=[20.0], phi_v=[0.0])
    threads = cdbrdf._jit.cpu_count()
    rows = []
    ok = True
    for name in args.presets:
        m = presets.model(name)
        m.tabulate(tiny)  # compile / load the cached kernels
        t0 = time.perf_counter()
        table = m.tabulate(g)
        t_all = time.perf_counter() - t0
        t0 = time.perf_counter()
        par = m.tabulate(one)
        t_par = time.perf_counter() - t0
        cdbrdf._jit.cpu_count = lambda: 1  # the kernels' ranges in one thread
        try:
            t0 = time.perf_counter()
            ser = m.tabulate(one)
            t_ser = time.perf_counter() - t0
        finally:
            cdbrdf._jit.cpu_count = cpu_count
        same = np.array_equal(par.values, ser.values) and np.array_equal(
            par.values[0], table.values[-1]
        )
        passed = t_all <= TARGET_S and same
        ok &= passed
        rows.append((name, np.prod(g.shape), t_all, np.prod(g.shape) / t_all, t_ser / t_par, same, passed))
    print(f"threads: {threads}; points/sample, texels: "
          f"{presets.params('denim').points}, {presets.params('denim').texels}")
    print(f"{'preset':8s} {'samples':>8s} {'time s':>7s} {'samples/s':>10s} {'1-thread/N-thread':>18s} "
          f"{'identical':>9s}  result")
    for name, n, t, rate, speed, same, passed in rows:
        print(f"{name:8s} {n:8d} {t:7.1f} {rate:10.0f} {speed:18.2f} {str(same):>9s}  "
              f"time <= {TARGET_S:.0f} s {'PASS' if passed else 'FAIL'}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
