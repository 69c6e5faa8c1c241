"""Figures of a :class:`~cdbrdf.table.CDBRDF`: the paper's Fig. 7 mosaic and slices.

Library calls return arrays (:func:`mosaic_arrays`) or a
:class:`matplotlib.figure.Figure` (:func:`plot_mosaic`, :func:`plot_slice`,
:func:`plot_hemisphere`). Figures are built with :class:`~matplotlib.figure.Figure`
directly: no pyplot, no backend switch, no global state is touched, so they
work headless and inside notebooks alike (``fig.savefig(path)`` writes PNG, PDF
or SVG; in Jupyter, display ``fig`` itself).

The mosaic
----------
For each curvature the samples are laid out as one image, exactly
:meth:`CDBRDF.fig7 <cdbrdf.table.CDBRDF.fig7>`: rows are light directions,
columns view directions, both grouped by azimuth (groups in azimuth order) with
the elevation increasing inside a group (Matsufuji & Kawai, Fig. 7). With the
paper's grid (12 azimuths x 6 elevations) each image is 72 x 72.

Colours
-------
Tables hold linear, scene-referred RGB (Rec. 709 primaries). Display images
are ``srgb_encode(exposure * values)``, clipped to [0, 1]. The automatic
exposure maps the :data:`EXPOSURE_PERCENTILE`-th percentile of the luminance
``Y = 0.2126 R + 0.7152 G + 0.0722 B`` over *all shown panels* to 1, so the
panels share one scale and can be compared by eye. Difference images show the
signed luminance difference ``Y(kappa) - Y(kappa_ref)`` with a diverging
colour map, symmetric about 0, in the table's unit (sr^-1 for
``quantity="brdf"``, "relative" otherwise).

References
----------
Matsufuji, Kawai, "Measurement and Rendering of Curvature Dependent BRDF",
Fig. 7.
"""

from __future__ import annotations

import textwrap
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .errors import QueryError
from .table import CDBRDF

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

__all__ = [
    "Mosaic",
    "mosaic_arrays",
    "plot_mosaic",
    "plot_slice",
    "plot_hemisphere",
    "plot_render_comparison",
    "plot_curvature_map",
    "tonemap_srgb8",
    "luminance",
    "srgb_encode",
    "auto_exposure",
    "kappa_label",
    "EXPOSURE_PERCENTILE",
    "EXPOSURE_MODES",
    "KAPPA_ATOL",
    "SLICE_PLANES",
    "LUMINANCE_WEIGHTS",
]

#: Percentile of the luminance over all shown panels that the automatic
#: exposure maps to display white.
EXPOSURE_PERCENTILE = 99.5

#: Named exposures: ``"auto"`` maps the :data:`EXPOSURE_PERCENTILE`-th
#: percentile of the shown luminance to 1; ``"white"`` (``quantity="brdf"``
#: only) multiplies by pi, so that a perfect white Lambertian reflector
#: (f = 1/pi sr^-1) is display white, as next to a white card in a photograph.
EXPOSURE_MODES: tuple[str, ...] = ("auto", "white")

#: Percentile of |difference| that sets the default difference colour range.
DIFF_PERCENTILE = 99.5

#: Tolerance (mm^-1) when matching a requested curvature to the table's axis.
KAPPA_ATOL = 1e-6

#: Rec. 709 / sRGB luminance weights of linear R, G, B.
LUMINANCE_WEIGHTS = np.array([0.2126, 0.7152, 0.0722])

#: Planes of :func:`plot_slice`: the view azimuths (relative to the light's
#: azimuth) of the positive and the negative half of the signed view elevation.
SLICE_PLANES: dict[str, tuple[float, float]] = {
    "incidence": (180.0, 0.0),
    "perpendicular": (90.0, 270.0),
}

_FILLED_COLOUR = "#ff2bd6"  # magenta: stands out on fabrics and on the diff map
_DIFF_FILLED_COLOUR = "#4d4d4d"
_DIFF_CMAP = "RdBu_r"
_SEQ_CMAP = "inferno"


