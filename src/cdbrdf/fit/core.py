"""Fitting a model's physical parameters to a flat measurement: bounded least squares in CIELAB.

The residuals are the CIE 1976 L*a*b* differences (:func:`cdbrdf.colour.linear_to_lab`
of ``pi f``: a white Lambertian surface is L* = 100) between the model and
the measurement at the fit's direction pairs: a perceptual space, in which
the cube root weighs a dark fabric's values as much as a bright one's and a
sheen's grazing peak no more than it is seen. They are minimised within the
parameters' physical bounds by :func:`scipy.optimize.least_squares`
(trust-region reflective). The Jacobian is taken by finite differences of the
model's RGB (chained through the analytic derivative of L*a*b*); a colour's
three channels are stepped together, since each changes only its own channel
of the BRDF, so a colour costs one model evaluation, not three (the models'
channels are independent: ``tests/test_fit.py`` checks it).

Uncertainty of each parameter: from the Jacobian at the optimum, ``sigma =
sqrt(diag((J^T J)^-1) s^2)`` with ``s^2`` the residual variance (sum of
squares over ``m - p``), over the parameters not held by a bound (one at a
bound is reported as such, without a sigma). ``s`` is dominated by what the
model cannot represent rather than by measurement noise, so these are formal
uncertainties: how well the measurement pins each parameter down given the
model, with residuals taken as independent.

The fit's error (:func:`errors`) is measured with the model at its full
integration quality on separate direction pairs: the relative RMS difference
``sqrt(mean (f_model - f)^2) / sqrt(mean f^2)`` over directions and channels
and the median (and 90th percentile) Delta E*ab.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..colour import D65_WHITE_XYZ, RGB_TO_XYZ, delta_e_ab, linear_to_lab
from ..errors import OptionError
from .data import FitData
from .models import FitModel, Parameter, fit_model

__all__ = ["FitResult", "fit", "errors", "lab_jacobian", "DEFAULT_MAX_EVALUATIONS"]

log = logging.getLogger(__name__)

#: Model evaluations one fit may take by default (a Jacobian by finite differences costs one per
#: parameter and one per colour; Broyden's updates between them none).
DEFAULT_MAX_EVALUATIONS = 40
#: Broyden updates of the Jacobian between two by finite differences.
_REFRESH = 8
_LAB_EPSILON = 216.0 / 24389.0
_LAB_KAPPA = 24389.0 / 27.0


def lab_jacobian(rgb: NDArray[np.float64]) -> NDArray[np.float64]:
    """``d(L*, a*, b*) / d(R, G, B)`` of :func:`cdbrdf.colour.linear_to_lab` at linear RGB ``(n, 3)``: ``(n, 3, 3)``."""
    t = (np.asarray(rgb, dtype=np.float64) @ RGB_TO_XYZ.T) / D65_WHITE_XYZ
    df = np.where(t > _LAB_EPSILON, np.cbrt(np.maximum(t, _LAB_EPSILON)) ** -2 / 3.0, _LAB_KAPPA / 116.0)
    df = df / D65_WHITE_XYZ  # d f(X/Xn) / dX, per component
    d = np.zeros(t.shape[:-1] + (3, 3))
    d[..., 0, 1] = 116.0 * df[..., 1]
    d[..., 1, 0], d[..., 1, 1] = 500.0 * df[..., 0], -500.0 * df[..., 1]
    d[..., 2, 1], d[..., 2, 2] = 200.0 * df[..., 1], -200.0 * df[..., 2]
    return d @ RGB_TO_XYZ


@dataclass(frozen=True, eq=False)
class FitResult:
    """A fitted model.

    Attributes
    ----------
    model
        The fit model's name (:data:`cdbrdf.fit.FIT_MODELS`).
    description
        What the model is.
    values
        Fitted value of each free parameter (a colour as three numbers).
    sigma
        Its uncertainty (one standard deviation, same units; ``None`` for a
        parameter at a bound).
    bounds
        Each parameter's ``[lower, upper]`` and the reason for them.
    at_bound
        The parameters that ended at a bound.
    fixed
        What was held fixed and why.
    model_params
        The model's whole parameter set (to rebuild it).
    errors
        ``{"fit": ..., "test": ...}``: :func:`errors` at the fit's pairs and at separate ones.
    evaluations, seconds, message
        Model evaluations taken, time, the solver's message.
    """

    model: str
    description: str
    values: dict[str, Any]
    sigma: dict[str, Any]
    bounds: dict[str, Any]
    at_bound: tuple[str, ...]
    fixed: dict[str, Any]
    model_params: dict[str, Any]
    errors: dict[str, Any]
    evaluations: int
    seconds: float
    message: str
    fit_model: FitModel = field(repr=False)

    def build(self) -> Any:
        """The fitted model at its full integration quality."""
        return self.fit_model.build(self.values, quality="full")

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready record (for a file's provenance)."""
        return {"model": self.model, "description": self.description, "values": self.values, "sigma": self.sigma,
                "bounds": self.bounds, "at_bound": list(self.at_bound), "fixed": self.fixed,
                "model_params": self.model_params, "errors": self.errors, "evaluations": self.evaluations,
                "seconds": round(self.seconds, 2), "message": self.message,
                "space": "CIE 1976 L*a*b* of pi f (white = 1), least squares within physical bounds"}


