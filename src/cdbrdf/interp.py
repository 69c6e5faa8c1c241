"""5-D multilinear lookup of a :class:`~cdbrdf.table.CDBRDF`.

The rule, fixed by the project's conventions and used identically by the
renderer (:mod:`cdbrdf.render`):

- **curvature**: linear between samples of any spacing, clamped to the ends;
- **elevation**: linear between samples, clamped beyond the last one;
- **azimuth**: linear and periodic on the evenly spaced circle;
- **pole rule**: at theta = 0 every azimuth is the same direction. The lookup
  grid's first elevation node is theta = 0 and holds, for every azimuth, the
  *mean of the stored ring at theta = 0* (or, when the table's first elevation
  is above 0, a virtual pole node holding the mean of that first ring). Between
  the pole and the next elevation the value is blended linearly. The result is
  continuous, independent of the azimuth at theta = 0, and exactly equal to
  the table at every sample with both elevations above 0.

Non-finite query components give a NaN output row; an elevation outside
[0, 90] degrees raises :class:`~cdbrdf.errors.QueryError` naming the argument
(``on_invalid="nan"`` gives NaN rows instead).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .errors import QueryError

__all__ = ["LookupGrid", "prepare", "evaluate", "evaluate_reference"]

#: Queries handled per kernel call when inputs need broadcasting copies.
_CHUNK = 1 << 16


@dataclass(frozen=True)
class LookupGrid:
    """A table prepared for lookup: pole rule applied, pole node present.

    Attributes
    ----------
    values
        ``(n_kappa, n_phi_l, n_theta_l, n_phi_v, n_theta_v, channel)``,
        C-contiguous, float32 or float64 (the table's dtype); the theta axes
        below start at 0 and node 0 holds the ring mean.
    kappa, theta_l, theta_v
        Sorted axes (mm^-1, degrees); ``theta_*[0] == 0``.
    phi_l0, phi_l_step, phi_v0, phi_v_step
        First azimuth and spacing (degrees); the spacing is 360 / n_phi.
    """

    values: NDArray[np.floating]
    kappa: NDArray[np.float64]
    theta_l: NDArray[np.float64]
    theta_v: NDArray[np.float64]
    phi_l0: float
    phi_l_step: float
    phi_v0: float
    phi_v_step: float

    @property
    def shape(self) -> tuple[int, ...]:
        return self.values.shape


def _pole(values: NDArray[np.floating], theta: NDArray[np.float64], t_axis: int, p_axis: int):
    """Apply the pole rule along one (theta, phi) axis pair."""
    ring_mean = values.mean(axis=p_axis, keepdims=True, dtype=np.float64)
    idx = [slice(None)] * values.ndim
    idx[t_axis] = slice(0, 1)
    ring_mean = np.take(ring_mean, [0], axis=t_axis).astype(values.dtype)
    pole = np.broadcast_to(ring_mean, values[tuple(idx)].shape)
    if theta[0] == 0.0:
        out = values.copy()
        out[tuple(idx)] = pole
        return out, theta
    return np.concatenate([pole, values], axis=t_axis), np.concatenate([[0.0], theta])


def prepare(table) -> LookupGrid:
    """Build (or fetch the cached) :class:`LookupGrid` of a table."""
    cached = getattr(table, "_lookup", None)
    if cached is not None:
        return cached
    g = table.grid
    v, thl = _pole(np.asarray(table.values), g.theta_l, 2, 1)
    v, thv = _pole(v, g.theta_v, 4, 3)
    v = np.ascontiguousarray(v)
    v.setflags(write=False)
    lg = LookupGrid(
        values=v,
        kappa=np.ascontiguousarray(g.kappa),
        theta_l=np.ascontiguousarray(thl, dtype=np.float64),
        theta_v=np.ascontiguousarray(thv, dtype=np.float64),
        phi_l0=float(g.phi_l[0]),
        phi_l_step=360.0 / g.phi_l.size,
        phi_v0=float(g.phi_v[0]),
        phi_v_step=360.0 / g.phi_v.size,
    )
    try:
        table._lookup = lg
    except AttributeError:
        pass
    return lg


def _inv_spacing(axis: NDArray[np.float64]) -> NDArray[np.float64]:
    """``1 / (axis[i + 1] - axis[i])`` (one zero for a single-sample axis)."""
    if axis.size < 2:
        return np.zeros(1)
    return np.ascontiguousarray(1.0 / np.diff(axis))


def _kernel_consts(lg: LookupGrid) -> tuple:
    """The kernel's table and axis arguments, built once per table.

    RGB tables are padded to 4 values per sample so that a sample is one
    aligned 16-byte (float32) or 32-byte (float64) block.
    """
    cached = lg.__dict__.get("_kernel_consts")
    if cached is not None:
        return cached
    nk, npl, ntl, npv, ntv, nc = lg.values.shape
    if nc == 3:
        padded = np.zeros(lg.values.shape[:-1] + (4,), dtype=lg.values.dtype)
        padded[..., :3] = lg.values
        flat, stride = padded.reshape(-1), 4
    else:
        flat, stride = np.ascontiguousarray(lg.values).reshape(-1), nc
    consts = (
        flat, nk, npl, ntl, npv, ntv, nc, stride,
        lg.kappa, _inv_spacing(lg.kappa),
        lg.theta_l, _inv_spacing(lg.theta_l),
        lg.theta_v, _inv_spacing(lg.theta_v),
        _inv_step(lg.theta_l), _inv_step(lg.theta_v),
        lg.phi_l0, 1.0 / lg.phi_l_step, lg.phi_v0, 1.0 / lg.phi_v_step,
    )
    object.__setattr__(lg, "_kernel_consts", consts)
    return consts


def _rgb_consts(lg: LookupGrid) -> tuple | None:
    """Arguments of :func:`cdbrdf._kernels.lookup_rgb`, or None when it does not apply.

    It needs an RGB table, evenly spaced elevation axes and at most
    ``RGB_MAX_KAPPA`` curvatures; other tables use ``lookup_generic``.
    """
    from ._kernels import RGB_MAX_KAPPA

    if "_rgb_consts" in lg.__dict__:
        return lg.__dict__["_rgb_consts"]
    consts = None
    base = _kernel_consts(lg)
    flat, nk, npl, ntl, npv, ntv, nc = base[:7]
    inv_tl, inv_tv = base[14], base[15]
    if nc == 3 and inv_tl > 0.0 and inv_tv > 0.0 and nk <= RGB_MAX_KAPPA:
        k_node = np.full(RGB_MAX_KAPPA, lg.kappa[-1])
        k_node[:nk] = lg.kappa
        k_scan = np.full(RGB_MAX_KAPPA, np.inf)
        k_scan[1:nk - 1] = lg.kappa[1:nk - 1]
        k_inv = np.zeros(RGB_MAX_KAPPA)
        k_inv[:max(nk - 1, 1)] = _inv_spacing(lg.kappa)
        consts = (
            flat, nk, npl, ntl, npv, ntv, float(lg.kappa[0]), float(lg.kappa[-1]), k_node, k_scan, k_inv,
            inv_tl, inv_tv, lg.phi_l0, 1.0 / lg.phi_l_step, lg.phi_v0, 1.0 / lg.phi_v_step,
        )
    object.__setattr__(lg, "_rgb_consts", consts)
    return consts


def _inv_step(axis: NDArray[np.float64]) -> float:
    """1 / spacing of an evenly spaced axis, or 0.0 when the spacing varies."""
    if axis.size < 3:
        return 0.0
    d = np.diff(axis)
    if np.allclose(d, d[0], rtol=1e-12, atol=0.0):
        return float(1.0 / d[0])
    return 0.0


def _as_query(name: str, x: ArrayLike) -> NDArray[np.floating]:
    try:
        a = np.asarray(x)
    except (TypeError, ValueError) as exc:
        raise QueryError(f"{name}: cannot be read as numbers ({exc})") from None
    if a.dtype not in (np.float64, np.float32):
        if not (np.issubdtype(a.dtype, np.number) or a.dtype == bool):
            raise QueryError(f"{name}: expected numbers, got dtype {a.dtype}")
        if np.iscomplexobj(a):
            raise QueryError(f"{name}: complex values are not angles or curvatures")
        a = a.astype(np.float64)
    return a


def evaluate(
    table,
    theta_v: ArrayLike,
    phi_v: ArrayLike,
    theta_l: ArrayLike,
    phi_l: ArrayLike,
    kappa: ArrayLike = 0.0,
    *,
    on_invalid: str = "raise",
) -> NDArray[np.float64]:
    """Interpolate ``table`` at continuous directions (degrees) and curvature (mm^-1).

    Arguments broadcast against each other (NumPy rules); the result has shape
    ``broadcast_shape + (n_channels,)``, float64. See the module docstring for
    the interpolation and pole rules.

    Parameters
    ----------
    table
        A :class:`~cdbrdf.table.CDBRDF`.
    theta_v, phi_v, theta_l, phi_l
        View and light elevation (in [0, 90]) and azimuth (any real), degrees.
    kappa
        Curvature, mm^-1 (clamped to the table's range).
    on_invalid
        ``"raise"`` (default): an elevation outside [0, 90] raises
        :class:`QueryError`; ``"nan"``: such rows are NaN.

    Returns
    -------
    numpy.ndarray
        Interpolated values; rows with a non-finite input are NaN.
    """
    from . import _kernels

    if on_invalid not in ("raise", "nan"):
        raise ValueError(f"on_invalid: {on_invalid!r} is not one of raise, nan")
    names = ("theta_v", "phi_v", "theta_l", "phi_l", "kappa")
    qs = [_as_query(n, x) for n, x in zip(names, (theta_v, phi_v, theta_l, phi_l, kappa))]
    try:
        shape = np.broadcast_shapes(*(q.shape for q in qs))
    except ValueError:
        raise QueryError(
            "theta_v, phi_v, theta_l, phi_l, kappa: shapes "
            + ", ".join(str(q.shape) for q in qs)
            + " do not broadcast together"
        ) from None
    lg = prepare(table)
    nc = lg.values.shape[-1]
    n = int(np.prod(shape, dtype=np.int64))
    out = np.empty((n, nc), dtype=np.float64)
    consts = _rgb_consts(lg)
    if consts is not None:
        kernel = _kernels.lookup_rgb
    else:
        consts = _kernel_consts(lg)
        kernel = _kernels.lookup_generic

    direct = []
    for q in qs:
        if q.size == 1:
            direct.append(q.reshape(1).astype(np.float64))
        elif q.shape == shape and q.flags.c_contiguous and q.dtype == np.float64:
            direct.append(q.reshape(-1))
        else:
            direct.append(None)
    bad_v = bad_l = 0
    if n == 0:
        pass
    elif all(d is not None for d in direct):
        bad_v, bad_l = kernel(*consts, *direct, n, out, 0)
    else:
        views = [np.broadcast_to(q, shape) if d is None else None for q, d in zip(qs, direct)]
        for s in range(0, n, _CHUNK):
            e = min(n, s + _CHUNK)
            args = [d if d is not None else v.flat[s:e].astype(np.float64, copy=False) for d, v in zip(direct, views)]
            a, b = kernel(*consts, *args, e - s, out, s)
            bad_v += a
            bad_l += b
    if on_invalid == "raise" and (bad_v or bad_l):
        which = [f"theta_v ({bad_v} queries)"] * bool(bad_v) + [f"theta_l ({bad_l} queries)"] * bool(bad_l)
        raise QueryError(
            "elevation outside [0, 90] degrees in " + " and ".join(which)
            + "; directions below the surface have no reflectance"
        )
    return out.reshape(shape + (nc,))


def evaluate_reference(
    table, theta_v: float, phi_v: float, theta_l: float, phi_l: float, kappa: float = 0.0
) -> NDArray[np.float64]:
    """Slow, readable pure-Python lookup of one query (for tests and docs).

    Follows the same rules as :func:`evaluate` written out step by step.
    """
    lg = prepare(table)
    q = dict(theta_v=theta_v, phi_v=phi_v, theta_l=theta_l, phi_l=phi_l, kappa=kappa)
    if not all(np.isfinite(float(x)) for x in q.values()):
        return np.full(table.n_channels, np.nan)

    def lin(axis, x):
        if axis.size == 1 or x <= axis[0]:
            return [(0, 1.0)]
        if x >= axis[-1]:
            return [(axis.size - 1, 1.0)]
        i = int(np.searchsorted(axis, x, side="right") - 1)
        w = (x - axis[i]) / (axis[i + 1] - axis[i])
        return [(i, 1 - w), (i + 1, w)]

    def per(phi0, step, n, x):
        if n == 1:
            return [(0, 1.0)]
        u = (x - phi0) / step
        f = np.floor(u)
        w = u - f
        return [(int(f) % n, 1 - w), ((int(f) + 1) % n, w)]

    res = np.zeros(table.n_channels)
    nk, npl, ntl, npv, ntv, _ = lg.values.shape
    for ik, wk in lin(lg.kappa, kappa):
        for ipl, wpl in per(lg.phi_l0, lg.phi_l_step, npl, phi_l):
            for itl, wtl in lin(lg.theta_l, theta_l):
                for ipv, wpv in per(lg.phi_v0, lg.phi_v_step, npv, phi_v):
                    for itv, wtv in lin(lg.theta_v, theta_v):
                        res += wk * wpl * wtl * wpv * wtv * lg.values[ik, ipl, itl, ipv, itv]
    return res
