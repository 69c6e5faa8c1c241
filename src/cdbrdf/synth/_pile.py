"""Compiled kernels of the pile model (:mod:`cdbrdf.synth.pile`). Private.

Each kernel handles items ``start`` to ``stop`` and releases the GIL;
:func:`cdbrdf._jit.run_split` runs ranges in threads. Every per-item sum runs
sequentially within its item, so the results do not depend on the number of
threads.

The fibre's scattering per unit length, for a fibre of diameter ``d`` and
direction ``t``, light ``l`` and view ``v`` (unit vectors away from the
surface), is ``d sigma(l, v)`` with (per steradian)::

    sigma = cos_i cos_o [A k_d T(theta_i) T(theta_o) / (Tbar pi^2)
                         + w_s K F(eta, cos_d cos(phi / 2)) g(theta_h) cos(phi / 2) / (4 cos_d^2)]

where ``cos_i = |l x t|``, ``cos_o = |v x t|`` (the cosines of the
longitudinal angles ``theta_i = asin(l . t)``, ``theta_o = asin(v . t)``),
``theta_h``, ``theta_d`` their half sum and half difference, ``phi`` the
azimuth between ``l`` and ``v`` around the fibre, ``g`` a normalised Gaussian
of width ``beta``: a diffuse cylinder (coloured, albedo ``A``) plus the
specular ``R`` lobe of Marschner et al. (2003), normalised numerically by
``K``. The diffuse part enters and leaves the fibre through its surface:
``T(theta) = 1 - a_s(theta)`` is what the specular lobe does not reflect
at that longitudinal angle (``a_s`` its albedo, tabulated over ``theta``
in ``trans``), and ``Tbar = (4 / pi) int_0^(pi/2) T cos^2`` makes the
diffuse part's albedo ``A T(theta_i)``, so that the fibre's whole albedo is
``a_s + A (1 - a_s) <= 1``. It is symmetric in ``l`` and ``v``
(reciprocal); the fibre's extinction cross-section per unit length is
``d cos_i``.
"""

from __future__ import annotations

import math

import numpy as np

from .._jit import njit
from .fibre import _fibre_angles, _fresnel

__all__: list[str] = []

# Layout of the fibre parameter row (F_TINV: 1 / Tbar).
F_R, F_G, F_B, F_KD, F_WS, F_BETA, F_ETA, F_K, F_SCALE, F_TINV = range(10)
N_FIBRE = 10

_INV_PI2 = 1.0 / (math.pi * math.pi)
_SQRT_2PI = math.sqrt(2.0 * math.pi)


@njit(cache=True, inline="always", error_model="numpy")
def _spec(tx, ty, tz, lx, ly, lz, vx, vy, vz, beta, eta):
    """The bare ``R`` lobe ``F g(theta_h) cos(phi/2) / (4 cos_d^2)`` (without ``cos_i cos_o``)."""
    _, _, th, td, chalf = _fibre_angles(tx, ty, tz, lx, ly, lz, vx, vy, vz)
    cd = math.cos(td)
    g = math.exp(-th * th / (2.0 * beta * beta)) / (_SQRT_2PI * beta)
    return _fresnel(eta, cd * chalf) * g * chalf / (4.0 * max(cd * cd, 1e-6))


@njit(cache=True, inline="always", error_model="numpy")
def _trans(trans, s):
    """``T`` at the longitudinal angle ``asin(|s|)``: linear in the table over 0..89 degrees, clamped."""
    n = trans.shape[0]
    x = math.asin(min(abs(s), 1.0)) / math.radians(89.0) * (n - 1)
    if x >= n - 1:
        return trans[n - 1]
    i = int(x)
    f = x - i
    return trans[i] * (1.0 - f) + trans[i + 1] * f


@njit(cache=True, nogil=True, error_model="numpy")
def fibre_albedo(thetas, fibre, trans, mode, n_theta, n_phi, out, start, stop):
    """Albedo ``int sigma(l, v) / cos_i dw_v`` over the whole sphere of a fibre along z.

    ``thetas``: longitudinal angles of the light (radians); mode 0: the bare
    ``R`` lobe with ``eta = 1e6`` (Fresnel 1) and ``K = 1``; mode 1: the full
    fibre with unit colour.
    """
    dt = math.pi / n_theta
    dp = 2.0 * math.pi / n_phi
    beta = fibre[F_BETA]
    for i in range(start, stop):
        lx, ly, lz = math.cos(thetas[i]), 0.0, math.sin(thetas[i])
        acc = 0.0
        for a in range(n_theta):
            # Polar angle from the fibre (z), midpoints.
            al = (a + 0.5) * dt
            sa, ca = math.sin(al), math.cos(al)
            for b in range(n_phi):
                ph = (b + 0.5) * dp
                vx, vy, vz = sa * math.cos(ph), sa * math.sin(ph), ca
                co = sa
                if mode == 0:
                    f = co * _spec(0.0, 0.0, 1.0, lx, ly, lz, vx, vy, vz, beta, 1e6)
                else:
                    dif = fibre[F_KD] * _INV_PI2 * fibre[F_TINV] * _trans(trans, lz) * _trans(trans, ca)
                    f = co * (dif + fibre[F_WS] * fibre[F_K]
                              * _spec(0.0, 0.0, 1.0, lx, ly, lz, vx, vy, vz, beta, fibre[F_ETA]))
                acc += f * sa
        out[i] = acc * dt * dp


