"""Compiled hot loops (numba). Private: call :mod:`cdbrdf.interp` instead.

Numba was chosen over a C/C++ extension because it needs no compiler on the
user's machine (wheels for every platform NumPy supports), compiles lazily on
first use (nothing happens at import) and caches the machine code on disk.
The kernels are serial over a range of queries and release the GIL;
:func:`cdbrdf.interp.evaluate` runs ranges in threads over the CPUs. (numba's
``parallel=True`` took four times as long to compile, about 13 s a kernel,
paid by every fresh install.) Each kernel is compiled once per table dtype
(float32, float64): it reads a :class:`cdbrdf.interp.KernelGrid`, whose
other types are the same for every table, and read-only float64 query
arrays.

The kernels implement the rule stated in :mod:`cdbrdf.interp` (clamped
curvature and elevations, periodic azimuth with an exact ``fmod`` wrap, the
pole rule, the rotation of queries on isotropic tables, weights snapped to 0
or 1 within the tolerance ``tol``) on a
:class:`cdbrdf.interp.KernelGrid`, which they take as one argument (a named
tuple: numba reads its fields by name). The snap tolerance is an argument
too, not a global of this module, so that numba's on-disk cache (keyed on
this file) can never keep a stale copy of interp's constant. This module
imports nothing of the package but :mod:`cdbrdf._jit`.

:func:`lookup_rgb` (RGB tables with evenly spaced elevations, the common
case) is about 4x faster than a scalar kernel without changing numba's
global configuration: per
block of queries, the index math is written with selects only so that
LLVM's loop vectoriser handles several queries at once, and the 32 corners
are summed with explicit LLVM vector instructions (:func:`_blend_rgb`, a
numba intrinsic), which numba's pipeline does not emit by itself (its SLP
vectoriser is off).
"""

from __future__ import annotations

import numpy as np
from llvmlite import ir
from numba import types
from numba.core.extending import intrinsic

from ._jit import njit

__all__: list[str] = []


@njit(inline="always", cache=True, error_model="numpy")
def _snap(w, tol):
    """The snapping rule: a weight within ``tol`` of 0 or 1 becomes exactly 0 or 1."""
    w = 0.0 if w < tol else w
    return 1.0 if w > 1.0 - tol else w


