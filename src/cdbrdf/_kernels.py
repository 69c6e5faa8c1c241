"""Compiled hot loops (numba). Private: call :mod:`cdbrdf.interp` instead.

Numba was chosen over a C/C++ extension because it needs no compiler on the
user's machine (wheels for every platform NumPy supports), compiles lazily on
first use (nothing happens at import), caches the machine code on disk, and
parallelises with ``prange`` over all cores. The kernel is a plain 5-D
multilinear interpolation on a grid already prepared by
:func:`cdbrdf.interp.prepare` (pole rule applied, pole node present), so the
same arithmetic can be reproduced in Dr.Jit for the renderer.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

__all__: list[str] = []

_SNAP = 1e-9


@njit(inline="always", cache=True, error_model="numpy")
def _locate(axis, inv_d, n, inv_step, x):
    """Lower index and weight of ``x`` on a sorted axis, clamped at both ends.

    ``inv_d[i] = 1 / (axis[i + 1] - axis[i])``. ``inv_step > 0`` declares the
    axis evenly spaced (index by multiplication); otherwise short axes are
    scanned and long ones bisected. The weight is exactly 0 at every node.
    """
    if n == 1 or x <= axis[0]:
        return 0, 0.0
    if x >= axis[n - 1]:
        return n - 2, 1.0
    if inv_step > 0.0:
        i = min(int((x - axis[0]) * inv_step), n - 2)
        if x < axis[i]:  # guard against rounding
            i -= 1
        elif i < n - 2 and x >= axis[i + 1]:
            i += 1
    elif n <= 16:
        i = 0
        for j in range(1, n - 1):
            i += axis[j] <= x
    else:
        lo = 0
        hi = n - 1
        while hi - lo > 1:
            mid = (lo + hi) >> 1
            if axis[mid] <= x:
                lo = mid
            else:
                hi = mid
        i = lo
    return i, (x - axis[i]) * inv_d[i]


@njit(inline="always", cache=True, error_model="numpy")
def _locate_periodic(phi0, inv_step, n, x):
    """Lower index and weight of azimuth ``x`` on an evenly spaced circle.

    Weights within 1e-9 of a node snap to it, so nodes are reproduced exactly
    despite the rounding of ``(x - phi0) / step``.
    """
    if n == 1:
        return 0, 0.0
    u = (x - phi0) * inv_step
    f = np.floor(u)
    w = u - f
    if w < _SNAP:
        w = 0.0
    elif w > 1.0 - _SNAP:
        w = 0.0
        f += 1.0
    if f < 0.0 or f >= n:
        f = f - n * np.floor(f / n)
    return int(f), w


@njit(inline="always", cache=True, error_model="numpy")
def _query(q_tv, q_pv, q_tl, q_pl, q_k, i, s_tv, s_pv, s_tl, s_pl, s_k):
    return q_tv[i * s_tv], q_pv[i * s_pv], q_tl[i * s_tl], q_pl[i * s_pl], q_k[i * s_k]


@njit(inline="always", cache=True, error_model="numpy")
def _invalid(tv, pv, tl, pl, k):
    """0 valid, 1 non-finite, 2 bad view elevation, 3 bad light elevation, 4 both."""
    if not (
        np.isfinite(tv) and np.isfinite(pv) and np.isfinite(tl) and np.isfinite(pl) and np.isfinite(k)
    ):
        return 1
    bv = tv < 0.0 or tv > 90.0
    bl = tl < 0.0 or tl > 90.0
    if bv and bl:
        return 4
    if bv:
        return 2
    if bl:
        return 3
    return 0


@njit(inline="always", cache=True, error_model="numpy")
def _cell(g_kap, d_kap, g_thl, d_thl, g_thv, d_thv, inv_tl, inv_tv, pl0, pl_inv, pv0, pv_inv,
          n_k, n_pl, n_tl, n_pv, n_tv, tv, pv, tl, pl, k):
    ik, wk = _locate(g_kap, d_kap, n_k, 0.0, k)
    itl, wtl = _locate(g_thl, d_thl, n_tl, inv_tl, tl)
    itv, wtv = _locate(g_thv, d_thv, n_tv, inv_tv, tv)
    ipl, wpl = _locate_periodic(pl0, pl_inv, n_pl, pl)
    ipv, wpv = _locate_periodic(pv0, pv_inv, n_pv, pv)
    # Pole: grid node 0 of each elevation axis is theta = 0, whose ring holds
    # one value, so the azimuth weight must not matter there.
    if itl == 0 and wtl == 0.0:
        wpl = 0.0
    if itv == 0 and wtv == 0.0:
        wpv = 0.0
    ik1 = ik + 1 if n_k > 1 else ik
    itl1 = itl + 1 if n_tl > 1 else itl
    itv1 = itv + 1 if n_tv > 1 else itv
    ipl1 = ipl + 1 if ipl + 1 < n_pl else 0
    ipv1 = ipv + 1 if ipv + 1 < n_pv else 0
    return ik, ik1, wk, ipl, ipl1, wpl, itl, itl1, wtl, ipv, ipv1, wpv, itv, itv1, wtv


_FASTMATH = {"contract"}  # fused multiply-add only: NaN/inf semantics are kept


@njit(parallel=True, cache=True, error_model="numpy", fastmath=_FASTMATH)
def lookup_rgb(
    flat, n_k, n_pl, n_tl, n_pv, n_tv, n_c, stride,
    g_kap, d_kap, g_thl, d_thl, g_thv, d_thv, inv_tl, inv_tv, pl0, pl_inv, pv0, pv_inv,
    q_tv, q_pv, q_tl, q_pl, q_k, n, out, offset,
):
    """RGB tables (``n_c == 3``, padded to ``stride = 4``): see :func:`lookup_generic`.

    Interpolate ``n`` queries into ``out[offset:offset + n]``.

    ``flat`` is the prepared table (:func:`cdbrdf.interp.prepare`) raveled in
    C order with ``stride`` values per sample (RGB tables are padded to 4 so
    that a sample is one aligned 16-byte load). Query arrays have length ``n``
    or 1 (broadcast). Rows with a non-finite component, or an elevation
    outside [0, 90], are NaN; the counts of bad view and light elevations are
    returned.

    The 32 corners are summed as 8 light/curvature corners of 4-corner view
    bilinear sums; every node is reproduced exactly (weights 0 and 1 only).
    """
    s_tv = 1 if q_tv.shape[0] > 1 else 0
    s_pv = 1 if q_pv.shape[0] > 1 else 0
    s_tl = 1 if q_tl.shape[0] > 1 else 0
    s_pl = 1 if q_pl.shape[0] > 1 else 0
    s_k = 1 if q_k.shape[0] > 1 else 0
    s_view = n_tv * stride
    s_tlight = n_pv * s_view
    one = np.uint64(1)
    two = np.uint64(2)
    bad_v = 0
    bad_l = 0
    for i in prange(n):
        tv, pv, tl, pl, k = _query(q_tv, q_pv, q_tl, q_pl, q_k, i, s_tv, s_pv, s_tl, s_pl, s_k)
        row = offset + i
        bad = _invalid(tv, pv, tl, pl, k)
        if bad != 0:
            if bad == 2 or bad == 4:
                bad_v += 1
            if bad == 3 or bad == 4:
                bad_l += 1
            for c in range(n_c):
                out[row, c] = np.nan
            continue
        ik, ik1, wk, ipl, ipl1, wpl, itl, itl1, wtl, ipv, ipv1, wpv, itv, itv1, wtv = _cell(
            g_kap, d_kap, g_thl, d_thl, g_thv, d_thv, inv_tl, inv_tv, pl0, pl_inv, pv0, pv_inv,
            n_k, n_pl, n_tl, n_pv, n_tv, tv, pv, tl, pl, k,
        )
        v00 = np.uint64(ipv * s_view + itv * stride)
        v01 = np.uint64(ipv * s_view + itv1 * stride)
        v10 = np.uint64(ipv1 * s_view + itv * stride)
        v11 = np.uint64(ipv1 * s_view + itv1 * stride)
        w00 = (1.0 - wpv) * (1.0 - wtv)
        w01 = (1.0 - wpv) * wtv
        w10 = wpv * (1.0 - wtv)
        w11 = wpv * wtv
        r = 0.0
        g = 0.0
        b = 0.0
        for a in range(2):
            ka = ik if a == 0 else ik1
            wa = (1.0 - wk) if a == 0 else wk
            for e in range(2):
                pe = ipl if e == 0 else ipl1
                we = wa * ((1.0 - wpl) if e == 0 else wpl)
                for d in range(2):
                    td = itl if d == 0 else itl1
                    wd = we * ((1.0 - wtl) if d == 0 else wtl)
                    base = np.uint64(((ka * n_pl + pe) * n_tl + td) * s_tlight)
                    x0 = wd * w00
                    x1 = wd * w01
                    x2 = wd * w10
                    x3 = wd * w11
                    o0 = base + v00
                    o1 = base + v01
                    o2 = base + v10
                    o3 = base + v11
                    r += (x0 * flat[o0] + x1 * flat[o1]) + (x2 * flat[o2] + x3 * flat[o3])
                    g += (x0 * flat[o0 + one] + x1 * flat[o1 + one]) + (x2 * flat[o2 + one] + x3 * flat[o3 + one])
                    b += (x0 * flat[o0 + two] + x1 * flat[o1 + two]) + (x2 * flat[o2 + two] + x3 * flat[o3 + two])
        out[row, 0] = r
        out[row, 1] = g
        out[row, 2] = b
    return bad_v, bad_l


@njit(parallel=True, cache=True, error_model="numpy", fastmath=_FASTMATH)
def lookup_generic(
    flat, n_k, n_pl, n_tl, n_pv, n_tv, n_c, stride,
    g_kap, d_kap, g_thl, d_thl, g_thv, d_thv, inv_tl, inv_tv, pl0, pl_inv, pv0, pv_inv,
    q_tv, q_pv, q_tl, q_pl, q_k, n, out, offset,
):
    """Interpolate ``n`` queries into ``out[offset:offset + n]``.

    ``flat`` is the prepared table (:func:`cdbrdf.interp.prepare`) raveled in
    C order with ``stride`` values per sample (RGB tables are padded to 4 so
    that a sample is one aligned 16-byte load). Query arrays have length ``n``
    or 1 (broadcast). Rows with a non-finite component, or an elevation
    outside [0, 90], are NaN; the counts of bad view and light elevations are
    returned.

    The 32 corners are summed as 8 light/curvature corners of 4-corner view
    bilinear sums; every node is reproduced exactly (weights 0 and 1 only).
    """
    s_tv = 1 if q_tv.shape[0] > 1 else 0
    s_pv = 1 if q_pv.shape[0] > 1 else 0
    s_tl = 1 if q_tl.shape[0] > 1 else 0
    s_pl = 1 if q_pl.shape[0] > 1 else 0
    s_k = 1 if q_k.shape[0] > 1 else 0
    s_view = n_tv * stride
    s_tlight = n_pv * s_view
    bad_v = 0
    bad_l = 0
    for i in prange(n):
        tv, pv, tl, pl, k = _query(q_tv, q_pv, q_tl, q_pl, q_k, i, s_tv, s_pv, s_tl, s_pl, s_k)
        row = offset + i
        bad = _invalid(tv, pv, tl, pl, k)
        if bad != 0:
            if bad == 2 or bad == 4:
                bad_v += 1
            if bad == 3 or bad == 4:
                bad_l += 1
            for c in range(n_c):
                out[row, c] = np.nan
            continue
        ik, ik1, wk, ipl, ipl1, wpl, itl, itl1, wtl, ipv, ipv1, wpv, itv, itv1, wtv = _cell(
            g_kap, d_kap, g_thl, d_thl, g_thv, d_thv, inv_tl, inv_tv, pl0, pl_inv, pv0, pv_inv,
            n_k, n_pl, n_tl, n_pv, n_tv, tv, pv, tl, pl, k,
        )
        v00 = np.uint64(ipv * s_view + itv * stride)
        v01 = np.uint64(ipv * s_view + itv1 * stride)
        v10 = np.uint64(ipv1 * s_view + itv * stride)
        v11 = np.uint64(ipv1 * s_view + itv1 * stride)
        w00 = (1.0 - wpv) * (1.0 - wtv)
        w01 = (1.0 - wpv) * wtv
        w10 = wpv * (1.0 - wtv)
        w11 = wpv * wtv
        for c in range(n_c):
            out[row, c] = 0.0
        for a in range(2):
            ka = ik if a == 0 else ik1
            wa = (1.0 - wk) if a == 0 else wk
            for e in range(2):
                pe = ipl if e == 0 else ipl1
                we = wa * ((1.0 - wpl) if e == 0 else wpl)
                for d in range(2):
                    td = itl if d == 0 else itl1
                    wd = we * ((1.0 - wtl) if d == 0 else wtl)
                    bd = np.uint64(((ka * n_pl + pe) * n_tl + td) * s_tlight)
                    for c in range(n_c):
                        cc = np.uint64(c)
                        out[row, c] += wd * (
                            (w00 * flat[bd + v00 + cc] + w01 * flat[bd + v01 + cc])
                            + (w10 * flat[bd + v10 + cc] + w11 * flat[bd + v11 + cc])
                        )
    return bad_v, bad_l
