"""How each fill method estimates the samples it fills, and the checks of its uncertainty. Private.

The machinery of :mod:`cdbrdf.measure.fill` (which documents the methods):
the paper's nearest direction, the curvature fits, the model fill's
prediction, the ``auto`` choice among them, and the checks (hidden-like and
self) the uncertainty is fitted to.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..errors import TableError
from ..frames import direction_from_angles
from ..schema import FILL_METHOD_CODES
from ..table import Grid
from ._fill_sigma import MIN_CHECK_SAMPLES, TINY, Checks
from ._fill_sigma import log_error as _log_error
from ._fill_sigma import reach as _reach
from .fill_model import ModelFit, model_predict

__all__: list[str] = []

#: Distances closer than this (degrees) are ties.
TIE_TOLERANCE_DEG = 1e-9

#: Share of a stand's measured samples the self check uses: those nearest (in
#: ``angle(v, v') + angle(l, l')``) to the samples it fills, which resemble them most.
CHECK_FRACTION = 0.25

_TINY = TINY
_CODE = FILL_METHOD_CODES


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


@dataclass
class _Estimate:
    """Fills of target samples: flat indices, values, per-sample codes, sources and weights (slots), reaches."""

    idx: NDArray[np.intp]
    values: NDArray[np.float64]
    code: NDArray[np.uint8]
    sources: NDArray[np.int64]
    weights: NDArray[np.float64]
    reach: NDArray[np.float64]


def _estimate(method: str, vals: NDArray[np.float64], valid: NDArray[np.bool_], grid: Grid,
              targets: NDArray[np.bool_], fit: ModelFit | None) -> _Estimate:
    """Fill the ``targets`` (invalid samples) by ``method`` from the ``valid`` ones (nothing is written)."""
    nk, nc = grid.shape[0], vals.shape[-1]
    per = valid.size // nk
    vk = vals.reshape(nk, per, nc)
    tk = targets.reshape(nk, per)
    rows: list[tuple[NDArray, NDArray, int, NDArray, NDArray, NDArray]] = []
    to_nearest = targets.copy() if method == "nearest" else np.zeros(grid.shape, dtype=bool)
    for k in range(nk) if method != "nearest" else ():
        if not tk[k].any():
            continue
        for stands, ids in _source_stands(valid, k, grid.kappa, nearest_only=method == "nearest-stand").items():
            ids = ids[tk[k, ids]]
            if not ids.size:
                continue
            if not stands:
                to_nearest.reshape(nk, per)[k, ids] = True
                continue
            if method == "model":
                assert fit is not None
                value, reach, w = model_predict(fit, vals, k, ids, stands, grid.kappa)
                c = _CODE["model"]
            else:
                w = kappa_fit_weights(grid.kappa[list(stands)], float(grid.kappa[k]))
                src = vk[list(stands)][:, ids]  # (n_stands, n_ids, nc); sources are measured
                value = _combine(src, w)
                c = _CODE["kappa_fit" if len(stands) > 1 else "nearest_stand"]
                reach = _reach(value, src[0]) if len(stands) > 1 else np.zeros(value.shape)
            src_idx = np.stack([s * per + ids for s in stands], axis=1)
            rows.append((k * per + ids, value, c, src_idx, np.broadcast_to(w, src_idx.shape), reach))
    if to_nearest.any():
        nsrc, ndist = _nearest_sources(valid, grid, to_nearest)
        i = np.flatnonzero(to_nearest.ravel())
        j = nsrc.ravel()[i]
        rows.append((i, vals.reshape(-1, nc)[j], _CODE["nearest"], j[:, None], np.ones((i.size, 1)),
                     np.broadcast_to(ndist.ravel()[i][:, None], (i.size, nc))))
    n_slot = max([1] + [r[3].shape[1] for r in rows])

    def pad(a: NDArray, fill_value: float) -> NDArray:
        return np.pad(a, ((0, 0), (0, n_slot - a.shape[1])), constant_values=fill_value)

    if not rows:
        z = np.zeros((0, nc))
        return _Estimate(np.zeros(0, dtype=np.intp), z, np.zeros(0, dtype=np.uint8),
                         np.zeros((0, n_slot), dtype=np.int64), np.zeros((0, n_slot)), z)
    return _Estimate(
        idx=np.concatenate([r[0] for r in rows]).astype(np.intp),
        values=np.concatenate([r[1] for r in rows]),
        code=np.concatenate([np.full(r[0].size, r[2], dtype=np.uint8) for r in rows]),
        sources=np.concatenate([pad(r[3], -1) for r in rows]).astype(np.int64),
        weights=np.concatenate([pad(np.asarray(r[4], dtype=np.float64), 0.0) for r in rows]),
        reach=np.concatenate([np.asarray(r[5], dtype=np.float64) for r in rows]),
    )


def _checks(method: str, vals: NDArray[np.float64], valid: NDArray[np.bool_], grid: Grid, fit: ModelFit | None,
            est: _Estimate) -> Checks:
    """The checks of a fill's uncertainty (module description): hidden-like, and self checks where those lack."""
    nk, nc = grid.shape[0], vals.shape[-1]
    per = valid.size // nk
    vflat = valid.reshape(nk, per)
    checks = Checks()
    for k0 in range(nk):
        hid = ~vflat[k0]
        if not hid.any():
            continue
        for s in range(nk):
            # the directions stand k0 hides, measured on stand s: hidden there too, filled the same way
            t = hid & vflat[s]
            if s == k0 or not t.any() or t.sum() == vflat[s].sum():
                continue
            v2 = valid.copy()
            v2.reshape(nk, per)[s, t] = False
            targets = np.zeros(valid.shape, dtype=bool)
            targets.reshape(nk, per)[s, t] = True
            chk = _estimate(method, vals, v2, grid, targets, fit)
            e = _log_error(chk.values, vals.reshape(-1, nc)[chk.idx])
            for c in np.unique(chk.code).tolist():
                sel = chk.code == c
                checks.add("hidden-like", c, k0, chk.reach[sel], e[sel])
    ks = est.idx // per
    for k0 in np.unique(ks).tolist() if method != "model" else ():  # (the model is known at hidden directions only)
        codes = np.unique(est.code[ks == k0]).tolist()
        if all(checks.count("hidden-like", c) >= MIN_CHECK_SAMPLES for c in codes):
            continue
        # the measured samples of the stand nearest to its filled ones, removed and filled again
        chk_ids = _nearest_checks(np.flatnonzero(vflat[k0]), np.flatnonzero(~vflat[k0]), grid)
        if chk_ids.size < 1 or chk_ids.size == vflat[k0].sum():
            chk_ids = chk_ids[: max(0, vflat[k0].sum() - 1)]
        if not chk_ids.size:
            continue
        v2 = valid.copy()
        v2.reshape(nk, per)[k0, chk_ids] = False
        targets = np.zeros(valid.shape, dtype=bool)
        targets.reshape(nk, per)[k0, chk_ids] = True
        chk = _estimate(method, vals, v2, grid, targets, fit)
        e = _log_error(chk.values, vals.reshape(-1, nc)[chk.idx])
        for c in np.unique(chk.code).tolist():
            sel = chk.code == c
            checks.add("self", c, k0, chk.reach[sel], e[sel])
    return checks