# -- small helpers ---------------------------------------------------------------------
def luminance(values: ArrayLike, *, channel: int | str | None = None, channels: Sequence[str] | None = None) -> NDArray[np.float64]:
    """Luminance (or one channel) of linear values ``(..., channel)``.

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
        return v[..., _channel_index(channel, nc, channels)]
    if nc == 3:
        return v @ LUMINANCE_WEIGHTS
    if nc == 1:
        return v[..., 0]
    raise ValueError(
        f"channel: the table has {nc} channels; pick one with channel= "
        f"(an index 0..{nc - 1} or a name)"
    )


def _channel_index(channel: int | str, nc: int, channels: Sequence[str] | None) -> int:
    names = list(channels) if channels is not None else [f"c{i}" for i in range(nc)]
    if isinstance(channel, str):
        if channel not in names:
            raise ValueError(f"channel: {channel!r} is not one of {', '.join(names)}")
        return names.index(channel)
    if isinstance(channel, (bool, np.bool_)) or not isinstance(channel, (int, np.integer)):
        raise ValueError(f"channel: expected an index or a name, got {channel!r}")
    if not -nc <= int(channel) < nc:
        raise ValueError(f"channel: index {channel} is out of range for {nc} channel(s)")
    return int(channel) % nc


def srgb_encode(linear: ArrayLike) -> NDArray[np.float64]:
    """The sRGB transfer function (IEC 61966-2-1) of values clipped to [0, 1]."""
    x = np.clip(np.asarray(linear, dtype=np.float64), 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1.0 / 2.4) - 0.055)


def auto_exposure(lum: ArrayLike, *, percentile: float = EXPOSURE_PERCENTILE) -> float:
    """Exposure factor mapping the ``percentile``-th percentile of ``lum`` to 1.

    Returns 1 when that percentile is not positive (an all-black table).
    """
    y = np.asarray(lum, dtype=np.float64)
    y = y[np.isfinite(y)]
    if y.size == 0:
        return 1.0
    p = float(np.percentile(y, percentile))
    return 1.0 / p if p > 0 else 1.0


def _resolve_exposure(exposure: float | str | None, lum: NDArray[np.float64], quantity: str) -> tuple[float, str]:
    """The exposure factor and a note saying how it was chosen."""
    if exposure is None or (isinstance(exposure, str) and exposure == "auto"):
        return auto_exposure(lum), f"auto: {EXPOSURE_PERCENTILE:g}th percentile → 1"
    if isinstance(exposure, str):
        if exposure != "white":
            raise ValueError(
                f"exposure: {exposure!r} is not a number nor one of {', '.join(EXPOSURE_MODES)}"
            )
        if quantity != "brdf":
            raise ValueError(
                "exposure: 'white' needs an absolute table (quantity 'brdf'); "
                "this one is 'relative': give a number or 'auto'"
            )
        return float(np.pi), "white: f = 1/π sr⁻¹ → 1"
    try:
        x = float(exposure)
    except (TypeError, ValueError):
        raise ValueError(f"exposure: expected a positive number or one of {', '.join(EXPOSURE_MODES)}, got {exposure!r}") from None
    if not (np.isfinite(x) and x > 0):
        raise ValueError(f"exposure: must be a positive number, got {exposure!r}")
    return x, "given"


def kappa_label(kappa_mm: float, *, unit: bool = True) -> str:
    """``"κ = 0.13 mm⁻¹ (convex)"``: the curvature with its sign's meaning."""
    k = float(kappa_mm)
    kind = "flat" if k == 0 else ("convex" if k > 0 else "concave")
    num = "0" if k == 0 else f"{k:+.3g}".replace("-", "\u2212")
    return f"\u03ba = {num}" + (" mm\u207b\u00b9" if unit else "") + f" ({kind})"


def _fmt_kappas(ks: NDArray[np.float64]) -> str:
    return ", ".join(f"{k:g}" for k in ks)


def _select_kappa(table: CDBRDF, kappa: float | ArrayLike | None) -> NDArray[np.intp]:
    axis = table.kappa
    if kappa is None:
        return np.arange(axis.size)
    try:
        req = np.array(kappa, dtype=np.float64, ndmin=1)
    except (TypeError, ValueError):
        raise ValueError(f"kappa: cannot be read as numbers: {kappa!r}") from None
    if req.ndim != 1 or req.size == 0:
        raise ValueError("kappa: give one or more curvatures (mm^-1)")
    idx = []
    for k in req:
        hit = np.flatnonzero(np.abs(axis - k) <= KAPPA_ATOL)
        if not np.isfinite(k) or hit.size == 0:
            raise QueryError(
                f"kappa: {k:g} mm^-1 is not a curvature of the table; available: "
                f"{_fmt_kappas(axis)} (the mosaic shows samples, it does not interpolate)"
            )
        if int(hit[0]) in idx:
            raise QueryError(f"kappa: {k:g} mm^-1 is requested twice")
        idx.append(int(hit[0]))
    return np.array(idx, dtype=np.intp)


# -- the mosaic arrays -----------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class Mosaic:
    """The paper's Fig. 7 images of a table, as arrays.

    ``R = n_phi_l * n_theta_l`` rows (light directions) and ``C = n_phi_v *
    n_theta_v`` columns (view directions), grouped by azimuth with the
    elevation increasing inside a group.

    Attributes
    ----------
    kappa
        ``(n,)`` the curvatures shown, mm^-1, in the order requested.
    kappa_index
        ``(n,)`` their indices on the table's curvature axis.
    images
        ``(n, R, C, channel)`` linear values (the table's, copied).
    filled
        ``(n, R, C)`` True where the sample was filled, not measured.
    reference_kappa
        Curvature the differences are taken against, mm^-1: 0, or the
        nearest axis end when 0 lies outside the table's range.
    reference
        ``(R, C, channel)`` values at ``reference_kappa``: the table's slice
        when it is sampled, else linear in kappa between the two neighbouring
        slices (the table's lookup at every sample direction).
    reference_filled
        ``(R, C)`` True where the reference (or a slice it is blended from)
        was filled.
    reference_sampled
        True when the reference is one of the table's slices (kappa = 0 is
        sampled, or 0 lies outside the range); False when interpolated.
    difference
        ``(n, R, C, channel)`` ``images - reference``.
    row_phi_deg, row_theta_deg
        ``(R,)`` light azimuth and elevation of each row, degrees.
    col_phi_deg, col_theta_deg
        ``(C,)`` view azimuth and elevation of each column, degrees.
    phi_l, theta_l, phi_v, theta_v
        The table's direction axes, degrees.
    channels
        Channel names.
    quantity
        ``"brdf"`` (values in sr^-1) or ``"relative"``.
    material
        The table's material name ("" when unknown).
    """

    kappa: NDArray[np.float64]
    kappa_index: NDArray[np.intp]
    images: NDArray[np.floating]
    filled: NDArray[np.bool_]
    reference_kappa: float
    reference: NDArray[np.float64]
    reference_filled: NDArray[np.bool_]
    reference_sampled: bool
    difference: NDArray[np.float64]
    row_phi_deg: NDArray[np.float64]
    row_theta_deg: NDArray[np.float64]
    col_phi_deg: NDArray[np.float64]
    col_theta_deg: NDArray[np.float64]
    phi_l: NDArray[np.float64]
    theta_l: NDArray[np.float64]
    phi_v: NDArray[np.float64]
    theta_v: NDArray[np.float64]
    channels: tuple[str, ...]
    quantity: str
    material: str

    @property
    def unit(self) -> str:
        """Unit of the values: ``"sr^-1"`` or ``"relative"``."""
        return "sr^-1" if self.quantity == "brdf" else "relative"

    def luminance(self, *, channel: int | str | None = None) -> NDArray[np.float64]:
        """``(n, R, C)`` luminance (or one channel) of :attr:`images`."""
        return luminance(self.images, channel=channel, channels=self.channels)

    def difference_luminance(self, *, channel: int | str | None = None) -> NDArray[np.float64]:
        """``(n, R, C)`` luminance (or one channel) of :attr:`difference`."""
        return luminance(self.difference, channel=channel, channels=self.channels)