@njit(cache=True, nogil=True, error_model="numpy")
def pile_pairs(views, lights, tangents, weights, caps, z_edges, layer_scale, diameter, fibre, trans, ground, corr_mm,
               out, slabs, start, stop):
    """Pile and ground reflectance of pairs ``start`` to ``stop``.

    Parameters (arrays)
    -------------------
    views, lights
        ``(n, 3)`` unit directions in the flat frame, z up.
    tangents
        ``(M, 3)`` fibre directions.
    weights
        ``(L, M)``: fibre length per unit volume (mm / mm^3) of each direction in
        each layer, flat cloth.
    caps
        ``(L, M)``: area of cut ends facing ``+t`` per unit volume (mm^2 / mm^3);
        each is a Lambertian disc of the fibre's colour.
    z_edges
        ``(L + 1,)`` layer boundaries, mm above the ground, increasing.
    layer_scale
        ``(L,)`` factor on each layer's density (the bend).
    fibre
        The fibre row; ``trans`` the transmission ``T`` of its surface over
        longitudinal angles 0..89 degrees; ``ground`` the ground's
        Lambertian albedo ``(3,)``.
    corr_mm
        Horizontal correlation length of the gaps (the hot spot), mm.
    out
        ``(n, 6)``: the pile's RGB BRDF, then the ground's.
    slabs
        ``(n, L + 1, 3)`` or empty ``(0, L + 1, 3)``: when not empty, row ``j``
        of a pair receives slab ``j``'s share of the pile's RGB BRDF (they
        add up to ``out[:, :3]``) and row ``L`` the joint optical depth
        of the two paths down to the ground (in its first column).
    """
    M = tangents.shape[0]
    L = weights.shape[0]
    d = diameter
    beta = fibre[F_BETA]
    eta = fibre[F_ETA]
    ks = fibre[F_WS] * fibre[F_K]
    scale = fibre[F_SCALE]
    tinv = fibre[F_TINV]
    e_l = np.empty(M)
    e_v = np.empty(M)
    e_d = np.empty(M)
    e_s = np.zeros(M)
    c_l = np.empty(M)
    c_v = np.empty(M)
    c_d = np.empty(M)
    for q in range(start, stop):
        vx, vy, vz = views[q, 0], views[q, 1], views[q, 2]
        lx, ly, lz = lights[q, 0], lights[q, 1], lights[q, 2]
        for c in range(6):
            out[q, c] = 0.0
        if vz <= 0.0 or lz <= 0.0:
            continue
        for m in range(M):
            tx, ty, tz = tangents[m, 0], tangents[m, 1], tangents[m, 2]
            pl = lx * tx + ly * ty + lz * tz
            pv = vx * tx + vy * ty + vz * tz
            ci = math.sqrt(max(0.0, 1.0 - pl * pl))
            co = math.sqrt(max(0.0, 1.0 - pv * pv))
            e_l[m] = ci
            e_v[m] = co
            e_d[m] = ci * co * _trans(trans, pl) * _trans(trans, pv) * tinv
            c_l[m] = abs(pl)
            c_v[m] = abs(pv)
            c_d[m] = max(pl, 0.0) * max(pv, 0.0)
            if ks > 0.0:
                e_s[m] = ci * co * _spec(tx, ty, tz, lx, ly, lz, vx, vy, vz, beta, eta)
        # Horizontal distance between the two paths per mm of depth.
        sx = vx / vz - lx / lz
        sy = vy / vz - ly / lz
        spread = math.sqrt(sx * sx + sy * sy)
        tau_l = 0.0
        tau_v = 0.0
        depth = 0.0
        tj_top = 0.0
        diff = 0.0
        spec = 0.0
        for jj in range(L):
            j = L - 1 - jj  # from the top down
            dz = z_edges[j + 1] - z_edges[j]
            s_l = 0.0
            s_v = 0.0
            s_d = 0.0
            s_s = 0.0
            for m in range(M):
                w = weights[j, m] * d
                a = caps[j, m]
                if w == 0.0 and a == 0.0:
                    continue
                s_l += w * e_l[m] + a * c_l[m]
                s_v += w * e_v[m] + a * c_v[m]
                s_d += w * e_d[m] * _INV_PI2 + a * c_d[m] / math.pi
                s_s += w * e_s[m]
            g = layer_scale[j]
            tau_l_bot = tau_l + g * s_l * dz / lz
            tau_v_bot = tau_v + g * s_v * dz / vz
            depth_bot = depth + dz
            cc = math.exp(-spread * depth_bot / corr_mm)
            tj_bot = max(tau_l_bot, tau_v_bot) + (1.0 - cc) * min(tau_l_bot, tau_v_bot)
            dt = tj_bot - tj_top
            if dt > 1e-9:
                path = math.exp(-tj_top) * (-math.expm1(-dt)) / dt * dz
            else:
                path = math.exp(-tj_top) * dz
            k = g * path / (lz * vz)
            diff += k * s_d
            spec += k * s_s
            if slabs.shape[0] > 0:
                for c in range(3):
                    slabs[q, j, c] = scale * k * (s_d * fibre[F_R + c] + ks * s_s)
            tau_l, tau_v, depth, tj_top = tau_l_bot, tau_v_bot, depth_bot, tj_bot
        ts = math.exp(-tj_top) / math.pi
        if slabs.shape[0] > 0:
            slabs[q, L, 0] = tj_top
        spec *= ks
        out[q, 0] = scale * (diff * fibre[F_R] + spec)
        out[q, 1] = scale * (diff * fibre[F_G] + spec)
        out[q, 2] = scale * (diff * fibre[F_B] + spec)
        out[q, 3] = ground[0] * ts
        out[q, 4] = ground[1] * ts
        out[q, 5] = ground[2] * ts
