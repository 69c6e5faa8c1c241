"""Regenerate the bundled materials (``src/cdbrdf/data/<name>.h5``) from their presets.

Run: ``.venv/bin/python scripts/regenerate_materials.py [NAME ...] [--out DIR]``

Tabulates each preset of :mod:`cdbrdf.synth.presets` on the paper's grid
with :func:`cdbrdf.materials.regenerate` (about 40 s for all four on 2 cores) and
writes it into the package's ``data`` folder, or into ``--out``. The values
come out identical on the same platform; ``tests/test_materials.py`` checks
a recomputed sub-grid against the bundled files.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

from cdbrdf import materials
from cdbrdf.commands._progress import ProgressBars


def main(argv: Sequence[str] | None = None) -> int:
    """Regenerate the chosen materials; print each file written."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("names", nargs="*", help=f"materials (default all: {', '.join(materials.names())})")
    parser.add_argument("--out", help="write into this folder instead of the package's data folder")
    args = parser.parse_args(argv)
    unknown = [n for n in args.names if n not in materials.names()]
    if unknown:
        parser.error(f"unknown material {unknown[0]!r}; valid names: {', '.join(materials.names())}")
    with ProgressBars(unit="kappa", leave=True) as bars:
        for path in materials.regenerate(args.names or None, out_dir=args.out, progress=bars.update):
            print(path)
    return 0


if __name__ == "__main__":
    sys.exit(main())
