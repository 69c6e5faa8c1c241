"""Figures of a capture plan: which samples the stands hide, in the Fig. 7 layout."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from ..errors import OptionError
from ..table import Grid

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.figure import Figure

__all__ = ["HIDDEN_COLOURS", "plot_hidden"]

#: Colours of the hidden codes of :func:`cdbrdf.measure.stands.hidden_mask`:
#: 0 visible, 1 view hidden, 2 light hidden, 3 both.
HIDDEN_COLOURS: tuple[str, str, str, str] = ("#3b6ea8", "#f2f2f2", "#d98c3a", "#a03030")


def plot_hidden(grid: Grid, hidden: ArrayLike, *, fig: Figure | None = None, dpi: float = 120.0) -> Figure:
    """The samples hidden by the stands, one panel per curvature, in the Fig. 7 layout.

    Rows are light directions, columns view directions, both grouped by
    azimuth with the elevation increasing inside a group (as
    :meth:`cdbrdf.CDBRDF.fig7`); tick labels give each group's azimuth.

    Parameters
    ----------
    grid
        The plan's grid.
    hidden
        ``grid.shape`` codes of :func:`cdbrdf.measure.stands.hidden_mask`:
        0 visible, 1 view hidden, 2 light hidden, 3 both
        (colours :data:`HIDDEN_COLOURS`).
    fig
        Draw into this (empty) figure instead of a new one.
    dpi
        Resolution of a new figure.

    Returns
    -------
    matplotlib.figure.Figure
        The plan's samples coloured by what hides them.

    Raises
    ------
    ValueError
        When ``hidden`` does not have the grid's shape.
    """
    from matplotlib.colors import ListedColormap
    from matplotlib.figure import Figure

    h = np.asarray(hidden)
    if h.shape != tuple(grid.shape):
        raise OptionError(f"hidden: expected the grid's shape {tuple(grid.shape)}, got {h.shape}")
    k, pl, tl, pv, tv = h.shape
    mos = h.reshape(k, pl * tl, pv * tv)
    if fig is None:
        fig = Figure(figsize=(3.2 * k, 3.6), dpi=dpi, layout="tight")
    axes = fig.subplots(1, k, squeeze=False)
    cmap = ListedColormap(list(HIDDEN_COLOURS))
    for i, ax in enumerate(axes[0]):
        ax.imshow(mos[i], cmap=cmap, vmin=-0.5, vmax=3.5, interpolation="nearest")
        ax.set_title(f"kappa = {grid.kappa[i]:g} 1/mm\n{int((mos[i] > 0).sum())} hidden", fontsize=9)
        ax.set_xlabel("view (azimuth groups, elevation inside)", fontsize=7)
        ax.set_ylabel("light", fontsize=7)
        ax.set_xticks(np.arange(pv) * tv - 0.5, [f"{p:g}" for p in grid.phi_v], fontsize=5)
        ax.set_yticks(np.arange(pl) * tl - 0.5, [f"{p:g}" for p in grid.phi_l], fontsize=5)
    fig.suptitle("hidden by the stand: white = view, orange = light, red = both", fontsize=9)
    return fig
