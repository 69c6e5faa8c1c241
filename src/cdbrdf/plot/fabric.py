"""Figures of the fabric model (:mod:`cdbrdf.synth`) for the documentation.

- :func:`plot_kappa_curves`: luminance and rgb chromaticity against curvature
  for a few view/light directions (:data:`DIRECTIONS`), computed from the
  model (continuous kappa);
- :func:`plot_weave`: the repeat seen from above at a few curvatures (which
  yarn is on top, and the height), showing gaps open and close.

``scripts/fabric_figures.py`` writes them, with the bundled tables' mosaics,
into ``docs/img``.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from ..colour import luminance, srgb_encode

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.figure import Figure

    from ..synth.cloth import ClothModel

__all__ = ["DIRECTIONS", "plot_kappa_curves", "plot_weave"]

#: (label, theta_v, phi_v, theta_l, phi_l) in degrees.
DIRECTIONS: tuple[tuple[str, float, float, float, float], ...] = (
    ("v 0, l 30/180", 0.0, 0.0, 30.0, 180.0),
    ("v 45/0, l 45/180 (mirror, xz)", 45.0, 0.0, 45.0, 180.0),
    ("v 45/90, l 45/270 (mirror, yz)", 45.0, 90.0, 45.0, 270.0),
    ("v 60/0, l 30/90", 60.0, 0.0, 30.0, 90.0),
)


def plot_kappa_curves(model: ClothModel, *, kappa: Sequence[float] | None = None) -> Figure:
    """Luminance and chromaticity against curvature for :data:`DIRECTIONS`.

    Parameters
    ----------
    model
        The fabric model (e.g. :func:`cdbrdf.synth.presets.model`).
    kappa
        Curvatures, mm^-1 (default 13 from -0.3 to 0.3). With an odd count the
        luminance is shown relative to the middle one (kappa = 0 by default).

    Returns
    -------
    matplotlib.figure.Figure
        Four panels: luminance, then the r, g, b chromaticities.
    """
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


def plot_weave(model: ClothModel, *, kappa: Sequence[float] = (-0.22, 0.0, 0.22)) -> Figure:
    """The repeat from above at a few curvatures: top yarn (warp/weft/hole) and height.

    Parameters
    ----------
    model
        The fabric model.
    kappa
        Curvatures, mm^-1, one column each.

    Returns
    -------
    matplotlib.figure.Figure
        Top row: the yarn on top in its colour, shaded by the normal and
        sRGB-encoded; bottom row: the height (um).
    """
    from matplotlib.figure import Figure

    from ..synth.weave import BACKING, WARP, WEFT

    p = model.params
    fig = Figure(figsize=(3.6 * len(kappa), 6.5), layout="constrained")
    axes = fig.subplots(2, len(kappa), squeeze=False)
    for i, k in enumerate(kappa):
        hf = model.heightfield(k)
        lx, ly = hf.size_mm
        rgb = np.zeros(hf.shape + (3,))
        for kind, yarn_rgb in ((WARP, p.warp_rgb), (WEFT, p.weft_rgb), (BACKING, p.backing_rgb)):
            rgb[hf.kind == kind] = yarn_rgb
        shade = np.clip(0.35 + 0.65 * hf.normal[..., 2], 0, 1)[..., None]
        disp = srgb_encode(rgb * shade / max(rgb.max(), 1e-6))
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