def _check_score(checks: Checks, k0: int) -> float:
    """Median absolute log error of a method's check for hidden stand ``k0`` (hidden-like, else self; inf: none)."""
    for origin in ("hidden-like", "self"):
        es = [e for key, (_, e) in checks.items.items() if key[0] == origin and key[2] == k0]
        if sum(e.shape[0] for e in es) >= MIN_CHECK_SAMPLES:
            return float(np.median(np.abs(np.concatenate(es))))
    return math.inf


#: The methods ``auto`` chooses from, in order of preference on equal scores.
_AUTO_CANDIDATES = ("model", "kappa-fit", "nearest-stand", "nearest")


def _select(vals: NDArray[np.float64], valid: NDArray[np.bool_], grid: Grid, fit: ModelFit | None
            ) -> tuple[_Estimate, Checks, NDArray[np.float64], dict[str, Any]]:
    """``auto``: per hidden stand the candidate whose check errs least; the runner-up's log difference as spread."""
    nk = grid.shape[0]
    per = valid.size // nk
    cands = [m for m in _AUTO_CANDIDATES if m != "model" or fit is not None]
    ests = {m: _estimate(m, vals, valid, grid, ~valid, fit) for m in cands}
    checks = {m: _checks(m, vals, valid, grid, fit, ests[m]) for m in cands}
    # every estimate covers the same targets; align them by flat index
    order = {m: np.argsort(e.idx, kind="stable") for m, e in ests.items()}
    parts: list[_Estimate] = []
    spreads: list[NDArray[np.float64]] = []
    merged = Checks()
    selection: dict[str, Any] = {}
    for k0 in range(nk):
        if valid.reshape(nk, per)[k0].all():
            continue
        scores = {m: _check_score(checks[m], k0) for m in cands}
        ranked = sorted(cands, key=lambda m: (scores[m], cands.index(m)))
        best, runner = ranked[0], ranked[1] if len(ranked) > 1 else ranked[0]
        eb, er = ests[best], ests[runner]
        ib = order[best][(eb.idx[order[best]] // per) == k0]
        ir = order[runner][(er.idx[order[runner]] // per) == k0]
        parts.append(_Estimate(eb.idx[ib], eb.values[ib], eb.code[ib], eb.sources[ib], eb.weights[ib], eb.reach[ib]))
        d = np.abs(_log_error(eb.values[ib], er.values[ir]))
        spreads.append(np.where(np.isfinite(d), d, 0.0))
        for key, (x, e) in checks[best].items.items():
            if key[2] == k0:
                merged.add(key[0], key[1], key[2], x, e)
        selection[f"{grid.kappa[k0]:g}"] = {"method": best, "runner_up": runner,
                                            "check_median_abs_log_error": {m: round(v, 5) if math.isfinite(v) else None
                                                                              for m, v in scores.items()}}
    n_slot = max(p.sources.shape[1] for p in parts)

    def pad(a: NDArray, value: float) -> NDArray:
        return np.pad(a, ((0, 0), (0, n_slot - a.shape[1])), constant_values=value)

    est = _Estimate(idx=np.concatenate([p.idx for p in parts]), values=np.concatenate([p.values for p in parts]),
                    code=np.concatenate([p.code for p in parts]),
                    sources=np.concatenate([pad(p.sources, -1) for p in parts]),
                    weights=np.concatenate([pad(p.weights, 0.0) for p in parts]),
                    reach=np.concatenate([p.reach for p in parts]))
    return est, merged, np.concatenate(spreads), selection


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