def _reference(table: CDBRDF) -> tuple[float, NDArray[np.float64], NDArray[np.bool_], bool]:
    ks = table.kappa
    v = table.values
    m = table.measured
    if ks.size == 1 or 0.0 <= ks[0] or ks[-1] <= 0.0:
        i = int(np.argmin(np.abs(ks)))
        return float(ks[i]), np.asarray(v[i], dtype=np.float64), ~m[i], True
    hit = np.flatnonzero(ks == 0.0)
    if hit.size:
        i = int(hit[0])
        return 0.0, np.asarray(v[i], dtype=np.float64), ~m[i], True
    j = int(np.searchsorted(ks, 0.0)) - 1  # ks[j] < 0 < ks[j + 1]
    w = (0.0 - ks[j]) / (ks[j + 1] - ks[j])
    ref = (1.0 - w) * np.asarray(v[j], np.float64) + w * np.asarray(v[j + 1], np.float64)
    return 0.0, ref, ~(m[j] & m[j + 1]), False


def mosaic_arrays(table: CDBRDF, *, kappa: float | ArrayLike | None = None) -> Mosaic:
    """The Fig. 7 images, filled masks and differences against kappa = 0.

    Parameters
    ----------
    table
        The table.
    kappa
        Curvatures to show, mm^-1 (one or several, in the order wanted); each
        must be on the table's axis (within :data:`KAPPA_ATOL`). Default: all.
        The mosaic shows samples only; use :meth:`CDBRDF.evaluate` or
        :meth:`CDBRDF.brdf` for curvatures between samples.

    Returns
    -------
    Mosaic
        Images, masks, differences and the coordinates of every row/column.

    Raises
    ------
    ValueError
        When a requested curvature is not on the axis (the message lists the
        available ones) or is requested twice.

    Notes
    -----
    The difference reference is kappa = 0: the flat slice when sampled, else
    the values linearly interpolated in kappa at every sample direction
    (clamped to the nearest axis end when 0 lies outside the range, as the
    lookup does).

    Examples
    --------
    >>> import numpy as np, cdbrdf
    >>> from cdbrdf.plot import mosaic_arrays
    >>> g = cdbrdf.Grid.paper()
    >>> t = cdbrdf.CDBRDF(np.full(g.shape + (3,), 0.2), **g.axes())
    >>> m = mosaic_arrays(t, kappa=[0.0, 0.13])
    >>> m.images.shape, m.difference.max()
    ((2, 72, 72, 3), np.float64(0.0))
    """
    if not isinstance(table, CDBRDF):
        raise TypeError(f"table: expected a CDBRDF, got {type(table).__name__}")
    idx = _select_kappa(table, kappa)
    _, npl, ntl, npv, ntv, nc = table.shape
    rows, cols = npl * ntl, npv * ntv
    images = np.array(table.fig7()[idx])
    filled = ~table.measured.reshape(-1, rows, cols)[idx]
    k_ref, ref, ref_filled, sampled = _reference(table)
    ref = ref.reshape(rows, cols, nc)
    ref_filled = ref_filled.reshape(rows, cols)
    diff = images.astype(np.float64) - ref[None]
    for a in (images, filled, ref, ref_filled, diff):
        a.setflags(write=False)
    return Mosaic(
        kappa=np.array(table.kappa[idx]),
        kappa_index=idx,
        images=images,
        filled=filled,
        reference_kappa=k_ref,
        reference=ref,
        reference_filled=ref_filled,
        reference_sampled=sampled,
        difference=diff,
        row_phi_deg=np.repeat(table.phi_l, ntl),
        row_theta_deg=np.tile(table.theta_l, npl),
        col_phi_deg=np.repeat(table.phi_v, ntv),
        col_theta_deg=np.tile(table.theta_v, npv),
        phi_l=np.array(table.phi_l),
        theta_l=np.array(table.theta_l),
        phi_v=np.array(table.phi_v),
        theta_v=np.array(table.theta_v),
        channels=tuple(table.channels),
        quantity=table.quantity,
        material=str(table.attrs.get("material", "") or ""),
    )


