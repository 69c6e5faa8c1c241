"""The lookup rule of :mod:`cdbrdf.interp` written in Dr.Jit, for the renderer.

The plug-in (:mod:`cdbrdf.render._bsdf`) calls :func:`lookup_jit` inside its
``eval``: in ``llvm_ad_rgb`` Dr.Jit traces it once per render into
straight-line vector code (compares, selects and 32 gathers of a packed RGB
sample), never a Python call per ray.

It follows the rule of :mod:`cdbrdf.interp` on the same
:class:`~cdbrdf.interp.LookupGrid` (pole-applied values, axes, inverse
spacings, azimuth origins and inverse steps) with interp's constants:
curvature and elevations linear and clamped at both ends, azimuths linear and
periodic, every weight snapped to exactly 0 or 1 within
``interp.snap_tolerance`` of the variant's precision (1e-6 in float32), and
the pole rule (at elevation node 0 with weight 0 the azimuth weight is 0)
and, on isotropic tables, the rotation of the query (the view azimuth axis
holds ``phi_v - phi_l``).
It differs from the float64 lookup in two documented ways only:

- arithmetic in the variant's precision (float32 in ``llvm_ad_rgb``) and RGB
  samples packed into 21-bit fixed point (:func:`pack_table`), so it agrees
  with :func:`cdbrdf.interp.evaluate` to about 3e-5 of the table's range;
- no exact ``fmod`` reduction of huge azimuths (the plug-in's azimuths come
  from ``atan2``, within [-180, 180]): a lane whose wrapped index is not a
  number in range (a non-finite azimuth, or one whose float32 floor does not
  wrap exactly) uses node 0 with weight 0, so no gather ever leaves the table.

Invalid queries are not turned into NaN here: an elevation outside [0, 90] is
clamped, a NaN elevation or curvature gives NaN; the caller masks invalid
directions (the plug-in returns 0 for them).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..errors import TableError
from ..interp import LookupGrid, snap_tolerance

__all__ = ["PACK_BITS", "MAX_ABS_VALUE", "lookup_jit", "pack_table"]

#: Largest table value (in magnitude) the renderer accepts: its arithmetic is
#: float32 (largest 3.4e38), with headroom for the weighted sums and ``scale``.
MAX_ABS_VALUE = 1e30

#: Bits per channel of the packed RGB table (3 x 21 bits in one 64-bit word).
PACK_BITS = 21
_PACK_MAX = (1 << PACK_BITS) - 1


def _tolerance(dr: Any, Float: Any) -> float:
    """The snap tolerance of the variant's precision (float32 or float64)."""
    return snap_tolerance("float64" if dr.type_v(Float) == dr.VarType.Float64 else "float32")


def _snap(dr: Any, w: Any, tol: float) -> Any:
    """interp's snapping rule: a weight within ``tol`` of 0 or 1 becomes exactly 0 or 1."""
    w = dr.select(w < tol, 0.0, w)
    return dr.select(w > 1.0 - tol, 1.0, w)


def _locate(dr: Any, Float: Any, UInt: Any, axis: np.ndarray, inv_d: np.ndarray, x: Any, tol: float) -> tuple[Any, Any]:
    """Lower index and weight of ``x`` on a sorted axis, clamped at both ends.

    The Dr.Jit form of ``cdbrdf._kernels._locate``: the index is a scan of the
    interior nodes with selects (axes are short), the weight
    ``(x - axis[i]) * inv_d[i]`` clipped to [0, 1] and snapped. The index is
    in ``[0, n - 2]`` for every input, NaN included.
    """
    n = axis.size
    if n == 1:
        return UInt(0), Float(0.0)
    lo = UInt(0)
    a0 = Float(float(axis[0]))
    inv = Float(float(inv_d[0]))
    for j in range(1, n - 1):
        m = x >= float(axis[j])
        lo = dr.select(m, UInt(j), lo)
        a0 = dr.select(m, Float(float(axis[j])), a0)
        inv = dr.select(m, Float(float(inv_d[j])), inv)
    w = dr.clip((x - a0) * inv, 0.0, 1.0)
    return lo, _snap(dr, w, tol)


