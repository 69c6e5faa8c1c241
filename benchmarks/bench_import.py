"""Benchmark: imported RGL materials against Mitsuba's own ``measured`` plug-in; import and lookup times.

Run: ``.venv/bin/python benchmarks/bench_import.py [--size 256] [--spp 1024] [--data ../shared/data/rgl]``

1. **Reference renders** (:mod:`cdbrdf.importers.reference`): for every RGL
   file of ``../shared/data/rgl`` (matte, moderately glossy, glossy), the
   sphere and the sine sheet under a directional light plus a constant
   environment, rendered with Mitsuba's ``measured`` reading the file and with
   the ``cdbrdf`` plug-in on the table imported at the default grid; the mean
   relative difference over the object's 4 x 4 pixel blocks, at two seeds (its
   spread is the Monte Carlo uncertainty). Also the glossy file at the paper's
   grid, point-sampled and with cell means, and a strongly glossy analytic
   material (Mitsuba's ``roughplastic``, GGX alpha 0.02, diffuse 0.05)
   against the BSDF itself at the default grid and at 1 degree.
2. **Import time** of each file at the default grid (best of ``--repeat``).
3. **Lookup time** of 10^6 random queries on the default isotropic table
   against the paper's anisotropic grid (same run, same kernel path).

Targets at the default grid: <= 2 % matte, <= 5 % moderately glossy, <= 10 %
glossy. Exits 1 when one is missed.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
FILES = {"matte": ("paper_white_rgb.bsdf", 0.02), "moderately glossy": ("satin_rosaline_rgb.bsdf", 0.05),
         "glossy": ("cc_ibiza_sunset_rgb.bsdf", 0.10)}
PLASTIC = {"type": "roughplastic", "alpha": 0.02, "distribution": "ggx",
           "diffuse_reflectance": {"type": "rgb", "value": 0.05}}


def _row(label, grid, table, res, seconds=None):
    est = table.attrs.get("provenance", {}).get("expected_error") or {}
    figs = "  ".join(f"{r.scene} {100 * r.mean_relative:5.2f}% (seed 2: {100 * r.mean_relative_seed2:5.2f}%, "
                     f"brightness {r.brightness_ratio:.3f})" for r in res)
    t = f" import {seconds:.1f}s" if seconds is not None else ""
    print(f"{label:<22} {grid:<16} {figs}  est. BRDF {100 * est.get('brdf_relative_l1', float('nan')):.2f}% "
          f"albedo {100 * est.get('albedo_relative_error_mean', float('nan')):.2f}% "
          f"peak/median {est.get('peak_to_median')}{t}", flush=True)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--size", type=int, default=256, help="film width and height (default 256)")
    ap.add_argument("--spp", type=int, default=1024, help="samples per pixel (default 1024)")
    ap.add_argument("--repeat", type=int, default=3, help="timed imports per file (default 3)")
    ap.add_argument("--data", type=Path, default=ROOT.parent / "shared" / "data" / "rgl",
                    help="folder of the RGL files (default ../shared/data/rgl)")
    ap.add_argument("--json", type=Path, help="also write the figures to this JSON file")
    args = ap.parse_args(argv)

    import cdbrdf.render as cr
    from cdbrdf import Grid
    from cdbrdf.importers import import_brdf, read_source, table_from, target_grid
    from cdbrdf.importers.mitsuba import source as mitsuba_source
    from cdbrdf.importers.reference import compare
    from cdbrdf.interp import evaluate

    cr.set_variant("llvm_ad_rgb")
    import drjit as dr
    import mitsuba as mi

    print(f"reference renders {args.size}x{args.size}, {args.spp} spp, 4x4 blocks, Mitsuba {mi.__version__}, "
          f"Dr.Jit {dr.__version__}")
    out: dict = {"size": args.size, "spp": args.spp, "renders": [], "import_s": {}, "lookup": {}}
    ok = True
    kw = dict(size=args.size, spp=args.spp, noise=True)
    tables = {}
    for kind, (name, target) in FILES.items():
        p = args.data / name
        if not p.is_file():
            print(f"missing {p}: skipped")
            continue
        times = []
        for _ in range(args.repeat):
            t0 = time.perf_counter()
            t = import_brdf(p)
            times.append(time.perf_counter() - t0)
        tables[kind] = t
        res = compare(t, p, **kw)
        _row(kind, "default", t, res, min(times))
        worst = max(max(r.mean_relative, r.mean_relative_seed2) for r in res)
        ok &= worst <= target
        out["import_s"][name] = round(min(times), 2)
        out["renders"].append({"material": name, "grid": "default", "target": target,
                               "figures": [r.summary() for r in res],
                               "expected_error": t.attrs["provenance"]["expected_error"]})
        if kind == "glossy":
            src = read_source(p)
            g = target_grid("paper", src)
            for method in ("point", "cell"):
                tp = table_from(src, g, method=method)
                res = compare(tp, p, **kw)
                _row(f"{kind} ({method})", "paper", tp, res)
                out["renders"].append({"material": name, "grid": "paper", "method": method,
                                       "figures": [r.summary() for r in res]})
    src = mitsuba_source(PLASTIC)
    for grid in ("default", "regular:1,1,89"):
        t0 = time.perf_counter()
        tp = table_from(src, target_grid(grid, src))
        dt = time.perf_counter() - t0
        res = compare(tp, PLASTIC, **kw)
        _row("plastic a=0.02", grid, tp, res, dt)
        out["renders"].append({"material": "roughplastic alpha 0.02", "grid": grid,
                               "figures": [r.summary() for r in res],
                               "expected_error": tp.attrs["provenance"]["expected_error"]})

    # lookup: the default isotropic table against the paper's anisotropic grid, same queries, same run
    if tables:
        iso = next(iter(tables.values()))
        g = Grid.paper(kappa=[0.0])
        aniso = table_from(read_source(args.data / FILES["matte"][0]), g, estimate=False) if "matte" in tables \
            else None
        rng = np.random.default_rng(0)
        n = 1_000_000
        q = (rng.uniform(0, 90, n), rng.uniform(0, 360, n), rng.uniform(0, 90, n), rng.uniform(0, 360, n))
        res_t = {}
        for label, t in (("isotropic default", iso), ("paper anisotropic", aniso)):
            if t is None:
                continue
            evaluate(t, *q)  # compile, prepare
            best = min(_timed(lambda t=t: evaluate(t, *q)) for _ in range(5))
            res_t[label] = best
            print(f"lookup {label:<18} {t.shape}: {1e3 * best:.1f} ms per 10^6 queries")
        if len(res_t) == 2:
            ratio = res_t["isotropic default"] / res_t["paper anisotropic"]
            print(f"lookup isotropic / anisotropic = {ratio:.2f}")
            out["lookup"] = {k: round(1e3 * v, 2) for k, v in res_t.items()} | {"ratio": round(ratio, 3)}
        # render time: the plug-in on the fine isotropic table, on the paper's grid, and Mitsuba's measured
        import tempfile

        from cdbrdf.importers.reference import scene_dict
        from cdbrdf.render import load_dict

        with tempfile.TemporaryDirectory() as tmp:
            bsdfs = {"measured": {"type": "measured", "filename": str(args.data / FILES["matte"][0])},
                     "cdbrdf isotropic": {"type": "cdbrdf", "table": iso, "curvature": 0.0}}
            if aniso is not None:
                bsdfs["cdbrdf paper"] = {"type": "cdbrdf", "table": aniso, "curvature": 0.0}
            times = {}
            for label, b in bsdfs.items():
                sc = load_dict(scene_dict("sphere", b, size=args.size, spp=64, folder=Path(tmp)))
                mi.render(sc, spp=64)  # compile
                times[label] = min(_timed(lambda sc=sc: dr.eval(mi.render(sc, spp=64))) for _ in range(3))
            for label, v in times.items():
                print(f"render sphere {args.size}^2 x 64 spp, {label:<17}: {v:.2f} s "
                      f"({v / times['measured']:.2f} x measured)")
            out["render_s"] = {k: round(v, 3) for k, v in times.items()}
    if args.json:
        args.json.write_text(json.dumps(out, indent=2))
    print("targets (<= 2 % matte, <= 5 % moderately glossy, <= 10 % glossy):", "OK" if ok else "MISSED")
    return 0 if ok else 1


def _timed(f) -> float:
    t0 = time.perf_counter()
    f()
    return time.perf_counter() - t0


if __name__ == "__main__":
    sys.exit(main())
