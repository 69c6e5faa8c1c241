"""Synthetic materials: reflectance models of woven cloth and pile fabrics that depend on bending.

- :mod:`cdbrdf.synth.weave`: weave patterns and the yarn micro-geometry;
- :mod:`cdbrdf.synth.bending`: the yarn geometry of a cloth on a cylinder
  (Peirce 1937); :mod:`cdbrdf.synth.physics`: what bending does, in numbers;
- :mod:`cdbrdf.synth.surface`: integration points on the micro-surface;
- :mod:`cdbrdf.synth.fibre`: per-fibre scattering (Sadeghi et al. 2013);
- :mod:`cdbrdf.synth.cloth`: the cloth's curvature-dependent BRDF and its
  tabulation (:class:`ClothModel`, :class:`ClothParams`);
- :mod:`cdbrdf.synth.pile`: pile fabrics, cut strands or loops on a ground
  (:class:`PileModel`, :class:`PileParams`);
- :mod:`cdbrdf.synth.presets`: ``denim`` and ``shot``, ``velvet`` and ``towel``;
- :mod:`cdbrdf.synth.metrics`: measures of a table (``bend_contrast``);
- :mod:`cdbrdf.synth.convergence`: the integration-error study (the
  figures of the model are in :mod:`cdbrdf.plot.fabric`).

Nothing is computed at import time.
"""

from __future__ import annotations

from .cloth import MODEL_NAME, MODEL_VERSION, ClothModel, ClothParams
from .pile import PILE_KINDS, PileModel, PileParams
from .presets import PRESETS, model, names, params
from .weave import WEAVES, weave_matrix

__all__ = [
    "ClothModel",
    "ClothParams",
    "MODEL_NAME",
    "MODEL_VERSION",
    "PILE_KINDS",
    "PileModel",
    "PileParams",
    "PRESETS",
    "WEAVES",
    "model",
    "names",
    "params",
    "weave_matrix",
]
