"""Filling the samples that could not be measured: the fill method registry.

A sample is *invalid* when the stand hides it, its photograph is missing or
unreadable, or it is saturated. :func:`fill` gives it a value by one of the
methods of :data:`FILL_METHODS` (``docs/capture.md``, "Filling", has the
measured accuracy of each):

``kappa-fit`` (the default)
    The **same direction** on the stands that measured it, along the
    curvature axis: a straight line ``log f = a + b (kappa - kappa_0)`` is
    fitted by weighted least squares, weights ``1 / |kappa_s - kappa_0|``
    (nearer stands count more), to the logarithm of the sample's value on
    every stand ``kappa_s`` that measured the direction, and evaluated at the
    hidden stand's curvature ``kappa_0`` (``exp(a)``). The filled value is
    therefore ``exp(sum_s w_s log f_s)`` with weights ``w_s`` that depend
    only on the curvatures; they are recorded. A channel with a source
    value <= 0 is combined linearly (``sum_s w_s f_s``) instead. Where only
    one stand measured the direction the value is copied from it
    (``nearest_stand``); where none did, the paper's rule fills it
    (``nearest``).
``nearest-stand``
    The same direction on the nearest stand (in curvature; ties to the lower
    curvature) that measured it, copied; ``nearest`` where none did.
``nearest``
    The paper's rule (Matsufuji & Kawai), kept exactly: the value of the
    measured sample *at the same curvature* that minimises
    ``d = angle(v, v') + angle(l, l')`` (great-circle angles in degrees
    between the view directions and between the light directions). Ties
    (distances equal within :data:`TIE_TOLERANCE_DEG`) go to the candidate
    with the smallest C-order flat index over ``(phi_l, theta_l, phi_v,
    theta_v)``. :func:`fill_nearest` is this rule alone.

Every filled sample records how it was filled (a per-sample method of
:data:`cdbrdf.schema.FILL_METHOD_CODES`), all its sources (flat indices over
the five sample axes) and their weights, and an **uncertainty**: the
estimated standard deviation of its error, ``sigma = value * sqrt(s0^2 +
(alpha x)^2)``, where ``x`` is how far the fill reaches (for ``kappa_fit``
``|log(value / f_first)|``, the change from the nearest stand's value; for
``nearest`` the distance ``d`` in degrees; 0 for a copy from another stand)
and ``s0``, ``alpha`` are fitted by maximum likelihood to a check made on
the same table: measured samples of the same stand, predicted in the same
way from the same stands (the :data:`CHECK_FRACTION` of them nearest to the
filled samples, which resemble them most) or from their nearest other
measured direction (``nearest``), against their measured values.
"""

from __future__ import annotations

import copy
import logging
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..errors import OptionError, TableError
from ..frames import direction_from_angles
from ..schema import FILL_METHOD_CODES
from ..table import CDBRDF, Grid

__all__ = [
    "FILL_METHODS",
    "DEFAULT_FILL",
    "check_fill_method",
    "Fill",
    "fill",
    "refill",
    "fill_provenance",
    "fill_nearest",
    "kappa_fit_weights",
    "angle_between_deg",
    "TIE_TOLERANCE_DEG",
    "MIN_CHECK_SAMPLES",
    "CHECK_FRACTION",
]

_LOG = logging.getLogger(__name__)

#: Distances closer than this (degrees) are ties.
TIE_TOLERANCE_DEG = 1e-9

#: The fill methods, by name, with a one-line description (``cdbrdf measure --fill``).
FILL_METHODS: Mapping[str, str] = MappingProxyType({
    "kappa-fit": "the same direction on the stands that measured it: a line fitted along the curvature "
                 "to the logarithm of its values (weights 1/|delta kappa|), at the hidden curvature",
    "nearest-stand": "the same direction on the nearest stand that measured it, copied",
    "nearest": "nearest measured direction at the same curvature (angle(view) + angle(light); "
               "ties: lowest flat index)",
})
#: The method :func:`fill`, :func:`cdbrdf.measure.measure` and ``cdbrdf measure`` use by default.
DEFAULT_FILL = "kappa-fit"

