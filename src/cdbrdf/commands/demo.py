"""``cdbrdf demo -o DIR [--quick] [--fabrics LIST]``: the paper end to end on the bundled fabrics."""

from __future__ import annotations

import argparse

from ._text import say

__all__ = ["register", "run"]


def _fabrics(text: str) -> list[str]:
    """A comma-separated list of bundled materials, each once."""
    from ..materials import names

    items = [t.strip() for t in text.split(",")]
    if not items or any(not t for t in items):
        raise argparse.ArgumentTypeError(f"expected a comma-separated list of {', '.join(names())}, got {text!r}")
    for t in items:
        if t not in names():
            raise argparse.ArgumentTypeError(f"{t!r:.40} unknown; expected some of {', '.join(names())}")
    if len(set(items)) != len(items):
        raise argparse.ArgumentTypeError(f"a fabric named twice in {text!r:.80}")
    return items


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "demo",
        help="the paper end to end: plan, photograph (simulated), measure, mosaics, renders, report",
        description="For each fabric (default: denim, shot and velvet): plan the paper's capture, "
        "photograph it with the simulated rig, measure the photographs into a CDBRDF, compare with "
        "the ground truth, draw the Fig. 7 mosaics and render the sine sheet and a draped cloth "
        "with the plain BRDF and the CDBRDF; writes DIR/report.html.",
    )
    from ._args import output_folder

    p.add_argument("-o", "--output", required=True, metavar="DIR", type=output_folder(replaced=False),
                   help="output folder (replaced whole if it holds an earlier output of the demo and nothing "
                   "added to it since)")
    p.add_argument("--quick", action="store_true", help="coarse grid and small images: a few minutes")
    from ..demo import DEFAULT_FABRICS

    p.add_argument("--fabrics", type=_fabrics, default=None, metavar="LIST",
                   help=f"bundled fabrics to run, comma-separated (default: {','.join(DEFAULT_FABRICS)}; "
                   "all: denim,shot,velvet,towel)")
    from .plan import stand_options

    stand_options(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ..demo import CONFIGS, DEFAULT_FABRICS, DEMO_MAKER, DEMO_SIGNATURE, run_demo
    from ..outputs import check_output_folder
    from ._progress import ProgressBars
    from .plan import stands_from_args

    # refuse at once, before the estimate and the run
    check_output_folder(args.output, maker=DEMO_MAKER, signature=DEMO_SIGNATURE)
    cfg = CONFIGS["quick" if args.quick else "full"]
    stands = stands_from_args(args, cfg.grid.kappa)
    materials = args.fabrics or list(DEFAULT_FABRICS)
    est = cfg.expected_seconds(len(materials))
    if not args.quiet:
        g = cfg.grid
        say(
            f"cdbrdf demo ({cfg.name}): {len(materials)} material(s), "
            f"{cfg.n_photos:,} photographs each on a {g.phi_v.size * g.theta_v.size} x "
            f"{g.phi_l.size * g.theta_l.size} x {g.kappa.size} grid; expected time about "
            f"{max(1, round(est / 60))} min on a 2-core machine",
            err=True,
        )
    with ProgressBars(quiet=args.quiet, leave=True, mininterval=0.1) as bars:
        result = run_demo(args.output, quick=args.quick, materials=materials,
                          stands=stands, progress=bars.update)
    if not args.quiet:
        for m in result.materials:
            say(f"{m.name}: median error of measured samples "
                  f"{100 * m.error['median_rel_error_measured']:.2f} %, "
                  f"{sum(s['filled'] for s in m.per_stand)} samples filled", err=True)
        stages = ", ".join(f"{k.replace('_', ' ')} {v:.0f} s" for k, v in result.timings_s.items() if k != "total")
        say(f"done in {result.seconds / 60:.1f} min ({stages})", err=True)
    say(f"report: {result.report.resolve()}")
    return 0