def _locate_periodic(dr: Any, Float: Any, UInt: Any, phi0: float, inv_step: float, n: int, x: Any,
                     tol: float) -> tuple[Any, Any]:
    """Lower index and weight of an azimuth on an evenly spaced circle.

    A weight within ``tol`` of 0 snaps to this node, within ``tol`` of 1 to
    the next one (index + 1, weight 0), as in ``cdbrdf._kernels``. The index
    is in ``[0, n)`` for every input, NaN and infinities included: a lane
    whose wrapped position is not a number in range gets index 0 and weight 0.
    """
    if n == 1:
        return UInt(0), Float(0.0)
    u = (x - phi0) * inv_step
    f = dr.floor(u)
    w = u - f
    up = w > 1.0 - tol
    f = dr.select(up, f + 1.0, f)
    w = dr.select(up | (w < tol), 0.0, w)
    i = f - n * dr.floor(f / n)
    ok = (i >= 0.0) & (i <= n - 1.0) & (w >= 0.0) & (w < 1.0)  # False for NaN
    i = dr.select(ok, i, 0.0)
    w = dr.select(ok, w, 0.0)
    return UInt(dr.clip(i, 0.0, n - 1.0)), w


def pack_table(mi: Any, grid: LookupGrid) -> tuple[Any, float, float]:
    """Upload a prepared table: ``(buffer, offset, step)``.

    RGB tables are packed as three :data:`PACK_BITS`-bit fixed-point channels
    per 64-bit word (``value = offset + step * q``; ``step`` = range /
    (2^21 - 1), i.e. about 5e-7 of the table's range), so one gather fetches
    a whole sample: the lookup is gather-bound and this makes it about 1.5x
    faster than three float gathers. One-channel tables stay float32
    (``offset = 0, step = 1``).

    Parameters
    ----------
    mi
        The ``mitsuba`` module, with a variant set.
    grid
        The table's prepared grid (``table.lookup_grid()``).

    Returns
    -------
    tuple
        The Dr.Jit buffer, the offset and the step of the fixed-point code.
    """
    v = np.asarray(grid.values, dtype=np.float64)
    lo, hi = float(v.min()), float(v.max())
    if max(abs(lo), abs(hi)) > MAX_ABS_VALUE:
        raise TableError(
            f"table values span {lo:g}..{hi:g}: the renderer computes in float32 and needs values "
            f"within +-{MAX_ABS_VALUE:g} (rescale the table, e.g. with the plug-in's 'scale')"
        )
    if v.shape[-1] == 1:
        return mi.Float(v.astype(np.float32).reshape(-1)), 0.0, 1.0
    step = (hi - lo) / _PACK_MAX if hi > lo else 1.0
    q = np.rint((v - lo) / step).astype(np.uint64)
    word = q[..., 0] | (q[..., 1] << np.uint64(PACK_BITS)) | (q[..., 2] << np.uint64(2 * PACK_BITS))
    import drjit as dr

    UInt64: Any = dr.uint64_array_t(mi.Float)
    return UInt64(word.reshape(-1)), lo, step