#: Fewest measured samples a check must have for its own uncertainty fit; smaller
#: checks are pooled over the stand, then over the table.
MIN_CHECK_SAMPLES = 30

#: Share of a stand's measured samples the check of a curvature fit uses: those nearest (in
#: ``angle(v, v') + angle(l, l')``) to the samples it fills, which resemble them most.
CHECK_FRACTION = 0.25

#: Relative uncertainty given when no check is possible (too few measured samples).
_UNKNOWN_SIGMA = 1.0
#: Values at or below this are not taken in logarithms.
_TINY = 1e-300

_CODE = FILL_METHOD_CODES


def check_fill_method(method: object) -> str:
    """``method`` when it is one of :data:`FILL_METHODS`.

    Raises
    ------
    OptionError
        Otherwise (a :class:`ValueError`); the message lists the valid methods.
    """
    if not isinstance(method, str) or method not in FILL_METHODS:
        raise OptionError(f"fill: {method!r} is not one of {', '.join(FILL_METHODS)}")
    return method


def angle_between_deg(a: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.float64]:
    """Angle in degrees between unit vectors ``(..., 3)``, accurate also for tiny angles.

    ``atan2(|a x b|, a . b)``: identical directions give exactly 0.
    """
    cross = np.linalg.norm(np.cross(a, b), axis=-1)
    dot = np.sum(a * b, axis=-1)
    return np.degrees(np.arctan2(cross, dot))


def _pair_distances(theta: NDArray, phi: NDArray) -> NDArray[np.float64]:
    """Angles (degrees) between every pair of the directions ``(phi, theta)`` in C order."""
    t, p = np.meshgrid(theta, phi, indexing="xy")  # (n_phi, n_theta) with phi outer
    d = direction_from_angles(t.ravel(), p.ravel())
    return angle_between_deg(d[:, None, :], d[None, :, :])


# -- the paper's rule -------------------------------------------------------------------
def fill_nearest(
    values: NDArray[np.floating],
    valid: NDArray[np.bool_],
    grid: Grid,
    *,
    std: NDArray[np.floating] | None = None,
) -> tuple[NDArray[np.float64], NDArray[np.int64], NDArray[np.float64] | None]:
    """Fill invalid samples from the nearest measured direction at the same curvature.

    The paper's rule alone (``method="nearest"`` of :func:`fill`, which also
    records the provenance and the uncertainty).

    Parameters
    ----------
    values
        ``grid.shape + (channels,)``; invalid entries may hold anything (NaN).
    valid
        ``grid.shape`` booleans: True where measured.
    grid
        The sample axes.
    std
        Optional per-sample standard deviations, filled the same way.

    Returns
    -------
    values : numpy.ndarray
        Filled copy (float64).
    fill_source : numpy.ndarray
        ``grid.shape`` int64: -1 where measured, else the C-order flat index
        (over the five sample axes) of the source sample.
    std : numpy.ndarray or None
        Filled copy of ``std``.

    Raises
    ------
    TableError
        When a curvature has no measured sample at all (nothing to fill from).
    """
    shape = grid.shape
    valid = np.asarray(valid, dtype=bool)
    if valid.shape != shape:
        raise TableError(f"valid: shape {valid.shape} differs from the grid {shape}")
    out = np.array(values, dtype=np.float64, copy=True)
    out_std = None if std is None else np.array(std, dtype=np.float64, copy=True)
    fill_src, _dist = _nearest_sources(valid, grid, ~valid)
    flat_out = out.reshape(valid.size, -1)
    flat_std = None if out_std is None else out_std.reshape(valid.size, -1)
    i = np.flatnonzero(~valid.ravel())
    j = fill_src.ravel()[i]
    flat_out[i] = flat_out[j]
    if flat_std is not None:
        flat_std[i] = flat_std[j]
    return out, fill_src, out_std


