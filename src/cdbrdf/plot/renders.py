"""Figures of renders: BRDF vs CDBRDF side by side (the paper's Figs. 9-10) and curvature maps.

The difference of two renders is drawn as a textile team reads it: the
colour difference of the two pictures as they are shown (exposed,
tone-mapped to 8-bit sRGB, then CIE L*a*b* under D65:
:func:`cdbrdf.colour.srgb_to_lab`), CIEDE2000 by default
(:data:`cdbrdf.colour.DELTA_E_METRICS`), with a colour bar that names the metric.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike

from ..colour import DELTA_E_METRICS, srgb_to_lab, tonemap_srgb8
from ..colour import delta_e as colour_difference
from ..errors import OptionError
from ._common import new_figure

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.figure import Figure

__all__ = ["DELTA_E_LABELS", "DELTA_E_FLOOR", "plot_render_comparison", "plot_curvature_map", "displayed_delta_e"]

#: How a figure names each metric of :data:`cdbrdf.colour.DELTA_E_METRICS` (a colour bar's label).
DELTA_E_LABELS: dict[str, str] = {
    "2000": "CIEDE2000 $\\Delta E_{00}$",
    "2000-textiles": "CIEDE2000 (2:1:1) $\\Delta E_{00}$",
    "ab": "CIE 1976 $\\Delta E^*_{ab}$",
}

#: The least top of a heat map's scale, per metric: about a just-noticeable difference, so that
#: two pictures no one can tell apart stay dark (1 for CIEDE2000, 2.3 for Delta E*ab).
DELTA_E_FLOOR: dict[str, float] = {"2000": 1.0, "2000-textiles": 1.0, "ab": 2.3}


def displayed_delta_e(image_a: ArrayLike, image_b: ArrayLike, *, exposure_ev: float = 0.0,
                      metric: str = "2000") -> np.ndarray:
    """Per-pixel colour difference of two linear renders as they are shown.

    Each is exposed and tone-mapped to 8-bit sRGB
    (:func:`cdbrdf.colour.tonemap_srgb8`), converted to CIE L*a*b* (D65,
    :func:`cdbrdf.colour.srgb_to_lab`) and compared by ``metric``
    (:func:`cdbrdf.colour.delta_e`).

    Parameters
    ----------
    image_a, image_b
        Linear RGB ``(H, W, 3)`` (more channels are ignored), of one shape.
    exposure_ev
        The exposure both are shown at, stops.
    metric
        A key of :data:`cdbrdf.colour.DELTA_E_METRICS`.

    Returns
    -------
    numpy.ndarray
        ``(H, W)`` float64.
    """
    a = np.asarray(image_a, dtype=np.float64)[..., :3]
    b = np.asarray(image_b, dtype=np.float64)[..., :3]
    if a.shape != b.shape or a.ndim != 3:
        raise OptionError(f"images: expected two (H, W, 3) images of one shape, got {a.shape} and {b.shape}")
    if metric not in DELTA_E_METRICS:
        raise OptionError(f"delta E metric: {metric!r:.40} is not one of {', '.join(DELTA_E_METRICS)}")
    lab_a = srgb_to_lab(tonemap_srgb8(a, exposure_ev=exposure_ev))
    lab_b = srgb_to_lab(tonemap_srgb8(b, exposure_ev=exposure_ev))
    return colour_difference(lab_a, lab_b, metric=metric)


def plot_render_comparison(
    brdf_image: ArrayLike,
    cdbrdf_image: ArrayLike,
    *,
    exposure_ev: float = 0.0,
    title: str | None = None,
    labels: tuple[str, str] = ("(a) plain BRDF (kappa = 0)", "(b) CDBRDF"),
    width_in: float = 12.0,
    swatches: Any = None,
    delta_e: str = "2000",
    fig: Figure | None = None,
) -> Figure:
    """Two renders side by side and their colour difference as shown (the paper's Figs. 9-10).

    Parameters
    ----------
    brdf_image, cdbrdf_image
        Linear RGB renders ``(H, W, 3)`` of the same scene with the plain BRDF
        and with the CDBRDF.
    exposure_ev
        Exposure in stops applied to both before sRGB encoding.
    title
        Figure title.
    labels
        Titles of panels (a) and (b).
    width_in
        Width of a new figure, inches.
    swatches
        A :class:`cdbrdf.render.CrestContrast` of the two renders: a row of
        colour swatches under the panels, the mean colour of each render at
        the convex crests and where the surface is flat, with the median
        Delta E*ab of each region.
    delta_e
        The metric of panel (c), a key of :data:`cdbrdf.colour.DELTA_E_METRICS`:
        ``"2000"`` (CIEDE2000, the default), ``"2000-textiles"`` or ``"ab"``
        (CIE 1976 Delta E*ab).
    fig
        Draw into this (empty) figure instead of a new one.

    Returns
    -------
    matplotlib.figure.Figure
        Panels (a) BRDF, (b) CDBRDF, (c) heat map of the colour difference
        of (a) and (b) as shown (:func:`displayed_delta_e`), from 0 to its
        99.5th percentile (at least :data:`DELTA_E_FLOOR`), with a colour bar
        labelled with the metric (:data:`DELTA_E_LABELS`); with
        ``swatches``, the row of swatches under them.
    """
    a = np.asarray(brdf_image, dtype=np.float64)[..., :3]
    b = np.asarray(cdbrdf_image, dtype=np.float64)[..., :3]
    if a.shape != b.shape or a.ndim != 3:
        raise OptionError(
            f"brdf_image, cdbrdf_image: expected two (H, W, 3) images of one shape, got {a.shape} and {b.shape}"
        )
    diff = displayed_delta_e(a, b, exposure_ev=exposure_ev, metric=delta_e)
    h, w = diff.shape
    panel_w = width_in / 3.2
    extra = 0.9 if swatches is not None else 0.0
    fig = new_figure(fig, (width_in, panel_w * h / w + (1.0 if title else 0.7) + extra), 150)
    fig.set_layout_engine("constrained")
    if swatches is not None:
        subs: Any = fig.subfigures(2, 1, height_ratios=[panel_w * h / w + 0.5, extra])
        top, bottom = subs[0], subs[1]
        axes = top.subplots(1, 3)
        _draw_swatches(bottom, swatches, labels)
    else:
        axes = fig.subplots(1, 3)
    axes[0].imshow(tonemap_srgb8(a, exposure_ev=exposure_ev))
    axes[0].set_title(labels[0])
    axes[1].imshow(tonemap_srgb8(b, exposure_ev=exposure_ev))
    axes[1].set_title(labels[1])
    vmax = max(float(np.percentile(diff, 99.5)), DELTA_E_FLOOR[delta_e])
    im = axes[2].imshow(diff, cmap="inferno", vmin=0.0, vmax=vmax)
    axes[2].set_title(f"(c) {DELTA_E_LABELS[delta_e].split(' $')[0]}: CDBRDF vs BRDF")
    for ax in axes:
        ax.set_xticks([])
        ax.set_yticks([])
    cb = fig.colorbar(im, ax=axes[2], shrink=0.85)
    cb.set_label(DELTA_E_LABELS[delta_e] + " (as shown)")
    if title:
        fig.suptitle(title)
    return fig


def _draw_swatches(fig: Any, contrast: Any, labels: tuple[str, str]) -> None:
    """Crest and flat swatches, plain BRDF beside CDBRDF, with their Delta E*ab."""
    regions = [("crest", contrast.crest_srgb, contrast.crest_delta_e,
                f"convex crests (kappa >= {contrast.crest_fraction * contrast.kappa_max:.2g} / mm)"),
               ("flat", contrast.flat_srgb, contrast.flat_delta_e,
                f"flat (|kappa| <= {contrast.flat_fraction * contrast.kappa_max:.2g} / mm)")]
    axes = fig.subplots(1, len(regions))
    for ax, (_, colours, de, what) in zip(axes, regions, strict=True):
        ax.set_xticks([])
        ax.set_yticks([])
        if not colours:
            ax.set_axis_off()
            continue
        strip = np.array([[colours["brdf"], colours["cdbrdf"]]], dtype=np.float64)
        ax.imshow(np.clip(strip, 0.0, 1.0), aspect="auto", extent=(0, 2, 0, 1))
        for x, label in ((0.5, labels[0].split(" ")[0]), (1.5, labels[1].split(" ")[0])):
            ax.text(x, 0.5, label, ha="center", va="center", fontsize=9,
                    color="white" if float(np.mean(strip)) < 0.5 else "black")
        ax.set_title(f"{what}: Delta E*ab {de:.1f}", fontsize=9)


def plot_curvature_map(
    surfaces: Sequence[tuple[str, ArrayLike, ArrayLike, ArrayLike]],
    *,
    limit: float | None = None,
    width_in: float = 10.0,
    fig: Figure | None = None,
) -> Figure:
    """Surfaces in 3-D coloured by their signed curvature (red convex, blue concave).

    Parameters
    ----------
    surfaces
        ``(title, vertices (n, 3) mm, faces (m, 3), kappa (n,) mm^-1)`` per panel.
    limit
        Colour-scale limit in mm^-1 (default: the 99th percentile of ``|kappa|``).
    width_in
        Width of a new figure, inches.
    fig
        Draw into this (empty) figure instead of a new one.

    Returns
    -------
    matplotlib.figure.Figure
        One 3-D panel per surface and a shared colour bar.
    """
    from matplotlib import colormaps
    from matplotlib.cm import ScalarMappable
    from matplotlib.colors import Normalize

    if not surfaces:
        raise OptionError("surfaces: give at least one surface")
    ks = [np.asarray(k, dtype=np.float64) for _, _, _, k in surfaces]
    lim = float(limit) if limit is not None else float(np.percentile(np.abs(np.concatenate(ks)), 99)) or 1e-3
    norm = Normalize(-lim, lim)
    cmap = colormaps["RdBu_r"]
    n = len(surfaces)
    fig = new_figure(fig, (width_in, width_in / n * 0.85 + 0.6), 120)
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
