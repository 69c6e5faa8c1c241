"""Benchmark: rendering the sine sheet with the cdbrdf plug-in against Mitsuba's ``diffuse``.

Run: ``.venv/bin/python benchmarks/bench_render.py [--size 512] [--spp 64] [--repeat 3]``

Same scene, same run, same Mitsuba variant (``llvm_ad_rgb``): the paper's
sine sheet (60 x 60 mm, amplitude 2 mm, wavelength 20 mm) under one
directional light, path tracer with max_depth 3, rendered with

- the ``cdbrdf`` plug-in (5-D lookup of a table on the paper's grid, per-vertex
  curvature attribute),
- the plug-in in ``brdf`` mode (4-D lookup),
- Mitsuba's built-in ``diffuse`` BSDF (the reference).

Every scene is rendered once untimed (JIT compilation, cached kernels), then
``--repeat`` times interleaved; the best time of each counts. Target: the
plug-in's time <= 1.5x ``diffuse``'s. Exits 1 when missed.
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np

import cdbrdf

TARGET_RATIO = 1.5


def _table() -> cdbrdf.CDBRDF:
    g = cdbrdf.Grid.paper()
    m = g.mesh()
    rng = np.random.default_rng(0)
    base = 0.05 + 0.3 * rng.random(g.shape + (3,))
    tilt = np.clip(m["kappa"] / 0.22, -1, 1)[..., None] * np.array([0.1, 0.1, -0.05])
    return cdbrdf.CDBRDF((base + tilt).clip(0.01).astype(np.float32), **g.axes())


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--size", type=int, default=512, help="image width and height (default 512)")
    ap.add_argument("--spp", type=int, default=64, help="samples per pixel (default 64)")
    ap.add_argument("--repeat", type=int, default=3, help="timed renders per scene (default 3)")
    args = ap.parse_args(argv)

    import cdbrdf.render as cr

    cr.set_variant("llvm_ad_rgb")
    import drjit as dr
    import mitsuba as mi

    from cdbrdf.render.scenes import sine_scene

    table = _table()
    kw = dict(size=(args.size, args.size), spp=args.spp, max_depth=3)
    scenes = {
        "diffuse": sine_scene(table, bsdf={"type": "diffuse", "reflectance": {"type": "rgb", "value": 0.5}}, **kw),
        "cdbrdf": sine_scene(table, mode="cdbrdf", **kw),
        "brdf": sine_scene(table, mode="brdf", **kw),
    }

    def render(scene, seed):
        t0 = time.perf_counter()
        img = mi.render(scene, spp=args.spp, seed=seed)
        dr.eval(img)
        dr.sync_thread()
        return time.perf_counter() - t0

    first = {name: render(sc, 0) for name, sc in scenes.items()}
    times: dict[str, list[float]] = {name: [] for name in scenes}
    for r in range(args.repeat):
        for name, sc in scenes.items():
            times[name].append(render(sc, r + 1))
    best = {name: min(t) for name, t in times.items()}
    ref = best["diffuse"]
    print(f"sine sheet {args.size}x{args.size}, {args.spp} spp, path max_depth 3, llvm_ad_rgb "
          f"(Mitsuba {mi.__version__}, Dr.Jit {dr.__version__}); best of {args.repeat}")
    print(f"{'BSDF':<10} {'first (s)':>10} {'best (s)':>10} {'ratio':>7}")
    for name in scenes:
        print(f"{name:<10} {first[name]:>10.2f} {best[name]:>10.2f} {best[name] / ref:>7.2f}")
    ratio = best["cdbrdf"] / ref
    ok = ratio <= TARGET_RATIO
    print(f"cdbrdf / diffuse = {ratio:.2f} (target <= {TARGET_RATIO}): {'OK' if ok else 'MISSED'}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
