"""A CDBRDF from a flat measurement: the measurement at kappa = 0, bent by a fabric model fitted to it.

Most users have a flat measured BRDF (RGL, MERL, UTIA, a Neural-BRDF
network, a one-curvature CDBRDF file), not cylinder stands. :func:`bend`
turns one into a CDBRDF:

1. **Fit.** The woven and/or the pile model (:mod:`cdbrdf.fit`) is fitted
   to the measurement at kappa = 0 (bounded least squares in CIELAB, an
   uncertainty per parameter); ``model="auto"`` fits both and keeps the one
   with the smaller median Delta E*ab at separate test directions.
2. **The flat slice is the measurement**: resampled onto the grid as
   ``cdbrdf import`` does (cell means; an isotropic source through its
   isotropic layout, expanded), its measured mask kept.
3. **Every other curvature is predicted**: the measurement times the fitted
   model's change from flat, ``f(kappa) = f_0 (m(kappa) + e) / (m(0) + e)``
   per sample and channel (``e`` = :data:`RATIO_EPSILON` x the model's mean,
   so that a sample the model leaves dark does not blow up; the ratio is held
   within ``[1 / RATIO_LIMIT, RATIO_LIMIT]``), made reciprocal by averaging
   it with its light <-> view mirror, and energy-conserving: a slice whose
   directional albedo exceeds ``max(1, the flat slice's)`` for some view is
   scaled down as a whole (which keeps it reciprocal; the factor is recorded).
4. **The file says so**: those samples are marked not measured, with the
   fill method ``model`` (code 5 of ``fill_method``), their sources the
   flat samples of the same direction and of its mirror (weights 1/2 each,
   the value being their mean times the model's ratio); the provenance holds
   the fitted model, its parameters with their uncertainties, the fit's
   error, the other candidates' errors, and the statement that the bending is
   predicted, not measured (``docs/format.md``).
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable, Sequence
from os import PathLike
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .errors import OptionError, TableError
from .grid import PAPER_KAPPA, Grid
from .provenance import Provenance

__all__ = ["BEND_MODELS", "RATIO_LIMIT", "RATIO_EPSILON", "FIT_PAIRS", "TEST_PAIRS", "bend", "fit_flat", "bend_grid"]

log = logging.getLogger(__name__)

#: Models ``bend`` fits: ``auto`` (both, the better kept), ``woven``, ``pile``.
BEND_MODELS: tuple[str, ...] = ("auto", "woven", "pile")
#: The model's ratio to flat is held within [1 / RATIO_LIMIT, RATIO_LIMIT].
RATIO_LIMIT = 8.0
#: Added to the model's values, as a share of its mean at kappa = 0 per channel, before the ratio is taken.
RATIO_EPSILON = 1e-3
#: Direction pairs the fit uses, and those its error is measured at.
FIT_PAIRS = 128
TEST_PAIRS = 512
STATEMENT = ("the kappa = 0 slice is the flat measurement; every other curvature is predicted by the fitted model's "
             "change from flat (model(kappa) / model(0)), not measured")


def fit_flat(source: Any, *, model: str = "auto", fit_pairs: int = FIT_PAIRS, test_pairs: int = TEST_PAIRS,
             max_evaluations: int | None = None) -> tuple[Any, dict[str, Any]]:
    """Fit the fabric model(s) to a flat measurement.

    Parameters
    ----------
    source
        A :class:`cdbrdf.importers.Source` (its ``evaluate`` and symmetry are used).
    model
        One of :data:`BEND_MODELS`.
    fit_pairs, test_pairs
        Direction pairs of the fit and of its error (:mod:`cdbrdf.fit.data`).
    max_evaluations
        Model evaluations per fit (default each model's own, :attr:`cdbrdf.fit.FitModel.max_evaluations`).

    Returns
    -------
    tuple
        ``(the best FitResult, {model name: its test errors})``.
    """
    from . import fit as F

    if model not in BEND_MODELS:
        raise OptionError(f"model: {model!r} is not one of {', '.join(BEND_MODELS)}")
    data = F.sample(source.evaluate, isotropic=source.isotropic, n=fit_pairs, seed=0)
    test = F.sample(source.evaluate, isotropic=source.isotropic, n=test_pairs, seed=1)
    names = ("woven", "pile") if model == "auto" else (model,)
    results = [F.fit(data, name, test=test, max_evaluations=max_evaluations) for name in names]
    best = min(results, key=lambda r: r.errors["test"]["delta_e_median"])
    return best, {r.model: r.errors["test"] for r in results}


def bend_grid(grid: str | Grid | None, source: Any, kappa: ArrayLike | None) -> Grid:
    """The anisotropic grid of a bent table: ``grid``'s directions (default the paper's), ``kappa`` with 0 in it.

    Parameters
    ----------
    grid
        ``"paper"``, ``"native"``, ``"regular:THETA_STEP,PHI_STEP[,THETA_MAX]"``, a Grid, or None (the paper's).
    source
        The flat measurement (:class:`cdbrdf.importers.Source`), for ``"native"``.
    kappa
        Curvatures, 1/mm (default the paper's).

    Returns
    -------
    Grid
        Anisotropic, the same light and view axes.

    Raises
    ------
    TableError
        When the light and view axes differ (the table is made reciprocal by
        mirroring them) or a curvature is not finite.
    """
    from .importers.convert import target_grid

    g = target_grid("paper" if grid is None else grid, source, kappa=0.0, symmetry="anisotropic")
    if not (np.array_equal(g.theta_l, g.theta_v) and np.array_equal(g.phi_l, g.phi_v)):
        raise TableError("grid: the light and view axes must be the same (the bent table is made reciprocal by "
                         "mirroring them)")
    ks = np.asarray(PAPER_KAPPA if kappa is None else kappa, dtype=np.float64).reshape(-1)
    if not np.all(np.isfinite(ks)):
        raise TableError(f"kappa: must be finite curvatures in 1/mm, got {ks.tolist()}")
    if not np.any(ks == 0.0):
        log.info("kappa: 0 added (the flat measurement is the kappa = 0 slice)")
    ks = np.unique(np.append(ks, 0.0))
    return Grid(kappa=ks, phi_l=g.phi_l, theta_l=g.theta_l, phi_v=g.phi_v, theta_v=g.theta_v)


def _check_curvatures(model: str, kappa: NDArray[np.float64]) -> None:
    """Refuse, before any fit, a curvature the model's fixed geometry cannot be bent to (one line).

    The fits keep each model's lengths (the cloth's thickness, the pile's
    height), so their limits are known beforehand: the typical fabric of each
    kind is bent to every curvature at one direction pair.
    """
    from .fit import FitData, fit_model

    names = ("woven", "pile") if model == "auto" else (model,)
    a = np.array([30.0])
    probe = FitData(a, a, a, a, np.full((1, 3), 0.1), isotropic=False)
    for name in names:
        fm = fit_model(name, weave="plain")
        m = fm.build(fm.initial(probe))
        for k in kappa:
            try:
                m.evaluate(30.0, 0.0, 30.0, 180.0, float(k))
            except (OptionError, ValueError) as exc:
                why = str(exc).splitlines()[0].removeprefix("kappa: ")
                raise OptionError(f"kappa: {float(k):g} 1/mm cannot bend the {name} model: {why}") from None


def _flat_slice(source: Any, grid: Grid) -> Any:
    """The measurement on ``grid``'s directions at kappa = 0 (an isotropic source through its isotropic layout).

    Cell means as ``cdbrdf import`` makes them, with quadrature points an
    eighth of the finest step apart (at least 1 degree: the import's default
    spacing, at most 8 points per interval of every axis).
    """
    from .importers.convert import table_from
    from .importers.resample import DEFAULT_SPACING_DEG

    steps = np.concatenate([np.diff(grid.theta_l), [360.0 / grid.phi_v.size]])
    spacing = max(DEFAULT_SPACING_DEG, float(steps.min()) / 8.0)
    g0 = Grid(kappa=[0.0], phi_l=grid.phi_l, theta_l=grid.theta_l, phi_v=grid.phi_v, theta_v=grid.theta_v)
    if source.isotropic and grid.phi_l[0] == 0.0 and grid.phi_v[0] == 0.0:
        iso = Grid(kappa=[0.0], phi_l=[0.0], theta_l=grid.theta_l, phi_v=grid.phi_v, theta_v=grid.theta_v,
                   symmetry="isotropic")
        t = table_from(source, iso, spacing_deg=spacing).expanded()
        if np.array_equal(t.phi_l, grid.phi_l) and np.array_equal(t.phi_v, grid.phi_v):
            return t
    return table_from(source, g0, spacing_deg=spacing)


def _mirror(a: NDArray[Any]) -> NDArray[Any]:
    """Light <-> view of an array over (kappa, phi_l, theta_l, phi_v, theta_v, ...)."""
    order = (0, 3, 4, 1, 2) + tuple(range(5, a.ndim))
    return np.transpose(a, order)


def _albedo_max(table: Any) -> NDArray[np.float64]:
    """Per curvature, the largest directional albedo over the grid's view nodes (midpoint rule, 2 x 4 degrees)."""
    th = (np.arange(45) + 0.5) * 2.0
    ph = (np.arange(90) + 0.5) * 4.0
    tl, pl = (a.ravel() for a in np.meshgrid(th, ph, indexing="ij"))
    w = np.repeat(np.sin(np.radians(th)) * np.cos(np.radians(th)) * np.radians(2.0) * np.radians(4.0), ph.size)
    tv, pv = (a.ravel() for a in np.meshgrid(table.theta_v, table.phi_v, indexing="ij"))
    out = np.zeros(table.kappa.size)
    for i, k in enumerate(table.kappa):
        f = table.evaluate(np.repeat(tv, tl.size), np.repeat(pv, tl.size), np.tile(tl, tv.size),
                           np.tile(pl, tv.size), float(k))
        alb = np.einsum("vlc,l->vc", f.reshape(tv.size, tl.size, -1), w)
        out[i] = float(alb.max())
    return out


def _bent_values(flat: NDArray[np.float64], model: NDArray[np.float64], i0: int) -> tuple[NDArray[np.float64],
                                                                                          dict[str, Any]]:
    """The flat values times the model's reciprocal ratio to flat, per curvature ``(n_kappa, ...)``."""
    m0 = model[i0]
    eps = RATIO_EPSILON * np.maximum(m0.reshape(-1, m0.shape[-1]).mean(axis=0), 1e-12)
    ratio = (model + eps) / (m0 + eps)
    clamped = int(np.count_nonzero((ratio < 1.0 / RATIO_LIMIT) | (ratio > RATIO_LIMIT)))
    ratio = np.clip(ratio, 1.0 / RATIO_LIMIT, RATIO_LIMIT)
    f0 = flat[None]
    values = 0.5 * (f0 * ratio + _mirror(f0 * ratio))
    values[i0] = flat
    asym = float(np.median(np.abs(ratio - _mirror(ratio)) / (0.5 * (ratio + _mirror(ratio)))))
    return values, {"epsilon_share_of_mean": RATIO_EPSILON, "limit": [1.0 / RATIO_LIMIT, RATIO_LIMIT],
                    "clamped_values": clamped, "model_ratio_asymmetry_median": round(asym, 6),
                    "ratio_range": [round(float(ratio.min()), 5), round(float(ratio.max()), 5)]}


def _provenance_arrays(grid: Grid, measured0: NDArray[np.bool_], i0: int) -> dict[str, Any]:
    """``measured``, ``fill_source``, ``fill_method``, ``fill_sources``, ``fill_weights`` of a bent table.

    At kappa = 0 the flat slice's own mask (its unmeasured samples: method
    ``unknown``); elsewhere ``model`` with the flat samples of the same
    direction and of its mirror as sources, 1/2 each (those measured, used
    slots first).
    """
    from .schema import FILL_METHOD_CODES

    shape = grid.shape
    index0 = np.arange(int(np.prod(shape))).reshape(shape)[i0]  # flat indices of the kappa = 0 slice
    pairs = np.stack([index0, _mirror(index0[None])[0]], axis=-1)  # (..., 2): own direction, mirror
    ok = np.stack([measured0, _mirror(measured0[None])[0]], axis=-1)
    order = np.argsort(~ok, axis=-1, kind="stable")  # measured sources first
    src = np.where(np.take_along_axis(ok, order, -1), np.take_along_axis(pairs, order, -1), -1)
    n_ok = ok.sum(axis=-1, keepdims=True)
    wts = np.where(src >= 0, 1.0 / np.maximum(n_ok, 1), 0.0)
    measured = np.zeros(shape, dtype=bool)
    measured[i0] = measured0
    sources = np.broadcast_to(src, shape + (2,)).copy()
    weights = np.broadcast_to(wts, shape + (2,)).copy()
    sources[i0], weights[i0] = -1, 0.0
    method = np.full(shape, FILL_METHOD_CODES["model"], dtype=np.uint8)
    method[i0] = np.where(measured0, FILL_METHOD_CODES["measured"], FILL_METHOD_CODES["unknown"])
    first = sources[..., 0]
    fill_source = np.where(measured, -1, np.where(first >= 0, first, -2))
    return {"measured": measured, "fill_source": fill_source, "fill_method": method, "fill_sources": sources,
            "fill_weights": weights}


def bend(
    flat: str | PathLike[str],
    *,
    model: str = "auto",
    kappa: Sequence[float] | ArrayLike | None = None,
    grid: str | Grid | None = None,
    material: str | None = None,
    fit_pairs: int = FIT_PAIRS,
    max_evaluations: int | None = None,
    progress: Callable[[str, int, int], None] | None = None,
) -> Any:
    """A CDBRDF from a flat measurement bent by a fitted fabric model (see the module's description).

    Parameters
    ----------
    flat
        A flat BRDF file of any importable format (RGL ``.bsdf``, MERL
        ``.binary``, UTIA ``.bin``, Neural-BRDF ``.h5``/``.json``, a
        one-curvature CDBRDF file at kappa = 0).
    model
        ``"auto"`` (woven and pile fitted, the better kept), ``"woven"`` or ``"pile"``.
    kappa
        Curvatures of the table, 1/mm (0 is added when missing); default the paper's.
    grid
        The directions: ``"paper"`` (default), ``"regular:THETA_STEP,PHI_STEP[,THETA_MAX]"``,
        ``"native"`` or a :class:`~cdbrdf.grid.Grid` (its curvatures are replaced by ``kappa``).
    material
        Name of the material (default the source's).
    fit_pairs
        Direction pairs of the fit.
    max_evaluations
        Model evaluations per fit (default each model's own, :attr:`cdbrdf.fit.FitModel.max_evaluations`).
    progress
        ``progress(stage, done, total)``, stages ``"fit"``, ``"model"``.

    Returns
    -------
    CDBRDF
        Anisotropic, ``quantity`` of the source; provenance as described.

    Raises
    ------
    FileNotFoundError, FormatError, TableError, OptionError
        One line naming the file or argument and the problem.
    """
    from ._version import __version__
    from .importers import read_source
    from .table import CDBRDF

    t0 = time.perf_counter()
    source = read_source(flat, material=material)
    if source.table is not None and float(source.table.kappa[0]) != 0.0:
        raise TableError(f"{source.path}: holds curvature {float(source.table.kappa[0]):g} 1/mm; bend needs a flat "
                         "measurement (kappa = 0)")
    g = bend_grid(grid, source, kappa)
    if model not in BEND_MODELS:
        raise OptionError(f"model: {model!r} is not one of {', '.join(BEND_MODELS)}")
    _check_curvatures(model, g.kappa)
    i0 = int(np.flatnonzero(g.kappa == 0.0)[0])
    if progress is not None:
        progress("fit", 0, 1)
    best, candidates = fit_flat(source, model=model, fit_pairs=fit_pairs, max_evaluations=max_evaluations)
    if progress is not None:
        progress("fit", 1, 1)
    fitted = best.build()
    flat_table = _flat_slice(source, g)
    try:
        mtab = fitted.tabulate(g, progress=None if progress is None else lambda d, n: progress("model", d, n))
    except (OptionError, ValueError) as exc:  # a curvature the fitted fabric cannot be bent to
        raise OptionError(f"kappa: {str(exc).splitlines()[0]}") from None
    values, ratio_info = _bent_values(np.asarray(flat_table.values[0], dtype=np.float64),
                                      np.asarray(mtab.values, dtype=np.float64), i0)
    arrays = _provenance_arrays(g, np.asarray(flat_table.measured[0]), i0)
    table = CDBRDF(values.astype(np.float32), g, provenance=Provenance(**arrays))
    alb = _albedo_max(table)
    limit = max(1.0, float(alb[i0]))
    scale = np.where((alb > limit) & (np.arange(alb.size) != i0), limit / np.maximum(alb, 1e-30), 1.0)
    if np.any(scale < 1.0):
        log.warning("the bent slices at kappa %s reflect up to %.3g of the light; scaled to %.3g",
                    ", ".join(f"{k:g}" for k in g.kappa[scale < 1.0]), float(alb.max()), limit)
        values = values * scale[:, None, None, None, None, None]
    flat_prov = flat_table.attrs.get("provenance", {})
    prov = {
        "kind": "bent",
        "software": f"cdbrdf {__version__}",
        "statement": STATEMENT,
        "flat": {"source": source.provenance(), "grid": flat_prov.get("grid"),
                 "resampling": flat_prov.get("resampling"), "expected_error": flat_prov.get("expected_error")},
        "model": best.to_dict(),
        "candidates": candidates,
        "bending": {"method": "model", "ratio": ratio_info, "reciprocity": "averaged with its light <-> view "
                    "mirror", "albedo_max": [round(float(a), 5) for a in alb],
                    "energy_scale": [round(float(s), 6) for s in scale], "albedo_limit": round(limit, 5)},
        "seconds": round(time.perf_counter() - t0, 1),
    }
    attrs = {"quantity": source.quantity, "colour_space": source.colour_space, "material": source.material,
             "predicted": STATEMENT, "model": best.model, "provenance": prov}
    log.info("bent %s with the %s model (median Delta E*ab %.2f at flat) in %.1f s", source.path, best.model,
             best.errors["test"]["delta_e_median"], prov["seconds"])
    return CDBRDF(values.astype(np.float32), g, provenance=Provenance(**arrays), attrs=attrs)
