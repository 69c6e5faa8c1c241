"""``cdbrdf mosaic FILE -o OUT.png``: the paper's Fig. 7 mosaic of a table."""

from __future__ import annotations

import argparse
from pathlib import Path

from ..errors import OptionError
from ._text import say

__all__ = ["register", "run", "FORMATS"]

#: Output formats, chosen by the output file's suffix.
FORMATS: dict[str, str] = {".png": "png", ".pdf": "pdf", ".svg": "svg"}


def _exposure_type():  # noqa: ANN202 - an argparse type
    from ..plot import EXPOSURE_MODES  # light: numpy only, matplotlib is imported lazily
    from ._args import finite_float, keyword

    return keyword(EXPOSURE_MODES, finite_float(0, lo_open=True))


def register(sub: argparse._SubParsersAction) -> None:
    from ._args import finite_float, input_path, name_or_index, output_path

    p = sub.add_parser(
        "mosaic",
        help="draw the Fig. 7 mosaic (one image per curvature + differences) of a file",
        description=(
            "Draw the paper's Fig. 7 mosaic of a CDBRDF file: for each curvature one "
            "image (rows: light direction, columns: view direction, grouped by azimuth, "
            "elevation inside a group), all with one exposure, filled (unmeasured) "
            "samples hatched, and a second row of luminance differences against "
            "kappa = 0. The output format follows the suffix of OUT: "
            + ", ".join(FORMATS) + "."
        ),
        epilog="example: cdbrdf mosaic denim.h5 -o denim.png --kappa 0 0.13 0.22",
    )
    p.add_argument("file", metavar="FILE", type=input_path(), help="a CDBRDF file (.h5)")
    p.add_argument("-o", "--output", metavar="OUT", required=True, type=output_path(),
                   help="the image to write (.png, .pdf or .svg); replaced if it exists")
    p.add_argument("--kappa", metavar="K", type=finite_float(-100, 100, unit="1/mm"), nargs="+", action="extend",
                   help="curvatures to show, mm^-1, as sampled in the file "
                   "(default: all; e.g. --kappa -0.13 0 0.13)")
    p.add_argument("--exposure", metavar="X", type=_exposure_type(), default="auto",
                   help="linear exposure factor before sRGB encoding, or 'auto' (default: "
                   "the 99.5th percentile of the luminance over all panels maps to white) "
                   "or 'white' (x pi: a white Lambertian reflector maps to white; "
                   "tables in sr^-1 only)")
    p.add_argument("--no-diff", dest="diff", action="store_false",
                   help="leave out the row of differences against kappa = 0")
    p.add_argument("--no-marks", dest="mark_filled", action="store_false",
                   help="do not hatch filled (unmeasured) samples")
    p.add_argument("--channel", metavar="C", type=name_or_index(),
                   help="show one channel (index or name, e.g. G) in grey instead of RGB")
    p.add_argument("--title", help="figure title (default: material and quantity)")
    p.add_argument("--dpi", type=finite_float(10, 1200), default=150.0,
                   help="resolution of a PNG in dots per inch, 10 to 1200 (default: 150)")
    p.set_defaults(func=run)


def _output(path_text: str) -> tuple[Path, str]:
    out = Path(path_text)
    fmt = FORMATS.get(out.suffix.lower())
    if fmt is None:
        got = f"{out.suffix!r}" if out.suffix else "no suffix"
        raise OptionError(
            f"{out}: cannot tell the output format from {got}; use one of "
            + ", ".join(FORMATS)
        )
    from ..fsutil import check_output_file

    check_output_file(out)  # a folder, a missing folder, a device or FIFO: before any work
    return out, fmt


def run(args: argparse.Namespace) -> int:
    from ..io import atomic_path
    from ..plot import plot_mosaic
    from ..sources import open_source

    out, fmt = _output(args.output)
    table = open_source(args.file).flat
    fig = plot_mosaic(
        table,
        kappa=args.kappa,
        exposure=args.exposure,
        diff=args.diff,
        channel=args.channel,
        mark_filled=args.mark_filled,
        title=args.title,
        dpi=args.dpi,
    )
    with atomic_path(out) as tmp:
        fig.savefig(tmp, format=fmt, dpi=args.dpi)  # atomic_path gives the file its mode
    if not args.quiet:
        n = len(args.kappa) if args.kappa else table.kappa.size
        say(f"wrote {out} ({n} curvature{'s' * (n != 1)}, {fmt.upper()})")
    return 0
