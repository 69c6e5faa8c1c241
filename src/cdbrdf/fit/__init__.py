"""Fitting the fabric models' physical parameters to a flat measured BRDF.

- :mod:`cdbrdf.fit.data`: the measurement at fixed direction pairs
  (:class:`FitData`, :func:`sample`);
- :mod:`cdbrdf.fit.models`: the models' free parameters and their physical
  bounds (:data:`FIT_MODELS`: ``woven``, ``pile``, and the analytic baseline
  ``sheen``);
- :mod:`cdbrdf.fit.sheen`: the baseline (Lambert + Charlie sheen);
- :mod:`cdbrdf.fit.core`: the least-squares fit in CIELAB with an
  uncertainty per parameter (:func:`fit`, :class:`FitResult`).

``docs/fabric-model.md`` ("Fitted to real cloth") has the method and the
table over the shared measured fabrics. This package uses the models through
their public parameter sets and ``evaluate`` only; it imports nothing above
:mod:`cdbrdf.synth`.
"""

from __future__ import annotations

from .core import FitResult, errors, fit
from .data import ISOTROPIC_TURNS_DEG, THETA_MAX_DEG, FitData, directions, sample
from .models import FIT_MODELS, WEAVE_CHOICES, FitModel, Parameter, fit_model
from .sheen import SheenParams, sheen_brdf

__all__ = [
    "FIT_MODELS",
    "ISOTROPIC_TURNS_DEG",
    "THETA_MAX_DEG",
    "WEAVE_CHOICES",
    "FitData",
    "FitModel",
    "FitResult",
    "Parameter",
    "SheenParams",
    "directions",
    "errors",
    "fit",
    "fit_model",
    "sample",
    "sheen_brdf",
]
