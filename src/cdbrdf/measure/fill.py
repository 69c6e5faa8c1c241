"""Filling samples that could not be measured, as the paper does.

"Each such sample takes the value of the nearest direction that could be
measured" (Matsufuji & Kawai): an invalid sample (hidden by the stand,
missing, unreadable, saturated) copies the value of the measured sample *at
the same curvature* that minimises the distance

    d = angle(v, v') + angle(l, l')

(great-circle angles in degrees between the view directions and between the
light directions). Ties (distances equal within 1e-9 degree) go to the
candidate with the smallest C-order flat index over ``(phi_l, theta_l,
phi_v, theta_v)``, i.e. lowest light azimuth, then light elevation, then
view azimuth, then view elevation. The result records for each filled sample
the flat index (over all five sample axes) of its source.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ..errors import TableError
from ..frames import direction_from_angles
from ..table import Grid

__all__ = ["fill_nearest", "angle_between_deg", "TIE_TOLERANCE_DEG"]

#: Distances closer than this (degrees) are ties.
TIE_TOLERANCE_DEG = 1e-9


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


def fill_nearest(
    values: NDArray[np.floating],
    valid: NDArray[np.bool_],
    grid: Grid,
    *,
    std: NDArray[np.floating] | None = None,
) -> tuple[NDArray[np.float64], NDArray[np.int64], NDArray[np.float64] | None]:
    """Fill invalid samples from the nearest measured direction at the same curvature.

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
    fill = np.full(shape, -1, dtype=np.int64)
    nk, npl, ntl, npv, ntv = shape
    n_l, n_v = npl * ntl, npv * ntv
    d_l = _pair_distances(grid.theta_l, grid.phi_l)  # (n_l, n_l)
    d_v = _pair_distances(grid.theta_v, grid.phi_v)  # (n_v, n_v)
    for k in range(nk):
        m = valid[k].reshape(n_l, n_v)
        if m.all():
            continue
        if not m.any():
            raise TableError(
                f"kappa = {grid.kappa[k]:g} 1/mm: no sample was measured, so none can be filled"
            )
        flat_vals = out[k].reshape(n_l * n_v, -1)
        flat_std = None if out_std is None else out_std[k].reshape(n_l * n_v, -1)
        base = k * n_l * n_v
        for li, vi in zip(*np.nonzero(~m)):
            d = d_l[li][:, None] + d_v[vi][None, :]
            d = np.where(m, d, np.inf)
            best = d.min()
            j = int(np.flatnonzero(d.ravel() <= best + TIE_TOLERANCE_DEG)[0])
            i = li * n_v + vi
            flat_vals[i] = flat_vals[j]
            if flat_std is not None:
                flat_std[i] = flat_std[j]
            fill[k].reshape(-1)[i] = base + j
    return out, fill, out_std
