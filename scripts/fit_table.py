"""The fit table of docs/fabric-model.md: the woven and pile models and the analytic baseline fitted to real cloth.

Run: ``python scripts/fit_table.py [--data ../shared/data] [--out fit-table.json] [--only NAME ...]``

For every Neural-BRDF fabric of the shared data (13 MERL, 10 RGL) the three
models of :data:`cdbrdf.fit.FIT_MODELS` are fitted at 128 direction pairs
(both elevations at most 70 degrees) and their error measured at 512 others:
relative RMS and median Delta E*ab, the physical models at their full
integration quality. The RGL tensor files of the shared data (a paper, a
vinyl film, a car paint) are not cloth and are left out. Results are cached
in the output JSON by the network's SHA-256, the models' versions and the
fit's settings: a second run refits only what changed. Prints the Markdown
table.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
MODELS = ("sheen", "woven", "pile")
FIT_PAIRS, TEST_PAIRS = 128, 512


def _settings() -> dict:
    from cdbrdf.fit import fit_model
    from cdbrdf.synth.cloth import MODEL_VERSION
    from cdbrdf.synth.pile import PILE_MODEL_VERSION

    return {"woven": MODEL_VERSION, "pile": PILE_MODEL_VERSION, "fit_pairs": FIT_PAIRS, "test_pairs": TEST_PAIRS,
            "max_evaluations": {m: fit_model(m).max_evaluations for m in MODELS}, "fit": 5}


def fit_one(path: Path) -> dict:
    from cdbrdf import fit as F
    from cdbrdf.importers import read_source

    src = read_source(path)
    data = F.sample(src.evaluate, isotropic=src.isotropic, n=FIT_PAIRS, seed=0)
    test = F.sample(src.evaluate, isotropic=src.isotropic, n=TEST_PAIRS, seed=1)
    out = {"name": path.stem, "database": path.parent.name, "sha256": src.sha256,
           "network_asymmetry": src.details.get("network_asymmetry_median"), "models": {}}
    for m in MODELS:
        t0, c0 = time.perf_counter(), time.process_time()
        r = F.fit(data, m, test=test)
        d = r.to_dict()
        d["seconds"] = round(time.perf_counter() - t0, 1)
        d["cpu_seconds"] = round(time.process_time() - c0, 1)  # every thread's: what the fit costs, whatever the load
        out["models"][m] = d
        e = r.errors["test"]
        print(f"  {path.stem}: {m:5s} dE {e['delta_e_median']:6.2f} rms {e['relative_rms']:.3f}  {d['seconds']:5.1f} s "
              f"({d['cpu_seconds']:.1f} s CPU, {r.evaluations} evaluations)", flush=True)
    return out


def markdown(results: list[dict]) -> str:
    rows = ["| fabric | source | baseline: rel. RMS, median dE | woven | pile | best physical vs baseline |",
            "|---|---|---|---|---|---|"]
    for r in results:
        e = {m: r["models"][m]["errors"]["test"] for m in MODELS}
        best = min(("woven", "pile"), key=lambda m: e[m]["delta_e_median"])
        verdict = "as good or better" if e[best]["delta_e_median"] <= e["sheen"]["delta_e_median"] else "worse"
        cell = {m: f"{e[m]['relative_rms']:.3f}, {e[m]['delta_e_median']:.2f}" for m in MODELS}
        rows.append(f"| {r['name']} | {r['database'].upper()} | {cell['sheen']} | {cell['woven']} | {cell['pile']} | "
                    f"{best}: {verdict} |")
    return "\n".join(rows)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--data", type=Path, default=ROOT.parent / "shared" / "data")
    ap.add_argument("--out", type=Path, default=Path("fit-table.json"))
    ap.add_argument("--only", nargs="*", default=None, help="fabric names (default all)")
    args = ap.parse_args(argv)

    files = sorted((args.data / "nbrdf").glob("*/*.h5"))
    if args.only:
        files = [f for f in files if f.stem in args.only]
    settings = _settings()
    cache = {}
    if args.out.exists():
        old = json.loads(args.out.read_text())
        if old.get("settings") == settings:
            cache = {r["sha256"]: r for r in old["results"]}
    t0 = time.perf_counter()
    results = []
    for f in files:
        from cdbrdf.importers import read_source

        sha = read_source(f).sha256
        if sha in cache:
            results.append(cache[sha])
            continue
        results.append(fit_one(f))
        args.out.write_text(json.dumps({"settings": settings, "results": results}, indent=1))
    args.out.write_text(json.dumps({"settings": settings, "results": results}, indent=1))
    print(markdown(results))
    cpu = sum(r["models"][m].get("cpu_seconds", 0.0) for r in results for m in MODELS)
    print(f"{len(results)} fabrics in {time.perf_counter() - t0:.0f} s ({cpu:.0f} s CPU for the fits)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
