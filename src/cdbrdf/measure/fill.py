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
from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..errors import OptionError, TableError
from ..provenance import Provenance
from ..schema import FILL_METHOD_CODES
from ..table import CDBRDF, Grid
from ._fill_estimate import (
    CHECK_FRACTION,
    TIE_TOLERANCE_DEG,
    _checks,
    _estimate,
    _nearest_sources,
    _select,
    angle_between_deg,
    kappa_fit_weights,
)
from ._fill_sigma import MIN_CHECK_SAMPLES, TINY
from .fill_model import ModelFit, fit_model

__all__ = [
    "FILL_METHODS",
    "DEFAULT_FILL",
    "BTF_FILLS",
    "BTF_DEFAULT_FILL",
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


#: The fill methods, by name, with a one-line description (``cdbrdf measure --fill``).
FILL_METHODS: Mapping[str, str] = MappingProxyType({
    "kappa-fit": "the same direction on the stands that measured it: a line fitted along the curvature "
                 "to the logarithm of its values (weights 1/|delta kappa|), at the hidden curvature",
    "nearest-stand": "the same direction on the nearest stand that measured it, copied",
    "nearest": "nearest measured direction at the same curvature (angle(view) + angle(light); "
               "ties: lowest flat index)",
    "model": "the fabric model fitted to the measured samples of every stand: its change with curvature "
             "applied to the same direction's measured values on the other stands",
    "auto": "per hidden stand, the method of the others (model for RGB tables) whose fills of the samples "
            "it hides, hidden on the other stands too, err least; its uncertainty includes the runner-up's",
})
#: The fills a CD-BTF's texels take (``cdbrdf measure --btf``): the fill must be the same for every texel
#: (it depends on the mask and the grid only), so the methods that choose or fit from the values are not
#: offered; and the one it uses by default.
BTF_FILLS: tuple[str, ...] = ("kappa-fit", "nearest-stand", "nearest")
BTF_DEFAULT_FILL = "kappa-fit"

#: The method :func:`fill`, :func:`cdbrdf.measure.measure` and ``cdbrdf measure`` use by default
#: (``docs/capture.md``, "Filling", has the evidence).
DEFAULT_FILL = "auto"


_TINY = TINY

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

    def provenance(self) -> Provenance:
        """The fill's per-sample provenance (:class:`cdbrdf.provenance.Provenance`) for the table."""
        return Provenance(measured=self.fill_method == _CODE["measured"], fill_source=self.fill_source,
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
    material: str | None = None,
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
        ``"model"`` (default), ``"kappa-fit"``, ``"nearest-stand"`` or
        ``"nearest"`` (the paper's rule, bit for bit as :func:`fill_nearest`).
    std
        Optional per-sample (patch) standard deviations, filled too.
    material
        The fabric (``"model"`` only): a preset of that name is the model
        fitted; otherwise the best-fitting preset.

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
        by the paper's rule, nothing to check a fill against by the others),
        or for ``"model"`` on values that are not RGB.
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
    for k in range(nk):
        if not valid.reshape(nk, per)[k].any():  # nothing to fill from, nothing to check against
            raise TableError(f"kappa = {grid.kappa[k]:g} 1/mm: no sample was measured, so none can be filled")
    fit = _model_fit(method, vals, valid, grid, material)
    spread: NDArray[np.float64] | None = None
    selection: dict[str, Any] | None = None
    if method == "auto" and not valid.all():
        est, checks, spread, selection = _select(vals, valid, grid, fit)
    else:
        est = _estimate(method, vals, valid, grid, ~valid, fit)
        checks = _checks(method, vals, valid, grid, fit, est)
    flat_vals = vals.reshape(n, nc)
    flat_vals[est.idx] = est.values
    code = np.where(valid, _CODE["measured"], _CODE["unknown"]).astype(np.uint8)
    code.reshape(-1)[est.idx] = est.code
    out_std = None if std is None else np.array(std, dtype=np.float64, copy=True)
    if out_std is not None:
        flat_std = out_std.reshape(n, nc)
        first = est.sources[:, 0]
        ratio = np.ones((est.idx.size, nc))
        scaled = np.isin(est.code, [_CODE["kappa_fit"], _CODE["model"]])
        ok = scaled[:, None] & (flat_vals[first] > _TINY) & (est.values > _TINY)
        ratio[ok] = est.values[ok] / flat_vals[first][ok]
        flat_std[est.idx] = flat_std[first] * ratio
    fstd = np.zeros((n, nc))
    models: list[dict[str, Any]] = []
    ks = est.idx // per
    for c, k in sorted({(int(c), int(k)) for c, k in zip(est.code, ks, strict=True)}):
        sel = (est.code == c) & (ks == k)
        sig = checks.model(c, k)
        rel = sig(est.reach[sel]) if spread is None else np.hypot(sig(est.reach[sel]), spread[sel])
        fstd[est.idx[sel]] = np.abs(est.values[sel]) * rel
        name = _CODE_NAME[c]
        models.append({"kappa": float(grid.kappa[k]), "method": name, "samples": int(sel.sum()),
                       **sig.doc(_REACH_NAME[name])})
    n_slot = est.sources.shape[1]
    fill_sources = np.full((n, n_slot), -1, dtype=np.int64)
    fill_weights = np.zeros((n, n_slot))
    fill_sources[est.idx] = est.sources
    fill_weights[est.idx] = est.weights
    fill_source = np.where(valid, -1, fill_sources[:, 0].reshape(shape)).astype(np.int64)
    counts = {name: int(np.count_nonzero(code == c)) for name, c in _CODE.items() if name != "unknown"}
    summary: dict[str, Any] = {"method": method, "samples": counts, "uncertainty": models}
    if fit is not None:
        summary["model"] = fit.summary()
    if selection is not None:
        summary["selection"] = selection
    return Fill(method=method, values=vals, std=out_std, fill_source=fill_source, fill_method=code,
                fill_sources=fill_sources.reshape(*shape, n_slot), fill_weights=fill_weights.reshape(*shape, n_slot),
                fill_std=fstd.reshape(vals.shape), summary=summary)


_CODE_NAME = {v: k for k, v in _CODE.items()}
#: What a per-sample method's uncertainty grows with.
_REACH_NAME = {"kappa_fit": "abs_log_change", "nearest_stand": "none", "nearest": "distance_deg",
               "model": "abs_log_model_change"}


def _model_fit(method: str, vals: NDArray[np.float64], valid: NDArray[np.bool_], grid: Grid,
               material: str | None) -> ModelFit | None:
    """The model of a ``"model"`` fill, evaluated at every direction some stand did not measure."""
    if method not in ("model", "auto") or valid.all():
        return None
    nk = grid.shape[0]
    flat = valid.reshape(nk, -1)
    if method == "auto":
        # the model only where its fill can be checked (enough hidden directions measured on other stands)
        checkable = max(int(((~flat[k]) & flat).sum() - ((~flat[k]) & flat[k]).sum()) for k in range(nk))
        if vals.shape[-1] != 3 or checkable < MIN_CHECK_SAMPLES:
            return None
    elif vals.shape[-1] != 3:
        raise TableError(f"fill: 'model' fills RGB tables; this one has {vals.shape[-1]} channel(s)")
    hidden = np.flatnonzero((~flat).any(axis=0))
    return fit_model(vals, valid, grid, material=material, directions=hidden)


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
    result = fill(vals, valid, table.grid, method=method, std=std, material=table.attrs.get("material"))
    std = result.std
    if table.std is not None and result.std is not None:
        std = result.std.astype(table.std.dtype)
    return CDBRDF(result.values.astype(table.values.dtype), table.grid, std=std,
                  attrs=fill_provenance(table.attrs, result), provenance=result.provenance())