def _nearest_sources(
    valid: NDArray[np.bool_], grid: Grid, targets: NDArray[np.bool_], *, exclude_self: bool = False
) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
    """The paper's nearest measured sample at the same curvature of each target sample.

    Returns the flat source index (-1 for non-targets) and the distance
    ``angle(v, v') + angle(l, l')`` in degrees (NaN for non-targets). With
    ``exclude_self`` a target that is itself valid never picks itself (the
    check of the uncertainty).

    Raises
    ------
    TableError
        When a curvature with targets has no measured sample at all.
    """
    shape = grid.shape
    src = np.full(shape, -1, dtype=np.int64)
    dist = np.full(shape, np.nan)
    nk, npl, ntl, npv, ntv = shape
    n_l, n_v = npl * ntl, npv * ntv
    d_l = _pair_distances(grid.theta_l, grid.phi_l)  # (n_l, n_l)
    d_v = _pair_distances(grid.theta_v, grid.phi_v)  # (n_v, n_v)
    for k in range(nk):
        t = targets[k].reshape(n_l, n_v)
        if not t.any():
            continue
        m = valid[k].reshape(n_l, n_v)
        if not m.any() or (exclude_self and m.sum() < 2):
            raise TableError(
                f"kappa = {grid.kappa[k]:g} 1/mm: no sample was measured, so none can be filled"
            )
        base = k * n_l * n_v
        src_k = src[k].reshape(-1)
        dist_k = dist[k].reshape(-1)
        for li, vi in zip(*np.nonzero(t), strict=True):
            d = d_l[li][:, None] + d_v[vi][None, :]
            mask = m
            if exclude_self and m[li, vi]:
                mask = m.copy()
                mask[li, vi] = False
            d = np.where(mask, d, np.inf)
            best = d.min()
            j = int(np.flatnonzero(d.ravel() <= best + TIE_TOLERANCE_DEG)[0])
            src_k[li * n_v + vi] = base + j
            dist_k[li * n_v + vi] = best
    return src, dist


# -- the curvature axis -----------------------------------------------------------------
def kappa_fit_weights(kappa_sources: NDArray[np.float64], kappa_target: float) -> NDArray[np.float64]:
    """Weights of the ``kappa-fit`` estimate at ``kappa_target`` from values at ``kappa_sources``.

    The weighted least-squares line ``y = a + b (kappa - kappa_target)``
    through the points ``(kappa_s, y_s)`` with weights ``1 / |kappa_s -
    kappa_target|``, evaluated at ``kappa_target``, is ``sum_s w_s y_s``;
    this returns ``w`` (they sum to 1). One source gives ``[1]``.

    Parameters
    ----------
    kappa_sources
        Curvatures of the stands that measured the direction, mm^-1 (distinct,
        none equal to the target).
    kappa_target
        Curvature of the sample to fill, mm^-1.
    """
    x = np.asarray(kappa_sources, dtype=np.float64) - float(kappa_target)
    if x.size == 1:
        return np.ones(1)
    w = 1.0 / np.abs(x)
    a = np.stack([np.ones_like(x), x], axis=1)
    aw = a * w[:, None]
    return np.linalg.solve(a.T @ aw, aw.T)[0]


def _source_stands(valid: NDArray[np.bool_], k: int, kappa: NDArray[np.float64], nearest_only: bool
                   ) -> dict[tuple[int, ...], NDArray[np.intp]]:
    """Invalid directions of stand ``k`` grouped by the stands used for them (nearest first).

    ``nearest_only``: just the nearest stand (in curvature; ties to the lower
    curvature) that measured the direction.
    """
    nk = valid.shape[0]
    flat = valid.reshape(nk, -1)
    hid = np.flatnonzero(~flat[k])
    others = [s for s in range(nk) if s != k]
    order = sorted(others, key=lambda s: (abs(kappa[s] - kappa[k]), kappa[s]))
    groups: dict[tuple[int, ...], list[int]] = {}
    if not hid.size:
        return {}
    meas = flat[order][:, hid]  # (n_other, n_hid) in nearest-first order
    for col, i in enumerate(hid.tolist()):
        stands = [order[r] for r in np.flatnonzero(meas[:, col])]
        if nearest_only:
            stands = stands[:1]
        groups.setdefault(tuple(stands), []).append(i)
    return {s: np.array(ids, dtype=np.intp) for s, ids in groups.items()}


