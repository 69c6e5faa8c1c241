"""The model fill: the fabric model fitted to the measured samples of every stand fills the hidden ones.

``cdbrdf measure --fill model`` (:func:`cdbrdf.measure.fill.fill`,
``method="model"``). The data fills can only carry a measured value to a
hidden sample along the curvature or across directions; where the fabric's
response to bending at the hidden directions is its own (the grazing
directions of a concave stand, which no other stand measures at a concave
curvature), they miss it. A model of the fabric predicts it. This module:

1. **chooses the model**: the preset named by the table's material
   (:mod:`cdbrdf.synth.presets`), else the preset that fits the measured
   samples best;
2. **fits it** to the measured samples of all stands: the model's parts
   (woven: the white surface reflection, each yarn's and the backing's
   volume scattering, the further orders; pile: the light of the pile and
   that of the ground) are recombined channel by channel with non-negative
   weights (least squares of the relative error; :class:`ModelFit`), which
   fits the yarn colours, the gloss and the share of the further orders
   without re-solving the model's geometry;
3. **fills** a hidden sample by the fitted model's change with curvature
   applied to the same direction's measured values on the other stands:
   ``f(kappa_0) = exp(sum_s w_s (log f(kappa_s) + log M(kappa_0) - log M(kappa_s)))``,
   ``w_s`` proportional to ``1 / |kappa_s - kappa_0|`` (the model carries the
   curvature, the measurement the level), so that an error of the model's
   absolute level cancels.

The reach of a model fill (what its uncertainty grows with) is the model's
predicted change ``|log(M(kappa_0) / M(kappa_first))|``.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..grid import Grid
from ._fill_sigma import TINY

__all__ = ["ModelFit", "fit_model", "FIT_SAMPLES"]

_LOG = logging.getLogger(__name__)

#: Measured samples (at most) the model is fitted to, besides those at the hidden directions.
FIT_SAMPLES = 1200


def _angles(grid: Grid, k: NDArray[np.intp], d: NDArray[np.intp]) -> tuple[NDArray[np.float64], ...]:
    """``(theta_v, phi_v, theta_l, phi_l, kappa)`` of samples ``(k, d)`` (``d``: flat over the direction axes)."""
    _, npl, ntl, npv, ntv = grid.shape
    il, iv = np.divmod(d, npv * ntv)
    ipl, itl = np.divmod(il, ntl)
    ipv, itv = np.divmod(iv, ntv)
    return (grid.theta_v[itv], grid.phi_v[ipv], grid.theta_l[itl], grid.phi_l[ipl], grid.kappa[k])


def _parts(name: str, args: tuple[NDArray[np.float64], ...], *, further: bool = True) -> NDArray[np.float64]:
    """The preset's parts at samples: ``(n, channels 3, parts)``, their per-channel sum the model's value.

    ``further=False``: single scattering only (cheap: how a candidate preset is chosen).
    """
    from ..synth import presets
    from ..synth.pile import PileModel

    model = presets.model(name) if further else presets.model(name, scattering="single")
    if isinstance(model, PileModel):
        pile, ground = model.evaluate_parts(*args)
        return np.stack([pile, ground], axis=-1)
    p = model.params
    probe = model.recoloured(warp_rgb=(0.0, 1.0, 0.0), weft_rgb=(0.0, 0.0, 1.0), backing_rgb=(0.0, 0.0, 0.0),
                             scattering="single").evaluate(*args)
    back = model.recoloured(warp_rgb=(0.0, 0.0, 0.0), weft_rgb=(0.0, 0.0, 0.0), backing_rgb=(1.0, 1.0, 1.0),
                            scattering="single").evaluate(*args)[:, 0]
    spec = probe[:, 0]
    vol = np.stack([probe[:, 1] - spec, probe[:, 2] - spec, back - spec], axis=-1)  # (n, 3 kinds)
    colours = np.array([p.warp_rgb, p.weft_rgb, p.backing_rgb])  # (kinds, channels)
    n = spec.size
    out = np.empty((n, 3, 5 if further else 4))
    out[..., 0] = spec[:, None]
    out[..., 1:4] = np.broadcast_to(np.clip(vol, 0.0, None)[:, None, :], (n, 3, 3))
    if further:
        single = spec[:, None] + vol @ colours  # (n, channels)
        out[..., 4] = np.clip(model.evaluate(*args) - single, 0.0, None)
    return out


def _nnls_relative(parts: NDArray[np.float64], f: NDArray[np.float64]) -> tuple[NDArray[np.float64], float]:
    """Non-negative weights of the parts ``(n, p)`` minimising the relative error to ``f (n,)``; their RMS."""
    from scipy.optimize import nnls

    ok = (f > TINY) & np.all(np.isfinite(parts), axis=1)
    if ok.sum() < parts.shape[1]:
        return np.ones(parts.shape[1]), float("inf")
    a = parts[ok] / f[ok, None]
    w, _ = nnls(a, np.ones(int(ok.sum())), maxiter=50 * parts.shape[1])
    rel = a @ w - 1.0
    return w, float(np.sqrt(np.mean(rel**2)))


@dataclass
class ModelFit:
    """A preset fitted to a table's measured samples, evaluated where the fill needs it.

    Attributes
    ----------
    preset
        The preset's name.
    weights
        ``(channels, parts)`` the non-negative weight of each part per channel.
    fit_rel_rms
        Relative RMS error of the fit over the samples it was fitted to.
    directions
        ``(D,)`` flat direction indices (over the four direction axes) the
        model is known at, at every curvature.
    values
        ``(n_kappa, D, channels)`` the fitted model there.
    chosen_from
        The candidates and their fit error when the preset was chosen by fit.
    """

    preset: str
    weights: NDArray[np.float64]
    fit_rel_rms: float
    directions: NDArray[np.intp]
    values: NDArray[np.float64]
    chosen_from: dict[str, float] = field(default_factory=dict)

    def at(self, k: int, d: NDArray[np.intp]) -> NDArray[np.float64]:
        """The fitted model at curvature index ``k`` and directions ``d`` (which must be among :attr:`directions`)."""
        pos = np.searchsorted(self.directions, d)
        return self.values[k, pos]

    def summary(self) -> dict[str, Any]:
        """JSON-ready: the preset, the weights, the fit error."""
        def num(v: float) -> float | None:
            return round(v, 5) if np.isfinite(v) else None

        out: dict[str, Any] = {"preset": self.preset, "part_weights": np.round(self.weights, 5).tolist(),
                               "fit_rel_rms": num(self.fit_rel_rms)}
        if self.chosen_from:
            out["chosen_from"] = {k: num(v) for k, v in self.chosen_from.items()}
        return out


def _fit_one(name: str, vals: NDArray[np.float64], grid: Grid, fit_k: NDArray[np.intp], fit_d: NDArray[np.intp],
             need_d: NDArray[np.intp], *, further: bool = True) -> ModelFit:
    nk = grid.shape[0]
    kk = np.concatenate([fit_k, np.repeat(np.arange(nk), need_d.size)])
    dd = np.concatenate([fit_d, np.tile(need_d, nk)])
    parts = _parts(name, _angles(grid, kk, dd), further=further)  # (n, 3, p)
    nf = fit_k.size
    per = int(np.prod(grid.shape[1:]))
    f = vals.reshape(nk, per, -1)[fit_k, fit_d]  # (nf, channels)
    nc = f.shape[1]
    weights = np.zeros((nc, parts.shape[2]))
    errs = []
    for c in range(nc):
        weights[c], err = _nnls_relative(parts[:nf, c], f[:, c])
        errs.append(err)
    model = np.einsum("nip,ip->ni", parts[nf:], weights)
    return ModelFit(preset=name, weights=weights, fit_rel_rms=float(np.sqrt(np.mean(np.square(errs)))),
                    directions=need_d, values=model.reshape(nk, need_d.size, nc))


def fit_model(vals: NDArray[np.float64], valid: NDArray[np.bool_], grid: Grid, *, material: str | None,
              directions: NDArray[np.intp]) -> ModelFit:
    """Fit a preset to the measured samples and evaluate it at ``directions`` on every stand.

    Parameters
    ----------
    vals
        ``grid.shape + (channels,)`` values (measured where ``valid``).
    valid
        ``grid.shape`` booleans.
    grid
        The sample axes.
    material
        The table's material: a preset of that name is used; otherwise every
        preset is fitted and the best (lowest relative RMS) kept.
    directions
        Sorted flat direction indices where the fill needs the model.

    Returns
    -------
    ModelFit
        The fit.
    """
    from ..synth import presets

    nk = grid.shape[0]
    flat = valid.reshape(nk, -1)
    per = flat.shape[1]
    # fitted to the measured samples at the hidden directions (every stand) and a spread of the others
    at_need = np.zeros(per, dtype=bool)
    at_need[directions] = True
    kk, dd = np.nonzero(flat & at_need[None, :])
    others_k, others_d = np.nonzero(flat & ~at_need[None, :])
    rng = np.random.default_rng(0)
    take = rng.permutation(others_k.size)[: max(0, FIT_SAMPLES - kk.size // 2)]
    fit_k = np.concatenate([kk, others_k[np.sort(take)]])
    fit_d = np.concatenate([dd, others_d[np.sort(take)]])
    chosen_from: dict[str, float] = {}
    if material in presets.names():
        name = str(material)
    else:  # the candidates compared in single scattering (cheap), the best fitted in full
        none = np.zeros(0, dtype=np.intp)
        singles = [_fit_one(c, vals, grid, fit_k, fit_d, none, further=False) for c in presets.names()]
        chosen_from = {f.preset: f.fit_rel_rms for f in singles}
        name = min(singles, key=lambda f: f.fit_rel_rms).preset
    best = _fit_one(name, vals, grid, fit_k, fit_d, directions)
    best.chosen_from = chosen_from
    _LOG.info("model fill: %s fitted to %d measured samples (relative RMS %.3f)", best.preset, fit_k.size,
              best.fit_rel_rms)
    return best


def model_fill_weights(kappa_sources: NDArray[np.float64], kappa_target: float) -> NDArray[np.float64]:
    """Weights ``w_s`` of the source stands of a model fill: ``1 / |kappa_s - kappa_0|``, summing to 1."""
    x = np.abs(np.asarray(kappa_sources, dtype=np.float64) - float(kappa_target))
    w = 1.0 / np.maximum(x, 1e-12)
    return w / w.sum()


def model_predict(fit: ModelFit, vals: NDArray[np.float64], k0: int, ids: NDArray[np.intp],
                  stands: tuple[int, ...], kappa: NDArray[np.float64]
                  ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """The model fill of directions ``ids`` at stand ``k0`` from ``stands`` (nearest first).

    Returns ``(values (n, c), reach (n, c), weights (len(stands),))``.
    """
    nk = vals.shape[0]
    v = vals.reshape(nk, -1, vals.shape[-1])
    w = model_fill_weights(kappa[list(stands)], float(kappa[k0]))
    m0 = fit.at(k0, ids)
    logs = np.zeros(m0.shape)
    lin = np.zeros(m0.shape)
    pos = np.ones(m0.shape, dtype=bool)
    for ws, s in zip(w, stands, strict=True):
        ms = fit.at(s, ids)
        fs = v[s, ids]
        ok = (fs > TINY) & (ms > TINY) & (m0 > TINY)
        pos &= ok
        with np.errstate(divide="ignore", invalid="ignore"):
            logs += ws * np.where(ok, np.log(np.where(ok, fs, 1.0)) + np.log(np.where(ok, m0, 1.0))
                                  - np.log(np.where(ok, ms, 1.0)), 0.0)
            lin += ws * fs * np.where(ms > TINY, m0 / np.where(ms > TINY, ms, 1.0), 1.0)
    out = np.where(pos, np.exp(logs), lin)
    first = fit.at(stands[0], ids)
    ok = (m0 > TINY) & (first > TINY)
    with np.errstate(divide="ignore", invalid="ignore"):
        reach = np.where(ok, np.abs(np.log(np.where(ok, m0, 1.0) / np.where(ok, first, 1.0))), 1.0)
    return out, reach, w
