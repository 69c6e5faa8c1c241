"""Figures of tables, captures, renders and the fabric model.

Library calls return arrays (:func:`mosaic_arrays`) or a
:class:`matplotlib.figure.Figure`. Figures are built with
:class:`~matplotlib.figure.Figure` directly: no pyplot, no backend switch, no
global state is touched, so they work headless and inside notebooks alike
(``fig.savefig(path)`` writes PNG, PDF or SVG, :func:`save_figure` does it
atomically; in Jupyter, display ``fig`` itself). Importing this package
imports neither matplotlib nor the fabric model: they are imported by the
functions that draw.

One module per figure kind:

- :mod:`cdbrdf.plot.mosaic`: the paper's Fig. 7 (:func:`mosaic_arrays`,
  :func:`plot_mosaic`);
- :mod:`cdbrdf.plot.slices`: reflectance along a plane (:func:`plot_slice`);
- :mod:`cdbrdf.plot.hemisphere`: polar plots of the view hemisphere
  (:func:`plot_hemisphere`);
- :mod:`cdbrdf.plot.renders`: BRDF vs CDBRDF renders (Figs. 9-10,
  :func:`plot_render_comparison`) and surfaces coloured by curvature
  (:func:`plot_curvature_map`);
- :mod:`cdbrdf.plot.capture`: the samples a capture plan's stands hide
  (:func:`plot_hidden`);
- :mod:`cdbrdf.plot.fabric`: the fabric model against curvature and its weave
  (:func:`plot_kappa_curves`, :func:`plot_weave`).

The colour rules (sRGB, luminance, exposure) live in :mod:`cdbrdf.colour`;
the names re-exported here from it (:func:`srgb_encode`, :func:`auto_exposure`,
:func:`tonemap_srgb8`, :data:`EXPOSURE_PERCENTILE`, :data:`EXPOSURE_MODES`,
:data:`LUMINANCE_WEIGHTS`) are the same objects.

References
----------
Matsufuji, Kawai, "Measurement and Rendering of Curvature Dependent BRDF",
Figs. 7, 9 and 10.
"""

from __future__ import annotations

from ..colour import (
    EXPOSURE_MODES,
    EXPOSURE_PERCENTILE,
    LUMINANCE_WEIGHTS,
    auto_exposure,
    srgb_encode,
    tonemap_srgb8,
)
from ._common import FIGURE_FORMATS, kappa_label, luminance, save_figure
from .capture import plot_hidden
from .fabric import plot_kappa_curves, plot_weave
from .hemisphere import plot_hemisphere
from .mosaic import DIFF_PERCENTILE, KAPPA_ATOL, Mosaic, mosaic_arrays, plot_mosaic
from .renders import displayed_delta_e, plot_curvature_map, plot_render_comparison
from .slices import SLICE_PLANES, plot_slice

__all__ = [
    "Mosaic",
    "mosaic_arrays",
    "plot_mosaic",
    "plot_slice",
    "plot_hemisphere",
    "plot_render_comparison",
    "displayed_delta_e",
    "plot_curvature_map",
    "plot_hidden",
    "plot_kappa_curves",
    "plot_weave",
    "save_figure",
    "tonemap_srgb8",
    "luminance",
    "srgb_encode",
    "auto_exposure",
    "kappa_label",
    "EXPOSURE_PERCENTILE",
    "EXPOSURE_MODES",
    "DIFF_PERCENTILE",
    "FIGURE_FORMATS",
    "KAPPA_ATOL",
    "SLICE_PLANES",
    "LUMINANCE_WEIGHTS",
]
