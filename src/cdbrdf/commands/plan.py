"""``cdbrdf plan -o DIR``: a capture plan (capture.csv + stands.json) and its hidden regions."""

from __future__ import annotations

import argparse
from collections.abc import Iterable
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from ..measure.stands import Stand

from ._text import say

__all__ = ["register", "run", "check_grid_rows", "stand_options", "stands_from_args"]


def stand_options(p: argparse.ArgumentParser) -> None:
    """``--face-width`` and ``--wall-height``: the stands' geometry (shared with ``cdbrdf demo``)."""
    from ..measure.stands import DEFAULT_FACE_WIDTH_MM, DEFAULT_WALL_HEIGHT_MM
    from ._args import finite_float

    p.add_argument("--face-width", type=finite_float(0, 1000, lo_open=True, unit="mm"), default=None,
                   metavar="MM", help=f"fabric face width (arc) of the stands, mm ({DEFAULT_FACE_WIDTH_MM:g})")
    p.add_argument("--wall-height", type=finite_float(0, 1000, unit="mm"), default=None, metavar="MM",
                   help="concave stands: wall height above the face's edges, mm "
                   f"({DEFAULT_WALL_HEIGHT_MM:g}; 0: a trough cut into a flat block, which hides far fewer "
                   "directions)")


def stands_from_args(args: argparse.Namespace, kappa: Iterable[float]) -> list[Stand]:
    """One :class:`~cdbrdf.measure.stands.Stand` per curvature, from :func:`stand_options`."""
    from ..measure.stands import DEFAULT_FACE_WIDTH_MM, DEFAULT_WALL_HEIGHT_MM, Stand

    w = DEFAULT_FACE_WIDTH_MM if args.face_width is None else args.face_width
    h = DEFAULT_WALL_HEIGHT_MM if args.wall_height is None else args.wall_height
    return [Stand(kappa=float(k), face_width_mm=w, wall_height_mm=h) for k in kappa]


def register(sub: argparse._SubParsersAction) -> None:
    from ._args import finite_float, float_list, int_range, output_folder

    p = sub.add_parser(
        "plan",
        help="write a capture plan (capture.csv, stands.json) marking directions the stands hide",
        description="Write a capture.csv template and a stands.json for a grid and a set of "
        "stands (the paper's by default): one row per photograph, each marked measurable or "
        "hidden by its stand (camera or light blocked by a concave trough or its walls), "
        "plus white-reference rows, a summary and a picture of the hidden regions "
        "(plan.png, Fig. 7 layout). See docs/capture.md.",
    )
    p.add_argument("-o", "--output", required=True, type=output_folder(replaced=False),
                   help="capture folder to create")
    p.add_argument("--kappa", type=float_list(-100, 100, unique=True, unit="1/mm"), default=None,
                   help="stand curvatures in 1/mm, comma-separated (default -0.22,-0.13,0,0.13,0.22)")
    p.add_argument("--theta-step", type=finite_float(0, 90, lo_open=True, unit="deg"), default=15.0,
                   help="elevation step, degrees (15)")
    p.add_argument("--theta-max", type=finite_float(0, 90, hi_open=True, unit="deg"), default=75.0,
                   help="largest elevation, degrees, below 90 (75)")
    p.add_argument("--phi-step", type=finite_float(0, 360, lo_open=True, unit="deg"), default=30.0,
                   help="azimuth step, degrees, dividing 360 (30)")
    stand_options(p)
    p.add_argument("--pixel-mm", type=finite_float(0, 1000, unit="mm"), default=0.0,
                   help="size of a camera pixel at the stand, mm: hidden marks then cover the "
                   "whole patch, not only its centre (default 0: centre only)")
    p.add_argument("--patch", type=int_range(1, 999), default=7, help="patch size N for --pixel-mm, 1 to 999 (7)")
    p.add_argument("--format", default="png", choices=("png", "tif", "exr"), help="image format (png)")
    p.add_argument("--no-white", action="store_true", help="no white-reference rows")
    p.add_argument("--no-picture", action="store_true", help="do not write plan.png")
    p.add_argument("--force", action="store_true", help="overwrite an existing capture.csv")
    p.set_defaults(func=run)


def check_grid_rows(grid, *, white: bool = True, brackets: int = 1) -> None:  # noqa: ANN001
    """Refuse a grid whose capture plan would exceed the ``capture_rows`` limit.

    Parameters
    ----------
    grid
        A :class:`cdbrdf.Grid`.
    white
        Whether white-reference rows (one per light direction) are added.
    brackets
        Photographs per sample (exposure brackets).

    Raises
    ------
    cdbrdf.errors.LimitError
        Before anything is allocated or written.
    """
    from ..limits import check

    k, pl, tl, pv, tv = grid.shape
    rows = (k * pl * tl * pv * tv + (pl * tl if white else 0)) * brackets
    check("capture_rows", rows,
          what=f"a grid of {k} x {pl * tl} x {pv * tv} (kappa x light x view) samples")


def run(args: argparse.Namespace) -> int:
    from ..fsutil import check_output_file
    from ..measure.capture import CAPTURE_FILE, STAND_FILE
    from ..measure.plan import write_plan
    from ..measure.stands import hidden_mask
    from ..table import PAPER_KAPPA, Grid

    out = Path(args.output)
    if (out / CAPTURE_FILE).exists() and not args.force:
        raise FileExistsError(f"{out / CAPTURE_FILE}: already exists (use --force to overwrite)")
    if out.is_dir():  # a device or FIFO in place of one of the plan's files: refused before any is written
        for name in (CAPTURE_FILE, STAND_FILE, "plan.png"):
            check_output_file(out / name)
    kappa = PAPER_KAPPA if args.kappa is None else np.array(sorted(args.kappa))
    grid = Grid.regular(theta_step_deg=args.theta_step, phi_step_deg=args.phi_step,
                        theta_max_deg=args.theta_max, kappa=kappa)
    check_grid_rows(grid, white=not args.no_white)
    stands = stands_from_args(args, grid.kappa)
    rows = write_plan(out, grid, stands, extension=args.format, white=not args.no_white,
                      pixel_mm=args.pixel_mm, patch_px=args.patch)
    hid = hidden_mask(grid, stands, pixel_mm=args.pixel_mm, patch_px=args.patch)
    if not args.no_picture:
        from ..plot import plot_hidden, save_figure

        save_figure(plot_hidden(grid, hid), out / "plan.png", dpi=120)
    if not args.quiet:
        n_s = sum(1 for r in rows if r["kind"] == "sample")
        n_w = len(rows) - n_s
        say(f"{out / CAPTURE_FILE}: {len(rows)} photographs ({n_s} samples, {n_w} white references)")
        for i, k in enumerate(grid.kappa):
            h = hid[i]
            say(f"  kappa {k:+g} 1/mm: {int((h > 0).sum())} of {h.size} hidden "
                  f"(view {int((h & 1).astype(bool).sum())}, light {int((h & 2).astype(bool).sum())})")
        walled = [i for i, st in enumerate(stands) if st.kappa < 0 and st.wall_height_mm > 0 and hid[i].any()]
        if walled:  # the walls hide most of it (docs/capture.md, "Filling": the fill's error grows with it)
            from dataclasses import replace

            bare = [replace(st, wall_height_mm=0.0) for st in stands]
            hid0 = hidden_mask(grid, bare, pixel_mm=args.pixel_mm, patch_px=args.patch)
            counts = ", ".join(f"{int((hid0[i] > 0).sum())} at {grid.kappa[i]:+g}" for i in walled)
            say(f"  without walls (--wall-height 0) the concave stands would hide {counts}")
    return 0
