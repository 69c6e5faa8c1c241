"""Pictures of the cloth presets for the documentation (``docs/fabric-model.md``).

Run: ``.venv/bin/python scripts/fabric_figures.py docs/img [--convergence]``

Writes, for each bundled material:

- ``<name>_kappa.png``: luminance and rgb chromaticity against curvature for a
  few view/light directions, computed from the model (continuous kappa;
  :func:`cdbrdf.plot.plot_kappa_curves`);
- ``<name>_mosaic.png``: the paper's Fig. 7 mosaic of the bundled table
  (:func:`cdbrdf.plot.plot_mosaic`);
- ``<name>_weave.png``: the repeat seen from above at kappa = -0.22, 0 and
  +0.22 (which yarn is on top, and the height), showing gaps open and close
  (:func:`cdbrdf.plot.plot_weave`).

``--before DIR`` also draws ``<name>_mosaic_before.png`` from the tables
``DIR/<name>.h5`` (e.g. the bundled tables of an earlier commit, written out
with ``git show COMMIT:src/cdbrdf/data/denim.h5 > DIR/denim.h5``), at its
own automatic exposure, for a before/after comparison.

``--convergence`` also prints the integration-error study of the document
(:func:`cdbrdf.synth.convergence.convergence`; minutes).
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

import cdbrdf
from cdbrdf import materials
from cdbrdf.plot import plot_kappa_curves, plot_mosaic, plot_weave, save_figure
from cdbrdf.synth.convergence import convergence
from cdbrdf.synth.presets import model as preset_model


def main(argv: Sequence[str] | None = None) -> int:
    """Write the pictures into OUT_DIR; print each file written (and the study)."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("out_dir", help="folder for the PNG files (e.g. docs/img)")
    parser.add_argument("--convergence", action="store_true", help="also print the convergence study (slow)")
    parser.add_argument("--before", metavar="DIR", help="also draw <name>_mosaic_before.png from DIR/<name>.h5")
    args = parser.parse_args(argv)
    out = Path(args.out_dir)
    out.mkdir(parents=True, exist_ok=True)
    for name in materials.names():
        m = preset_model(name)
        figures = (
            ("kappa", plot_kappa_curves(m)),
            ("weave", plot_weave(m)),
            ("mosaic", plot_mosaic(materials.load(name), exposure="auto", dpi=110)),
        )
        for suffix, fig in figures:
            print(save_figure(fig, out / f"{name}_{suffix}.png", dpi=110))
        if args.before:
            old = cdbrdf.load(Path(args.before) / f"{name}.h5")
            fig = plot_mosaic(old, exposure="auto", dpi=110, title=f"{name}: before")
            print(save_figure(fig, out / f"{name}_mosaic_before.png", dpi=110))
    if args.convergence:
        for name in materials.names():
            print(f"{name}: points texels rms_rel max_rel")
            for r, t, rms, mx in convergence(name):
                print(f"  {r:5d} {t:4d} {rms:.4f} {mx:.4f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
