"""Importance sampling of the light direction from a prepared table: the tables and the rule.

The plug-in (:mod:`cdbrdf.render._bsdf`) samples Mitsuba's ``wo`` (the light
direction, in radiance transport) proportionally to the tabulated
reflectance times the cosine, conditioned on the curvature and the view
direction, mixed with cosine sampling. This module builds the sampling
tables from a :class:`~cdbrdf.interp.LookupGrid` (NumPy, no Mitsuba) and
states the sampling rule once, in NumPy (:func:`sample`, :func:`pdf`): the
scalar variants call it per ray and the tests hold the Dr.Jit copy
(:mod:`cdbrdf.render._sampling_jit`) to it.

The distributions
-----------------
One 2-D distribution per *slice*, i.e. per node ``(kappa, theta_v, phi_v)``
of the prepared grid (the pole node of theta_v included), over the light
direction in the coordinates

    u1 = (phi_l - phi_l[0]) / 360 (mod 1),    u2 = sin^2(theta_l),

in which the cosine-weighted hemisphere is uniform (``cos(theta) d omega =
pi du1 du2``): a density ``p(u)`` on the unit square is the solid-angle
density ``p(u) cos(theta_l) / pi``, so cosine sampling is ``p = 1`` and a
density proportional to the table ``f`` samples ``f cos``. The unit square is
cut into ``nx x ny`` cells; a slice's cell holds the mean over the cell of
the luminance of the table (Rec. 709 ``Y``; the value of a one-channel table),
computed exactly from the lookup rule of :mod:`cdbrdf.interp`: the slice is
bilinear in (phi_l, theta_l) degrees, periodic in phi_l, clamped beyond the
last theta_l, so its cell means are ``A_theta @ V @ A_phi.T`` with the 1-D
means of the interpolation weights (negative means are set to 0). A slice
keeps its mean ``mass`` (in sr^-1) and its density ``cells / mass`` (mean 1),
or the uniform density when its mass is 0.

Blending and mixing (the rule)
------------------------------
For a query ``(kappa, theta_v, phi_v)`` the lookup rule gives up to 8
neighbouring slices ``s`` with multilinear weights ``w_s`` (kappa and theta_v
clamped, phi_v periodic, the pole rule of theta_v). The table part of the
density is the normalised blend of the slices' cell means,

    p_T(u) = sum_s w_s mass_s D_s(u) / sum_s w_s mass_s,

i.e. proportional to the lookup's own interpolation of the cell means, and
the density is the mixture with cosine sampling

    p(u) = (1 - c) p_T(u) + c,     c = cosine_weight in (0, 1],

(``c = 1`` where ``sum_s w_s mass_s = 0``), so no direction of the
hemisphere has zero density. Sampling draws the component with ``sample1``:
cosine with probability ``c``, else slice ``s`` with probability
``w_s mass_s / sum``, and then ``sample2`` through that slice's marginal CDF
(rows, u2) and conditional CDF (columns, u1), linear inside a cell. The
density reported for a direction is always ``p(u)`` recomputed from the
direction, so ``sample`` and ``pdf`` agree exactly.

Isotropic tables (one light azimuth; the view azimuth axis holds the
difference ``phi_v - phi_l``, the lookup rotates every query) have slices
over (kappa, theta_v) only, and u1 is that difference: ``u1 = (phi_v - phi_l
- phi_v[0]) / 360 (mod 1)``, so the sampled light azimuth is ``phi_v - (phi_v[0]
+ 360 u1)`` (a shift: same density). The cell means come from the same
lookup rule along the difference axis, and the conditioning is the lookup's
weights in kappa and theta_v.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..colour import LUMINANCE_WEIGHTS
from ..interp import PERIOD_DEG, LookupGrid

__all__ = [
    "DEFAULT_COSINE_WEIGHT",
    "MAX_CELLS",
    "SamplerTables",
    "build_sampler",
    "default_resolution",
    "slice_weights",
    "pdf",
    "sample",
    "direction_to_square",
    "square_to_direction",
]

#: Default share of cosine sampling in the mixture (:func:`pdf`).
DEFAULT_COSINE_WEIGHT = 0.1

#: Most cells of all slices together (each array of the tables holds this many floats).
MAX_CELLS = 1 << 22

#: Sub-samples per cell and axis when averaging the interpolation weights.
_SUBSAMPLES = 8

_RAD2DEG = 180.0 / math.pi


@dataclass(frozen=True)
class SamplerTables:
    """The sampling distributions of one prepared table (see the module docstring).

    Attributes
    ----------
    nx, ny
        Cells along u1 (light azimuth) and u2 (sin^2 of the light elevation).
    phi0_deg
        Light azimuth at u1 = 0 (the table's first light azimuth), degrees;
        for an isotropic table the azimuth difference at u1 = 0 (the first
        ``phi_v``).
    kappa, theta_v
        The slice nodes: the prepared grid's curvature (mm^-1) and view
        elevation axes (degrees, node 0 the pole).
    phi_v0_deg, n_phi_v
        First view azimuth (degrees) and number of view azimuths (evenly
        spaced) the slices are conditioned on (1 for an isotropic table).
    mass
        ``(n_slices,)`` float64 mean cell value of each slice (sr^-1); slice
        ``s = (i_kappa * n_theta_v + i_theta_v) * n_phi_v + i_phi_v``.
    density
        ``(n_slices, ny, nx)`` float32 normalised cell densities (mean 1).
    marginal_cdf
        ``(n_slices, ny)`` float32 inclusive cumulative row masses (last = 1).
    conditional_cdf
        ``(n_slices, ny, nx)`` float32 inclusive cumulative cell masses per row (last = 1).
    isotropic
        The table's layout is isotropic (u1 is the azimuth difference).
    """

    nx: int
    ny: int
    phi0_deg: float
    kappa: NDArray[np.float64]
    kappa_inv_d: NDArray[np.float64]
    theta_v: NDArray[np.float64]
    theta_v_inv_d: NDArray[np.float64]
    phi_v0_deg: float
    n_phi_v: int
    mass: NDArray[np.float64]
    density: NDArray[np.float32]
    marginal_cdf: NDArray[np.float32]
    conditional_cdf: NDArray[np.float32]
    isotropic: bool = False

    @property
    def n_slices(self) -> int:
        """Number of slices (conditioning nodes)."""
        return int(self.mass.size)

    @property
    def nbytes(self) -> int:
        """Bytes held by the arrays."""
        return int(self.mass.nbytes + self.density.nbytes + self.marginal_cdf.nbytes
                   + self.conditional_cdf.nbytes)

    def __repr__(self) -> str:
        return (f"SamplerTables(slices={self.n_slices}, cells={self.nx}x{self.ny}, "
                f"{self.nbytes / 2**20:.1f} MiB)")


def default_resolution(grid: LookupGrid) -> tuple[int, int]:
    """Cells ``(nx, ny)`` for a prepared grid: 2 per light azimuth step, 4 per light elevation step.

    The table is bilinear between its samples, so a few cells per step
    follow it closely (finer cells were measured to lower the noise of
    renders by less than 3 % while the larger tables cost 5 to 10 % more
    time, ``docs/benchmarks.md``). ``nx`` is 1 for a table with one light
    azimuth (nothing depends on it); both are at least 8 (``nx`` unless 1),
    at most 256, and shrink together so that all slices hold at most
    :data:`MAX_CELLS` cells.
    """
    nk, npl, ntl, npv, ntv = grid.values.shape[:5]
    iso = bool(getattr(grid, "isotropic", False))
    n_az = npv if iso else npl  # the azimuth u1 runs along
    nx = 1 if n_az == 1 else int(np.clip(2 * n_az, 8, 256))
    ny = int(np.clip(4 * (ntl - 1), 8, 256))
    slices = nk * ntv * (1 if iso else npv)
    while slices * nx * ny > MAX_CELLS and (nx > 1 or ny > 4):
        nx = max(1, nx // 2) if nx > 1 else 1
        ny = max(4, ny // 2)
    return nx, ny


# -- the 1-D weights of the lookup rule (float64, NumPy) --------------------------------------
def _clamped_weights(axis: NDArray[np.float64],
                     x: NDArray[np.float64]) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
    """Lower node and weight of ``x`` on a sorted axis, clamped at both ends (interp's rule, unsnapped)."""
    n = axis.size
    if n == 1:
        return np.zeros(x.shape, np.int64), np.zeros(x.shape)
    i = np.clip(np.searchsorted(axis, x, side="right") - 1, 0, n - 2)
    w = np.clip((x - axis[i]) / (axis[i + 1] - axis[i]), 0.0, 1.0)
    return i, w


def _periodic_weights(phi0: float, n: int, x: NDArray[np.float64]) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
    """Lower node and weight of azimuth ``x`` on ``n`` evenly spaced nodes from ``phi0``."""
    if n == 1:
        return np.zeros(x.shape, np.int64), np.zeros(x.shape)
    u = np.mod(np.fmod(x, PERIOD_DEG) - phi0, PERIOD_DEG) * (n / PERIOD_DEG)
    f = np.floor(u)
    i = f.astype(np.int64) % n
    return i, u - f


def _mean_weights(i: NDArray[np.int64], w: NDArray[np.float64], n_nodes: int, n_cells: int,
                  periodic: bool) -> NDArray[np.float64]:
    """``(n_cells, n_nodes)``: per cell, the mean weight of every node over the cell's sub-samples."""
    m = np.zeros((n_cells, n_nodes))
    i = i.reshape(n_cells, -1)
    w = w.reshape(n_cells, -1)
    rows = np.broadcast_to(np.arange(n_cells)[:, None], i.shape)
    np.add.at(m, (rows, i), 1.0 - w)
    hi = (i + 1) % n_nodes if periodic else np.minimum(i + 1, n_nodes - 1)
    np.add.at(m, (rows, hi), w)
    return m / i.shape[1]


def _cell_weights(grid: LookupGrid, nx: int, ny: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``A_phi (nx, n_az)`` and ``A_theta (ny, n_theta_l)``: mean interpolation weights per cell.

    ``n_az`` is the light azimuth axis, or (isotropic) the azimuth difference axis.
    """
    n_az, phi0 = (grid.values.shape[3], grid.phi_v0) if grid.isotropic else (grid.values.shape[1], grid.phi_l0)
    sub = (np.arange(_SUBSAMPLES) + 0.5) / _SUBSAMPLES
    u1 = (np.arange(nx)[:, None] + sub[None, :]) / nx
    phi = phi0 + PERIOD_DEG * u1
    a_phi = _mean_weights(*_periodic_weights(phi0, n_az, phi), n_az, nx, periodic=True)
    u2 = (np.arange(ny)[:, None] + sub[None, :]) / ny
    theta = np.degrees(np.arcsin(np.sqrt(u2)))
    a_theta = _mean_weights(*_clamped_weights(np.asarray(grid.theta_l), theta), grid.theta_l.size, ny,
                            periodic=False)
    return a_phi, a_theta


def _sampling_values(grid: LookupGrid) -> NDArray[np.float64]:
    """The scalar the sampler follows: Rec. 709 luminance of RGB, the value of one channel."""
    v = np.asarray(grid.values, dtype=np.float64)
    if v.shape[-1] == 3:
        return v @ LUMINANCE_WEIGHTS
    if v.shape[-1] == 1:
        return v[..., 0]
    return v.mean(axis=-1)


def cell_means(grid: LookupGrid, nx: int, ny: int) -> NDArray[np.float64]:
    """``(n_kappa, n_theta_v, n_phi_v, ny, nx)``: mean luminance of the table over every cell of every slice.

    Isotropic: ``(n_kappa, n_theta_v, 1, ny, nx)``, u1 along the azimuth difference.
    """
    a_phi, a_theta = _cell_weights(grid, nx, ny)
    y = _sampling_values(grid)  # (k, pl, tl, pv, tv)
    if grid.isotropic:
        return np.einsum("ktdw,yt,xd->kwyx", y[:, 0], a_theta, a_phi, optimize=True)[:, :, None]
    return np.einsum("kptvw,yt,xp->kwvyx", y, a_theta, a_phi, optimize=True)


def build_sampler(grid: LookupGrid, *, resolution: tuple[int, int] | None = None) -> SamplerTables:
    """The sampling tables of a prepared grid (see the module docstring).

    Parameters
    ----------
    grid
        The table's prepared grid (``table.lookup_grid()``).
    resolution
        Cells ``(nx, ny)`` (default :func:`default_resolution`).

    Returns
    -------
    SamplerTables
    """
    nx, ny = resolution if resolution is not None else default_resolution(grid)
    if nx < 1 or ny < 1:
        raise ValueError(f"resolution: need at least one cell per axis, got {nx}x{ny}")
    cells = np.maximum(cell_means(grid, nx, ny), 0.0)
    cells = np.where(np.isfinite(cells), cells, 0.0)
    nk, ntv, npv = cells.shape[:3]
    cells = cells.reshape(nk * ntv * npv, ny, nx)
    mass = cells.mean(axis=(1, 2))
    ok = mass > 0.0
    density = np.ones_like(cells)
    density[ok] = cells[ok] / mass[ok, None, None]
    rows = density.sum(axis=2)  # (s, ny)
    marginal = np.cumsum(rows, axis=1)
    marginal /= marginal[:, -1:]
    cond = np.cumsum(density, axis=2)
    row_tot = cond[:, :, -1:]
    uniform = np.broadcast_to((np.arange(nx) + 1.0) / nx, cond.shape)
    cond = np.where(row_tot > 0.0, cond / np.where(row_tot > 0.0, row_tot, 1.0), uniform)
    marginal[:, -1] = 1.0
    cond[:, :, -1] = 1.0
    kappa = np.asarray(grid.kappa, dtype=np.float64)
    theta_v = np.asarray(grid.theta_v, dtype=np.float64)
    return SamplerTables(
        nx=int(nx), ny=int(ny), phi0_deg=float(grid.phi_v0 if grid.isotropic else grid.phi_l0),
        kappa=kappa, kappa_inv_d=np.asarray(grid.kappa_inv_d, dtype=np.float64),
        theta_v=theta_v, theta_v_inv_d=np.asarray(grid.theta_v_inv_d, dtype=np.float64),
        phi_v0_deg=float(grid.phi_v0), n_phi_v=int(npv),
        mass=mass, density=density.astype(np.float32),
        marginal_cdf=marginal.astype(np.float32), conditional_cdf=cond.astype(np.float32),
        isotropic=bool(grid.isotropic),
    )


# -- the rule in NumPy (float64 arithmetic on the float32 tables) ----------------------------------
def slice_weights(tables: SamplerTables, theta_v: ArrayLike, phi_v: ArrayLike,
                  kappa: ArrayLike) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
    """The neighbouring slices of queries and their multilinear weights: ``(index, weight)``, each ``(n, 8)``.

    Curvature and view elevation are clamped, the view azimuth periodic, and
    at the view pole (elevation node 0, weight 0) the azimuth weight is 0, as
    in the lookup rule; unused corners have weight 0.
    """
    tv = np.atleast_1d(np.asarray(theta_v, dtype=np.float64))
    pv = np.atleast_1d(np.asarray(phi_v, dtype=np.float64))
    k = np.atleast_1d(np.asarray(kappa, dtype=np.float64))
    tv, pv, k = np.broadcast_arrays(tv, pv, k)
    ik, wk = _clamped_weights(tables.kappa, k)
    it, wt = _clamped_weights(tables.theta_v, tv)
    ip, wp = _periodic_weights(tables.phi_v0_deg, tables.n_phi_v, pv)
    wp = np.where((it == 0) & (wt == 0.0), 0.0, wp)
    ntv, npv = tables.theta_v.size, tables.n_phi_v
    nk = tables.kappa.size
    idx, wts = [], []
    for dk, fk in ((0, 1.0 - wk), (1, wk)):
        for dt, ft in ((0, 1.0 - wt), (1, wt)):
            for dp, fp in ((0, 1.0 - wp), (1, wp)):
                kk = np.minimum(ik + dk, nk - 1)
                tt = np.minimum(it + dt, ntv - 1)
                pp = (ip + dp) % npv
                idx.append((kk * ntv + tt) * npv + pp)
                wts.append(fk * ft * fp)
    return np.stack(idx, axis=-1).reshape(-1, 8), np.stack(wts, axis=-1).reshape(-1, 8)


def _azimuth(tables: SamplerTables, u1: NDArray[np.float64], phi_v: ArrayLike) -> NDArray[np.float64]:
    """The light azimuth (degrees) at ``u1``: ``phi0 + 360 u1``, or ``phi_v`` minus it (isotropic)."""
    a = tables.phi0_deg + PERIOD_DEG * u1
    return np.asarray(phi_v, dtype=np.float64) - a if tables.isotropic else a


def square_to_direction(tables: SamplerTables, u: NDArray[np.float64],
                        phi_v: ArrayLike = 0.0) -> NDArray[np.float64]:
    """Directions ``(n, 3)`` (front hemisphere) of points ``u (n, 2)`` of the unit square (view azimuth ``phi_v``)."""
    phi = np.radians(_azimuth(tables, u[:, 0], phi_v))
    s = np.sqrt(np.clip(u[:, 1], 0.0, 1.0))
    c = np.sqrt(np.clip(1.0 - u[:, 1], 0.0, 1.0))
    return np.stack([s * np.cos(phi), s * np.sin(phi), c], axis=-1)


def direction_to_square(tables: SamplerTables, d: NDArray[np.float64], phi_v: ArrayLike = 0.0) -> NDArray[np.float64]:
    """Points ``(n, 2)`` of the unit square of directions ``d (n, 3)`` (view azimuth ``phi_v``)."""
    u2 = np.clip(d[:, 0] ** 2 + d[:, 1] ** 2, 0.0, 1.0)
    phi = np.degrees(np.arctan2(d[:, 1], d[:, 0]))
    if tables.isotropic:
        phi = np.asarray(phi_v, dtype=np.float64) - phi
    u1 = np.mod((phi - tables.phi0_deg) / PERIOD_DEG, 1.0)
    return np.stack([np.where(u1 >= 1.0, 0.0, u1), u2], axis=-1)


def _cells(tables: SamplerTables, u: NDArray[np.float64]) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    col = np.clip(np.floor(u[:, 0] * tables.nx), 0, tables.nx - 1).astype(np.int64)
    row = np.clip(np.floor(u[:, 1] * tables.ny), 0, tables.ny - 1).astype(np.int64)
    return col, row


def pdf(tables: SamplerTables, theta_v: ArrayLike, phi_v: ArrayLike, kappa: ArrayLike,
        directions: ArrayLike, *, cosine_weight: float = DEFAULT_COSINE_WEIGHT) -> NDArray[np.float64]:
    """Solid-angle density of light directions ``(n, 3)`` (front frame) for view angles and curvature.

    Zero for directions with ``z <= 0``.
    """
    d = np.atleast_2d(np.asarray(directions, dtype=np.float64))
    idx, w = slice_weights(tables, theta_v, phi_v, kappa)
    idx, w = np.broadcast_to(idx, (d.shape[0], 8)), np.broadcast_to(w, (d.shape[0], 8))
    q = w * tables.mass[idx]
    total = q.sum(axis=1)
    u = direction_to_square(tables, d, phi_v)
    col, row = _cells(tables, u)
    dens = tables.density[idx, row[:, None], col[:, None]].astype(np.float64)
    safe = np.where(total > 0.0, total, 1.0)
    p_t = (q * dens).sum(axis=1) / safe
    c = np.where(total > 0.0, cosine_weight, 1.0)
    p_u = (1.0 - c) * p_t + c
    return np.where(d[:, 2] > 0.0, p_u * d[:, 2] / math.pi, 0.0)


def _invert_cdf(cdf: NDArray[np.float32], x: NDArray[np.float64]) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
    """Cell and position inside it of ``x`` in [0, 1) for rows of inclusive CDFs ``(n, m)``."""
    m = cdf.shape[1]
    c = cdf.astype(np.float64)
    j = np.minimum((c[:, : m - 1] <= x[:, None]).sum(axis=1), m - 1)
    lo = np.where(j > 0, c[np.arange(c.shape[0]), np.maximum(j - 1, 0)], 0.0)
    hi = c[np.arange(c.shape[0]), j]
    t = np.where(hi > lo, (x - lo) / np.where(hi > lo, hi - lo, 1.0), 0.5)
    return j, np.clip(t, 0.0, 1.0)


def sample(tables: SamplerTables, theta_v: ArrayLike, phi_v: ArrayLike, kappa: ArrayLike,
           sample1: ArrayLike, sample2: ArrayLike, *,
           cosine_weight: float = DEFAULT_COSINE_WEIGHT) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Draw light directions (front frame): ``(directions (n, 3), pdf (n,))``.

    ``sample1 (n,)`` picks the component, ``sample2 (n, 2)`` the direction;
    the returned density is :func:`pdf` of the drawn direction.
    """
    s1 = np.atleast_1d(np.asarray(sample1, dtype=np.float64))
    s2 = np.atleast_2d(np.asarray(sample2, dtype=np.float64))
    n = s2.shape[0]
    idx, w = slice_weights(tables, theta_v, phi_v, kappa)
    idx, w = np.broadcast_to(idx, (n, 8)), np.broadcast_to(w, (n, 8))
    s1 = np.broadcast_to(s1, (n,))
    q = w * tables.mass[idx]
    total = q.sum(axis=1)
    c = np.where(total > 0.0, cosine_weight, 1.0)
    cosine = s1 < c
    r = np.where(cosine, 0.0, (s1 - c) / np.where(c < 1.0, 1.0 - c, 1.0)) * total
    cum = np.cumsum(q, axis=1)
    pick = np.minimum((cum[:, :7] <= r[:, None]).sum(axis=1), 7)
    s = idx[np.arange(n), pick]
    row, ty = _invert_cdf(tables.marginal_cdf[s], s2[:, 1])
    col, tx = _invert_cdf(tables.conditional_cdf[s, row], s2[:, 0])
    u = np.stack([(col + tx) / tables.nx, (row + ty) / tables.ny], axis=-1)
    pv = np.broadcast_to(np.asarray(phi_v, dtype=np.float64), (n,))
    d = square_to_direction(tables, u, pv)
    # cosine branch: the same map with the uniform density
    dc = square_to_direction(tables, s2, pv)
    d = np.where(cosine[:, None], dc, d)
    return d, pdf(tables, theta_v, phi_v, kappa, d, cosine_weight=cosine_weight)
