"""Hemispheres of a table: polar plots of the view directions for a fixed light."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from ..colour import resolve_exposure, srgb_encode
from ..errors import OptionError
from ..table import CDBRDF
from ._common import check_angle, continuous_kappa, kappa_label, luminance, new_figure, unit_label

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.figure import Figure

__all__ = ["plot_hemisphere"]

_SEQ_CMAP = "inferno"


def plot_hemisphere(
    table: CDBRDF,
    *,
    theta_l_deg: float = 45.0,
    phi_l_deg: float = 0.0,
    kappa: float | ArrayLike = 0.0,
    channel: int | str | None = None,
    colour: str = "luminance",
    exposure: float | str | None = None,
    n_theta: int = 76,
    n_phi: int = 181,
    panel_size_in: float = 3.0,
    dpi: float = 150.0,
    fig: Figure | None = None,
) -> Figure:
    """Polar plots of the view hemisphere for a fixed light, one per curvature.

    As in BRDF Explorer: the radius is the view elevation (0 at the centre, up
    to the table's last elevation), the angle the view azimuth (0 deg = +x, the
    bending direction, counter-clockwise towards +y). Values are the table's
    lookup. The light direction is marked with a circle, its mirror direction
    with a cross.

    Parameters
    ----------
    table
        The table.
    theta_l_deg, phi_l_deg
        Light direction, degrees.
    kappa
        One or several curvatures, mm^-1 (interpolated, clamped).
    channel
        For ``colour="luminance"``: None (luminance), an index or a name.
    colour
        ``"luminance"``: a colour map with a shared colour bar in the table's
        unit; ``"rgb"``: the sRGB-encoded colour with a shared exposure
        (automatic as in :func:`plot_mosaic`).
    exposure
        For ``colour="rgb"``: the linear factor before encoding, or a mode of
        :data:`EXPOSURE_MODES` (as in :func:`plot_mosaic`).
    n_theta, n_phi
        Resolution of the evaluation grid.
    panel_size_in, dpi, fig
        Size of a new figure, or an empty figure to draw into.

    Returns
    -------
    matplotlib.figure.Figure
        One polar panel per curvature.
    """
    from matplotlib.colors import Normalize
    from matplotlib.patheffects import withStroke

    if colour not in ("luminance", "rgb"):
        raise OptionError(f"colour: {colour!r} is not one of luminance, rgb")
    if colour == "rgb" and table.n_channels != 3:
        raise OptionError(f"colour: 'rgb' needs 3 channels, the table has {table.n_channels}")
    tl = check_angle("theta_l_deg", theta_l_deg, 0.0, 90.0)
    pl = check_angle("phi_l_deg", phi_l_deg, -720.0, 720.0)
    if int(n_theta) < 2 or int(n_phi) < 3:
        raise OptionError("n_theta, n_phi: need at least 2 and 3 samples")
    ks = continuous_kappa(table, kappa)
    tmax = float(table.theta_v[-1])
    te = np.linspace(0.0, tmax, int(n_theta) + 1)
    pe = np.linspace(0.0, 360.0, int(n_phi) + 1)
    tc = 0.5 * (te[1:] + te[:-1])
    pc = 0.5 * (pe[1:] + pe[:-1])
    vals = table.evaluate(tc[None, :, None], pc[None, None, :], tl, pl, ks[:, None, None])
    n = ks.size
    if fig is None:
        fig = new_figure(None, (n * panel_size_in + 0.9, panel_size_in + 0.7), dpi)
    axes = [fig.add_subplot(1, n, i + 1, projection="polar") for i in range(n)]
    unit = unit_label(table.quantity)
    if colour == "luminance":
        y = luminance(vals, channel=channel, channels=table.channels)
        top = float(np.percentile(y, 99.8))
        vmax = top if top > 0 else 1.0
        norm = Normalize(0.0, vmax)
        meshes = [
            ax.pcolormesh(np.radians(pe), te, yk, cmap=_SEQ_CMAP, norm=norm, shading="flat", rasterized=True)
            for ax, yk in zip(axes, y)
        ]
        what = "luminance Y" if channel is None and table.n_channels == 3 else "value"
        cb = fig.colorbar(
            meshes[-1], ax=axes, shrink=0.8, pad=0.08,
            extend="max" if float(np.max(y)) > vmax else "neither",
        )
        cb.set_label(f"{what} [{unit}]", fontsize=7)
        cb.ax.tick_params(labelsize=6)
    else:
        expo, how = resolve_exposure(exposure, luminance(vals), table.quantity)
        for ax, vk in zip(axes, vals):
            rgb = srgb_encode(expo * vk)
            ax.pcolormesh(np.radians(pe), te, rgb, shading="flat", rasterized=True)
        fig.supxlabel(f"exposure \u00d7{expo:.4g} ({how}), sRGB-encoded", fontsize=6.5)
    for ax, k in zip(axes, ks):
        ax.set_ylim(0, tmax)
        ax.set_yticks([t for t in (15, 30, 45, 60, 75) if t < tmax - 1e-9])
        labels = ax.set_yticklabels([f"{t:g}\u00b0" for t in ax.get_yticks()], fontsize=5.5, color="white")
        for lab in labels:
            lab.set_path_effects([withStroke(linewidth=1.2, foreground="0.15")])
        ax.tick_params(axis="x", labelsize=6, pad=0)
        ax.grid(color="white" if colour == "luminance" else "0.3", alpha=0.3, lw=0.4)
        ax.plot(np.radians(pl), tl, "o", mfc="none", mec="cyan", ms=6, mew=1.2)
        ax.plot(np.radians(pl + 180.0), tl, "x", color="cyan", ms=6, mew=1.2)
        ax.set_title(kappa_label(k), fontsize=8)
    fig.suptitle(
        f"{table.attrs.get('material') or 'CDBRDF'}: view hemisphere, light "
        f"\u03b8$_l$ = {tl:g}\u00b0, \u03c6$_l$ = {pl:g}\u00b0 (\u25cb light, \u00d7 mirror)",
        fontsize=9,
    )
    return fig

