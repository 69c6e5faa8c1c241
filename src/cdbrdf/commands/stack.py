"""``cdbrdf stack --kappa K1 FILE1 --kappa K2 FILE2 ... -o OUT.h5``: a CDBRDF from per-stand plain BRDFs."""

from __future__ import annotations

import argparse
import time

from ._text import say

__all__ = ["register", "run"]


def _kappa(text: str) -> float:
    from ._args import finite_float

    return finite_float(-100, 100, unit="1/mm")(text)


def _kappa_or_file(text: str) -> str:
    """One token of ``--kappa K FILE``: a curvature in range, or an existing file (the pairs are checked in run)."""
    from ._args import existing_file

    try:
        float(text)
    except ValueError:
        return existing_file()(text)
    _kappa(text)
    return text


def register(sub: argparse._SubParsersAction) -> None:
    from ._args import output_file, partner_files, with_role
    from .import_ import add_import_options

    p = sub.add_parser(
        "stack",
        help="build a CDBRDF from plain BRDF files measured on stands of known curvature",
        description=(
            "Stack plain BRDFs, one per measurement stand, along the curvature axis: each "
            "--kappa K FILE gives a stand's curvature (1/mm, > 0 convex) and its file (RGL, MERL, "
            "UTIA, Neural-BRDF or a one-curvature CDBRDF file). Every file is resampled onto one grid (CDBRDF "
            "files on that grid are copied exactly, with their masks); the files must agree on "
            "quantity, units, colour space and material."),
        epilog="example: cdbrdf stack --kappa 0 flat.h5 --kappa 0.13 stand1.h5 --kappa 0.22 stand2.h5 -o denim.h5",
    )
    kind = with_role(_kappa_or_file, "input")
    setattr(kind, "pulls_in", partner_files)  # noqa: B010 - the other half of a Neural-BRDF pair is an input too
    p.add_argument("--kappa", dest="entries", nargs=2, action="append", required=True, metavar=("K", "FILE"),
                   type=kind,
                   help="a stand's curvature in 1/mm and its plain BRDF file (repeat for every stand)")
    p.add_argument("-o", "--output", required=True, type=output_file(".h5", ".nc"), help="the CDBRDF file to write")
    add_import_options(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ..importers import stack
    from ._args import existing_file
    from ._progress import ProgressBars
    from .import_ import import_options, summary

    entries = []
    for k, f in args.entries:
        try:
            entries.append((_kappa(k), existing_file()(f)))
        except argparse.ArgumentTypeError as exc:
            raise ValueError(f"--kappa {k} {f}: {exc}") from None
    quiet = getattr(args, "quiet", False)
    t0 = time.perf_counter()
    with ProgressBars(quiet=quiet, unit="file") as bars:
        table = stack(entries, grid=args.grid, progress=bars.callback("stack"), **import_options(args))
    table.save(args.output)
    if not quiet:
        ks = ", ".join(f"{k:g}" for k in table.kappa)
        say(f"wrote {args.output}: kappa {ks} 1/mm; {summary(table)}; {time.perf_counter() - t0:.1f} s")
    return 0
