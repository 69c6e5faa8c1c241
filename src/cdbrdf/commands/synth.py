"""``cdbrdf synth denim|shot [--set name=value ...] [--grid ...] -o FILE``."""

from __future__ import annotations

import argparse
import time

import numpy as np

__all__ = ["register", "run", "parse_grid", "parse_sets"]

_GRIDS = "paper | regular:THETA_STEP,PHI_STEP"


def register(sub: argparse._SubParsersAction) -> None:
    from ..synth.presets import names

    p = sub.add_parser(
        "synth",
        help="tabulate a synthetic woven-cloth material (denim, shot) into a CDBRDF file",
        description="Tabulate the woven-cloth model of a preset onto a grid and write "
        "the CDBRDF file. Parameters of the preset can be overridden with --set "
        "(see docs/fabric-model.md for their meaning).",
    )
    p.add_argument("preset", choices=names(), help="the material preset")
    p.add_argument(
        "--set",
        dest="sets",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="override a parameter, e.g. --set thickness_mm=0.8 --set warp_rgb=0.1,0.1,0.4 "
        "(repeatable)",
    )
    p.add_argument("--grid", default="paper", help=f"sample grid: {_GRIDS} (default paper)")
    p.add_argument(
        "--kappa",
        help="curvatures in 1/mm, comma-separated (default the paper's -0.22,-0.13,0,0.13,0.22)",
    )
    p.add_argument("-o", "--output", required=True, help="output file (.h5)")
    p.set_defaults(func=run)


def parse_sets(items: list[str]) -> dict:
    """``["name=value", ...]`` -> typed overrides (validated names)."""
    from ..synth.cloth import ClothParams

    out = {}
    for item in items:
        if "=" not in item:
            raise ValueError(f"--set: expected NAME=VALUE, got {item!r}")
        name, value = item.split("=", 1)
        name = name.strip()
        out[name] = ClothParams.parse_value(name, value)
    return out


def parse_grid(spec: str, kappa: str | None = None):
    """A :class:`cdbrdf.Grid` from ``--grid`` and ``--kappa``."""
    from ..table import PAPER_KAPPA, Grid

    if kappa is None:
        k = PAPER_KAPPA
    else:
        try:
            k = np.array([float(x) for x in kappa.split(",") if x.strip()])
        except ValueError:
            raise ValueError(f"--kappa: expected numbers separated by commas, got {kappa!r}") from None
    s = spec.strip()
    if s == "paper":
        return Grid.paper(kappa=k)
    if s.startswith("regular:"):
        try:
            t, p = (float(x) for x in s.split(":", 1)[1].split(","))
        except ValueError:
            raise ValueError(f"--grid: expected regular:THETA_STEP,PHI_STEP, got {spec!r}") from None
        return Grid.regular(theta_step_deg=t, phi_step_deg=p, kappa=k)
    raise ValueError(f"--grid: unknown grid {spec!r}; valid: {_GRIDS}")


def run(args: argparse.Namespace) -> int:
    from tqdm import tqdm

    from ..synth import presets

    overrides = parse_sets(args.sets)
    model = presets.model(args.preset, **overrides)
    grid = parse_grid(args.grid, args.kappa)
    quiet = getattr(args, "quiet", False)
    bar = tqdm(total=grid.kappa.size, desc=f"synth {args.preset}", unit="kappa", disable=quiet)
    t0 = time.perf_counter()

    def progress(done: int, total: int) -> None:
        bar.update(done - bar.n)

    try:
        table = model.tabulate(grid, progress=progress)
    finally:
        bar.close()
    table.save(args.output)
    if not quiet:
        print(f"wrote {args.output}: {args.preset}, shape {table.shape}, "
              f"{time.perf_counter() - t0:.1f} s")
    return 0
