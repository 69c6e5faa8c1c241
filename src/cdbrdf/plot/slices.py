"""Slices of a table: reflectance along a plane of view directions, one curve per curvature."""

from __future__ import annotations

from collections.abc import Mapping
from types import MappingProxyType
from typing import TYPE_CHECKING, cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import OptionError
from ..table import CDBRDF
from ._common import (
    channel_index,
    check_angle,
    continuous_kappa,
    kappa_colours,
    kappa_label,
    luminance,
    new_figure,
    unit_label,
)

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

__all__ = ["SLICE_PLANES", "plot_slice"]

#: Planes of :func:`plot_slice`: the view azimuths (relative to the light's
#: azimuth) of the positive and the negative half of the signed view elevation.
SLICE_PLANES: Mapping[str, tuple[float, float]] = MappingProxyType({
    "incidence": (180.0, 0.0),
    "perpendicular": (90.0, 270.0),
})


def plot_slice(
    table: CDBRDF,
    *,
    theta_l_deg: float = 45.0,
    phi_l_deg: float = 0.0,
    kappa: float | ArrayLike | None = None,
    plane: str = "incidence",
    channel: int | str | None = None,
    n_points: int = 301,
    ax: Axes | None = None,
    figsize: tuple[float, float] = (5.5, 3.6),
    dpi: float = 150.0,
) -> Figure:
    """Reflectance along a plane of view directions, one curve per curvature.

    The light is fixed at ``(theta_l_deg, phi_l_deg)``. The horizontal axis is
    the signed view elevation in the chosen plane: for ``plane="incidence"``
    positive values lie on the far side from the light (the specular side,
    view azimuth ``phi_l + 180``), negative values on the light's side (view
    azimuth ``phi_l``); ``"perpendicular"`` uses ``phi_l + 90`` / ``phi_l + 270``.
    Curves are the table's lookup (:meth:`CDBRDF.evaluate`), so any curvature
    may be asked for (interpolated, clamped at the axis ends); where the plane
    runs through table samples they are drawn as dots (hollow: filled sample).

    Parameters
    ----------
    table
        The table.
    theta_l_deg, phi_l_deg
        Light direction, degrees.
    kappa
        Curvatures, mm^-1. Default: every curvature of the table.
    plane
        One of :data:`SLICE_PLANES`.
    channel
        None: luminance (or the only channel); an index or a name: that channel.
    n_points
        Number of view elevations evaluated.
    ax
        Draw into these axes; else a new figure is made.
    figsize, dpi
        Size of a new figure.

    Returns
    -------
    matplotlib.figure.Figure
        The figure holding the axes.
    """
    if plane not in SLICE_PLANES:
        raise OptionError(f"plane: {plane!r} is not one of {', '.join(SLICE_PLANES)}")
    tl = check_angle("theta_l_deg", theta_l_deg, 0.0, 90.0)
    pl = check_angle("phi_l_deg", phi_l_deg, -720.0, 720.0)
    if int(n_points) < 2:
        raise OptionError(f"n_points: need at least 2, got {n_points!r}")
    ks = continuous_kappa(table, kappa)
    tmax = float(table.theta_v[-1])
    s = np.linspace(-tmax, tmax, int(n_points))
    d_pos, d_neg = SLICE_PLANES[plane]
    phi_v = np.where(s >= 0, pl + d_pos, pl + d_neg)
    theta_v = np.abs(s)

    if ax is None:
        fig = new_figure(None, figsize, dpi)
        ax = fig.add_subplot()
    else:
        fig = cast("Figure", ax.figure)
    colours = kappa_colours(ks)
    vals = table.evaluate(theta_v[None, :], phi_v[None, :], tl, pl, ks[:, None])
    y = luminance(vals, channel=channel, channels=table.channels)
    for k, c, yk in zip(ks, colours, y):
        ax.plot(s, yk, color=c, lw=1.3, label=kappa_label(k))

    # table samples on the plane
    def on_axis(a: NDArray[np.float64], x: float, periodic: bool) -> int | None:
        d = (a - x) % 360.0 if periodic else a - x
        if periodic:
            d = np.minimum(d, 360.0 - d)
        hit = np.flatnonzero(np.abs(d) <= 1e-9)
        return int(hit[0]) if hit.size else None

    il = on_axis(table.theta_l, tl, False)
    jl = on_axis(table.phi_l, pl % 360.0, True)
    if il is not None and jl is not None:
        for k, c in zip(ks, colours):
            ik = on_axis(table.kappa, k, False)
            if ik is None:
                continue
            for sign, dphi in ((1, d_pos), (-1, d_neg)):
                jv = on_axis(table.phi_v, (pl + dphi) % 360.0, True)
                if jv is None:
                    continue
                sel = table.theta_v > 0 if sign < 0 else np.ones(table.theta_v.size, bool)
                tv = table.theta_v[sel]
                v = table.values[ik, jl, il, jv][sel]
                yy = luminance(v, channel=channel, channels=table.channels)
                meas = table.measured[ik, jl, il, jv][sel]
                ax.scatter(sign * tv[meas], yy[meas], s=12, color=c, zorder=3, linewidths=0)
                ax.scatter(sign * tv[~meas], yy[~meas], s=14, facecolors="white", edgecolors=c, zorder=3,
                           linewidths=0.9)

    ax.axvline(tl, color="0.5", lw=0.6, ls="--")
    ax.axvline(-tl, color="0.5", lw=0.6, ls=":")
    ax.axvline(0, color="0.8", lw=0.5)
    ax.set_xlim(-tmax, tmax)
    ax.set_ylim(bottom=min(0.0, float(np.min(y))))
    side = {
        "incidence": ("light side", "mirror side"),
        "perpendicular": ("\u03c6$_l$+270\u00b0", "\u03c6$_l$+90\u00b0"),
    }[plane]
    ax.set_xlabel(f"signed view elevation \u03b8$_v$ [\u00b0]  ({side[0]} \u2190 | \u2192 {side[1]})", fontsize=8)
    unit = unit_label(table.quantity)
    if channel is None:
        what = "luminance Y" if table.n_channels == 3 else table.channels[0]
    else:
        what = f"channel {table.channels[channel_index(channel, table.n_channels, table.channels)]}"
    ax.set_ylabel(f"{what} [{unit}]", fontsize=8)
    ax.tick_params(labelsize=7)
    name = table.attrs.get("material") or "CDBRDF"
    ax.set_title(
        f"{name}: {plane} plane, light \u03b8$_l$ = {tl:g}\u00b0, \u03c6$_l$ = {pl:g}\u00b0",
        fontsize=9,
    )
    ax.legend(fontsize=6.5, frameon=False)
    ax.grid(alpha=0.25, lw=0.5)
    return fig