# -- figure helpers -----------------------------------------------------------------------
def _new_figure(fig: "Figure | None", figsize: tuple[float, float], dpi: float) -> "Figure":
    from matplotlib.figure import Figure

    if fig is not None:
        return fig
    return Figure(figsize=figsize, dpi=dpi, layout="constrained")


def _display_rgb(values: NDArray[np.floating], exposure: float, channel, channels) -> NDArray[np.float64]:
    nc = values.shape[-1]
    if channel is None and nc == 3:
        return srgb_encode(exposure * np.asarray(values, dtype=np.float64))
    y = luminance(values, channel=channel, channels=channels)
    g = srgb_encode(exposure * y)
    return np.repeat(g[..., None], 3, axis=-1)


def _filled_path(mask: NDArray[np.bool_]):
    """A compound path of the filled pixels (runs merged along rows), pixel units."""
    from matplotlib.path import Path

    verts: list[list[float]] = []
    codes: list[int] = []
    for r in np.flatnonzero(mask.any(axis=1)):
        row = np.concatenate([[False], mask[r], [False]]).astype(np.int8)
        d = np.diff(row)
        for a, b in zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1)):
            verts += [[a, r], [b, r], [b, r + 1], [a, r + 1], [a, r]]
            codes += [Path.MOVETO, Path.LINETO, Path.LINETO, Path.LINETO, Path.CLOSEPOLY]
    if not verts:
        return None
    return Path(np.array(verts, dtype=float), codes)


def _outline_segments(mask: NDArray[np.bool_]) -> NDArray[np.float64]:
    """Pixel-edge segments separating filled from measured pixels, pixel units."""
    m = np.pad(mask, 1, constant_values=False)
    segs = []
    # horizontal edges: between row r-1 and r (padded indices)
    h = m[1:, 1:-1] != m[:-1, 1:-1]
    r, c = np.nonzero(h)
    segs.append(np.stack([np.stack([c, r], -1), np.stack([c + 1, r], -1)], 1))
    v = m[1:-1, 1:] != m[1:-1, :-1]
    r, c = np.nonzero(v)
    segs.append(np.stack([np.stack([c, r], -1), np.stack([c, r + 1], -1)], 1))
    return np.concatenate(segs).astype(float)


def _mark_filled(ax: "Axes", mask: NDArray[np.bool_], colour: str, lw: float) -> bool:
    from matplotlib.collections import LineCollection
    from matplotlib.patches import PathPatch

    path = _filled_path(mask)
    if path is None:
        return False
    if hasattr(PathPatch, "set_hatchcolor"):  # matplotlib >= 3.11
        style = {"edgecolor": "none", "hatchcolor": colour, "hatch_linewidth": lw * 0.6}
    else:  # older: the hatch takes the edge colour (the edge itself has width 0)
        style = {"edgecolor": colour}
    ax.add_patch(PathPatch(path, facecolor="none", hatch="//////", linewidth=0, zorder=3, **style))
    ax.add_collection(
        LineCollection(_outline_segments(mask), colors=colour, linewidths=lw, zorder=4, capstyle="projecting")
    )
    return True


def _group_axes(ax: "Axes", n_groups: int, per: int, phis: NDArray[np.float64], which: str, sep_colour: str, label: bool) -> None:
    from matplotlib.collections import LineCollection

    n = n_groups * per
    bounds = np.arange(1, n_groups) * per
    if per > 1 and n_groups > 1:
        if which == "x":
            segs = [[(b, 0), (b, n)] for b in bounds]
        else:
            segs = [[(0, b), (n, b)] for b in bounds]
        ax.add_collection(LineCollection(segs, colors=sep_colour, linewidths=0.45, zorder=5))
    step = max(1, int(np.ceil(n_groups / 12)))
    centres = (np.arange(0, n_groups, step) + 0.5) * per
    labels = [f"{p:g}\u00b0" for p in phis[::step]] if label else []
    ticks_major = np.arange(0, n_groups + 1) * per
    if which == "x":
        ax.set_xticks(ticks_major, [])
        ax.set_xticks(centres, labels if label else [""] * len(centres), minor=True)
        ax.tick_params(axis="x", which="minor", length=0, labelsize=5.5, pad=2, labelrotation=90)
        ax.tick_params(axis="x", which="major", length=2.5, width=0.5)
    else:
        ax.set_yticks(ticks_major, [])
        ax.set_yticks(centres, labels if label else [""] * len(centres), minor=True)
        ax.tick_params(axis="y", which="minor", length=0, labelsize=5.5, pad=2)
        ax.tick_params(axis="y", which="major", length=2.5, width=0.5)


def _setup_panel(ax: "Axes", m: Mosaic, *, ylabels: bool, xlabels: bool, sep_colour: str) -> None:
    rows, cols = m.images.shape[1:3]
    ax.set_xlim(0, cols)
    ax.set_ylim(rows, 0)
    _group_axes(ax, m.phi_v.size, m.theta_v.size, m.phi_v, "x", sep_colour, xlabels)
    _group_axes(ax, m.phi_l.size, m.theta_l.size, m.phi_l, "y", sep_colour, ylabels)
    for s in ax.spines.values():
        s.set_linewidth(0.5)
    if ylabels:
        ax.set_ylabel(
            "light direction: \u03c6$_l$ groups, \u03b8$_l$ "
            f"{m.theta_l[0]:g}\u2192{m.theta_l[-1]:g}\u00b0 inside",
            fontsize=7,
        )
    if xlabels:
        ax.set_xlabel(
            "view direction: \u03c6$_v$ groups, \u03b8$_v$ "
            f"{m.theta_v[0]:g}\u2192{m.theta_v[-1]:g}\u00b0 inside",
            fontsize=7,
        )