@njit(inline="always", cache=True, error_model="numpy")
def _locate(axis, inv_d, n, inv_step, x, tol):
    """Lower index and weight of ``x`` on a sorted axis, clamped at both ends.

    ``inv_d[i] = 1 / (axis[i + 1] - axis[i])``. ``inv_step > 0`` declares the
    axis evenly spaced (index by multiplication); otherwise short axes are
    scanned and long ones bisected. The weight is snapped (:func:`_snap`).
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
    return i, _snap((x - axis[i]) * inv_d[i], tol)


@njit(inline="always", cache=True, error_model="numpy")
def _wrap_azimuth(x):
    """``x`` (degrees) reduced exactly into (-360, 360) when it lies outside.

    As :func:`cdbrdf.interp.wrap_azimuth`: ``np.fmod`` is exact for every
    finite float64, so a huge azimuth (1e30, 1e308) keeps its true place on
    the circle and the index math after it works on small numbers only.
    Azimuths already inside are returned unchanged (bit for bit); infinities
    and NaN become NaN.
    """
    if -360.0 < x < 360.0:
        return x
    return np.fmod(x, 360.0)


@njit(inline="always", cache=True, error_model="numpy")
def _locate_periodic(phi0, inv_step, n, x, tol):
    """Lower index and weight of azimuth ``x`` on an evenly spaced circle.

    ``x`` is first reduced with :func:`_wrap_azimuth`, so ``(x - phi0) /
    step`` stays below ``2 n`` in magnitude and its floor wraps exactly. The
    index is clamped into ``[0, n)`` as a last line of defence (NaN gives 0).
    A weight within ``tol`` of 0 snaps to this node, within ``tol`` of 1 to
    the next one (index + 1, weight 0): the snapping rule of :func:`_snap`.
    """
    if n == 1:
        return 0, 0.0
    u = (_wrap_azimuth(x) - phi0) * inv_step
    f = np.floor(u)
    w = u - f
    if w < tol:
        w = 0.0
    elif w > 1.0 - tol:
        w = 0.0
        f += 1.0
    if f < 0.0 or f >= n:
        f = f - n * np.floor(f / n)
    if not (0.0 <= f <= n - 1.0):  # unreachable for finite x; also catches NaN
        f = 0.0
        w = 0.0
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


@intrinsic
def _blend_rgb(typingctx, flat, bases, wl, v0, v1, wv):
    """Sum the 32 corners of an RGB cell with LLVM vector instructions.

    ``flat`` holds 4 values per sample (RGB + padding) and the two view
    elevation neighbours ``itv, itv + 1`` of a sample are adjacent, so one
    8-value load at ``bases[c] + v0`` (view azimuth ``ipv``) or ``+ v1``
    (``ipv + 1``) fetches both. For each of the 8 light/curvature corners
    ``c`` the loads are widened to float64 and accumulated with the weight
    ``wl[c]``; the two accumulators are then weighted by the view bilinear
    weights ``wv = (w00, w01, w10, w11)`` (azimuth-major) and the RGB lanes
    returned. With weights 0 and 1 every step is exact, so nodes are too.
    """
    if not (isinstance(flat, types.Array) and flat.ndim == 1
            and flat.dtype in (types.float32, types.float64)):
        return None
    if not (isinstance(bases, types.UniTuple) and bases.count == 8 and isinstance(bases.dtype, types.Integer)):
        return None
    if not (isinstance(wl, types.UniTuple) and wl.count == 8 and wl.dtype == types.float64):
        return None
    if not (isinstance(wv, types.UniTuple) and wv.count == 4 and wv.dtype == types.float64):
        return None
    if not (isinstance(v0, types.Integer) and isinstance(v1, types.Integer)):
        return None
    ret = types.UniTuple(types.float64, 3)
    sig = ret(flat, bases, wl, v0, v1, wv)

    def codegen(context, builder, signature, args):
        aty, bty, _, v0ty, v1ty, _ = signature.args
        a_flat, a_bases, a_wl, a_v0, a_v1, a_wv = args
        ary = context.make_array(aty)(context, builder, a_flat)
        elt = context.get_data_type(aty.dtype)
        esize = context.get_abi_sizeof(elt)
        i32 = ir.IntType(32)
        f64 = ir.DoubleType()
        vin = ir.VectorType(elt, 8)
        vd = ir.VectorType(f64, 8)
        flags = ("contract",)
        data = ary.data
        off0 = context.cast(builder, a_v0, v0ty, types.int64)
        off1 = context.cast(builder, a_v1, v1ty, types.int64)
        zeros8 = ir.Constant(ir.VectorType(i32, 8), [0] * 8)
        undef = ir.Constant(vd, ir.Undefined)

        def splat(x):
            return builder.shuffle_vector(builder.insert_element(undef, x, ir.Constant(i32, 0)), undef, zeros8)

        def load(off):
            ptr = builder.bitcast(builder.gep(data, [off]), vin.as_pointer())
            x = builder.load(ptr, align=esize)
            return x if elt == f64 else builder.fpext(x, vd)

        t0s = []
        t1s = []
        for c in range(8):
            base = context.cast(builder, builder.extract_value(a_bases, c), bty.dtype, types.int64)
            w = splat(builder.extract_value(a_wl, c))
            t0s.append(builder.fmul(load(builder.add(base, off0)), w, flags=flags))
            t1s.append(builder.fmul(load(builder.add(base, off1)), w, flags=flags))

        def tree(ts):  # pairwise sum: short dependency chains
            while len(ts) > 1:
                ts = [builder.fadd(ts[j], ts[j + 1], flags=flags) for j in range(0, len(ts), 2)]
            return ts[0]

        acc0 = tree(t0s)
        acc1 = tree(t1s)
        # view weights, lanes 0-3 -> itv, lanes 4-7 -> itv + 1
        wvs = [builder.extract_value(a_wv, j) for j in range(4)]
        lanes = ir.Constant(ir.VectorType(i32, 8), [0, 0, 0, 0, 1, 1, 1, 1])

        def pairw(wa, wb):
            v = builder.insert_element(undef, wa, ir.Constant(i32, 0))
            v = builder.insert_element(v, wb, ir.Constant(i32, 1))
            return builder.shuffle_vector(v, undef, lanes)

        s = builder.fadd(builder.fmul(acc0, pairw(wvs[0], wvs[1]), flags=flags),
                         builder.fmul(acc1, pairw(wvs[2], wvs[3]), flags=flags), flags=flags)
        out = []
        for ch in range(3):
            lo = builder.extract_element(s, ir.Constant(i32, ch))
            hi = builder.extract_element(s, ir.Constant(i32, ch + 4))
            out.append(builder.fadd(lo, hi))
        return context.make_tuple(builder, ret, out)

    return sig, codegen


_FASTMATH = {"contract"}  # fused multiply-add only: NaN/inf semantics are kept


#: Queries per block of :func:`lookup_rgb` (its scratch is 22 values per query).
_BLOCK = 64


@njit(inline="always", cache=True, error_model="numpy")
def _periodic_select(x, phi0, inv_step, n, inv_n, tol):
    """:func:`_locate_periodic` with selects instead of branches, plus the next index.

    ``x`` must already be reduced by :func:`_wrap_azimuth` (done when the
    queries are copied), so ``|f| < 2 n``. The wrap ``f mod n`` multiplies by
    ``inv_n = 1 / n`` and corrects the rounding, which gives the exact
    remainder for integral ``|f| < 2**52``; the index is clamped into
    ``[0, n)`` whatever ``x`` is (NaN gives 0).
    """
    u = (x - phi0) * inv_step
    f = np.floor(u)
    w = u - f
    up = w > 1.0 - tol
    f = f + 1.0 if up else f
    w = 0.0 if (up or w < tol or n == 1) else w
    r = f - n * np.floor(f * inv_n)
    r = r - n if r >= n else r
    r = r + n if r < 0.0 else r
    r = r if (r >= 0.0) & (r <= n - 1.0) else 0.0  # last line of defence; NaN -> 0
    i = int(r)
    return i, (i + 1 if i + 1 < n else 0), w


@njit(inline="always", cache=True, error_model="numpy")
def _elevation_select(x, inv_step, n, tol):
    """Lower index and weight on an evenly spaced axis ``0, step, ..., (n - 1) step``.

    Clamped at both ends like :func:`_locate`, with selects instead of
    branches; the weight is the fractional part of ``x / step``, snapped
    (:func:`_snap`) so that nodes are reproduced exactly despite its rounding
    (``n >= 2``).
    """
    u = min(max(x * inv_step, 0.0), n - 1.0)
    i = min(int(u), n - 2)
    return i, _snap(u - i, tol)


@njit(nogil=True, cache=True, error_model="numpy", fastmath=_FASTMATH, inline="always")
def _gather_block(qbuf, first, m, q_tv, q_pv, q_tl, q_pl, q_k, iso):
    """Contiguous copies of ``m`` (possibly broadcast) queries from ``first``: lets the next loop vectorise."""
    s_tv = 1 if q_tv.shape[0] > 1 else 0
    s_pv = 1 if q_pv.shape[0] > 1 else 0
    s_tl = 1 if q_tl.shape[0] > 1 else 0
    s_pl = 1 if q_pl.shape[0] > 1 else 0
    s_k = 1 if q_k.shape[0] > 1 else 0
    for j in range(m):
        q = first + j
        qbuf[0, j] = q_tv[q * s_tv]
        pv = _wrap_azimuth(q_pv[q * s_pv])
        pl = _wrap_azimuth(q_pl[q * s_pl])
        # isotropic: the view azimuth axis is the difference phi_v - phi_l (phi_l has one node)
        qbuf[1, j] = _wrap_azimuth(pv - pl) if iso else pv
        qbuf[2, j] = q_tl[q * s_tl]
        qbuf[3, j] = pl
        qbuf[4, j] = q_k[q * s_k]


@njit(nogil=True, cache=True, error_model="numpy", fastmath=_FASTMATH)
def lookup_rgb(g, tol, q_tv, q_pv, q_tl, q_pl, q_k, start, stop, out, offset):
    """:func:`lookup_generic` for RGB tables with evenly spaced elevations.

    Same arguments and results (up to rounding) where ``g.rgb_kernel`` holds:
    3 channels (padded to ``stride = 4`` in ``g.flat``), evenly spaced
    elevation axes of at least 3 samples and at most
    ``cdbrdf.interp.RGB_MAX_KAPPA`` (8) curvatures, given in the slots
    ``g.kappa_node``, ``g.kappa_scan``, ``g.kappa_slot_inv_d`` that are
    unpacked below into scalars (the scan over the interior nodes is
    unrolled).

    Queries go in blocks of :data:`_BLOCK` (scratch of a few KiB per block,
    none of query size): a first loop, written with selects only so that
    LLVM vectorises it across queries, turns each query into a validity flag,
    a table offset and 12 weights; a second loop sums the 32 corners of each
    valid query with :func:`_blend_rgb` and classifies the invalid ones.
    """
    flat = g.flat
    n_k, n_pl, n_tl, n_pv, n_tv, _ = g.shape
    inv_tl = g.theta_l_inv_step
    inv_tv = g.theta_v_inv_step
    pl0 = g.phi_l0
    pl_inv = g.phi_l_inv_step
    pv0 = g.phi_v0
    pv_inv = g.phi_v_inv_step
    iso = g.isotropic
    k_lo, kn1, kn2, kn3, kn4, kn5, kn6, k_hi = g.kappa_node
    _, ks1, ks2, ks3, ks4, ks5, ks6, _ = g.kappa_scan
    ki0, ki1, ki2, ki3, ki4, ki5, ki6, _ = g.kappa_slot_inv_d
    s_view = n_tv * 4
    s_tlight = n_pv * s_view
    d_tl = s_tlight  # n_tl >= 3
    d_k = n_pl * n_tl * s_tlight if n_k > 1 else 0
    inv_npl = 1.0 / n_pl
    inv_npv = 1.0 / n_pv
    bad_v = 0
    bad_l = 0
    qbuf = np.empty((5, _BLOCK), dtype=np.float64)
    ibuf = np.empty((5, _BLOCK), dtype=np.int64)
    fbuf = np.empty((12, _BLOCK), dtype=np.float64)
    for first in range(start, stop, _BLOCK):
        m = min(_BLOCK, stop - first)
        _gather_block(qbuf, first, m, q_tv, q_pv, q_tl, q_pl, q_k, iso)
        for j in range(m):
            tv = qbuf[0, j]
            pv = qbuf[1, j]
            tl = qbuf[2, j]
            pl = qbuf[3, j]
            k = qbuf[4, j]
            # valid: elevations in [0, 90], everything finite (the rest is then unused)
            ibuf[4, j] = ((tv >= 0.0) & (tv <= 90.0) & (tl >= 0.0) & (tl <= 90.0)
                          & (pv - pv == 0.0) & (pl - pl == 0.0) & (k - k == 0.0))
            # curvature as _locate: clamp, count the interior nodes at or below
            kc = min(max(k, k_lo), k_hi)
            b1 = ks1 <= kc
            b2 = ks2 <= kc
            b3 = ks3 <= kc
            b4 = ks4 <= kc
            b5 = ks5 <= kc
            b6 = ks6 <= kc
            ik = np.int64(b1) + np.int64(b2) + np.int64(b3) + np.int64(b4) + np.int64(b5) + np.int64(b6)
            klo = kn6 if b6 else (kn5 if b5 else (kn4 if b4 else (
                kn3 if b3 else (kn2 if b2 else (kn1 if b1 else k_lo)))))
            kinv = ki6 if b6 else (ki5 if b5 else (ki4 if b4 else (
                ki3 if b3 else (ki2 if b2 else (ki1 if b1 else ki0)))))
            wk = (kc - klo) * kinv
            wk = 1.0 if kc >= k_hi else _snap(wk, tol)
            itl, wtl = _elevation_select(tl, inv_tl, n_tl, tol)
            itv, wtv = _elevation_select(tv, inv_tv, n_tv, tol)
            ipl, ipl1, wpl = _periodic_select(pl, pl0, pl_inv, n_pl, inv_npl, tol)
            ipv, ipv1, wpv = _periodic_select(pv, pv0, pv_inv, n_pv, inv_npv, tol)
            # pole rule, as in lookup_generic
            light_pole = itl == 0 and wtl == 0.0
            wpl = 0.0 if light_pole else wpl
            wpv = 0.0 if ((itv == 0 and wtv == 0.0) or (iso and light_pole)) else wpv
            ibuf[0, j] = ((ik * n_pl + ipl) * n_tl + itl) * s_tlight
            ibuf[1, j] = (ipl1 - ipl) * n_tl * s_tlight
            ibuf[2, j] = ipv * s_view + itv * 4
            ibuf[3, j] = ipv1 * s_view + itv * 4
            wk0 = 1.0 - wk
            wp00 = wk0 * (1.0 - wpl)
            wp01 = wk0 * wpl
            wp10 = wk * (1.0 - wpl)
            wp11 = wk * wpl
            wt0 = 1.0 - wtl
            fbuf[0, j] = wp00 * wt0
            fbuf[1, j] = wp00 * wtl
            fbuf[2, j] = wp01 * wt0
            fbuf[3, j] = wp01 * wtl
            fbuf[4, j] = wp10 * wt0
            fbuf[5, j] = wp10 * wtl
            fbuf[6, j] = wp11 * wt0
            fbuf[7, j] = wp11 * wtl
            wv0 = 1.0 - wpv
            wu0 = 1.0 - wtv
            fbuf[8, j] = wv0 * wu0
            fbuf[9, j] = wv0 * wtv
            fbuf[10, j] = wpv * wu0
            fbuf[11, j] = wpv * wtv
        for j in range(m):
            row = offset + first + j
            if ibuf[4, j] == 0:
                bad = _invalid(qbuf[0, j], qbuf[1, j], qbuf[2, j], qbuf[3, j], qbuf[4, j])
                if bad == 2 or bad == 4:
                    bad_v += 1
                if bad == 3 or bad == 4:
                    bad_l += 1
                out[row, 0] = np.nan
                out[row, 1] = np.nan
                out[row, 2] = np.nan
                continue
            b = ibuf[0, j]
            d_pl = ibuf[1, j]
            bases = (b, b + d_tl, b + d_pl, b + d_pl + d_tl,
                     b + d_k, b + d_k + d_tl, b + d_k + d_pl, b + d_k + d_pl + d_tl)
            wl = (fbuf[0, j], fbuf[1, j], fbuf[2, j], fbuf[3, j], fbuf[4, j], fbuf[5, j], fbuf[6, j], fbuf[7, j])
            wv = (fbuf[8, j], fbuf[9, j], fbuf[10, j], fbuf[11, j])
            # _blend_rgb is a numba intrinsic: numba passes its typing context, mypy cannot see that
            r, gg, bl = _blend_rgb(flat, bases, wl, ibuf[2, j], ibuf[3, j], wv)  # type: ignore[call-arg,var-annotated]
            out[row, 0] = r
            out[row, 1] = gg
            out[row, 2] = bl
    return bad_v, bad_l


@njit(nogil=True, cache=True, error_model="numpy", fastmath=_FASTMATH)
def lookup_generic(g, tol, q_tv, q_pv, q_tl, q_pl, q_k, start, stop, out, offset):
    """Interpolate queries ``start`` to ``stop`` on the grid ``g`` into ``out[offset + start:offset + stop]``.

    ``g`` is a :class:`cdbrdf.interp.KernelGrid` (its ``flat`` holds
    ``stride`` values per sample), ``tol`` the weight snap tolerance
    (``cdbrdf.interp.SNAP_TOLERANCE["float64"]``). Query arrays are read-only
    float64, of one length or of length 1 (broadcast). Rows with a
    non-finite component, or an elevation outside [0, 90], are NaN; the
    counts of bad view and light elevations are returned. The GIL is
    released: :func:`cdbrdf.interp.evaluate` runs ranges in threads.

    The 32 corners are summed as 8 light/curvature corners of 4-corner view
    bilinear sums; every node is reproduced exactly (weights 0 and 1 only).
    """
    # the grid's fields as locals
    flat = g.flat
    stride = g.stride
    n_k, n_pl, n_tl, n_pv, n_tv, n_c = g.shape
    kap, kap_d = g.kappa, g.kappa_inv_d
    thl, thl_d, inv_tl = g.theta_l, g.theta_l_inv_d, g.theta_l_inv_step
    thv, thv_d, inv_tv = g.theta_v, g.theta_v_inv_d, g.theta_v_inv_step
    pl0, pl_inv, pv0, pv_inv = g.phi_l0, g.phi_l_inv_step, g.phi_v0, g.phi_v_inv_step
    iso = g.isotropic
    s_tv = 1 if q_tv.shape[0] > 1 else 0
    s_pv = 1 if q_pv.shape[0] > 1 else 0
    s_tl = 1 if q_tl.shape[0] > 1 else 0
    s_pl = 1 if q_pl.shape[0] > 1 else 0
    s_k = 1 if q_k.shape[0] > 1 else 0
    s_view = n_tv * stride
    s_tlight = n_pv * s_view
    bad_v = 0
    bad_l = 0
    acc = np.zeros(n_c)  # one sample's channels, summed here: out is written once per row
    for i in range(start, stop):
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
        if iso:  # rotate to light azimuth 0: the view azimuth axis is the difference phi_v - phi_l
            pv = _wrap_azimuth(_wrap_azimuth(pv) - _wrap_azimuth(pl))
        ik, wk = _locate(kap, kap_d, n_k, 0.0, k, tol)
        itl, wtl = _locate(thl, thl_d, n_tl, inv_tl, tl, tol)
        itv, wtv = _locate(thv, thv_d, n_tv, inv_tv, tv, tol)
        ipl, wpl = _locate_periodic(pl0, pl_inv, n_pl, pl, tol)
        ipv, wpv = _locate_periodic(pv0, pv_inv, n_pv, pv, tol)
        # Pole: grid node 0 of each elevation axis is theta = 0, whose ring holds
        # one value, so the azimuth weight must not matter there (isotropic: the
        # stored azimuth difference depends on the light azimuth too).
        if itl == 0 and wtl == 0.0:
            wpl = 0.0
            if iso:
                wpv = 0.0
        if itv == 0 and wtv == 0.0:
            wpv = 0.0
        ik1 = ik + 1 if n_k > 1 else ik
        itl1 = itl + 1 if n_tl > 1 else itl
        itv1 = itv + 1 if n_tv > 1 else itv
        ipl1 = ipl + 1 if ipl + 1 < n_pl else 0
        ipv1 = ipv + 1 if ipv + 1 < n_pv else 0
        v00 = np.uint64(ipv * s_view + itv * stride)
        v01 = np.uint64(ipv * s_view + itv1 * stride)
        v10 = np.uint64(ipv1 * s_view + itv * stride)
        v11 = np.uint64(ipv1 * s_view + itv1 * stride)
        w00 = (1.0 - wpv) * (1.0 - wtv)
        w01 = (1.0 - wpv) * wtv
        w10 = wpv * (1.0 - wtv)
        w11 = wpv * wtv
        acc[:] = 0.0
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
                        acc[c] += wd * (
                            (w00 * flat[bd + v00 + cc] + w01 * flat[bd + v01 + cc])
                            + (w10 * flat[bd + v10 + cc] + w11 * flat[bd + v11 + cc])
                        )
        for c in range(n_c):
            out[row, c] = acc[c]
    return bad_v, bad_l
