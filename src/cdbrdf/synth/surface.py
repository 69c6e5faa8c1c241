"""Integration points on the cloth's micro-surface, spread by surface area.

The micro-surface is the bilinear interpolation of a
:class:`~cdbrdf.synth.weave.Heightfield`'s texel-centre heights. Its
reflectance integral ``int F dA`` over one repeat is estimated as
``sum_p w_p F(p)`` over ``n`` points ``p`` that sample the surface in
proportion to its area: a rank-1 (golden-ratio) lattice in the unit square is
mapped through the cells' area distribution (rows by their area, then cells
within the row), uniformly inside each cell; ``w_p`` is the exact area
element at ``p`` over the sampling density, so the estimate is unbiased
whatever the slopes (steep yarn flanks get as many points as their area
calls for).

Each point carries the bilinear surface's own normal there and the fibre
direction of the texel it lies in, projected into that surface.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .._jit import run_split
from . import _trace
from .weave import Heightfield, x_of_xi

__all__ = ["SurfacePoints", "surface_points"]

_GOLDEN = 0.6180339887498949


@dataclass(frozen=True, eq=False)
class SurfacePoints:
    """Integration points on the micro-surface of one repeat.

    Attributes
    ----------
    position
        ``(n, 3)`` x, y, z in mm.
    normal, tangent
        ``(n, 3)`` unit surface normal and fibre direction (in the surface).
    kind
        ``(n,)`` int8: the yarn (or backing) the point belongs to.
    weight
        ``(n,)`` each point's share of the surface area, mm^2 (they add up
        to about :attr:`area_mm2`).
    area_mm2
        The surface area of the repeat.
    """

    position: NDArray[np.float64]
    normal: NDArray[np.float64]
    tangent: NDArray[np.float64]
    kind: NDArray[np.int8]
    weight: NDArray[np.float64]
    area_mm2: float


def surface_points(hf: Heightfield, n: int) -> SurfacePoints:
    """``n`` points spread over the micro-surface of ``hf`` in proportion to its area.

    Parameters
    ----------
    hf
        The height field.
    n
        Number of points (>= 1).

    Returns
    -------
    SurfacePoints
    """
    ny, nx = hf.shape
    dy = hf.size_mm[1] / ny
    H = np.ascontiguousarray(hf.height)
    xedges = np.ascontiguousarray(x_of_xi(np.arange(nx + 1, dtype=np.float64), hf.xmap))
    areas = np.zeros((ny, nx))
    run_split(_trace.cell_areas, ny, H, xedges, dy, areas, grain=4)
    row = areas.sum(axis=1)
    total = float(row.sum())
    i = np.arange(n, dtype=np.float64)
    u_x = (i + 0.5) / n
    u_y = np.mod(0.5 + i * _GOLDEN, 1.0)
    # Rows by their area, then cells within the row.
    row_cdf = np.concatenate([[0.0], np.cumsum(row)]) / total
    j = np.clip(np.searchsorted(row_cdf, u_y, side="right") - 1, 0, ny - 1)
    r_y = (u_y - row_cdf[j]) / (row_cdf[j + 1] - row_cdf[j])
    cell_cdf = np.concatenate([np.zeros((ny, 1)), np.cumsum(areas, axis=1)], axis=1) / row[:, None]
    ic = np.empty(n, dtype=np.int64)
    for jj in np.unique(j):
        sel = j == jj
        # "right": a cell of zero area (a closed gap) is never chosen.
        ic[sel] = np.searchsorted(cell_cdf[jj], u_x[sel], side="right") - 1
    ic = np.clip(ic, 0, nx - 1)
    lo = cell_cdf[j, ic]
    r_x = (u_x - lo) / (cell_cdf[j, ic + 1] - lo)
    xi = np.mod(ic + 0.5 + np.clip(r_x, 0.0, 1.0), nx)
    yy = np.mod((j + 0.5 + np.clip(r_y, 0.0, 1.0)) * dy, hf.size_mm[1])
    pos = np.empty((n, 3))
    normal = np.empty((n, 3))
    tangent = np.empty((n, 3))
    kind = np.empty(n, dtype=np.int8)
    jac = np.empty(n)
    run_split(_trace.place_points, n, H, xedges, dy, np.ascontiguousarray(xi), np.ascontiguousarray(yy),
              np.ascontiguousarray(hf.tangent.reshape(-1, 3)), np.ascontiguousarray(hf.kind.reshape(-1)),
              pos, normal, tangent, kind, jac, grain=256)
    # Sampling density per unit of (texel coordinate x, mm of y): cell area / total / dy.
    weight = jac * dy * total / (areas[j, ic] * n)
    for a in (pos, normal, tangent, kind, weight):
        a.setflags(write=False)
    return SurfacePoints(position=pos, normal=normal, tangent=tangent, kind=kind, weight=weight, area_mm2=total)