def _combine(v: NDArray[np.float64], w: NDArray[np.float64]) -> NDArray[np.float64]:
    """``exp(sum w log v)`` over axis 0, channel by channel; linear where a source is <= 0."""
    pos = np.all(v > _TINY, axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        logv = np.log(np.where(v > _TINY, v, 1.0))
    out = np.exp(np.einsum("s,s...->...", w, logv))
    lin = np.einsum("s,s...->...", w, v)
    return np.where(pos, out, lin)


# -- the uncertainty --------------------------------------------------------------------
@dataclass(frozen=True)
class _SigmaModel:
    """``sigma_rel = sqrt(s0^2 + (alpha x)^2)`` with its fit's provenance."""

    s0: float
    alpha: float
    n_check: int
    pooled: str  # "group", "stand", "table" or "none"

    def __call__(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        return np.sqrt(self.s0**2 + (self.alpha * x) ** 2)


def _fit_sigma(x: NDArray[np.float64], e: NDArray[np.float64]) -> tuple[float, float]:
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


class _Checks:
    """Checks (measured samples predicted like the filled ones) and the sigma models fitted to them."""

    def __init__(self) -> None:
        self.items: dict[tuple[str, int, tuple[int, ...]], tuple[NDArray, NDArray, int]] = {}

    def add(self, kind: str, k: int, stands: tuple[int, ...], x: NDArray, e: NDArray) -> None:
        """Record the reach ``x`` and log error ``e`` (``(samples, channels)``) of a check."""
        ok = np.isfinite(e) & np.isfinite(x)
        n = int(np.count_nonzero(ok.any(axis=-1))) if ok.ndim > 1 else int(np.count_nonzero(ok))
        self.items[(kind, k, stands)] = (x[ok], e[ok], n)

    def model(self, kind: str, k: int, stands: tuple[int, ...]) -> _SigmaModel:
        """The model of one group: its own check, else pooled over the stand, else over the table."""
        levels = (
            ("group", [key for key in self.items if key == (kind, k, stands)]),
            ("stand", [key for key in self.items if key[0] == kind and key[1] == k]),
            ("table", [key for key in self.items if key[0] == kind]),
        )
        for pooled, keys in levels:
            n = sum(self.items[key][2] for key in keys)
            if n >= MIN_CHECK_SAMPLES:
                x = np.concatenate([self.items[key][0] for key in keys])
                e = np.concatenate([self.items[key][1] for key in keys])
                s0, a = _fit_sigma(x, e)
                return _SigmaModel(s0=s0, alpha=a, n_check=n, pooled=pooled)
        return _SigmaModel(s0=_UNKNOWN_SIGMA, alpha=0.0, n_check=0, pooled="none")


def _log_error(pred: NDArray[np.float64], meas: NDArray[np.float64]) -> NDArray[np.float64]:
    """``log(pred / meas)`` where both are positive, NaN elsewhere."""
    ok = (pred > _TINY) & (meas > _TINY)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(ok, np.log(np.where(ok, pred, 1.0) / np.where(ok, meas, 1.0)), np.nan)


def _reach(value: NDArray[np.float64], first: NDArray[np.float64]) -> NDArray[np.float64]:
    """``|log(value / first)|`` (relative change where a value is not positive)."""
    ok = (value > _TINY) & (first > _TINY)
    with np.errstate(divide="ignore", invalid="ignore"):
        lg = np.abs(np.log(np.where(ok, value, 1.0) / np.where(ok, first, 1.0)))
        rel = np.abs(value - first) / np.maximum(np.maximum(np.abs(value), np.abs(first)), _TINY)
    return np.where(ok, lg, rel)


# -- the result -------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class Fill:
    """A table's invalid samples, filled, with the provenance of every filled sample.

    Attributes
    ----------
    method
        The :data:`FILL_METHODS` name used.
    values
        ``grid.shape + (channels,)`` float64: measured values kept exactly,
        invalid ones filled.
    std
        The patch standard deviations, filled (a copy's source's; for a
        curvature fit the first source's, scaled by value / source value), or
        None.
    fill_source, fill_method, fill_sources, fill_weights, fill_std
        The per-sample provenance, as :class:`cdbrdf.CDBRDF` takes it.
    summary
        JSON-ready: the method, the number of samples filled by each
        per-sample method, and the uncertainty models (``s0``, ``alpha``,
        the number of check samples) per stand and source stands.
    """

    method: str
    values: NDArray[np.float64]
    std: NDArray[np.float64] | None
    fill_source: NDArray[np.int64]
    fill_method: NDArray[np.uint8]
    fill_sources: NDArray[np.int64]
    fill_weights: NDArray[np.float64]
    fill_std: NDArray[np.float64]
    summary: dict[str, Any] = field(default_factory=dict)

    def table_kwargs(self) -> dict[str, Any]:
        """Keyword arguments of :class:`cdbrdf.CDBRDF` for the fill (all but values, axes and attrs)."""
        return dict(measured=self.fill_method == _CODE["measured"], fill_source=self.fill_source, std=self.std,
                    fill_method=self.fill_method, fill_sources=self.fill_sources,
                    fill_weights=self.fill_weights, fill_std=self.fill_std)

    def description(self) -> str:
        """One line: the method's rule (what a file's provenance says)."""
        return (f"{self.method}: {FILL_METHODS[self.method]}"
                if self.method != "nearest" else _NEAREST_TEXT)


#: The provenance text of the paper's rule, as every earlier cdbrdf wrote it.
_NEAREST_TEXT = ("nearest measured direction at the same curvature "
                 "(angle(view) + angle(light); ties: lowest flat index)")


def fill(
    values: NDArray[np.floating],
    valid: NDArray[np.bool_],
    grid: Grid,
    *,
    method: str = DEFAULT_FILL,
    std: NDArray[np.floating] | None = None,
) -> Fill:
    """Fill the invalid samples of a table by one of :data:`FILL_METHODS`.

    Parameters
    ----------
    values
        ``grid.shape + (channels,)``; invalid entries may hold anything (NaN).
    valid
        ``grid.shape`` booleans: True where measured. Measured values are
        never changed.
    grid
        The sample axes.
    method
        ``"kappa-fit"`` (default), ``"nearest-stand"`` or ``"nearest"`` (the
        paper's rule, bit for bit as :func:`fill_nearest`).
    std
        Optional per-sample (patch) standard deviations, filled too.

    Returns
    -------
    Fill
        Values, standard deviations and the provenance of every filled sample.

    Raises
    ------
    ValueError
        For an unknown method (the message lists them).
    TableError
        When a curvature has no measured sample at all (nothing to fill from
        by the paper's rule, nothing to check a fill against by the others).
    """
    method = check_fill_method(method)
    shape = grid.shape
    valid = np.asarray(valid, dtype=bool)
    if valid.shape != shape:
        raise TableError(f"valid: shape {valid.shape} differs from the grid {shape}")
    vals = np.array(values, dtype=np.float64, copy=True)
    if vals.shape[:-1] != shape:
        raise TableError(f"values: shape {vals.shape} does not match the grid {shape} plus channels")
    nk, nc = shape[0], vals.shape[-1]
    n = valid.size
    per = n // nk
    out_std = None if std is None else np.array(std, dtype=np.float64, copy=True)
    valid_k = valid.reshape(nk, per)
    vk = vals.reshape(nk, per, nc)  # views: filling writes into vals
    std_k = None if out_std is None else out_std.reshape(nk, per, nc)
    for k in range(nk):
        if not valid_k[k].any():  # no sample of this curvature can be checked, nor filled by the paper's rule
            raise TableError(f"kappa = {grid.kappa[k]:g} 1/mm: no sample was measured, so none can be filled")
    code = np.where(valid, _CODE["measured"], _CODE["unknown"]).astype(np.uint8)
    code_k = code.reshape(nk, per)
    fstd = np.zeros((nk, per, nc))
    groups: list[tuple[int, tuple[int, ...], NDArray[np.intp], NDArray[np.float64]]] = []
    checks = _Checks()
    nearest_targets = ~valid if method == "nearest" else np.zeros(shape, dtype=bool)
    if method != "nearest":
        for k in range(nk):
            for stands, ids in _source_stands(valid, k, grid.kappa, nearest_only=method == "nearest-stand").items():
                if not stands:
                    nearest_targets.reshape(nk, per)[k, ids] = True
                    continue
                w = kappa_fit_weights(grid.kappa[list(stands)], float(grid.kappa[k]))
                src = vk[list(stands)][:, ids]  # (n_stands, n_ids, nc); sources are measured
                filled = _combine(src, w)
                vk[k, ids] = filled
                code_k[k, ids] = _CODE["kappa_fit" if len(stands) > 1 else "nearest_stand"]
                if std_k is not None:
                    first = src[0]
                    ok = (first > _TINY) & (filled > _TINY)
                    std_k[k, ids] = std_k[stands[0], ids] * np.where(ok, filled / np.where(ok, first, 1.0), 1.0)
                groups.append((k, stands, ids, w))
                # the check: the measured samples of this stand nearest to these, predicted from the same stands
                chk = _nearest_checks(np.flatnonzero(valid_k[k] & valid_k[list(stands)].all(axis=0)), ids, grid)
                if chk.size:
                    pred = _combine(vk[list(stands)][:, chk], w)
                    checks.add("kappa", k, stands, _reach(pred, vk[stands[0], chk]), _log_error(pred, vk[k, chk]))
    near: tuple[NDArray[np.int64], NDArray[np.float64]] | None = None
    if nearest_targets.any():
        nsrc, ndist = _nearest_sources(valid, grid, nearest_targets)
        i = np.flatnonzero(nearest_targets.ravel())
        j = nsrc.ravel()[i]
        flat_vals = vals.reshape(n, nc)
        flat_vals[i] = flat_vals[j]
        if out_std is not None:
            flat_std = out_std.reshape(n, nc)
            flat_std[i] = flat_std[j]
        code.reshape(-1)[i] = _CODE["nearest"]
        near = (nsrc, ndist)
        # the check: every measured sample of these stands from its nearest other measured direction
        for k in np.flatnonzero(nearest_targets.reshape(nk, per).any(axis=1)).tolist():
            if valid_k[k].sum() >= 2:
                csrc, cdist = _nearest_sources(valid, grid, _stand_mask(valid, k), exclude_self=True)
                ci = np.flatnonzero(valid_k[k]) + k * per
                e = _log_error(vals.reshape(n, nc)[csrc.ravel()[ci]], vals.reshape(n, nc)[ci])
                checks.add("nearest", k, (), np.broadcast_to(cdist.ravel()[ci][:, None], e.shape), e)

    # provenance and uncertainty, once every check is known
    n_slot = max([1] + [len(g[1]) for g in groups])
    fill_sources = np.full((nk, per, n_slot), -1, dtype=np.int64)
    fill_weights = np.zeros((nk, per, n_slot))
    models: list[dict[str, Any]] = []
    for k, stands, ids, w in groups:
        for slot, s_k in enumerate(stands):
            fill_sources[k, ids, slot] = s_k * per + ids
            fill_weights[k, ids, slot] = w[slot]
        sig = checks.model("kappa", k, stands)
        filled = vk[k, ids]
        fstd[k, ids] = np.abs(filled) * sig(_reach(filled, vk[stands[0], ids]))
        models.append({"kappa": float(grid.kappa[k]), "method": "kappa_fit" if len(stands) > 1 else "nearest_stand",
                       "source_kappa": [float(grid.kappa[s_k]) for s_k in stands], "source_weights": w.tolist(),
                       "samples": int(ids.size), **_model_doc(sig)})
    if near is not None:
        nsrc, ndist = near
        for k in np.flatnonzero(nearest_targets.reshape(nk, per).any(axis=1)).tolist():
            ids = np.flatnonzero(nearest_targets.reshape(nk, per)[k])
            fill_sources[k, ids, 0] = nsrc.reshape(nk, per)[k, ids]
            fill_weights[k, ids, 0] = 1.0
            sig = checks.model("nearest", k, ())
            d = np.broadcast_to(ndist.reshape(nk, per)[k, ids][:, None], (ids.size, nc))
            fstd[k, ids] = np.abs(vk[k, ids]) * sig(d)
            models.append({"kappa": float(grid.kappa[k]), "method": "nearest", "source_kappa": [float(grid.kappa[k])],
                           "samples": int(ids.size), **_model_doc(sig, x="distance_deg")})
    fill_source = np.where(valid, -1, fill_sources[..., 0].reshape(shape)).astype(np.int64)
    counts = {name: int(np.count_nonzero(code == c)) for name, c in _CODE.items() if name != "unknown"}
    return Fill(
        method=method,
        values=vals,
        std=out_std,
        fill_source=fill_source,
        fill_method=code,
        fill_sources=fill_sources.reshape(*shape, n_slot),
        fill_weights=fill_weights.reshape(*shape, n_slot),
        fill_std=fstd.reshape(vals.shape),
        summary={"method": method, "samples": counts, "uncertainty": models},
    )


def _nearest_checks(candidates: NDArray[np.intp], targets: NDArray[np.intp], grid: Grid) -> NDArray[np.intp]:
    """The :data:`CHECK_FRACTION` of ``candidates`` (at least :data:`MIN_CHECK_SAMPLES`) nearest to ``targets``.

    Indices are over the four direction axes of one curvature; the distance
    of a candidate is ``angle(v, v') + angle(l, l')`` to its nearest target.
    """
    n_keep = min(candidates.size, max(MIN_CHECK_SAMPLES, math.ceil(CHECK_FRACTION * candidates.size)))
    if n_keep == candidates.size:
        return candidates
    n_v = grid.phi_v.size * grid.theta_v.size
    d_l = _pair_distances(grid.theta_l, grid.phi_l)
    d_v = _pair_distances(grid.theta_v, grid.phi_v)
    tl, tv = np.divmod(targets, n_v)
    dmin = np.empty(candidates.size)
    for a in range(0, candidates.size, 256):
        cl, cv = np.divmod(candidates[a : a + 256], n_v)
        dmin[a : a + 256] = (d_l[cl][:, tl] + d_v[cv][:, tv]).min(axis=1)
    return np.sort(candidates[np.argsort(dmin, kind="stable")[:n_keep]])


def _stand_mask(valid: NDArray[np.bool_], k: int) -> NDArray[np.bool_]:
    """The measured samples of stand ``k`` (the targets of its nearest-direction check)."""
    m = np.zeros(valid.shape, dtype=bool)
    m[k] = valid[k]
    return m


def _model_doc(sig: _SigmaModel, *, x: str = "abs_log_change") -> dict[str, Any]:
    return {"sigma_s0": round(sig.s0, 6), "sigma_alpha": round(sig.alpha, 6), "sigma_x": x,
            "check_samples": sig.n_check, "check_pooled": sig.pooled}


# -- provenance and tables --------------------------------------------------------------
def fill_provenance(attrs: Mapping[str, Any], result: Fill) -> dict[str, Any]:
    """``attrs`` with the fill's description in its ``provenance`` (``fill``, ``fill_method``, ``fill_summary``)."""
    out = copy.deepcopy(dict(attrs))
    prov = out.get("provenance")
    if prov is None:
        prov = {}
    elif not isinstance(prov, dict):
        prov = {"previous": prov}
    prov["fill"] = result.description()
    prov["fill_method"] = result.method
    prov["fill_summary"] = result.summary
    out["provenance"] = prov
    return out


def refill(table: CDBRDF, *, method: str = DEFAULT_FILL) -> CDBRDF:
    """The table with its filled samples filled again, from its measured ones, by ``method``.

    Measured samples (and their standard deviations) are kept exactly; the
    values of filled samples are not used. ``refill(table, method="nearest")``
    of a measured table gives the table the paper's rule would have made.

    Raises
    ------
    ValueError
        For an unknown method (the message lists them).
    TableError
        When there is nothing to fill from (see :func:`fill`).
    """
    method = check_fill_method(method)
    valid = table.measured
    vals = np.where(valid[..., None], table.values, np.nan)
    std = None if table.std is None else np.where(valid[..., None], table.std, np.nan)
    result = fill(vals, valid, table.grid, method=method, std=std)
    kw = result.table_kwargs()
    if table.std is not None and result.std is not None:
        kw["std"] = result.std.astype(table.std.dtype)
    return CDBRDF(result.values.astype(table.values.dtype), **table.grid.axes(),
                  attrs=fill_provenance(table.attrs, result), **kw)
