"""``cdbrdf bend FLAT -o OUT.h5``: a CDBRDF from a flat measured BRDF, bent by a fabric model fitted to it."""

from __future__ import annotations

import argparse
import time
from typing import Any

from ._text import say

__all__ = ["register", "run", "summary"]


def register(sub: argparse._SubParsersAction) -> None:
    from ..bend import BEND_MODELS
    from ._args import brdf_file, float_list, output_file
    from .import_ import _grid

    p = sub.add_parser(
        "bend",
        help="a CDBRDF from a flat measured BRDF: the measurement at kappa 0, bent by a fabric model fitted to it",
        description=(
            "Fit the woven and/or the pile fabric model to a flat measured BRDF (RGL .bsdf, MERL .binary, "
            "UTIA .bin, a Neural-BRDF network, a one-curvature CDBRDF file), then write a CDBRDF whose kappa = 0 "
            "slice is the measurement and whose other curvatures are the measurement times the fitted model's "
            "change from flat (reciprocal, energy-conserving). The file records the model, its fitted parameters "
            "with their uncertainties, the fit's error, and that the bending is predicted, not measured "
            "(fill method model). See docs/guide.md."),
        epilog="example: cdbrdf bend acrylic_felt_white_rgb.h5 -o felt-cdbrdf.h5 --kappa=-0.2,0,0.1,0.2",
    )
    p.add_argument("flat", metavar="FLAT", type=brdf_file(),
                   help="the flat measurement (a Neural-BRDF network: NAME.h5 or NAME.json of the pair)")
    p.add_argument("-o", "--output", required=True, type=output_file(".h5", ".nc"), help="the CDBRDF file to write")
    p.add_argument("--model", choices=BEND_MODELS, default="auto",
                   help="the fabric model fitted: auto (woven and pile, the better fit kept; default), woven, pile")
    p.add_argument("--kappa", type=float_list(-10, 10, unique=True, unit="1/mm"), default=None, metavar="LIST",
                   help="curvatures in 1/mm, comma-separated (default the paper's -0.22,-0.13,0,0.13,0.22; "
                   "0 is added if missing)")
    p.add_argument("--grid", type=_grid, default=None, metavar="GRID",
                   help="directions: paper (default) | native | regular:THETA_STEP,PHI_STEP[,THETA_MAX]")
    p.add_argument("--material", help="material name (default: the file's description, else its name)")
    p.set_defaults(func=run)


def summary(table: Any) -> str:
    """One line on a bent table: the model, its fit, the curvatures."""
    prov = table.attrs.get("provenance", {})
    m = prov.get("model", {})
    err = m.get("errors", {}).get("test", {})
    cands = prov.get("candidates", {})
    others = ", ".join(f"{k} {v['delta_e_median']:.2f}" for k, v in cands.items() if k != m.get("model"))
    ks = ", ".join(f"{k:g}" for k in table.kappa)
    return (f"{table.attrs.get('material')!r}, bent by the {m.get('model')} model (fit at flat: median Delta E*ab "
            f"{err.get('delta_e_median', float('nan')):.2f}, relative RMS {err.get('relative_rms', float('nan')):.3f}"
            f"{'; ' + others if others else ''}); kappa {ks} 1/mm (kappa != 0 predicted, not measured)")


def run(args: argparse.Namespace) -> int:
    from ..bend import bend
    from ._progress import ProgressBars

    quiet = getattr(args, "quiet", False)
    t0 = time.perf_counter()
    with ProgressBars(quiet=quiet) as bars:
        table = bend(args.flat, model=args.model, kappa=args.kappa, grid=args.grid, material=args.material,
                     progress=bars.update)
    table.save(args.output)
    if not quiet:
        say(f"wrote {args.output}: {summary(table)}; {time.perf_counter() - t0:.1f} s")
    return 0
