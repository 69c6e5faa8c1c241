"""The compression of a CD-BTF: one principal component analysis over the texels, its rank from an error target.

The texels of one repeat are the rows of a matrix whose columns are every
(kappa, light, view, channel) sample; the tile mean is taken out and the
deviations are factorised as ``weights (n_texels, rank) @ basis (rank,
n_samples)`` by the eigen-decomposition of their Gram matrix (texels x
texels, accumulated in float64 over blocks of columns, so the dense matrix is
never copied as float64). The rank is the smallest that brings the relative
RMS error of the whole table *and* of every curvature slice to the target;
the errors follow from the eigenvalues exactly (the energy of the components
left out), per curvature from the components' energy in that slice.

The relative RMS error of a slice is ``||B - B_r||_F / ||B||_F`` over all its
texels, directions and channels, with ``B`` the uncompressed values (the tile
mean included).
"""

from __future__ import annotations

import logging
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

__all__: list[str] = []

_LOG = logging.getLogger(__name__)

#: Columns per block of the Gram and projection products (float64 blocks of n_texels x this).
_BLOCK = 8192

#: Relative RMS errors this small are rounding (an error target of 0 keeps only what is really there).
_ROUNDING = 1e-9


class Factors(NamedTuple):
    """A factorised CD-BTF (private: :class:`cdbrdf.btf.CDBTF` holds it)."""

    mean: NDArray[np.float64]  # (n_samples,) per kappa-major column
    weights: NDArray[np.float32]  # (n_texels, rank), unit RMS per component
    basis: NDArray[np.float32]  # (rank, n_samples)
    error: float
    error_per_kappa: NDArray[np.float64]
    spectrum: NDArray[np.float64]  # relative RMS error of every rank 0 .. max_rank (whole table)


def factorise(dense: NDArray[np.floating], n_kappa: int, *, max_error: float, max_rank: int,
              energy_per_kappa: NDArray[np.floating] | None = None) -> Factors:
    """Factorise ``dense (n_texels, n_samples)`` (kappa-major columns) at the smallest rank meeting ``max_error``.

    ``energy_per_kappa``: the squared norm of the uncompressed texels in each
    curvature slice that the errors are relative to, when ``dense`` is what
    another representation left of them (default: ``dense``'s own).

    When no rank up to ``max_rank`` meets the target the factorisation of
    ``max_rank`` is returned (its errors say how far it is); a warning is logged.
    """
    t, d = dense.shape
    mean = dense.mean(axis=0, dtype=np.float64)
    per_k = d // n_kappa
    gram = np.zeros((t, t))
    full_k = np.zeros(n_kappa)
    dev_k = np.zeros(n_kappa)  # the deviations' energy per slice
    for c0 in range(0, d, _BLOCK):
        c1 = min(d, c0 + _BLOCK)
        x = dense[:, c0:c1].astype(np.float64) - mean[c0:c1]
        gram += x @ x.T
        full = np.einsum("ij,ij->j", dense[:, c0:c1], dense[:, c0:c1], dtype=np.float64)
        np.add.at(full_k, np.arange(c0, c1) // per_k, full)
        np.add.at(dev_k, np.arange(c0, c1) // per_k, np.einsum("ij,ij->j", x, x))
    lam, u = np.linalg.eigh(gram)
    order = np.argsort(lam)[::-1]
    lam, u = np.maximum(lam[order], 0.0), u[:, order]
    r_max = int(min(max_rank, t - 1 if t > 1 else 0, d))
    u = u[:, :r_max]
    # the energy of each component in each curvature slice
    energy_k = np.zeros((n_kappa, r_max))
    proj = np.empty((r_max, d))
    for c0 in range(0, d, _BLOCK):
        c1 = min(d, c0 + _BLOCK)
        x = dense[:, c0:c1].astype(np.float64) - mean[c0:c1]
        p = u.T @ x
        proj[:, c0:c1] = p
        kk = np.arange(c0, c1) // per_k
        for k in np.unique(kk):
            energy_k[k] += np.einsum("ij,ij->i", p[:, kk == k], p[:, kk == k])
    if energy_per_kappa is not None:
        full_k = np.asarray(energy_per_kappa, dtype=np.float64).reshape(n_kappa)
    safe_k = np.where(full_k > 0, full_k, 1.0)
    cum = np.concatenate([np.zeros((n_kappa, 1)), np.cumsum(energy_k, axis=1)], axis=1)
    err_k = np.sqrt(np.maximum(dev_k[:, None] - cum, 0.0) / safe_k[:, None])  # (n_kappa, r_max + 1)
    total = float(full_k.sum()) or 1.0
    err = np.sqrt(np.maximum(dev_k.sum() - cum.sum(axis=0), 0.0) / total)
    # errors below _ROUNDING are the rounding of the mean and of the eigen-decomposition: no error
    ok = np.flatnonzero((err <= max_error + _ROUNDING) & np.all(err_k <= max_error + _ROUNDING, axis=0))
    if ok.size:
        rank = int(ok[0])
    else:
        rank = r_max
        _LOG.warning("no rank up to %d meets the error target %g (rank %d: %.4f)", r_max, max_error, rank, err[rank])
    scale = np.sqrt(t)
    weights = (u[:, :rank] * scale).astype(np.float32)
    basis = (proj[:rank] / scale).astype(np.float32)
    return Factors(mean=mean, weights=weights, basis=basis, error=float(err[rank]),
                   error_per_kappa=err_k[:, rank].copy(), spectrum=err)
