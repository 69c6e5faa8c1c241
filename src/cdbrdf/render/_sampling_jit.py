"""The sampling rule of :mod:`cdbrdf.render._sampling` written in Dr.Jit, for the plug-in.

:func:`upload` puts a :class:`~cdbrdf.render._sampling.SamplerTables` on the
device; per query, :func:`conditioning` finds the neighbouring slices and
their probabilities (the lookup rule's weights for kappa, theta_v and phi_v,
from :mod:`cdbrdf.render._lookup_jit`, times the slices' masses), then
:func:`pdf` evaluates the mixture density of a light direction (one gather of
a cell density per slice) and :func:`sample` draws one: ``sample1`` picks
cosine or a slice, ``sample2`` goes through the slice's marginal and
conditional CDFs (branch-free binary searches, ``log2`` gathers each). The
density returned with a sample is :func:`pdf` of the drawn direction, so the
two agree exactly. All arithmetic is in the variant's precision (float32);
tests hold it to the NumPy rule.
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple

import numpy as np

from ._lookup_jit import _locate, _locate_periodic, _tolerance
from ._sampling import SamplerTables

__all__ = ["SamplerUpload", "Conditioning", "upload", "conditioning", "pdf", "sample"]

_DEG2RAD = math.pi / 180.0


class SamplerUpload(NamedTuple):
    """The sampling tables on the device, with the static sizes the traced code needs."""

    tables: SamplerTables
    mass: Any
    density: Any
    marginal: Any
    conditional: Any


class Conditioning(NamedTuple):
    """Neighbouring slices of a query: ``(slice index, probability mass)`` pairs, their sum, the view azimuth."""

    corners: list[tuple[Any, Any]]
    total: Any
    phi_v: Any


def upload(mi: Any, tables: SamplerTables) -> SamplerUpload:
    """Copy the sampling tables to Dr.Jit arrays (float32)."""
    F = mi.Float
    return SamplerUpload(
        tables,
        F(np.ascontiguousarray(tables.mass, dtype=np.float32)),
        F(np.ascontiguousarray(tables.density.reshape(-1))),
        F(np.ascontiguousarray(tables.marginal_cdf.reshape(-1))),
        F(np.ascontiguousarray(tables.conditional_cdf.reshape(-1))),
    )


def conditioning(mi: Any, up: SamplerUpload, theta_v: Any, phi_v: Any, kappa: Any, active: Any = True) -> Conditioning:
    """The slices around ``(kappa, theta_v, phi_v)`` (degrees, mm^-1) and their masses ``w_s * mass_s``."""
    import drjit as dr

    t = up.tables
    Float, UInt = mi.Float, mi.UInt32
    tol = _tolerance(dr, Float)
    ik, wk = _locate(dr, Float, UInt, t.kappa, t.kappa_inv_d, kappa, tol)
    it, wt = _locate(dr, Float, UInt, t.theta_v, t.theta_v_inv_d, theta_v, tol)
    ip, wp = _locate_periodic(dr, Float, UInt, t.phi_v0_deg, t.n_phi_v / 360.0, t.n_phi_v, phi_v, tol)
    wp = dr.select((it == 0) & (wt == 0.0), 0.0, wp)
    ntv, npv = t.theta_v.size, t.n_phi_v
    ip1 = dr.select(ip + 1 < npv, ip + 1, 0)
    ks = [(ik, 1.0 - wk), (ik + 1, wk)] if t.kappa.size > 1 else [(ik, Float(1.0))]
    ts = [(it, 1.0 - wt), (it + 1, wt)] if ntv > 1 else [(it, Float(1.0))]
    ps = [(ip, 1.0 - wp), (ip1, wp)] if npv > 1 else [(ip, Float(1.0))]
    corners = []
    total = Float(0.0)
    for kk, fk in ks:
        for tt, ft in ts:
            for pp, fp in ps:
                s = (kk * ntv + tt) * npv + pp
                q = fk * ft * fp * dr.gather(Float, up.mass, s, active)
                corners.append((s, q))
                total += q
    return Conditioning(corners, total, phi_v)


def _cells(mi: Any, t: SamplerTables, u1: Any, u2: Any) -> tuple[Any, Any]:
    import drjit as dr

    UInt = mi.UInt32
    col = UInt(dr.clip(dr.floor(u1 * t.nx), 0.0, t.nx - 1.0))
    row = UInt(dr.clip(dr.floor(u2 * t.ny), 0.0, t.ny - 1.0))
    return col, row


def pdf(mi: Any, up: SamplerUpload, cond: Conditioning, wl: Any, phi_l_deg: Any, cosine_weight: float,
        active: Any = True) -> Any:
    """Solid-angle density of the light direction ``wl`` (front frame; ``phi_l_deg`` its azimuth)."""
    import drjit as dr

    t = up.tables
    Float = mi.Float
    u2 = dr.clip(dr.fma(wl.x, wl.x, wl.y * wl.y), 0.0, 1.0)
    az = cond.phi_v - phi_l_deg if t.isotropic else phi_l_deg  # isotropic: the azimuth difference
    u1 = (az - t.phi0_deg) * (1.0 / 360.0)
    u1 = u1 - dr.floor(u1)
    col, row = _cells(mi, t, u1, u2)
    cell = row * t.nx + col
    acc = Float(0.0)
    stride = t.nx * t.ny
    for s, q in cond.corners:
        acc += q * dr.gather(Float, up.density, s * stride + cell, active & (q > 0.0))
    ok = cond.total > 0.0
    c = dr.select(ok, cosine_weight, 1.0)
    p_t = acc / dr.select(ok, cond.total, 1.0)
    p_u = dr.fma(1.0 - c, p_t, c)
    return dr.select(active & (wl.z > 0.0), p_u * wl.z * (1.0 / math.pi), 0.0)


def _invert(mi: Any, buf: Any, base: Any, n: int, x: Any, active: Any) -> tuple[Any, Any]:
    """Cell ``j`` and position in it of ``x`` in [0, 1) on the inclusive CDF ``buf[base : base + n]``.

    ``j`` counts the entries among the first ``n - 1`` that are ``<= x``
    (a branch-free binary search, one gather per step).
    """
    import drjit as dr

    Float, UInt = mi.Float, mi.UInt32
    pos = UInt(0)
    if n > 1:
        step = 1 << int(math.floor(math.log2(n - 1)))
        while step >= 1:
            cand = pos + step
            ok = cand <= n - 1
            v = dr.gather(Float, buf, base + cand - 1, active & ok)
            pos = dr.select(ok & (v <= x), cand, pos)
            step //= 2
    lo = dr.gather(Float, buf, base + pos - 1, active & (pos > 0))
    hi = dr.gather(Float, buf, base + pos, active)
    width = hi - lo
    frac = dr.select(width > 0.0, (x - lo) / dr.select(width > 0.0, width, 1.0), 0.5)
    return pos, dr.clip(frac, 0.0, 1.0)


def sample(mi: Any, up: SamplerUpload, cond: Conditioning, sample1: Any, sample2: Any, cosine_weight: float,
           active: Any = True) -> Any:
    """Draw a light direction (front frame, ``mi.Vector3f``); its density is :func:`pdf`."""
    import drjit as dr

    t = up.tables
    Float = mi.Float
    ok = cond.total > 0.0
    c = dr.select(ok, cosine_weight, 1.0)
    cosine = sample1 < c
    r = dr.select(cosine, 0.0, (sample1 - c) / dr.select(c < 1.0, 1.0 - c, 1.0)) * cond.total
    s_pick = cond.corners[-1][0]
    found = mi.Bool(False)
    acc = Float(0.0)
    for s, q in cond.corners[:-1]:
        acc += q
        take = ~found & (r < acc)
        s_pick = dr.select(take, s, s_pick)
        found |= take
    table = active & ~cosine
    row, ty = _invert(mi, up.marginal, s_pick * t.ny, t.ny, sample2.y, table)
    col, tx = _invert(mi, up.conditional, (s_pick * t.ny + row) * t.nx, t.nx, sample2.x, table)
    u1 = dr.select(cosine, sample2.x, (Float(col) + tx) * (1.0 / t.nx))
    u2 = dr.select(cosine, sample2.y, (Float(row) + ty) * (1.0 / t.ny))
    az = t.phi0_deg + 360.0 * u1
    sp, cp = dr.sincos((cond.phi_v - az if t.isotropic else az) * _DEG2RAD)
    st = dr.sqrt(dr.clip(u2, 0.0, 1.0))
    ct = dr.sqrt(dr.clip(1.0 - u2, 0.0, 1.0))
    return mi.Vector3f(st * cp, st * sp, ct)
