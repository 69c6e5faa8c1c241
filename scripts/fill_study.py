"""How well each fill method can do at all: the fill fed the ground truth itself.

Run: ``.venv/bin/python scripts/fill_study.py [TABLE ...] [--stand WIDTH_MM:WALL_MM ...]``

For each table (a bundled material name or a CDBRDF file; default both
bundled materials) and each concave stand design, the samples the stands
hide on the paper's capture (:func:`cdbrdf.measure.stands.hidden_mask`, with
the patch test of the simulated rig's photographs: ``--pixel-mm``, 7 x 7
pixels) are removed from the table and filled again from the table's own
values at the samples the stands do not hide, by every method of
:data:`cdbrdf.measure.fill.FILL_METHODS`. The table is the truth, so what
remains is the error of the method alone, without the measurement's noise
and bias: a floor that no measurement with those stands can beat with that
method. It prints one Markdown row per design, stand and method: hidden
samples, median and 95th percentile of the relative luminance error of the
filled samples (the statistic of ``cdbrdf demo``'s report).

``docs/capture.md`` ("Filling") quotes its output for the bundled fabrics,
the paper's stands (face 6 mm, walls 1 mm) and stands without walls.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from cdbrdf import load, materials
from cdbrdf.colour import luminance
from cdbrdf.measure.fill import FILL_METHODS, fill
from cdbrdf.measure.stands import DEFAULT_FACE_WIDTH_MM, DEFAULT_WALL_HEIGHT_MM, Stand, hidden_mask

#: Pixel size of the simulated rig's photographs at the stand, mm (2 mm field over 64 pixels).
RIG_PIXEL_MM = 2.0 / 64


def _design(text: str) -> tuple[float, float]:
    try:
        w, h = (float(x) for x in text.split(":"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected WIDTH_MM:WALL_MM, e.g. 6:1, got {text!r}") from None
    return w, h


def study(table, *, face_width_mm: float, wall_height_mm: float, pixel_mm: float) -> list[dict]:
    """Rows ``{kappa, hidden, method, median, p95}`` (errors as fractions) for one stand design."""
    g = table.grid
    stands = [Stand(float(k), face_width_mm=face_width_mm, wall_height_mm=wall_height_mm) for k in g.kappa]
    valid = hidden_mask(g, stands, pixel_mm=pixel_mm) == 0
    truth = table.values.astype(np.float64)
    y = luminance(truth) if truth.shape[-1] == 3 else truth.mean(axis=-1)
    rows = []
    for method in FILL_METHODS:
        filled = fill(np.where(valid[..., None], truth, np.nan), valid, g, method=method).values
        yf = luminance(filled) if filled.shape[-1] == 3 else filled.mean(axis=-1)
        rel = np.abs(yf - y) / np.maximum(np.abs(y), 1e-6)
        for k, kappa in enumerate(g.kappa):
            sel = ~valid[k]
            if sel.any():
                rows.append({"kappa": float(kappa), "hidden": int(sel.sum()), "method": method,
                             "median": float(np.median(rel[k][sel])),
                             "p95": float(np.percentile(rel[k][sel], 95))})
    return rows


def main(argv: Sequence[str] | None = None) -> int:
    """Print the study as a Markdown table."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("tables", nargs="*", help="material names or CDBRDF files (default: the bundled materials)")
    parser.add_argument("--stand", type=_design, action="append", metavar="WIDTH_MM:WALL_MM",
                        help=f"a concave stand design (repeatable; default {DEFAULT_FACE_WIDTH_MM:g}:"
                             f"{DEFAULT_WALL_HEIGHT_MM:g}, the paper's, and {DEFAULT_FACE_WIDTH_MM:g}:0)")
    parser.add_argument("--pixel-mm", type=float, default=RIG_PIXEL_MM,
                        help="pixel size at the stand for the patch test (default: the simulated rig's)")
    args = parser.parse_args(argv)
    designs = args.stand or [(DEFAULT_FACE_WIDTH_MM, DEFAULT_WALL_HEIGHT_MM), (DEFAULT_FACE_WIDTH_MM, 0.0)]
    print("| table | stand (face / walls) | kappa | hidden | method | median | p95 |")
    print("|---|---|---|---|---|---|---|")
    for name in args.tables or materials.names():
        table = materials.load(name) if name in materials.names() else load(name)
        label = Path(name).stem
        for w, h in designs:
            for r in study(table, face_width_mm=w, wall_height_mm=h, pixel_mm=args.pixel_mm):
                print(f"| {label} | {w:g} / {h:g} mm | {r['kappa']:+.2f} | {r['hidden']} | {r['method']} "
                      f"| {100 * r['median']:.2f} % | {100 * r['p95']:.1f} % |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
