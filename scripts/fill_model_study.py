"""The model fill against truths whose parameters it does not know.

Run: ``.venv/bin/python scripts/fill_model_study.py [--grid quick|full] [--cases NAME,...]``

Each case is a ground truth tabulated from a fabric model that differs from
the preset the fill fits (a perturbed preset: other thickness, crimp, pile
height, density, colours; or a cloth no preset describes, which the fill
must choose a preset for), with the measurement's noise (0.5 % per sample,
multiplicative, as the simulated rig's measured samples) and the samples the
paper's stands hide on the chosen grid (:func:`cdbrdf.measure.stands.hidden_mask`,
the simulated rig's patch test). Every fill method fills them; per case,
method and hidden stand it prints the median and 95th percentile of the
relative luminance error of the filled samples against the truth and the
share of them within 2 of their own standard deviations (``fill_std``).
``docs/capture.md`` ("Filling") quotes its output.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Sequence
from typing import Any

import numpy as np

#: name -> (the preset the fill is told, or None: it chooses; the truth's preset; the truth's changes)
CASES: dict[str, tuple[str | None, str, dict[str, Any]]] = {
    "denim-thicker-looser": ("denim", "denim", {"thickness_mm": 0.95, "crimp_share_warp": 0.55,
                                                "warp_rgb": (0.01, 0.07, 0.2)}),
    "denim-thinner-glossier": ("denim", "denim", {"thickness_mm": 0.75, "warp_specular": 0.4, "warp_gloss_deg": 9.0}),
    "shot-wider-sheen": ("shot", "shot", {"weft_sheen_deg": 14.0, "thickness_mm": 0.34,
                                          "warp_rgb": (0.35, 0.05, 0.03)}),
    "velvet-taller-sparser": ("velvet", "velvet", {"pile_height_mm": 2.4, "strands_per_mm2": 15.0, "lean_deg": 10.0}),
    "towel-deeper-loops": ("towel", "towel", {"pile_height_mm": 3.9, "spread_deg": 22.0}),
    "plain-cotton-unknown": (None, "denim", {"weave": "plain", "warp_pitch_mm": 0.45, "weft_pitch_mm": 0.45,
                                             "warp_rgb": (0.6, 0.1, 0.08), "weft_rgb": (0.55, 0.5, 0.45),
                                             "thickness_mm": 0.6}),
}

NOISE = 0.005


def study(case: str, grid_name: str, methods: Sequence[str], seed: int = 3) -> list[dict[str, Any]]:
    """Rows ``{case, method, kappa, filled, median, p95, within_2_sigma, seconds}`` for one case."""
    from cdbrdf.colour import luminance
    from cdbrdf.demo import CONFIGS
    from cdbrdf.measure.fill import fill
    from cdbrdf.measure.stands import Stand, hidden_mask
    from cdbrdf.synth import presets

    told, base, changes = CASES[case]
    cfg = CONFIGS[grid_name]
    g = cfg.grid
    truth = presets.model(base, **changes).tabulate(g).values.astype(np.float64)
    valid = hidden_mask(g, [Stand(float(k)) for k in g.kappa], pixel_mm=cfg.field_mm / cfg.image_px) == 0
    rng = np.random.default_rng(seed)
    meas = truth * (1.0 + NOISE * rng.standard_normal(truth.shape))
    yt = luminance(truth)
    rows = []
    for method in methods:
        t0 = time.perf_counter()
        r = fill(np.where(valid[..., None], meas, np.nan), valid, g, method=method, material=told)
        dt = time.perf_counter() - t0
        y, s = luminance(r.values), luminance(r.fill_std)
        err = np.abs(y - yt)
        for k, kappa in enumerate(g.kappa):
            f = ~valid[k]
            if f.any():
                rel = err[k][f] / np.abs(yt[k][f])
                rows.append({"case": case, "method": method, "kappa": float(kappa), "filled": int(f.sum()),
                             "median": float(np.median(rel)), "p95": float(np.percentile(rel, 95)),
                             "within_2_sigma": float(np.mean(err[k][f] <= 2 * s[k][f])), "seconds": dt,
                             "model": r.summary.get("model", {}).get("preset")})
    return rows


def main(argv: Sequence[str] | None = None) -> int:
    """Print the study as a Markdown table."""
    from cdbrdf.measure.fill import FILL_METHODS

    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--grid", choices=("quick", "full"), default="quick")
    parser.add_argument("--cases", default=",".join(CASES), help=f"comma-separated, of: {', '.join(CASES)}")
    parser.add_argument("--methods", default=",".join(FILL_METHODS))
    args = parser.parse_args(argv)
    print("| case | method | kappa | filled | median | p95 | within 2 sigma | model |")
    print("|---|---|---|---|---|---|---|---|")
    for case in args.cases.split(","):
        for r in study(case, args.grid, args.methods.split(",")):
            print(f"| {r['case']} | {r['method']} | {r['kappa']:+.2f} | {r['filled']} | {100 * r['median']:.2f} % "
                  f"| {100 * r['p95']:.1f} % | {100 * r['within_2_sigma']:.0f} % | {r['model'] or ''} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
