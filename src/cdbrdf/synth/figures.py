"""Pictures of the cloth presets for the documentation.

Run ``python -m cdbrdf.synth.figures docs/img`` to (re)write:

- ``<name>_kappa.png``: luminance and rgb chromaticity against curvature for a
  few view/light directions, computed from the model (continuous kappa);
- ``<name>_mosaic.png``: the paper's Fig. 7 mosaic of the bundled table
  (:func:`cdbrdf.plot.plot_mosaic`);
- ``<name>_weave.png``: the repeat seen from above at kappa = -0.22, 0 and
  +0.22 (which yarn is on top, and the height), showing gaps open and close.

``--convergence`` prints the integration-error study of ``docs/fabric-model.md``.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .cloth import ClothModel
from .metrics import luminance
from .weave import BACKING, WARP, WEFT

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.figure import Figure

__all__ = ["DIRECTIONS", "plot_kappa_curves", "plot_weave", "convergence", "main"]

#: (label, theta_v, phi_v, theta_l, phi_l) in degrees.
DIRECTIONS: tuple[tuple[str, float, float, float, float], ...] = (
    ("v 0, l 30/180", 0.0, 0.0, 30.0, 180.0),
    ("v 45/0, l 45/180 (mirror, xz)", 45.0, 0.0, 45.0, 180.0),
    ("v 45/90, l 45/270 (mirror, yz)", 45.0, 90.0, 45.0, 270.0),
    ("v 60/0, l 30/90", 60.0, 0.0, 30.0, 90.0),
)


def plot_kappa_curves(model: ClothModel, *, kappa: Sequence[float] | None = None) -> "Figure":
    """Luminance and chromaticity against curvature for :data:`DIRECTIONS`."""
    import matplotlib
    from matplotlib.figure import Figure

    k = np.linspace(-0.3, 0.3, 13) if kappa is None else np.asarray(kappa, float)
    fig = Figure(figsize=(15, 3.6), layout="constrained")
    axes = fig.subplots(1, 4)
    colours = matplotlib.rcParams["axes.prop_cycle"].by_key()["color"]
    for (label, tv, pv, tl, pl), c in zip(DIRECTIONS, colours):
        f = model.evaluate(tv, pv, tl, pl, k)
        y = luminance(f)
        ch = f / f.sum(axis=-1, keepdims=True)
        axes[0].plot(k, y / y[k.size // 2] if k.size % 2 else y, "o-", color=c, ms=3, label=label)
        for j in range(3):
            axes[j + 1].plot(k, ch[:, j], "o-", color=c, ms=3)
    axes[0].set_ylabel("luminance / luminance at kappa = 0" if k.size % 2 else "luminance (1/sr)")
    for j, n in enumerate("rgb"):
        axes[j + 1].set_ylabel(f"chromaticity {n} = {n}/(r+g+b)")
    for ax in axes:
        ax.set_xlabel("kappa (1/mm)")
        ax.axvline(0.0, color="0.7", lw=0.8)
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=7)
    fig.suptitle(f"{model.params.name}: reflectance against curvature (model)")
    return fig


def plot_weave(model: ClothModel, *, kappa: Sequence[float] = (-0.22, 0.0, 0.22)) -> "Figure":
    """The repeat from above at a few curvatures: top yarn (warp/weft/hole) and height."""
    from matplotlib.figure import Figure

    p = model.params
    fig = Figure(figsize=(3.6 * len(kappa), 6.5), layout="constrained")
    axes = fig.subplots(2, len(kappa))
    for i, k in enumerate(kappa):
        hf = model.heightfield(k)
        lx, ly = hf.size_mm
        rgb = np.zeros(hf.shape + (3,))
        for kind, col in ((WARP, p.warp_rgb), (WEFT, p.weft_rgb), (BACKING, p.backing_rgb)):
            rgb[hf.kind == kind] = col
        shade = np.clip(0.35 + 0.65 * hf.normal[..., 2], 0, 1)[..., None]
        disp = np.clip(rgb * shade / max(rgb.max(), 1e-6), 0, 1) ** (1 / 2.2)
        # Texels are not evenly spaced along x: resample for display.
        edges = np.concatenate([[0.0], np.cumsum(hf.texel_width_mm)])
        xd = (np.arange(800) + 0.5) * lx / 800
        col = np.clip(np.searchsorted(edges, xd, side="right") - 1, 0, hf.shape[1] - 1)
        disp = disp[:, col]
        height = hf.height[:, col]
        ext = (0, lx, 0, ly)
        axes[0, i].imshow(disp, origin="lower", extent=ext, interpolation="nearest", aspect="equal")
        cov = hf.coverage()
        axes[0, i].set_title(
            f"kappa {k:+.2f}/mm: warp {cov['warp']:.0%}, weft {cov['weft']:.0%}, "
            f"holes {cov['backing']:.0%}", fontsize=8,
        )
        im = axes[1, i].imshow(height * 1000, origin="lower", extent=ext, cmap="viridis", aspect="equal")
        fig.colorbar(im, ax=axes[1, i], label="height (um)", shrink=0.8)
        for ax in axes[:, i]:
            ax.set_xlabel("x (mm, bending direction)")
            ax.set_ylabel("y (mm)")
    fig.suptitle(f"{p.name}: one weave repeat from above (stretch 1 + kappa t/2 along x)")
    return fig


def convergence(name: str, *, rays: Sequence[int] = (377, 987, 1597, 2584),
                texels: Sequence[int] = (64, 128, 192), ref_rays: int = 6765,
                ref_texels: int = 256) -> list[tuple[int, int, float, float]]:
    """Integration error against a fine reference on a sub-grid of the paper's grid.

    Returns rows ``(rays, texels, rms relative error, max relative error)`` of
    the luminance over view/light elevations 0..75 step 15, azimuths 0..330
    step 60, kappa in {0, 0.22}.
    """
    from .presets import model as preset_model

    T = np.arange(0.0, 76.0, 15.0)
    P = np.arange(0.0, 360.0, 60.0)
    TL, PL, TV, PV, K = np.meshgrid(T, P, T, P, [0.0, 0.22], indexing="ij")
    ref = luminance(preset_model(name, rays=ref_rays, texels=ref_texels).evaluate(TV, PV, TL, PL, K))
    rows = []
    scale = ref.mean()
    for tx in texels:
        for r in rays:
            y = luminance(preset_model(name, rays=r, texels=tx).evaluate(TV, PV, TL, PL, K))
            e = np.abs(y - ref) / np.maximum(ref, 0.1 * scale)
            rows.append((r, tx, float(np.sqrt(np.mean(e**2))), float(e.max())))
    return rows


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m cdbrdf.synth.figures OUT_DIR [--convergence]``."""
    parser = argparse.ArgumentParser(prog="python -m cdbrdf.synth.figures", description=__doc__.split("\n")[0])
    parser.add_argument("out_dir", help="folder for the PNG files (e.g. docs/img)")
    parser.add_argument("--convergence", action="store_true", help="also print the convergence study (slow)")
    args = parser.parse_args(argv)
    out = Path(args.out_dir)
    out.mkdir(parents=True, exist_ok=True)
    from .. import materials
    from .presets import model as preset_model

    for name in materials.names():
        m = preset_model(name)
        for suffix, fig in (("kappa", plot_kappa_curves(m)), ("weave", plot_weave(m))):
            fig.savefig(out / f"{name}_{suffix}.png", dpi=110)
            print(out / f"{name}_{suffix}.png")
        try:
            from ..plot import plot_mosaic
        except ImportError:  # pragma: no cover - plot module absent
            continue
        fig = plot_mosaic(materials.load(name), exposure="auto", dpi=110)
        fig.savefig(out / f"{name}_mosaic.png")
        print(out / f"{name}_mosaic.png")
    if args.convergence:
        for name in materials.names():
            print(f"{name}: rays texels rms_rel max_rel")
            for r, t, rms, mx in convergence(name):
                print(f"  {r:5d} {t:4d} {rms:.4f} {mx:.4f}")
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
