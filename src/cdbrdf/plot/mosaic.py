"""The paper's Fig. 7 of a :class:`~cdbrdf.table.CDBRDF`: mosaic arrays and figure.

For each curvature the samples are laid out as one image, exactly
:meth:`CDBRDF.fig7 <cdbrdf.table.CDBRDF.fig7>`: rows are light directions,
columns view directions, both grouped by azimuth (groups in azimuth order) with
the elevation increasing inside a group (Matsufuji & Kawai, Fig. 7). With the
paper's grid (12 azimuths x 6 elevations) each image is 72 x 72.

:func:`mosaic_arrays` returns the images, the filled masks (and how each
sample was filled) and the differences against kappa = 0 as arrays
(:class:`Mosaic`); :func:`plot_mosaic` draws them, marking samples filled from
the nearest direction and samples filled along the curvature differently.

Colours
-------
Tables hold linear, scene-referred RGB (Rec. 709 primaries). Display images
are ``srgb_encode(exposure * values)``, clipped to [0, 1]
(:mod:`cdbrdf.colour`). The automatic exposure maps the
:data:`~cdbrdf.colour.EXPOSURE_PERCENTILE`-th percentile of the luminance
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
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..colour import EXPOSURE_PERCENTILE, resolve_exposure, srgb_encode
from ..errors import OptionError, QueryError
from ..schema import FILL_METHOD_CODES
from ..table import CDBRDF
from ._common import channel_index, kappa_label, luminance, new_figure

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure
    from matplotlib.path import Path

__all__ = ["Mosaic", "mosaic_arrays", "plot_mosaic", "KAPPA_ATOL", "DIFF_PERCENTILE", "FILL_MARKS"]

#: Percentile of ``|difference|`` that sets the default difference colour range.
DIFF_PERCENTILE = 99.5

#: Tolerance (mm^-1) when matching a requested curvature to the table's axis.
KAPPA_ATOL = 1e-6

_FILLED_COLOUR = "#ff2bd6"  # magenta: stands out on fabrics and on the diff map
_CURVATURE_COLOUR = "#ffa31a"  # orange: filled along the curvature
_PREDICTED_COLOUR = "#1ad1ff"  # cyan: predicted by a fitted model's change with curvature
_DIFF_FILLED_COLOUR = "#4d4d4d"

#: How filled samples are marked, by the per-sample fill method
#: (:data:`cdbrdf.schema.FILL_METHOD_CODES`): ``(methods, colour, hatch, legend label)``.
FILL_MARKS: tuple[tuple[tuple[str, ...], str, str, str], ...] = (
    (("kappa_fit", "nearest_stand", "model"), _CURVATURE_COLOUR, "\\\\\\",
     "filled along the curvature (same direction, other stands)"),
    (("nearest",), _FILLED_COLOUR, "//////", "filled from the nearest direction (same curvature)"),
    (("model",), _PREDICTED_COLOUR, "......",
     "predicted by a fitted model's change with curvature"),
    (("unknown",), _FILLED_COLOUR, "//////", "filled (not measured)"),
)
_DIFF_CMAP = "RdBu_r"

#: A matplotlib colour: a name or an RGBA tuple.
_Colour = str | tuple[float, float, float, float]


# -- the mosaic arrays -----------------------------------------------------------------
def _fmt_kappas(ks: NDArray[np.float64]) -> str:
    return ", ".join(f"{k:g}" for k in ks)


def _select_kappa(table: CDBRDF, kappa: float | ArrayLike | None) -> NDArray[np.intp]:
    axis = table.kappa
    if kappa is None:
        return np.arange(axis.size)
    try:
        req = np.array(kappa, dtype=np.float64, ndmin=1)
    except (TypeError, ValueError):
        raise OptionError(f"kappa: cannot be read as numbers: {kappa!r}") from None
    if req.ndim != 1 or req.size == 0:
        raise OptionError("kappa: give one or more curvatures (mm^-1)")
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
    fill_method
        ``(n, R, C)`` how each sample was filled: codes of
        :data:`cdbrdf.schema.FILL_METHOD_CODES` (0 measured).
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
    fill_method: NDArray[np.uint8]
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
        """The luminance (or one channel) of :attr:`images`.

        Parameters
        ----------
        channel
            A channel's index or name; None for the luminance.

        Returns
        -------
        numpy.ndarray
            ``(n, R, C)``.
        """
        return luminance(self.images, channel=channel, channels=self.channels)

    def difference_luminance(self, *, channel: int | str | None = None) -> NDArray[np.float64]:
        """The luminance (or one channel) of :attr:`difference`.

        Parameters
        ----------
        channel
            A channel's index or name; None for the luminance.

        Returns
        -------
        numpy.ndarray
            ``(n, R, C)``.
        """
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
    >>> t = cdbrdf.CDBRDF(np.full(g.shape + (3,), 0.2), g)
    >>> m = mosaic_arrays(t, kappa=[0.0, 0.13])
    >>> m.images.shape, m.difference.max()
    ((2, 72, 72, 3), np.float64(0.0))
    """
    if not isinstance(table, CDBRDF):
        raise TypeError(f"table: expected a CDBRDF, got {type(table).__name__}")
    iso = table.isotropic
    if iso:  # shown expanded: each light azimuth's rows are the stored difference axis, turned by one group
        table = table.expanded(max_azimuths=12)
    idx = _select_kappa(table, kappa)
    _, npl, ntl, npv, ntv, nc = table.shape
    rows, cols = npl * ntl, npv * ntv
    images = np.array(table.fig7()[idx])
    filled = ~table.measured.reshape(-1, rows, cols)[idx]
    fill_method = table.fill_method.reshape(-1, rows, cols)[idx]
    k_ref, ref, ref_filled, sampled = _reference(table)
    ref = ref.reshape(rows, cols, nc)
    ref_filled = ref_filled.reshape(rows, cols)
    diff = images.astype(np.float64) - ref[None]
    for a in (images, filled, fill_method, ref, ref_filled, diff):
        a.setflags(write=False)
    return Mosaic(
        kappa=np.array(table.kappa[idx]),
        kappa_index=idx,
        images=images,
        filled=filled,
        fill_method=fill_method,
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
        material=str(table.attrs.get("material", "") or "") + (" [isotropic]" if iso else ""),
    )