# -- the mosaic figure --------------------------------------------------------------------
def plot_mosaic(
    table: CDBRDF | Mosaic,
    *,
    kappa: float | ArrayLike | None = None,
    exposure: float | str | None = None,
    diff: bool = True,
    diff_limit: float | None = None,
    channel: int | str | None = None,
    mark_filled: bool = True,
    title: str | None = None,
    fig: "Figure | None" = None,
    panel_size_in: float = 2.7,
    dpi: float = 150.0,
) -> "Figure":
    """The paper's Fig. 7: one image per curvature, side by side, shared exposure.

    Top row: for each curvature the ``(n_phi_l*n_theta_l) x (n_phi_v*n_theta_v)``
    image (rows light direction, columns view direction, grouped by azimuth;
    tick labels give the azimuth of each group, thin lines separate groups),
    ``srgb_encode(exposure * values)``. Filled (unmeasured) samples are hatched
    and outlined in magenta. Bottom row (``diff=True``): signed luminance
    difference against kappa = 0 (see :func:`mosaic_arrays`) with a diverging
    colour map and a colour bar in the table's unit; the reference's own panel,
    being zero, holds the legend instead.

    Parameters
    ----------
    table
        A :class:`~cdbrdf.table.CDBRDF`, or a :class:`Mosaic` from
        :func:`mosaic_arrays` (then ``kappa`` must be None).
    kappa
        Curvatures to show (on the table's axis), mm^-1. Default: all.
    exposure
        Linear factor applied before sRGB encoding, or a mode of
        :data:`EXPOSURE_MODES`. Default ``"auto"``: the
        :data:`EXPOSURE_PERCENTILE`-th percentile of the luminance over all
        shown panels maps to 1. ``"white"``: pi, a white Lambertian reflector
        maps to 1 (tables in sr^-1 only). The factor used is printed in the
        figure.
    diff
        Draw the difference row (skipped anyway when the only curvature shown
        is the reference).
    diff_limit
        Colour range of the difference, ± this value in the table's unit.
        Default: the :data:`DIFF_PERCENTILE`-th percentile of |difference| over
        the measured samples of the shown panels (values beyond, e.g. at
        filled samples, are saturated; the colour bar's arrows say so).
    channel
        None: RGB (or grey for a one-channel table). An index or name: that
        channel, shown in grey (also for the difference).
    mark_filled
        Hatch and outline filled samples.
    title
        Figure title. Default: the material name and the quantity.
    fig
        Draw into this (empty) figure instead of a new one.
    panel_size_in
        Width of one panel in inches (new figures only).
    dpi
        Resolution of a new figure (a PNG is ``figsize * dpi`` pixels).

    Returns
    -------
    matplotlib.figure.Figure
        The figure (save it with ``fig.savefig(path)``).

    Raises
    ------
    ValueError
        For a curvature not on the table's axis, a non-positive exposure or
        difference limit, or an unusable channel choice.
    """
    from matplotlib.colors import Normalize
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    if isinstance(table, Mosaic):
        if kappa is not None:
            raise ValueError("kappa: select curvatures in mosaic_arrays() when passing a Mosaic")
        m = table
    else:
        m = mosaic_arrays(table, kappa=kappa)
    if diff_limit is not None and not (np.isfinite(diff_limit) and diff_limit > 0):
        raise ValueError(f"diff_limit: must be a positive number, got {diff_limit!r}")

    n = m.kappa.size
    lum = m.luminance(channel=channel)
    expo, how = _resolve_exposure(exposure, lum, m.quantity)

    ref_col = None
    if m.reference_sampled:
        hits = np.flatnonzero(m.kappa == m.reference_kappa)
        ref_col = int(hits[0]) if hits.size else None
    show_diff = diff and not (n == 1 and ref_col == 0)
    nrows = 2 if show_diff else 1

    rows, cols = m.images.shape[1:3]
    aspect = rows / cols
    if fig is None:
        w = n * panel_size_in + (1.3 if show_diff else 0.6)
        h = nrows * (panel_size_in * aspect + 0.5) + 0.55
        fig = _new_figure(None, (w, h), dpi)
    axes = fig.subplots(nrows, n, squeeze=False)

    any_filled = any_diff_marked = False
    for j in range(n):
        ax = axes[0, j]
        rgb = _display_rgb(m.images[j], expo, channel, m.channels)
        ax.imshow(rgb, extent=(0, cols, rows, 0), interpolation="nearest", origin="upper", aspect="equal")
        _setup_panel(ax, m, ylabels=j == 0, xlabels=not show_diff, sep_colour=(1, 1, 1, 0.55))
        ax.set_title(kappa_label(m.kappa[j]), fontsize=8.5)
        if mark_filled and _mark_filled(ax, m.filled[j], _FILLED_COLOUR, 0.6):
            any_filled = True

    unit = "sr$^{-1}$" if m.quantity == "brdf" else "relative units"
    ylab = "Y" if channel is None and len(m.channels) == 3 else (
        m.channels[_channel_index(channel, len(m.channels), m.channels)] if channel is not None else m.channels[0]
    )
    ref_text = kappa_label(m.reference_kappa, unit=True).split(" (")[0]
    if show_diff:
        dl = luminance(m.difference, channel=channel, channels=m.channels)
        shown = [j for j in range(n) if j != ref_col]
        lim = diff_limit
        if lim is None:
            # measured samples only: filled ones are copies, their differences artefacts
            both = ~(m.filled | m.reference_filled[None])
            a = np.abs(dl[shown][both[shown]]) if shown else np.zeros(0)
            if a.size == 0 and shown:
                a = np.abs(dl[shown]).ravel()
            lim = float(np.percentile(a, DIFF_PERCENTILE)) if a.size else 0.0
            if not lim > 0:
                lim = float(a.max()) if a.size and a.max() > 0 else 1.0
        norm = Normalize(-lim, lim)
        im = None
        for j in range(n):
            ax = axes[1, j]
            if j == ref_col:
                ax.set_axis_off()
                continue
            im = ax.imshow(
                dl[j], cmap=_DIFF_CMAP, norm=norm, extent=(0, cols, rows, 0),
                interpolation="nearest", origin="upper", aspect="equal",
            )
            _setup_panel(ax, m, ylabels=j == 0 or (j == 1 and ref_col == 0), xlabels=True, sep_colour=(0, 0, 0, 0.3))
            ax.set_title(
                f"\u0394{ylab}: {kappa_label(m.kappa[j], unit=False).split(' (')[0]} \u2212 "
                f"{ref_text.replace('κ = ', '')}",
                fontsize=8,
            )
            if mark_filled and _mark_filled(ax, m.filled[j] | m.reference_filled, _DIFF_FILLED_COLOUR, 0.5):
                any_diff_marked = True
        if im is not None:
            over = bool(np.any(np.abs(dl[shown]) > lim)) if shown else False
            cb = fig.colorbar(
                im, ax=axes[1, :].tolist(), shrink=0.9, aspect=22, pad=0.015,
                extend="both" if over else "neither",
            )
            cb.set_label(f"\u0394{ylab} vs {ref_text} [{unit}]", fontsize=7)
            cb.ax.tick_params(labelsize=6)
            cb.outline.set_linewidth(0.5)

    # legend / notes
    handles = []
    if any_filled:
        handles.append(
            Patch(facecolor="none", edgecolor=_FILLED_COLOUR, hatch="////", label="filled (not measured)")
        )
    if any_diff_marked:
        handles.append(
            Patch(facecolor="none", edgecolor=_DIFF_FILLED_COLOUR, hatch="////", label="difference of a filled sample")
        )
    ref_note = (
        f"reference {ref_text}" + ("" if m.reference_sampled else " (interpolated in \u03ba)")
        if m.reference_kappa == 0.0 else f"reference {ref_text} (0 outside the table's range)"
    )
    expo_note = (
        f"exposure \u00d7{expo:.4g} "
        + (f"(auto: {EXPOSURE_PERCENTILE:g}th percentile of {ylab} \u2192 1)" if how.startswith("auto") else f"({how})")
        + ", sRGB-encoded"
    )
    if show_diff and ref_col is not None:
        lax = axes[1, ref_col]
        lines = [
            "rows: light direction",
            "columns: view direction",
            "grouped by azimuth \u03c6,",
            "elevation \u03b8 inside a group",
            "",
            expo_note.replace(", sRGB", ",\nsRGB").replace(" (", "\n("),
            "",
            "bottom row: " + ref_note,
        ]
        lax.text(0.5, 0.98, "\n".join(lines), ha="center", va="top", fontsize=6.5, transform=lax.transAxes, linespacing=1.35)
        if handles:
            lax.legend(handles=handles, loc="lower center", fontsize=6.5, frameon=False, handlelength=2.2, handleheight=1.4)
    else:
        notes = expo_note + ("; difference " + ref_note if show_diff else "")
        if handles:
            notes = "hatched: filled (not measured) samples; " + notes
        if any_diff_marked and not any_filled:
            notes = "hatched: differences of filled samples; " + notes
        width_chars = max(40, int(fig.get_figwidth() * 19))
        fig.supxlabel(textwrap.fill(notes, width_chars), fontsize=6.5)

    if title is None:
        name = m.material or "CDBRDF"
        title = f"{name}: reflectance per curvature ({'BRDF, sr$^{-1}$' if m.quantity == 'brdf' else 'relative scale'})"
    if title:
        fig.suptitle(title, fontsize=10)
    return fig