class _Problem:
    """The residuals and their Jacobian for one model and one measurement, with a cache of model evaluations."""

    def __init__(self, fm: FitModel, data: FitData) -> None:
        self.fm, self.data = fm, data
        self.layout: list[tuple[Parameter, slice]] = []
        i = 0
        for p in fm.parameters:
            self.layout.append((p, slice(i, i + p.channels)))
            i += p.channels
        self.size = i
        self.lower = np.concatenate([np.full(p.channels, p.bounds()[0]) for p in fm.parameters])
        self.upper = np.concatenate([np.full(p.channels, p.bounds()[1]) for p in fm.parameters])
        self.target = linear_to_lab(math.pi * data.values)
        self._cache: dict[bytes, NDArray[np.float64]] = {}
        self.evaluations = 0
        self.broyden_steps = 0
        self._last: tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]] | None = None

    def pack(self, values: Mapping[str, Any]) -> NDArray[np.float64]:
        x = np.concatenate([np.atleast_1d(p.to_internal(np.asarray(values[p.name], dtype=np.float64)))
                            for p, _ in self.layout])
        return np.clip(x, self.lower, self.upper)

    def values(self, x: NDArray[np.float64]) -> dict[str, Any]:
        out: dict[str, Any] = {}
        for p, sl in self.layout:
            v = p.to_physical(np.clip(x[sl], self.lower[sl], self.upper[sl]))
            v = np.clip(v, p.lower, p.upper)
            out[p.name] = tuple(float(a) for a in v) if p.channels > 1 else float(v[0])
        return out

    def rgb(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        key = np.round(np.asarray(x, dtype=np.float64), 12).tobytes()
        hit = self._cache.get(key)
        if hit is None:
            hit = np.maximum(self.fm.evaluate(self.values(x), self.data, quality="fit"), 0.0)
            self.evaluations += 1
            if len(self._cache) > 256:
                self._cache.clear()
            self._cache[key] = hit
        return hit

    def residuals(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        return (linear_to_lab(math.pi * self.rgb(x)) - self.target).ravel()

    def _step(self, p: Parameter, x: NDArray[np.float64], sl: slice) -> NDArray[np.float64]:
        lo, hi = p.bounds()
        h = (0.05 if p.log else (0.01 if p.channels > 1 else 0.02) * (hi - lo)) * np.ones(p.channels)
        return np.where(x[sl] + h <= hi, h, -h)

    def finite_differences(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        """The Jacobian of the residuals by finite differences (one evaluation per parameter and per colour)."""
        rgb0 = self.rgb(x)
        n = rgb0.shape[0]
        g = np.zeros((n, 3, self.size))
        for p, sl in self.layout:
            h = self._step(p, x, sl)
            x1 = x.copy()
            x1[sl] += h
            d = self.rgb(x1) - rgb0
            if p.channels == 3:  # each channel of the colour changes its own channel only
                for c in range(3):
                    g[:, c, sl.start + c] = d[:, c] / h[c]
            else:
                g[:, :, sl.start] = d / h[0]
        jl = lab_jacobian(math.pi * rgb0) * math.pi  # (n, 3 lab, 3 rgb)
        return np.einsum("nkc,ncp->nkp", jl, g).reshape(3 * n, self.size)

    def jacobian(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        """The solver's Jacobian: finite differences first and every :data:`_REFRESH` steps, Broyden's update between.

        Broyden's rank-one update (from the last point, with the residuals
        the solver has already evaluated) costs no model evaluation; the
        finite differences cost one per parameter and colour.
        """
        r = self.residuals(x)
        if self._last is not None and self.broyden_steps < _REFRESH:
            x0, r0, j0 = self._last
            dx = x - x0
            dd = float(dx @ dx)
            if dd > 0:
                j = j0 + np.outer(r - r0 - j0 @ dx, dx) / dd
                self.broyden_steps += 1
                self._last = (x.copy(), r, j)
                return j
        j = self.finite_differences(x)
        self.broyden_steps = 0
        self._last = (x.copy(), r, j)
        return j


def errors(fm: FitModel, values: Mapping[str, Any], data: FitData, *, quality: str = "full") -> dict[str, Any]:
    """How far the model with ``values`` is from the measurement at ``data``'s pairs.

    Returns
    -------
    dict
        ``relative_rms`` (``sqrt(mean (f_model - f)^2) / sqrt(mean f^2)`` over
        pairs and channels), ``delta_e_median``, ``delta_e_p90`` (Delta E*ab of
        ``pi f``), ``pairs``.
    """
    pred = fm.evaluate(values, data, quality=quality)
    meas = data.values
    rms = float(np.sqrt(np.mean((pred - meas) ** 2)) / max(float(np.sqrt(np.mean(meas**2))), 1e-30))
    de = delta_e_ab(linear_to_lab(math.pi * pred), linear_to_lab(math.pi * meas))
    return {"relative_rms": round(rms, 5), "delta_e_median": round(float(np.median(de)), 3),
            "delta_e_p90": round(float(np.quantile(de, 0.9)), 3), "pairs": int(data.n), "quality": quality}


def _uncertainty(prob: _Problem, x: NDArray[np.float64], jac: NDArray[np.float64], res: NDArray[np.float64],
                 active: NDArray[np.int_]) -> tuple[dict[str, Any], tuple[str, ...]]:
    """Per-parameter sigma (physical units) from the Jacobian at the optimum; parameters at a bound get None."""
    free = active == 0
    m, k = jac.shape[0], int(np.count_nonzero(free))
    s2 = float(res @ res) / max(m - k, 1)
    var = np.full(x.size, np.nan)
    if k:
        jf = jac[:, free]
        cov = np.linalg.pinv(jf.T @ jf, rcond=1e-12) * s2
        var[free] = np.clip(np.diag(cov), 0.0, None)
    sig_u = np.sqrt(var)
    sigma: dict[str, Any] = {}
    at_bound: list[str] = []
    for p, sl in prob.layout:
        u = x[sl]
        phys = p.to_physical(u)
        s = sig_u[sl] * (phys if p.log else 1.0)  # the delta method for a logarithm
        items = [None if not free[i] else round(float(s[j]), 6) for j, i in enumerate(range(sl.start, sl.stop))]
        if not all(free[sl]):
            at_bound.append(p.name)
        sigma[p.name] = items if p.channels > 1 else items[0]
    return sigma, tuple(at_bound)


def fit(data: FitData, model: str | FitModel = "woven", *, test: FitData | None = None,
        max_evaluations: int = DEFAULT_MAX_EVALUATIONS, start: Mapping[str, Any] | None = None) -> FitResult:
    """Fit a model's free parameters to a flat measurement (see the module's description).

    Parameters
    ----------
    data
        The measurement at the fit's pairs (:func:`cdbrdf.fit.sample`).
    model
        A name of :data:`cdbrdf.fit.FIT_MODELS` or a :class:`~cdbrdf.fit.FitModel`.
    test
        Other pairs of the same measurement for the error; default: ``data``.
    max_evaluations
        Most model evaluations (each Jacobian costs one per parameter and
        colour); the solver stops there (the message says so).
    start
        Starting values (default: the model's guess from the measurement).

    Returns
    -------
    FitResult
        The values, their uncertainties, the errors and what was fixed.
    """
    from scipy.optimize import least_squares

    fm = fit_model(model) if isinstance(model, str) else model
    if not isinstance(fm, FitModel):
        raise OptionError(f"model: expected a fit model name or FitModel, got {type(model).__name__}")
    if not (isinstance(max_evaluations, int) and max_evaluations >= 2):
        raise OptionError(f"max_evaluations: expected an integer >= 2, got {max_evaluations!r}")
    t0 = time.perf_counter()
    prob = _Problem(fm, data)
    x0 = prob.pack(start if start is not None else fm.initial(data))
    width = len(fm.parameters) + 1  # evaluations of one Jacobian by finite differences
    nfev = max(2, max_evaluations - 2 * width)
    sol = least_squares(prob.residuals, x0, jac=prob.jacobian, bounds=(prob.lower, prob.upper), method="trf",
                        x_scale="jac", max_nfev=nfev, ftol=1e-3, xtol=1e-4, gtol=1e-6)
    values = prob.values(sol.x)
    jac = prob.finite_differences(sol.x)  # the uncertainty needs the true Jacobian at the optimum
    sigma, at_bound = _uncertainty(prob, sol.x, jac, prob.residuals(sol.x), np.asarray(sol.active_mask))
    errs = {"fit": errors(fm, values, data, quality="fit"),
            "test": errors(fm, values, test if test is not None else data)}
    bounds = {p.name: {"lower": p.lower, "upper": p.upper, "unit": p.unit, "why": p.why} for p in fm.parameters}
    dt = time.perf_counter() - t0
    log.info("fitted %s in %.1f s (%d evaluations): median Delta E*ab %.2f, relative RMS %.3f", fm.name, dt,
             prob.evaluations, errs["test"]["delta_e_median"], errs["test"]["relative_rms"])
    return FitResult(model=fm.name, description=fm.description, values=values, sigma=sigma, bounds=bounds,
                     at_bound=at_bound, fixed=fm.fixed, model_params=fm.model_params(values), errors=errs,
                     evaluations=prob.evaluations, seconds=dt, message=str(sol.message), fit_model=fm)