# -- figure helpers -----------------------------------------------------------------------
def _display_rgb(
    values: NDArray[np.floating], exposure: float, channel: int | str | None, channels: tuple[str, ...]
) -> NDArray[np.float64]:
    """sRGB display values ``(..., 3)``: the colour, or one channel / the luminance in grey."""
    nc = values.shape[-1]
    if channel is None and nc == 3:
        return srgb_encode(exposure * np.asarray(values, dtype=np.float64))
    y = luminance(values, channel=channel, channels=channels)
    g = srgb_encode(exposure * y)
    return np.repeat(g[..., None], 3, axis=-1)


def _filled_path(mask: NDArray[np.bool_]) -> Path | None:
    """A compound path of the filled pixels (runs merged along rows), pixel units."""
    from matplotlib.path import Path

    verts: list[list[float]] = []
    codes: list[int] = []
    for r in np.flatnonzero(mask.any(axis=1)).tolist():
        row = np.concatenate([[False], mask[r], [False]]).astype(np.int8)
        d = np.diff(row)
        for a, b in zip(np.flatnonzero(d == 1).tolist(), np.flatnonzero(d == -1).tolist(), strict=True):
            verts += [[a, r], [b, r], [b, r + 1], [a, r + 1], [a, r]]
            codes += [int(c) for c in (Path.MOVETO, Path.LINETO, Path.LINETO, Path.LINETO, Path.CLOSEPOLY)]
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


def _mark_filled(ax: Axes, mask: NDArray[np.bool_], colour: str, lw: float, hatch: str = "//////") -> bool:
    """Hatch and outline the filled pixels of a panel; False when there are none."""
    from matplotlib.collections import LineCollection
    from matplotlib.patches import PathPatch

    path = _filled_path(mask)
    if path is None:
        return False
    if hasattr(PathPatch, "set_hatchcolor"):  # matplotlib >= 3.11
        style = {"edgecolor": "none", "hatchcolor": colour, "hatch_linewidth": lw * 0.6}
    else:  # older: the hatch takes the edge colour (the edge itself has width 0)
        style = {"edgecolor": colour}
    ax.add_patch(PathPatch(path, facecolor="none", hatch=hatch, linewidth=0, zorder=3, **style))
    ax.add_collection(
        LineCollection(list(_outline_segments(mask)), colors=colour, linewidths=lw, zorder=4, capstyle="projecting")
    )
    return True


