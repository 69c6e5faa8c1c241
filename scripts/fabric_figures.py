"""Pictures of the cloth presets for the documentation (``docs/fabric-model.md``).

Run: ``.venv/bin/python scripts/fabric_figures.py docs/img [NAME ...] [--convergence]``

Writes, for each bundled material:

- ``<name>_kappa.png``: luminance and rgb chromaticity against curvature for a
  few view/light directions, computed from the model (continuous kappa;
  :func:`cdbrdf.plot.plot_kappa_curves`);
- ``<name>_mosaic.png``: the paper's Fig. 7 mosaic of the bundled table
  (:func:`cdbrdf.plot.plot_mosaic`);
- ``<name>_weave.png``: the repeat seen from above at kappa = -0.22, 0 and
  +0.22 (which yarn is on top, and the height), showing gaps open and close
  (:func:`cdbrdf.plot.plot_weave`; woven presets only: the pile presets'
  curves span the curvatures their pile allows).

``--convergence`` also prints the integration-error study of the document
(:func:`cdbrdf.synth.convergence.convergence`; minutes).
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from cdbrdf import materials
from cdbrdf.plot import plot_kappa_curves, plot_mosaic, plot_weave, save_figure
from cdbrdf.synth.convergence import convergence
from cdbrdf.synth.pile import PileModel
from cdbrdf.synth.presets import model as preset_model


def main(argv: Sequence[str] | None = None) -> int:
    """Write the pictures into OUT_DIR; print each file written (and the study)."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("out_dir", help="folder for the PNG files (e.g. docs/img)")
    parser.add_argument("names", nargs="*", help="materials (default all)")
    parser.add_argument("--convergence", action="store_true", help="also print the convergence study (slow)")
    args = parser.parse_args(argv)
    out = Path(args.out_dir)
    out.mkdir(parents=True, exist_ok=True)
    for name in args.names or materials.names():
        m = preset_model(name)
        if isinstance(m, PileModel):
            figures = (("kappa", plot_kappa_curves(m, kappa=np.linspace(-0.24, 0.24, 13))),)  # type: ignore[arg-type]
        else:
            figures = (("kappa", plot_kappa_curves(m)), ("weave", plot_weave(m)))
        figures += (("mosaic", plot_mosaic(materials.load(name), exposure="auto", dpi=110)),)
        for suffix, fig in figures:
            print(save_figure(fig, out / f"{name}_{suffix}.png", dpi=110))
    if args.convergence:
        for name in [n for n in args.names or materials.names() if not isinstance(preset_model(n), PileModel)]:
            print(f"{name}: rays texels rms_rel max_rel")
            for r, t, rms, mx in convergence(name):
                print(f"  {r:5d} {t:4d} {rms:.4f} {mx:.4f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
