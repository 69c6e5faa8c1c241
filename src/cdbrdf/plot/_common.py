"""Helpers shared by the figures of :mod:`cdbrdf.plot` (private).

Channel selection and the luminance shown, curvature labels and colours,
argument checks, new figures and atomic figure files. Figures are built with
:class:`matplotlib.figure.Figure` directly (no pyplot, no backend switch);
matplotlib is imported inside the functions only.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from os import PathLike
from pathlib import Path
from types import MappingProxyType
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .. import colour
from ..errors import OptionError
from ..table import CDBRDF

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.figure import Figure

__all__ = [
    "FIGURE_FORMATS",
    "luminance",
    "channel_index",
    "kappa_label",
    "unit_label",
    "kappa_colours",
    "continuous_kappa",
    "check_angle",
    "new_figure",
    "save_figure",
]

#: Figure file formats, chosen by the file's suffix.
FIGURE_FORMATS: Mapping[str, str] = MappingProxyType({".png": "png", ".pdf": "pdf", ".svg": "svg"})


def luminance(
    values: ArrayLike, *, channel: int | str | None = None, channels: Sequence[str] | None = None
) -> NDArray[np.float64]:
    """Luminance (or one channel) of linear values ``(..., channel)``, as figures show it.

    :func:`cdbrdf.colour.luminance` for RGB; tables with other channel counts
    show one channel.

    Parameters
    ----------
    values
        Linear values; the last axis holds the channels.
    channel
        None: Rec. 709 luminance for 3 channels, the channel itself for 1
        channel. An index or a name (looked up in ``channels``) picks one.
    channels
        Channel names, for ``channel`` given by name.

    Returns
    -------
    numpy.ndarray
        ``values.shape[:-1]``, float64.

    Raises
    ------
    ValueError
        For a table with 2 or more than 3 channels and no ``channel``, or an
        unknown channel.
    """
    v = np.asarray(values, dtype=np.float64)
    nc = v.shape[-1]
    if channel is not None:
        return v[..., channel_index(channel, nc, channels)]
    if nc == 3:
        return colour.luminance(v)
    if nc == 1:
        return v[..., 0]
    raise OptionError(
        f"channel: the table has {nc} channels; pick one with channel= "
        f"(an index 0..{nc - 1} or a name)"
    )


def channel_index(channel: int | str, nc: int, channels: Sequence[str] | None) -> int:
    """The index of ``channel`` (an index or a name in ``channels``) among ``nc`` channels.

    Raises
    ------
    ValueError
        For an unknown name, an index out of range, or neither.
    """
    names = list(channels) if channels is not None else [f"c{i}" for i in range(nc)]
    if isinstance(channel, str):
        if channel not in names:
            raise OptionError(f"channel: {channel!r} is not one of {', '.join(names)}")
        return names.index(channel)
    if isinstance(channel, (bool, np.bool_)) or not isinstance(channel, (int, np.integer)):
        raise OptionError(f"channel: expected an index or a name, got {channel!r}")
    if not -nc <= int(channel) < nc:
        raise OptionError(f"channel: index {channel} is out of range for {nc} channel(s)")
    return int(channel) % nc


def kappa_label(kappa_mm: float, *, unit: bool = True) -> str:
    """The curvature with its sign's meaning, e.g. ``"κ = 0.13 mm⁻¹ (convex)"``.

    Parameters
    ----------
    kappa_mm
        The curvature, mm^-1.
    unit
        Include the unit.

    Returns
    -------
    str
        The label.
    """
    k = float(kappa_mm)
    kind = "flat" if k == 0 else ("convex" if k > 0 else "concave")
    num = "0" if k == 0 else f"{k:+.3g}".replace("-", "\u2212")
    return f"\u03ba = {num}" + (" mm\u207b\u00b9" if unit else "") + f" ({kind})"


def unit_label(quantity: str) -> str:
    """The unit of a table's values for an axis label: sr^-1 (``"brdf"``) or relative."""
    return "sr$^{-1}$" if quantity == "brdf" else "relative"


def kappa_colours(ks: NDArray[np.float64]) -> list[Any]:
    """One line colour per curvature: concave blue, flat black, convex red (``coolwarm``)."""
    from matplotlib import colormaps

    cmap = colormaps["coolwarm"]
    span = float(np.max(np.abs(ks))) if ks.size else 0.0
    out: list[Any] = []
    for k in ks:
        if k == 0 or span == 0:
            out.append("black")
        else:
            # skip the pale middle of the map: |t - 0.5| in [0.15, 0.5]
            t = 0.5 + np.sign(k) * (0.15 + 0.35 * abs(k) / span)
            out.append(cmap(float(np.clip(t, 0, 1))))
    return out


def continuous_kappa(table: CDBRDF, kappa: float | ArrayLike | None) -> NDArray[np.float64]:
    """Curvatures to evaluate, mm^-1 (any finite values); None: the table's axis.

    Raises
    ------
    ValueError
        When ``kappa`` is not one or more finite numbers.
    """
    if kappa is None:
        return np.array(table.kappa)
    try:
        ks = np.array(kappa, dtype=np.float64, ndmin=1)
    except (TypeError, ValueError):
        raise OptionError(f"kappa: cannot be read as numbers: {kappa!r}") from None
    if ks.ndim != 1 or ks.size == 0 or not np.all(np.isfinite(ks)):
        raise OptionError(f"kappa: give one or more finite curvatures (mm^-1), got {kappa!r}")
    return ks


def check_angle(name: str, value: float, lo: float, hi: float) -> float:
    """``value`` as a float of degrees in ``[lo, hi]``.

    Raises
    ------
    ValueError
        Naming ``name``, for a non-number or a value outside the range.
    """
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise OptionError(f"{name}: expected a number of degrees, got {value!r}") from None
    if not (np.isfinite(v) and lo <= v <= hi):
        raise OptionError(f"{name}: must lie in [{lo:g}, {hi:g}] degrees, got {value!r}")
    return v


def new_figure(fig: Figure | None, figsize: tuple[float, float], dpi: float) -> Figure:
    """``fig`` itself, or a new constrained-layout :class:`~matplotlib.figure.Figure` (inches, dots per inch)."""
    from matplotlib.figure import Figure

    if fig is not None:
        return fig
    return Figure(figsize=figsize, dpi=dpi, layout="constrained")


def save_figure(fig: Figure, path: str | PathLike[str], *, dpi: float = 150.0) -> Path:
    """Write a figure atomically, in the format of the file's suffix (:data:`FIGURE_FORMATS`).

    Parameters
    ----------
    fig
        The figure.
    path
        Output file: ``.png``, ``.pdf`` or ``.svg``; replaced if it exists.
    dpi
        Resolution of a PNG, dots per inch.

    Returns
    -------
    pathlib.Path
        ``path``.

    Raises
    ------
    ValueError
        For another suffix (nothing is written).
    FileNotFoundError, IsADirectoryError
        When the folder is missing or ``path`` is a folder.
    """
    from ..fsutil import atomic_path

    out = Path(path)
    fmt = FIGURE_FORMATS.get(out.suffix.lower())
    if fmt is None:
        got = f"{out.suffix!r}" if out.suffix else "no suffix"
        raise OptionError(
            f"{out}: cannot tell the figure format from {got}; use one of {', '.join(FIGURE_FORMATS)}"
        )
    with atomic_path(out, suffix=out.suffix) as tmp:
        fig.savefig(tmp, format=fmt, dpi=dpi)
    return out
