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

``--before DIR`` compares the bundled tables with earlier ones,
``DIR/<name>.h5`` (e.g. those of an earlier commit, written out with
``git show COMMIT:src/cdbrdf/data/denim.h5 > DIR/denim.h5``), at the
curvature each preset is judged at (:data:`JUDGED_KAPPA`):

- ``<name>_bend_before.png``, ``<name>_bend_after.png``: the mosaic at
  kappa = 0 and at that curvature, each at its own automatic exposure;
- ``<name>_swatches.png``: the mean colour near the normal flat and bent,
  before and after, with the median Delta E*ab between them
  (:func:`cdbrdf.synth.metrics.bend_contrast`).

``--convergence`` also prints the integration-error study of the document
(:func:`cdbrdf.synth.convergence.convergence`; minutes).
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

import numpy as np

import cdbrdf
from cdbrdf import materials
from cdbrdf.plot import plot_kappa_curves, plot_mosaic, plot_weave, save_figure
from cdbrdf.synth.convergence import convergence
from cdbrdf.synth.metrics import bend_contrast
from cdbrdf.synth.pile import PileModel
from cdbrdf.synth.presets import model as preset_model

#: The curvature (mm^-1) at which each preset's bending effect is judged against the flat cloth.
JUDGED_KAPPA = {"denim": 0.22, "shot": 0.13}


def swatch_figure(name: str, before: cdbrdf.CDBRDF, after: cdbrdf.CDBRDF, kappa: float):
    """Flat and bent swatch colours near the normal, before and after, with their Delta E*ab."""
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 1, figsize=(3.6, 2.6), layout="constrained")
    for ax, label, table in zip(axes, ("before", "after"), (before, after)):
        c = bend_contrast(table, kappa)
        bent, flat = c.swatches_srgb8()
        ax.imshow(np.stack([flat, flat, bent, bent])[None], interpolation="nearest")
        ax.set_xticks([0.5, 2.5], ["kappa = 0", f"kappa = {kappa:+.2f}"])
        ax.set_yticks([])
        ax.set_title(f"{name} {label}: median Delta E*ab {c.median_delta_e:.1f}, dL* {c.lightness_change:+.1f}",
                     fontsize=8)
        ax.tick_params(labelsize=8)
    return fig


def main(argv: Sequence[str] | None = None) -> int:
    """Write the pictures into OUT_DIR; print each file written (and the study)."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("out_dir", help="folder for the PNG files (e.g. docs/img)")
    parser.add_argument("names", nargs="*", help="materials (default all)")
    parser.add_argument("--convergence", action="store_true", help="also print the convergence study (slow)")
    parser.add_argument("--before", metavar="DIR", help="also draw <name>_mosaic_before.png from DIR/<name>.h5")
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
        if args.before:
            k = JUDGED_KAPPA[name]
            tables = {"before": cdbrdf.load(Path(args.before) / f"{name}.h5"), "after": materials.load(name)}
            for label, table in tables.items():
                fig = plot_mosaic(table, kappa=[0.0, k], exposure="auto", diff=False, panel_size_in=2.2, dpi=80,
                                  title=f"{name}, {label}")
                print(save_figure(fig, out / f"{name}_bend_{label}.png", dpi=80))
            print(save_figure(swatch_figure(name, tables["before"], tables["after"], k), out / f"{name}_swatches.png",
                              dpi=110))
    if args.convergence:
        for name in [n for n in args.names or materials.names() if not isinstance(preset_model(n), PileModel)]:
            print(f"{name}: points texels rms_rel max_rel")
            for r, t, rms, mx in convergence(name):
                print(f"  {r:5d} {t:4d} {rms:.4f} {mx:.4f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