def lookup_jit(mi: Any, grid: LookupGrid, packed: tuple[Any, float, float], theta_v: Any, phi_v: Any,
               theta_l: Any, phi_l: Any, kappa: Any, active: Any = True) -> Any:
    """Interpolate a prepared table in Dr.Jit -> ``mi.Color3f`` (see the module docstring).

    Parameters
    ----------
    mi
        The ``mitsuba`` module, with a variant set.
    grid
        The table's prepared grid (``table.lookup_grid()``), 1 or 3 channels.
    packed
        :func:`pack_table` of ``grid``.
    theta_v, phi_v, theta_l, phi_l
        View and light elevation and azimuth, degrees (``mi.Float``).
    kappa
        Curvature, mm^-1 (``mi.Float``).
    active
        Lanes to gather for (the others read nothing and give 0 * weight).

    Returns
    -------
    mi.Color3f
        The interpolated value (a one-channel table in all three channels).
    """
    import drjit as dr

    buf, offset, step = packed
    Float, UInt = mi.Float, mi.UInt32
    tol = _tolerance(dr, Float)
    nk, npl, ntl, npv, ntv, nc = grid.values.shape
    if grid.isotropic:  # the view azimuth axis holds phi_v - phi_l (interp's rotation)
        phi_v = phi_v - phi_l
    ik, wk = _locate(dr, Float, UInt, grid.kappa, grid.kappa_inv_d, kappa, tol)
    itl, wtl = _locate(dr, Float, UInt, grid.theta_l, grid.theta_l_inv_d, theta_l, tol)
    itv, wtv = _locate(dr, Float, UInt, grid.theta_v, grid.theta_v_inv_d, theta_v, tol)
    ipl, wpl = _locate_periodic(dr, Float, UInt, grid.phi_l0, grid.phi_l_inv_step, npl, phi_l, tol)
    ipv, wpv = _locate_periodic(dr, Float, UInt, grid.phi_v0, grid.phi_v_inv_step, npv, phi_v, tol)
    # Pole: node 0 of an elevation axis is theta = 0 (one value for every azimuth).
    light_pole = (itl == 0) & (wtl == 0.0)
    wpl = dr.select(light_pole, 0.0, wpl)
    view_pole = (itv == 0) & (wtv == 0.0)
    if grid.isotropic:  # the stored azimuth difference depends on the light azimuth too
        view_pole = view_pole | light_pole
    wpv = dr.select(view_pole, 0.0, wpv)
    ipl1 = dr.select(ipl + 1 < npl, ipl + 1, 0)
    ipv1 = dr.select(ipv + 1 < npv, ipv + 1, 0)
    k_nodes = [(ik, 1.0 - wk), (ik + 1, wk)] if nk > 1 else [(ik, Float(1.0))]
    pl_nodes = [(ipl, 1.0 - wpl), (ipl1, wpl)] if npl > 1 else [(ipl, Float(1.0))]
    tl_nodes = [(itl, 1.0 - wtl), (itl + 1, wtl)] if ntl > 1 else [(itl, Float(1.0))]
    pv_nodes = [(ipv, 1.0 - wpv), (ipv1, wpv)] if npv > 1 else [(ipv, Float(1.0))]
    tv_nodes = [(itv, 1.0 - wtv), (itv + 1, wtv)] if ntv > 1 else [(itv, Float(1.0))]
    Int32 = dr.int32_array_t(Float)
    rgb = nc == 3
    acc = [Float(0.0) for _ in range(3 if rgb else 1)]
    for ka, wa in k_nodes:
        for pb, wb in pl_nodes:
            wab = wa * wb
            base_b = (ka * npl + pb) * ntl
            for td, wd in tl_nodes:
                wabd = wab * wd
                base_d = (base_b + td) * npv
                for pe, we in pv_nodes:
                    wabde = wabd * we
                    base_e = (base_d + pe) * ntv
                    for tf, wf in tv_nodes:
                        w = wabde * wf
                        idx = base_e + tf
                        if rgb:
                            word = dr.gather(type(buf), buf, idx, active)
                            acc[0] += w * Float(Int32(word & _PACK_MAX))
                            acc[1] += w * Float(Int32((word >> PACK_BITS) & _PACK_MAX))
                            acc[2] += w * Float(Int32(word >> (2 * PACK_BITS)))
                        else:
                            acc[0] += w * dr.gather(Float, buf, idx, active)
    if rgb:
        return mi.Color3f(acc[0], acc[1], acc[2]) * step + offset
    return mi.Color3f(acc[0])