# -- slices ---------------------------------------------------------------------------------
def _kappa_colours(ks: NDArray[np.float64]) -> list[Any]:
    from matplotlib import colormaps

    cmap = colormaps["coolwarm"]
    span = float(np.max(np.abs(ks))) if ks.size else 0.0
    out = []
    for k in ks:
        if k == 0 or span == 0:
            out.append("black")
        else:
            # skip the pale middle of the map: |t - 0.5| in [0.15, 0.5]
            t = 0.5 + np.sign(k) * (0.15 + 0.35 * abs(k) / span)
            out.append(cmap(float(np.clip(t, 0, 1))))
    return out


def _continuous_kappa(table: CDBRDF, kappa: float | ArrayLike | None) -> NDArray[np.float64]:
    if kappa is None:
        return np.array(table.kappa)
    try:
        ks = np.array(kappa, dtype=np.float64, ndmin=1)
    except (TypeError, ValueError):
        raise ValueError(f"kappa: cannot be read as numbers: {kappa!r}") from None
    if ks.ndim != 1 or ks.size == 0 or not np.all(np.isfinite(ks)):
        raise ValueError(f"kappa: give one or more finite curvatures (mm^-1), got {kappa!r}")
    return ks


def _check_angle(name: str, value: float, lo: float, hi: float) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name}: expected a number of degrees, got {value!r}") from None
    if not (np.isfinite(v) and lo <= v <= hi):
        raise ValueError(f"{name}: must lie in [{lo:g}, {hi:g}] degrees, got {value!r}")
    return v