def _mark_fill_methods(ax: Axes, m: Mosaic, j: int) -> list[int]:
    """Mark the filled samples of panel ``j`` by method; the indices of :data:`FILL_MARKS` drawn."""
    used = []
    for r, (methods, colour, hatch, _label) in enumerate(FILL_MARKS):
        sel = np.isin(m.fill_method[j], [FILL_METHOD_CODES[x] for x in methods]) & m.filled[j]
        if _mark_filled(ax, sel, colour, 0.6, hatch):
            used.append(r)
    return used


def _group_axes(
    ax: Axes, n_groups: int, per: int, phis: NDArray[np.float64], which: str, sep_colour: _Colour, label: bool
) -> None:
    """Ticks at the azimuth groups of one axis of a panel, and lines between the groups."""
    from matplotlib.collections import LineCollection

    n = n_groups * per
    bounds = [b * per for b in range(1, n_groups)]
    if per > 1 and n_groups > 1:
        segs: list[list[tuple[float, float]]]
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


def _setup_panel(ax: Axes, m: Mosaic, *, ylabels: bool, xlabels: bool, sep_colour: _Colour) -> None:
    """Limits, group ticks and axis labels of one mosaic panel."""
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
    fig: Figure | None = None,
    panel_size_in: float = 2.7,
    dpi: float = 150.0,
) -> Figure:
    """The paper's Fig. 7: one image per curvature, side by side, shared exposure.

    Top row: for each curvature the ``(n_phi_l*n_theta_l) x (n_phi_v*n_theta_v)``
    image (rows light direction, columns view direction, grouped by azimuth;
    tick labels give the azimuth of each group, thin lines separate groups),
    ``srgb_encode(exposure * values)``. Filled (unmeasured) samples are hatched
    and outlined: in magenta (``//``) those filled from the nearest direction at
    the same curvature (or of unknown method), in orange (``\\``) those filled
    along the curvature from the same direction on other stands
    (:data:`FILL_MARKS`). Bottom row (``diff=True``): signed luminance
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
        Default: the :data:`DIFF_PERCENTILE`-th percentile of ``|difference|`` over
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
    if isinstance(table, Mosaic):
        if kappa is not None:
            raise OptionError("kappa: select curvatures in mosaic_arrays() when passing a Mosaic")
        m = table
    else:
        m = mosaic_arrays(table, kappa=kappa)
    if diff_limit is not None and not (np.isfinite(diff_limit) and diff_limit > 0):
        raise OptionError(f"diff_limit: must be a positive number, got {diff_limit!r}")

    n = m.kappa.size
    lum = m.luminance(channel=channel)
    expo, how = resolve_exposure(exposure, lum, m.quantity)

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
        fig = new_figure(None, (w, h), dpi)
    axes = fig.subplots(nrows, n, squeeze=False)

    marks_used: list[int] = []
    for j in range(n):
        ax = axes[0, j]
        rgb = _display_rgb(m.images[j], expo, channel, m.channels)
        ax.imshow(rgb, extent=(0, cols, rows, 0), interpolation="nearest", origin="upper", aspect="equal")
        _setup_panel(ax, m, ylabels=j == 0, xlabels=not show_diff, sep_colour=(1, 1, 1, 0.55))
        ax.set_title(kappa_label(m.kappa[j]), fontsize=8.5)
        if mark_filled:
            marks_used += [r for r in _mark_fill_methods(ax, m, j) if r not in marks_used]

    unit = "sr$^{-1}$" if m.quantity == "brdf" else "relative units"
    ylab = "Y" if channel is None and len(m.channels) == 3 else (
        m.channels[channel_index(channel, len(m.channels), m.channels)] if channel is not None else m.channels[0]
    )
    ref_text = kappa_label(m.reference_kappa, unit=True).split(" (")[0]
    any_diff_marked = False
    if show_diff:
        any_diff_marked = _difference_row(fig, axes, m, channel=channel, ref_col=ref_col, diff_limit=diff_limit,
                                          labels=(ylab, ref_text, unit), mark_filled=mark_filled)
    _notes(fig, axes, m, marks_used=marks_used, any_diff_marked=any_diff_marked,
           ref_col=ref_col if show_diff else None, show_diff=show_diff, labels=(ylab, ref_text),
           exposure=(expo, how))

    if title is None:
        name = m.material or "CDBRDF"
        title = f"{name}: reflectance per curvature ({'BRDF, sr$^{-1}$' if m.quantity == 'brdf' else 'relative scale'})"
    if title:
        fig.suptitle(title, fontsize=10)
    return fig


def _difference_limit(m: Mosaic, dl: np.ndarray, shown: list[int]) -> float:
    """The difference row's colour range: the :data:`DIFF_PERCENTILE`-th percentile of the measured samples'."""
    # measured samples only: filled ones are copies, their differences artefacts
    both = ~(m.filled | m.reference_filled[None])
    a = np.abs(dl[shown][both[shown]]) if shown else np.zeros(0)
    if a.size == 0 and shown:
        a = np.abs(dl[shown]).ravel()
    lim = float(np.percentile(a, DIFF_PERCENTILE)) if a.size else 0.0
    if not lim > 0:
        lim = float(a.max()) if a.size and a.max() > 0 else 1.0
    return lim


def _difference_row(fig: Figure, axes: Any, m: Mosaic, *, channel: int | str | None, ref_col: int | None,
                    diff_limit: float | None, labels: tuple[str, str, str], mark_filled: bool) -> bool:
    """The bottom row: the luminance difference against the reference, its colour bar; whether it hatched any."""
    from matplotlib.colors import Normalize

    ylab, ref_text, unit = labels
    n = m.kappa.size
    rows, cols = m.images.shape[1:3]
    dl = luminance(m.difference, channel=channel, channels=m.channels)
    shown = [j for j in range(n) if j != ref_col]
    lim = _difference_limit(m, dl, shown) if diff_limit is None else diff_limit
    norm = Normalize(-lim, lim)
    im = None
    marked = False
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
            marked = True
    if im is not None:
        over = bool(np.any(np.abs(dl[shown]) > lim)) if shown else False
        cb = fig.colorbar(
            im, ax=axes[1, :].tolist(), shrink=0.9, aspect=22, pad=0.015,
            extend="both" if over else "neither",
        )
        cb.set_label(f"\u0394{ylab} vs {ref_text} [{unit}]", fontsize=7)
        cb.ax.tick_params(labelsize=6)
        cb.outline.set_linewidth(0.5)
    return marked


def _notes(fig: Figure, axes: Any, m: Mosaic, *, marks_used: list[int], any_diff_marked: bool, ref_col: int | None,
           show_diff: bool, labels: tuple[str, str], exposure: tuple[float, str]) -> None:
    """The legend and the notes: in the reference's empty difference panel, else under the figure."""
    from matplotlib.patches import Patch

    ylab, ref_text = labels
    expo, how = exposure
    handles = []
    for r in sorted(marks_used):
        _methods, colour, hatch, label = FILL_MARKS[r]
        handles.append(Patch(facecolor="none", edgecolor=colour, hatch=hatch[:4], label=label))
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
    if ref_col is not None:
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
        lax.text(0.5, 0.98, "\n".join(lines), ha="center", va="top", fontsize=6.5, transform=lax.transAxes,
                 linespacing=1.35)
        if handles:
            lax.legend(handles=handles, loc="lower center", fontsize=6.5, frameon=False, handlelength=2.2,
                       handleheight=1.4)
        return
    notes = expo_note + ("; difference " + ref_note if show_diff else "")
    if marks_used:
        notes = "hatched: " + ", ".join(
            f"{FILL_MARKS[r][3]} ({'orange' if FILL_MARKS[r][1] == _CURVATURE_COLOUR else 'magenta'})"
            for r in sorted(marks_used)
        ) + "; " + notes
    if any_diff_marked and not marks_used:
        notes = "hatched: differences of filled samples; " + notes
    width_chars = max(40, int(fig.get_figwidth() * 19))
    fig.supxlabel(textwrap.fill(notes, width_chars), fontsize=6.5)
