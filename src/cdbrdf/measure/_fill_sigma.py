"""The uncertainty of filled samples: checks, the sigma model, its calibration. Private (:mod:`cdbrdf.measure.fill`).

A fill's uncertainty is ``sigma = value * c * sqrt(s0^2 + (alpha x)^2)`` with
``x`` how far the fill reaches (per method), ``s0`` and ``alpha`` fitted by
maximum likelihood to a *check* (measured samples predicted the way the
filled ones were, against their measured values) and ``c >= 1`` the factor
that makes :data:`COVERAGE` of the check's errors lie within 2 sigma (the
errors have heavier tails than a normal law).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__: list[str] = []

#: Fewest check samples a sigma model is fitted to; smaller checks are pooled.
MIN_CHECK_SAMPLES = 30
#: Share of a check's errors the calibrated model holds within 2 sigma.
COVERAGE = 0.95
#: Relative uncertainty given when no check is possible.
UNKNOWN_SIGMA = 1.0
#: Values at or below this are not taken in logarithms.
TINY = 1e-300


@dataclass(frozen=True)
class SigmaModel:
    """``sigma_rel = scale * sqrt(s0^2 + (alpha x)^2)`` with its fit's provenance."""

    s0: float
    alpha: float
    scale: float
    n_check: int
    pooled: str  # which check it was fitted to: "hidden-like", "pooled", "self" or "none"

    def __call__(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        return self.scale * np.sqrt(self.s0**2 + (self.alpha * x) ** 2)

    def doc(self, x_name: str) -> dict[str, Any]:
        """JSON-ready description."""
        return {"sigma_s0": round(self.s0, 6), "sigma_alpha": round(self.alpha, 6), "sigma_scale": round(self.scale, 4),
                "sigma_x": x_name, "check_samples": self.n_check, "check_pooled": self.pooled}


def fit_sigma(x: NDArray[np.float64], e: NDArray[np.float64]) -> tuple[float, float]:
    """Maximum-likelihood ``s0, alpha`` of ``e ~ N(0, s0^2 + (alpha x)^2)`` (Nelder-Mead, deterministic)."""
    from scipy.optimize import minimize

    x = np.abs(np.asarray(x, dtype=np.float64)).ravel()
    e = np.asarray(e, dtype=np.float64).ravel()
    rms = float(np.sqrt(np.mean(e**2)))
    if rms == 0.0:
        return 0.0, 0.0
    xs = float(np.sqrt(np.mean(x**2)))
    if xs == 0.0:  # nothing to scale with: a constant sigma
        return rms, 0.0
    xn = x / xs
    floor = 1e-6 * rms

    def nll(p: NDArray[np.float64]) -> float:
        s0, a = np.exp(p)
        var = s0**2 + (a * xn) ** 2 + floor**2
        return float(np.mean(0.5 * np.log(var) + 0.5 * e**2 / var))

    start = np.log([rms / math.sqrt(2), rms / math.sqrt(2)])
    res = minimize(nll, start, method="Nelder-Mead", options={"xatol": 1e-4, "fatol": 1e-10, "maxiter": 2000})
    s0, a = np.exp(res.x)
    return float(s0), float(a / xs)


def calibrated(x: NDArray[np.float64], e: NDArray[np.float64], pooled: str) -> SigmaModel:
    """The sigma model fitted to ``(x, e)`` and scaled so that :data:`COVERAGE` of ``|e|`` lie within 2 sigma."""
    s0, a = fit_sigma(x, e)
    base = SigmaModel(s0=s0, alpha=a, scale=1.0, n_check=int(e.shape[0]), pooled=pooled)
    sig = base(np.abs(x))
    ratio = np.abs(e) / np.maximum(sig, TINY)
    need = float(np.quantile(ratio, COVERAGE)) / 2.0 if e.size else 1.0
    return SigmaModel(s0=s0, alpha=a, scale=max(1.0, need), n_check=int(e.shape[0]), pooled=pooled)


class Checks:
    """Check errors by (origin, per-sample method code, hidden stand), and the sigma models fitted to them.

    ``origin`` is ``"hidden-like"`` (the samples a stand hides, measured on
    another stand, hidden there too and filled the same way: the fill's own
    regime) or ``"self"`` (every measured sample of the stand from its
    neighbours: used only where the first gives nothing).
    """

    def __init__(self) -> None:
        self.items: dict[tuple[str, int, int], tuple[NDArray[np.float64], NDArray[np.float64]]] = {}

    def add(self, origin: str, code: int, k: int, x: NDArray[np.float64], e: NDArray[np.float64]) -> None:
        """Record reaches ``x`` and log errors ``e`` (``(samples, channels)``) of a check (samples with a
        non-finite value in any channel are left out)."""
        e = np.asarray(e, dtype=np.float64)
        x = np.broadcast_to(np.asarray(x, dtype=np.float64), e.shape)
        ok = np.all(np.isfinite(e) & np.isfinite(x), axis=-1)
        key = (origin, int(code), int(k))
        old = self.items.get(key)
        xs, es = x[ok], e[ok]
        if old is not None:
            xs, es = np.concatenate([old[0], xs]), np.concatenate([old[1], es])
        self.items[key] = (xs, es)

    def count(self, origin: str, code: int, k: int | None = None) -> int:
        """Check samples of an origin and code (at one stand, or all)."""
        return sum(v[1].shape[0] for key, v in self.items.items()
                   if key[0] == origin and key[1] == code and (k is None or key[2] == k))

    def model(self, code: int, k: int) -> SigmaModel:
        """The model of a code at a stand: its hidden-like check, else pooled over the stands, else the self check."""
        levels: Sequence[tuple[str, str, int | None]] = (
            ("hidden-like", "hidden-like", k), ("hidden-like", "pooled", None), ("self", "self", k),
            ("self", "self", None))
        for origin, label, at in levels:
            keys = [key for key in self.items if key[0] == origin and key[1] == code and (at is None or key[2] == at)]
            n = sum(self.items[key][1].shape[0] for key in keys)
            if n >= MIN_CHECK_SAMPLES:
                x = np.concatenate([self.items[key][0] for key in keys])
                e = np.concatenate([self.items[key][1] for key in keys])
                return calibrated(x, e, label)
        return SigmaModel(s0=UNKNOWN_SIGMA, alpha=0.0, scale=1.0, n_check=0, pooled="none")


def log_error(pred: NDArray[np.float64], meas: NDArray[np.float64]) -> NDArray[np.float64]:
    """``log(pred / meas)`` where both are positive, NaN elsewhere."""
    ok = (pred > TINY) & (meas > TINY)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(ok, np.log(np.where(ok, pred, 1.0) / np.where(ok, meas, 1.0)), np.nan)


def reach(value: NDArray[np.float64], first: NDArray[np.float64]) -> NDArray[np.float64]:
    """``|log(value / first)|`` (relative change where a value is not positive)."""
    ok = (value > TINY) & (first > TINY)
    with np.errstate(divide="ignore", invalid="ignore"):
        lg = np.abs(np.log(np.where(ok, value, 1.0) / np.where(ok, first, 1.0)))
        rel = np.abs(value - first) / np.maximum(np.maximum(np.abs(value), np.abs(first)), TINY)
    return np.where(ok, lg, rel)