def plot_slice(
    table: CDBRDF,
    *,
    theta_l_deg: float = 45.0,
    phi_l_deg: float = 0.0,
    kappa: float | ArrayLike | None = None,
    plane: str = "incidence",
    channel: int | str | None = None,
    n_points: int = 301,
    ax: "Axes | None" = None,
    figsize: tuple[float, float] = (5.5, 3.6),
    dpi: float = 150.0,
) -> "Figure":
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
        raise ValueError(f"plane: {plane!r} is not one of {', '.join(SLICE_PLANES)}")
    tl = _check_angle("theta_l_deg", theta_l_deg, 0.0, 90.0)
    pl = _check_angle("phi_l_deg", phi_l_deg, -720.0, 720.0)
    if int(n_points) < 2:
        raise ValueError(f"n_points: need at least 2, got {n_points!r}")
    ks = _continuous_kappa(table, kappa)
    tmax = float(table.theta_v[-1])
    s = np.linspace(-tmax, tmax, int(n_points))
    d_pos, d_neg = SLICE_PLANES[plane]
    phi_v = np.where(s >= 0, pl + d_pos, pl + d_neg)
    theta_v = np.abs(s)

    if ax is None:
        fig = _new_figure(None, figsize, dpi)
        ax = fig.add_subplot()
    else:
        fig = ax.figure
    colours = _kappa_colours(ks)
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
                ax.scatter(sign * tv[~meas], yy[~meas], s=14, facecolors="white", edgecolors=c, zorder=3, linewidths=0.9)

    ax.axvline(tl, color="0.5", lw=0.6, ls="--")
    ax.axvline(-tl, color="0.5", lw=0.6, ls=":")
    ax.axvline(0, color="0.8", lw=0.5)
    ax.set_xlim(-tmax, tmax)
    ax.set_ylim(bottom=min(0.0, float(np.min(y))))
    side = {"incidence": ("light side", "mirror side"), "perpendicular": ("\u03c6$_l$+270\u00b0", "\u03c6$_l$+90\u00b0")}[plane]
    ax.set_xlabel(f"signed view elevation \u03b8$_v$ [\u00b0]  ({side[0]} \u2190 | \u2192 {side[1]})", fontsize=8)
    unit = "sr$^{-1}$" if table.quantity == "brdf" else "relative"
    what = "luminance Y" if channel is None and table.n_channels == 3 else (
        f"channel {table.channels[_channel_index(channel, table.n_channels, table.channels)]}" if channel is not None else table.channels[0]
    )
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
    fig: "Figure | None" = None,
) -> "Figure":
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
    """
    from matplotlib.colors import Normalize
    from matplotlib.patheffects import withStroke

    if colour not in ("luminance", "rgb"):
        raise ValueError(f"colour: {colour!r} is not one of luminance, rgb")
    if colour == "rgb" and table.n_channels != 3:
        raise ValueError(f"colour: 'rgb' needs 3 channels, the table has {table.n_channels}")
    tl = _check_angle("theta_l_deg", theta_l_deg, 0.0, 90.0)
    pl = _check_angle("phi_l_deg", phi_l_deg, -720.0, 720.0)
    if int(n_theta) < 2 or int(n_phi) < 3:
        raise ValueError("n_theta, n_phi: need at least 2 and 3 samples")
    ks = _continuous_kappa(table, kappa)
    tmax = float(table.theta_v[-1])
    te = np.linspace(0.0, tmax, int(n_theta) + 1)
    pe = np.linspace(0.0, 360.0, int(n_phi) + 1)
    tc = 0.5 * (te[1:] + te[:-1])
    pc = 0.5 * (pe[1:] + pe[:-1])
    vals = table.evaluate(tc[None, :, None], pc[None, None, :], tl, pl, ks[:, None, None])
    n = ks.size
    if fig is None:
        fig = _new_figure(None, (n * panel_size_in + 0.9, panel_size_in + 0.7), dpi)
    axes = [fig.add_subplot(1, n, i + 1, projection="polar") for i in range(n)]
    unit = "sr$^{-1}$" if table.quantity == "brdf" else "relative"
    if colour == "luminance":
        y = luminance(vals, channel=channel, channels=table.channels)
        top = float(np.percentile(y, 99.8))
        norm = Normalize(0.0, top if top > 0 else 1.0)
        mappable = None
        for ax, yk in zip(axes, y):
            mappable = ax.pcolormesh(np.radians(pe), te, yk, cmap=_SEQ_CMAP, norm=norm, shading="flat", rasterized=True)
        what = "luminance Y" if channel is None and table.n_channels == 3 else "value"
        cb = fig.colorbar(
            mappable, ax=axes, shrink=0.8, pad=0.08,
            extend="max" if float(np.max(y)) > norm.vmax else "neither",
        )
        cb.set_label(f"{what} [{unit}]", fontsize=7)
        cb.ax.tick_params(labelsize=6)
    else:
        expo, how = _resolve_exposure(exposure, luminance(vals), table.quantity)
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


def tonemap_srgb8(image: ArrayLike, *, exposure_ev: float = 0.0) -> NDArray[np.uint8]:
    """Linear radiance -> 8-bit sRGB: ``srgb(clip(image * 2**exposure_ev, 0, 1))``.

    NaN and negative values show as black.
    """
    x = np.asarray(image, dtype=np.float64) * 2.0**exposure_ev
    x = np.clip(np.nan_to_num(x, nan=0.0, posinf=1.0, neginf=0.0), 0.0, 1.0)
    return np.rint(srgb_encode(x) * 255.0).astype(np.uint8)


def plot_render_comparison(
    brdf_image: ArrayLike,
    cdbrdf_image: ArrayLike,
    *,
    exposure_ev: float = 0.0,
    title: str | None = None,
    labels: tuple[str, str] = ("(a) plain BRDF (kappa = 0)", "(b) CDBRDF"),
    width_in: float = 12.0,
    fig: "Figure | None" = None,
) -> "Figure":
    """Two renders side by side and their difference (the paper's Figs. 9-10).

    Parameters
    ----------
    brdf_image, cdbrdf_image
        Linear RGB renders ``(H, W, 3)`` of the same scene with the plain BRDF
        and with the CDBRDF.
    exposure_ev
        Exposure in stops applied to both before sRGB encoding.
    title
        Figure title.

    Returns
    -------
    matplotlib.figure.Figure
        Panels (a) BRDF, (b) CDBRDF, (c) heat map of the RGB distance
        ``|CDBRDF - BRDF|`` in linear radiance with a colour bar.
    """
    a = np.asarray(brdf_image, dtype=np.float64)[..., :3]
    b = np.asarray(cdbrdf_image, dtype=np.float64)[..., :3]
    if a.shape != b.shape or a.ndim != 3:
        raise ValueError(
            f"brdf_image, cdbrdf_image: expected two (H, W, 3) images of one shape, got {a.shape} and {b.shape}"
        )
    diff = np.linalg.norm(np.nan_to_num(b - a), axis=-1)
    h, w = diff.shape
    panel_w = width_in / 3.2
    fig = _new_figure(fig, (width_in, panel_w * h / w + (1.0 if title else 0.7)), 150)
    axes = fig.subplots(1, 3)
    fig.set_layout_engine("constrained")
    axes[0].imshow(tonemap_srgb8(a, exposure_ev=exposure_ev))
    axes[0].set_title(labels[0])
    axes[1].imshow(tonemap_srgb8(b, exposure_ev=exposure_ev))
    axes[1].set_title(labels[1])
    vmax = float(np.percentile(diff, 99.5)) or 1e-6
    im = axes[2].imshow(diff, cmap="inferno", vmin=0.0, vmax=vmax)
    axes[2].set_title("(c) |CDBRDF - BRDF|")
    for ax in axes:
        ax.set_xticks([])
        ax.set_yticks([])
    cb = fig.colorbar(im, ax=axes[2], shrink=0.85)
    cb.set_label("RGB distance (linear radiance)")
    if title:
        fig.suptitle(title)
    return fig


def plot_curvature_map(
    surfaces: Sequence[tuple[str, ArrayLike, ArrayLike, ArrayLike]],
    *,
    limit: float | None = None,
    width_in: float = 10.0,
    fig: "Figure | None" = None,
) -> "Figure":
    """Surfaces in 3-D coloured by their signed curvature (red convex, blue concave).

    Parameters
    ----------
    surfaces
        ``(title, vertices (n, 3) mm, faces (m, 3), kappa (n,) mm^-1)`` per panel.
    limit
        Colour-scale limit in mm^-1 (default: the 99th percentile of |kappa|).

    Returns
    -------
    matplotlib.figure.Figure
        One 3-D panel per surface and a shared colour bar.
    """
    from matplotlib import colormaps
    from matplotlib.colors import Normalize
    from matplotlib.cm import ScalarMappable

    if not surfaces:
        raise ValueError("surfaces: give at least one surface")
    ks = [np.asarray(k, dtype=np.float64) for _, _, _, k in surfaces]
    lim = float(limit) if limit is not None else float(np.percentile(np.abs(np.concatenate(ks)), 99)) or 1e-3
    norm = Normalize(-lim, lim)
    cmap = colormaps["RdBu_r"]
    n = len(surfaces)
    fig = _new_figure(fig, (width_in, width_in / n * 0.85 + 0.6), 120)
    for i, (title, v, f, k) in enumerate(surfaces):
        v = np.asarray(v, dtype=np.float64)
        f = np.asarray(f)
        k = np.asarray(k, dtype=np.float64)
        ax = fig.add_subplot(1, n, i + 1, projection="3d")
        face_k = k[f].mean(axis=1)
        tri = ax.plot_trisurf(v[:, 0], v[:, 1], v[:, 2], triangles=f, linewidth=0, antialiased=False,
                              shade=False)
        tri.set_facecolor(cmap(norm(face_k)))
        ax.set_title(title, fontsize=10)
        ax.set_box_aspect((np.ptp(v[:, 0]), np.ptp(v[:, 1]), max(np.ptp(v[:, 2]), 1e-6) * 2))
        ax.view_init(elev=35, azim=-60)
        ax.set_axis_off()
    cb = fig.colorbar(ScalarMappable(norm=norm, cmap=cmap), ax=fig.axes, shrink=0.7, pad=0.02)
    cb.set_label("curvature kappa [mm$^{-1}$]  (> 0 convex, < 0 concave)")
    return fig
