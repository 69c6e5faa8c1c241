"""Benchmark: rendering the sine sheet with the cdbrdf plug-in against Mitsuba's ``diffuse`` and ``measured``.

Run: ``.venv/bin/python benchmarks/bench_render.py [--size 512] [--spp 64] [--repeat 5] [--rgl FILE]``

Same scene, same run, same Mitsuba variant (``llvm_ad_rgb``): the paper's
sine sheet (60 x 60 mm, amplitude 2 mm, wavelength 20 mm) under one
directional light, path tracer with max_depth 3, rendered with

- Mitsuba's built-in ``diffuse`` BSDF (the reference of the ratios);
- the ``cdbrdf`` plug-in (5-D lookup of a table on the paper's grid,
  per-vertex curvature attribute) with cosine sampling and with table
  sampling, with the table packed (21-bit RGB) and as float32 packets (the
  storage of the differentiable table), and in ``brdf`` mode (4-D);
- the plug-in with a constant curvature (what the attribute read costs);
- Mitsuba's C++ ``measured`` BSDF on an RGL file (``../shared/data/rgl/``),
  skipped when the data is absent.

Every scene is rendered once untimed (JIT compilation, cached kernels), then
``--repeat`` times interleaved; the best time of each counts. Times are the
process's CPU time (all threads), which other jobs on a shared machine
disturb much less than wall time; wall times are printed beside them.
Targets: cosine sampling <= 1.2x ``diffuse``; table sampling faster than
``measured``. Exits 1 when one is missed.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

import cdbrdf

TARGET_COSINE = 1.2

#: RGL file for Mitsuba's ``measured`` (``../shared/data/rgl/`` from the repository root).
RGL_FILE = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "rgl" / "satin_rosaline_rgb.bsdf"


def _table() -> cdbrdf.CDBRDF:
    g = cdbrdf.Grid.paper()
    m = g.mesh()
    rng = np.random.default_rng(0)
    base = 0.05 + 0.3 * rng.random(g.shape + (3,))
    tilt = np.clip(m["kappa"] / 0.22, -1, 1)[..., None] * np.array([0.1, 0.1, -0.05])
    return cdbrdf.CDBRDF((base + tilt).clip(0.01).astype(np.float32), g)


def timed(mi, dr, scene, spp: int, seed: int) -> tuple[float, float]:
    """``(cpu_s, wall_s)`` of one render, evaluated and synchronised."""
    c0, t0 = time.process_time(), time.perf_counter()
    img = mi.render(scene, spp=spp, seed=seed)
    dr.eval(img)
    dr.sync_thread()
    return time.process_time() - c0, time.perf_counter() - t0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--size", type=int, default=512, help="image width and height (default 512)")
    ap.add_argument("--spp", type=int, default=64, help="samples per pixel (default 64)")
    ap.add_argument("--repeat", type=int, default=5, help="timed renders per scene (default 5)")
    ap.add_argument("--rgl", type=Path, default=RGL_FILE, help=f"RGL .bsdf file for measured (default {RGL_FILE})")
    args = ap.parse_args(argv)

    import cdbrdf.render as cr

    cr.set_variant("llvm_ad_rgb")
    import drjit as dr
    import mitsuba as mi

    from cdbrdf.render import RenderSpec
    from cdbrdf.render.scenes import sine_scene

    table = _table()
    spec = RenderSpec(size=(args.size, args.size), spp=args.spp, max_depth=3)

    def plugin(**p):
        return sine_scene(table, spec, bsdf={"type": "cdbrdf", "table": table, **p})

    scenes = {
        "diffuse": sine_scene(table, spec, bsdf={"type": "diffuse", "reflectance": {"type": "rgb", "value": 0.5}}),
        "cdbrdf cosine": plugin(sampling="cosine"),
        "cdbrdf table": plugin(sampling="table"),
        "cdbrdf cosine, float": plugin(sampling="cosine", storage="float"),
        "cdbrdf table, float": plugin(sampling="table", storage="float"),
        "cdbrdf cosine, const kappa": plugin(sampling="cosine", curvature=0.1),
        "brdf mode, cosine": plugin(sampling="cosine", mode="brdf"),
    }
    if args.rgl.is_file():
        scenes["measured (C++)"] = sine_scene(table, spec, bsdf={"type": "measured", "filename": str(args.rgl)})
    else:
        print(f"({args.rgl} not found: Mitsuba's measured is skipped)")

    for sc in scenes.values():
        timed(mi, dr, sc, args.spp, 0)
    cpu: dict[str, list[float]] = {name: [] for name in scenes}
    wall: dict[str, list[float]] = {name: [] for name in scenes}
    for r in range(args.repeat):
        for name, sc in scenes.items():
            c, w = timed(mi, dr, sc, args.spp, r + 1)
            cpu[name].append(c)
            wall[name].append(w)
    best = {n: min(v) for n, v in cpu.items()}
    best_w = {n: min(v) for n, v in wall.items()}
    ref, ref_w = best["diffuse"], best_w["diffuse"]
    print(f"sine sheet {args.size}x{args.size}, {args.spp} spp, path max_depth 3, llvm_ad_rgb "
          f"(Mitsuba {mi.__version__}, Dr.Jit {dr.__version__}); best of {args.repeat}")
    print(f"{'BSDF':<28} {'CPU (s)':>8} {'ratio':>6} {'wall (s)':>9} {'ratio':>6}")
    for name in scenes:
        print(f"{name:<28} {best[name]:>8.2f} {best[name] / ref:>6.2f} {best_w[name]:>9.2f} "
              f"{best_w[name] / ref_w:>6.2f}")
    ok = True
    r_cos = best["cdbrdf cosine"] / ref
    good = r_cos <= TARGET_COSINE
    ok &= good
    print(f"cdbrdf cosine / diffuse = {r_cos:.2f} (target <= {TARGET_COSINE}): {'OK' if good else 'MISSED'}")
    if "measured (C++)" in best:
        r_tab, r_meas = best["cdbrdf table"] / ref, best["measured (C++)"] / ref
        good = r_tab < r_meas
        ok &= good
        print(f"cdbrdf table / diffuse = {r_tab:.2f}, measured / diffuse = {r_meas:.2f} "
              f"(target: table faster than measured): {'OK' if good else 'MISSED'}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
