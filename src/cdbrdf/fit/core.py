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

__all__ = ["FitResult", "fit", "errors", "lab_jacobian"]

log = logging.getLogger(__name__)

#: Broyden updates of the Jacobian between two by finite differences.
_REFRESH = 3
_LAB_EPSILON = 216.0 / 24389.0
_LAB_KAPPA = 24389.0 / 27.0


def lab_jacobian(rgb: NDArray[np.float64]) -> NDArray[np.float64]:
    """The derivative of :func:`cdbrdf.colour.linear_to_lab` with respect to linear RGB.

    Parameters
    ----------
    rgb
        Linear Rec. 709 RGB, ``(n, 3)``.

    Returns
    -------
    numpy.ndarray
        ``d(L*, a*, b*) / d(R, G, B)``, ``(n, 3, 3)``.
    """
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
        """The fitted model at its full integration quality.

        Returns
        -------
        object
            A :class:`~cdbrdf.synth.ClothModel`, :class:`~cdbrdf.synth.PileModel` or the baseline
            (each with ``evaluate`` and, the fabric models, ``tabulate``).
        """
        return self.fit_model.build(self.values, quality="full")

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready record (for a file's provenance).

        Returns
        -------
        dict
            Every attribute but the fit model, and the fit's space.
        """
        return {"model": self.model, "description": self.description, "values": self.values, "sigma": self.sigma,
                "bounds": self.bounds, "at_bound": list(self.at_bound), "fixed": self.fixed,
                "model_params": self.model_params, "errors": self.errors, "evaluations": self.evaluations,
                "seconds": round(self.seconds, 2), "message": self.message,
                "space": "CIE 1976 L*a*b* of pi f (white = 1), least squares within physical bounds"}


class _BudgetSpent(Exception):
    """The solver asked for a model evaluation beyond the budget (internal: the best point so far is kept)."""


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
        #: Evaluations after which Jacobians are Broyden's only (the solver's own budget is the caller's).
        self.budget = 1 << 30
        self.width = _width(fm)
        self.broyden_steps = 0
        #: Whether the solver may still evaluate the model (the finite differences of restart() always may).
        self.capped = False
        self.best: tuple[float, NDArray[np.float64]] | None = None
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
            if self.capped and self.evaluations >= self.budget - self.width:
                raise _BudgetSpent
            hit = np.maximum(self.fm.evaluate(self.values(x), self.data, quality="fit"), 0.0)
            self.evaluations += 1
            if len(self._cache) > 256:
                self._cache.clear()
            self._cache[key] = hit
        return hit

    def residuals(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        r = (linear_to_lab(math.pi * self.rgb(x)) - self.target).ravel()
        cost = 0.5 * float(r @ r)
        if self.best is None or cost < self.best[0]:
            self.best = (cost, np.array(x, dtype=np.float64))
        return r

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
            if p.channels == 3 and self.fm.channels_independent:  # each channel changes its own channel only
                x1 = x.copy()
                x1[sl] += h
                d = self.rgb(x1) - rgb0
                for c in range(3):
                    g[:, c, sl.start + c] = d[:, c] / h[c]
                continue
            for j in range(p.channels):
                x1 = x.copy()
                x1[sl.start + j] += h[j]
                g[:, :, sl.start + j] = (self.rgb(x1) - rgb0) / h[j]
        jl = lab_jacobian(math.pi * rgb0) * math.pi  # (n, 3 lab, 3 rgb)
        return np.einsum("nkc,ncp->nkp", jl, g).reshape(3 * n, self.size)

    def restart(self, x: NDArray[np.float64]) -> None:
        """Take the finite-difference Jacobian at ``x`` as the next one the solver gets."""
        self._last = (x.copy(), self.residuals(x), self.finite_differences(x))
        self.broyden_steps = -1

    def jacobian(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        """The solver's Jacobian: finite differences first and every :data:`_REFRESH` steps, Broyden's update between.

        Broyden's rank-one update (from the last point, with the residuals
        the solver has already evaluated) costs no model evaluation; the
        finite differences cost one per parameter and colour.
        """
        r = self.residuals(x)
        spent = self.evaluations + 2 * self.width > self.budget  # one Jacobian is kept for the uncertainty
        if self._last is not None and (self.broyden_steps < _REFRESH or spent):
            x0, r0, j0 = self._last
            dx = x - x0
            dd = float(dx @ dx)
            if dd == 0 and self.broyden_steps == -1:  # the finite differences of restart() at this very point
                self.broyden_steps = 0
                return j0
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

    Parameters
    ----------
    fm
        The fit model.
    values
        Its free parameters' values.
    data
        The measurement at direction pairs.
    quality
        ``"full"`` (the model's own integration) or ``"fit"`` (the coarse setting of the fit).

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


def _solve(prob: _Problem, x0: NDArray[np.float64], budget: int) -> tuple[NDArray[np.float64], NDArray[np.int_], str]:
    """Trust-region least squares, restarted from its solution with a fresh Jacobian while that still helps.

    Broyden's updates (:meth:`_Problem.jacobian`) can make the solver stop
    early on a stale Jacobian; the finite differences at its solution (which
    the uncertainty needs anyway) restart it, until the cost falls by less
    than 1 % or the budget of model evaluations is spent.
    """
    from scipy.optimize import least_squares

    width = prob.width
    prob.budget = budget
    x = x0
    cost = 0.5 * float(np.sum(prob.residuals(x) ** 2))
    active = np.zeros(x.size, dtype=int)
    message = "no step taken: the budget of model evaluations is spent"
    for _ in range(8):
        if budget - prob.evaluations - width < 2:
            break
        prob.capped = True
        try:
            sol = least_squares(prob.residuals, x, jac=prob.jacobian, bounds=(prob.lower, prob.upper), method="trf",
                                x_scale="jac", ftol=1e-3, xtol=1e-4, gtol=1e-6)
            x, active, message, new_cost = sol.x, np.asarray(sol.active_mask), str(sol.message), float(sol.cost)
        except _BudgetSpent:
            assert prob.best is not None
            new_cost, x = prob.best
            span = prob.upper - prob.lower
            active = np.where(x <= prob.lower + 1e-9 * span, -1, np.where(x >= prob.upper - 1e-9 * span, 1, 0))
            message = "the budget of model evaluations is spent"
        prob.capped = False
        prob.restart(x)
        if new_cost > 0.99 * cost or message.startswith("the budget"):
            break
        cost = new_cost
    return x, active, message


def _width(fm: FitModel) -> int:
    """Model evaluations of one Jacobian by finite differences (the point itself included)."""
    return 1 + sum(1 if p.channels == 1 or fm.channels_independent else p.channels for p in fm.parameters)


def _probe(prob: _Problem, x0: NDArray[np.float64], budget: int) -> NDArray[np.float64]:
    """The best point of one short solver run within ``budget`` model evaluations (no restarts)."""
    from scipy.optimize import least_squares

    prob.budget = budget + prob.width  # the cap of rgb() is budget - width
    prob.capped = True
    try:
        x = least_squares(prob.residuals, x0, jac=prob.jacobian, bounds=(prob.lower, prob.upper), method="trf",
                          x_scale="jac", ftol=1e-3, xtol=1e-4, gtol=1e-6).x
    except _BudgetSpent:
        assert prob.best is not None
        x = prob.best[1]
    prob.capped = False
    return x


def _choose(fm: FitModel, data: FitData, start: Mapping[str, Any] | None,
            budget: int) -> tuple[FitModel, _Problem, NDArray[np.float64], NDArray[np.int_], str, int, dict[str, Any]]:
    """The model's variant to fit in full: each probed with a short fit (half the budget over them all).

    Returns the variant, its problem and the probe's result, the evaluations
    the other probes spent, and each probe's median Delta E*ab (at the fit's
    pairs) by the variant's distinguishing name.
    """
    variants = fm.variants()
    if len(variants) == 1:
        prob = _Problem(variants[0], data)
        x0 = prob.pack(start if start is not None else variants[0].initial(data))
        return variants[0], prob, x0, np.zeros(x0.size, dtype=int), "", 0, {}
    share = max(_width(variants[0]) + 2, budget // (2 * len(variants)))
    trials = []
    for v in variants:
        prob = _Problem(v, data)
        x = _probe(prob, prob.pack(start if start is not None else v.initial(data)), share)
        trials.append((0.5 * float(np.sum(prob.residuals(x) ** 2)), v, prob, x, np.zeros(x.size, dtype=int), ""))
    cost, v, prob, x, active, message = min(trials, key=lambda t: t[0])
    spent = sum(t[2].evaluations for t in trials) - prob.evaluations
    probes = {t[1].label: round(float(np.median(delta_e_ab(
        linear_to_lab(math.pi * t[2].rgb(t[3])), t[2].target))), 3) for t in trials}
    return v, prob, x, active, message, spent, probes


def fit(data: FitData, model: str | FitModel = "woven", *, test: FitData | None = None,
        max_evaluations: int | None = None, start: Mapping[str, Any] | None = None) -> FitResult:
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
        Most model evaluations (a Jacobian by finite differences costs one
        per parameter and colour); default the model's own
        (:attr:`~cdbrdf.fit.FitModel.max_evaluations`). The solver stops
        there (the message says so).
    start
        Starting values (default: the model's guess from the measurement).

    Returns
    -------
    FitResult
        The values, their uncertainties, the errors and what was fixed.
    """
    fm = fit_model(model) if isinstance(model, str) else model
    if not isinstance(fm, FitModel):
        raise OptionError(f"model: expected a fit model name or FitModel, got {type(model).__name__}")
    if max_evaluations is None:
        max_evaluations = fm.max_evaluations
    if not (isinstance(max_evaluations, int) and max_evaluations >= 2):
        raise OptionError(f"max_evaluations: expected an integer >= 2, got {max_evaluations!r}")
    t0 = time.perf_counter()
    fm, prob, x, active, message, spent, probes = _choose(fm, data, start, max_evaluations)
    if max_evaluations - spent - prob.evaluations - prob.width >= 2:
        x, active, message = _solve(prob, x, max_evaluations - spent)
    elif not message:
        message = "the budget of model evaluations is spent"
    jac = prob.finite_differences(x)  # the uncertainty needs the true Jacobian at the optimum (cached if fresh)
    sigma, at_bound = _uncertainty(prob, x, jac, prob.residuals(x), active)
    values = prob.values(x)
    errs = {"fit": errors(fm, values, data, quality="fit"),
            "test": errors(fm, values, test if test is not None else data)}
    bounds = {p.name: {"lower": p.lower, "upper": p.upper, "unit": p.unit, "why": p.why} for p in fm.parameters}
    dt = time.perf_counter() - t0
    log.info("fitted %s in %.1f s (%d evaluations): median Delta E*ab %.2f, relative RMS %.3f", fm.name, dt,
             prob.evaluations, errs["test"]["delta_e_median"], errs["test"]["relative_rms"])
    fixed = fm.fixed
    if probes:
        fixed = dict(fixed, probes=probes)
    return FitResult(model=fm.name, description=fm.description, values=values, sigma=sigma, bounds=bounds,
                     at_bound=at_bound, fixed=fixed, model_params=fm.model_params(values), errors=errs,
                     evaluations=spent + prob.evaluations, seconds=dt, message=message, fit_model=fm)
