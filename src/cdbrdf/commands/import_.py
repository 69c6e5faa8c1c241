"""``cdbrdf import FILE -o OUT.h5``: a plain BRDF file (RGL, MERL, UTIA, Neural-BRDF) as a one-curvature CDBRDF."""

from __future__ import annotations

import argparse
import time
from typing import Any

from ._text import say

__all__ = ["register", "run", "add_import_options", "import_options", "summary"]

_GRIDS = "default | paper | native | regular:THETA_STEP,PHI_STEP[,THETA_MAX]"


def _grid(text: str) -> str:
    """A ``--grid`` spec, checked for its form (the source decides the rest)."""
    import re

    from ..importers import GRIDS

    s = text.strip()
    if s in GRIDS:
        return s
    m = re.fullmatch(r"regular:([^,]+),([^,]+)(?:,([^,]+))?", s)
    if m:
        try:
            steps = [float(x) for x in m.groups() if x is not None]
        except ValueError:
            steps = []
        if steps and all(0 < x <= 360 for x in steps[:2]) and (len(steps) < 3 or 0 <= steps[2] < 90):
            return s
    raise argparse.ArgumentTypeError(f"expected {_GRIDS} (degrees; steps > 0, THETA_MAX < 90), got {text!r}")


def add_import_options(p: argparse.ArgumentParser) -> None:
    """The options ``import`` and ``stack`` share."""
    from ..importers import FORMATS, SYMMETRY_CHOICES
    from ..importers.resample import CORRECTIONS, METHODS
    from ..importers.utia import ENCODINGS
    from ._args import finite_float

    p.add_argument("--format", choices=("auto", *FORMATS), default="auto",
                   help="the file format (default auto: from the content, then the suffix)")
    p.add_argument("--grid", type=_grid, default=None, metavar="GRID",
                   help=f"target grid: {_GRIDS}; default: 2-degree isotropic grid for isotropic data, "
                   "the paper's grid for anisotropic data")
    p.add_argument("--symmetry", choices=SYMMETRY_CHOICES, default="auto",
                   help="table layout (default auto: the data's; anisotropic expands isotropic data)")
    p.add_argument("--material", help="material name (default: the file's description, else its name)")
    p.add_argument("--spacing", type=finite_float(0.01, 30, unit="deg"), default=1.0, metavar="DEG",
                   help="largest distance between the quadrature points of a cell, degrees (default 1)")
    p.add_argument("--method", choices=METHODS, default="cell",
                   help="cell: each sample the mean of its cell (default); point: the data at the nodes "
                   "(for comparisons only: wrong for glossy materials)")
    p.add_argument("--correction", choices=CORRECTIONS, default="deblur",
                   help="after the cell means (default deblur: one step against the interpolation's blur)")
    p.add_argument("--encoding", choices=ENCODINGS, default="srgb",
                   help="UTIA files: how the values are stored (default srgb)")
    p.add_argument("--float64", action="store_true",
                   help="store the values as float64 (default float32; CDBRDF files copied onto their own "
                   "grid keep their dtype)")


def import_options(args: argparse.Namespace) -> dict[str, Any]:
    """Keyword arguments of :func:`cdbrdf.importers.import_brdf` / :func:`~cdbrdf.importers.stack` from ``args``."""
    import numpy as np

    kw: dict[str, Any] = dict(format=args.format, symmetry=args.symmetry, material=args.material,
                              spacing_deg=args.spacing, method=args.method, correction=args.correction,
                              dtype=np.float64 if args.float64 else None)
    if args.format in ("auto", "utia") and args.encoding != "srgb":
        kw["encoding"] = args.encoding
    return kw


def summary(table: Any) -> str:
    """One line on a table an import made: source, layout, measured share, expected error."""
    prov = table.attrs.get("provenance", {})
    g = table.grid
    layout = f"{g.symmetry} {'x'.join(str(n) for n in table.shape[:5])}"
    est = prov.get("expected_error")
    err = ""
    if est:
        err = (f"; expected error: BRDF {100 * est['brdf_relative_l1']:.2f} %, albedo "
               f"{100 * est['albedo_relative_error_mean']:.2f} % (peak/median {est['peak_to_median']:g})")
    return f"{table.attrs.get('material')!r}, {layout}, measured {100 * table.measured.mean():.1f} %{err}"


def register(sub: argparse._SubParsersAction) -> None:
    from ._args import brdf_file, finite_float, output_file

    p = sub.add_parser(
        "import",
        help="import a plain BRDF file (RGL .bsdf, MERL .binary, UTIA .bin, Neural-BRDF .h5/.json) as a "
        "one-curvature CDBRDF",
        description=(
            "Read a plain BRDF in the format of a public database and write it as a CDBRDF file "
            "with one curvature. Each table sample is the mean of the data over its cell (not a "
            "point sample, which is wrong for glossy materials); isotropic data go onto the "
            "isotropic layout (phi_l = 0, phi_v = the azimuth difference), which makes a fine grid "
            "affordable. The file records the source (name, SHA-256, format, description), the "
            "grid, the resampling and the error it expects. See docs/import.md."),
        epilog="example: cdbrdf import cc_ibiza_sunset_rgb.bsdf -o ibiza.h5",
    )
    p.add_argument("file", metavar="FILE", type=brdf_file(),
                   help="the BRDF file (a Neural-BRDF network: NAME.h5 or NAME.json of the pair)")
    p.add_argument("-o", "--output", required=True, type=output_file(".h5", ".nc"), help="the CDBRDF file to write")
    p.add_argument("--kappa", type=finite_float(-100, 100, unit="1/mm"), default=0.0, metavar="K",
                   help="the curvature of the stand the material was measured on, 1/mm (default 0: flat)")
    add_import_options(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ..importers import import_brdf
    from ._progress import ProgressBars

    quiet = getattr(args, "quiet", False)
    t0 = time.perf_counter()
    with ProgressBars(quiet=quiet, unit="eval") as bars:
        table = import_brdf(args.file, grid=args.grid or "default", kappa=args.kappa,
                            progress=bars.callback("resample"), **import_options(args))
    table.save(args.output)
    if not quiet:
        say(f"wrote {args.output}: {summary(table)}; {time.perf_counter() - t0:.1f} s")
    return 0
