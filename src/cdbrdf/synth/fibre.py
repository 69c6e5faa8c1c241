"""Light scattering by the fibres at a point of a yarn's surface.

Each visible point of the cloth's micro-geometry carries a fibre of direction
``t`` lying in the surface (normal ``n``). It scatters light following the
microcylinder model of Sadeghi et al. (2013), evaluated with longitudinal
angles ``theta_i = asin(l . t)``, ``theta_r = asin(v . t)`` (from the fibre's
normal plane), their half and difference angles ``theta_h``, ``theta_d`` and
the azimuth difference ``phi_d`` around the fibre:

- surface reflection (white, anisotropic sheen along the specular cone of the
  fibre, Sadeghi eq. for ``f_r,s``)::

      f_s = w_s F(eta, cos(theta_d) cos(phi_d / 2)) cos(phi_d / 2) g(gamma_s, theta_h) / N_s

- volume scattering (coloured; a forward lobe on the same cone plus an
  isotropic part, Sadeghi's ``f_r,v`` with the isotropic part made Lambertian
  so that it has a known albedo)::

      f_v = A T(v) T(l) [k_d / pi + (1 - k_d) g(gamma_v, theta_h) / (cos theta_i + cos theta_r) / N_v]

  with ``A`` the yarn colour (albedo per channel), ``T = 1 - F(eta, n . w)``
  the Fresnel transmission of the fibre surface.

``g(gamma, x) = exp(-x^2 / (2 gamma^2))``. The constants ``N_s`` and ``N_v``
are the largest directional albedos of the bare lobes over all view
directions (numerical integration, :func:`lobe_norms`), so each lobe on its
own reflects at most all the light; the whole local BRDF is divided by
``max(1, max_v albedo)`` (:func:`local_albedo_max`) so that no point of the
surface reflects more than it receives. The local BRDF is symmetric in ``v``
and ``l`` (reciprocal).

References
----------
I. Sadeghi, O. Bisker, J. De Deken, H. W. Jensen, "A practical microcylinder
appearance model for cloth rendering", ACM Transactions on Graphics 32(2), 2013.
P. Irawan and S. Marschner, "Specular reflection from woven cloth",
ACM Transactions on Graphics 31(1), 2012.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from .._jit import njit

__all__ = ["FibreLobes", "lobe_norms", "local_albedo_max", "fresnel_dielectric"]

# Layout of one row of the per-kind parameter array used by the kernels.
P_R, P_G, P_B, P_WS, P_GS, P_GV, P_KD, P_ETA, P_INS, P_INV, P_INK, P_LAMB = range(12)
N_PARAM = 12

_ALBEDO_N_THETA = 90
_ALBEDO_N_PHI = 180
_NORM_MARGIN = 1.01


@njit(cache=True, inline="always", error_model="numpy")
def _fresnel(eta, cos_i):
    """Unpolarised Fresnel reflectance of a dielectric (outside index 1)."""
    c = min(max(cos_i, 0.0), 1.0)
    s2 = (1.0 - c * c) / (eta * eta)
    if s2 >= 1.0:
        return 1.0
    ct = math.sqrt(1.0 - s2)
    rs = (c - eta * ct) / (c + eta * ct)
    rp = (eta * c - ct) / (eta * c + ct)
    return 0.5 * (rs * rs + rp * rp)


def fresnel_dielectric(eta: float, cos_i: float) -> float:
    """Unpolarised Fresnel reflectance for a dielectric of index ``eta``."""
    return float(_fresnel(float(eta), float(cos_i)))


@njit(cache=True, inline="always", error_model="numpy")
def _fibre_angles(tx, ty, tz, lx, ly, lz, vx, vy, vz):
    """Angles of a light and a view direction about a fibre along unit ``t`` (Marschner et al. 2003).

    Returns ``(sin theta_i, sin theta_r, theta_h, theta_d, cos(phi / 2))``:
    the sines of the longitudinal angles, their half sum and half difference,
    and the cosine of half the azimuth between the two around the fibre.
    """
    si = min(max(lx * tx + ly * ty + lz * tz, -1.0), 1.0)
    sr = min(max(vx * tx + vy * ty + vz * tz, -1.0), 1.0)
    ti = math.asin(si)
    tr = math.asin(sr)
    th = 0.5 * (ti + tr)
    td = 0.5 * (tr - ti)
    # Azimuths around the fibre: components perpendicular to t.
    ax, ay, az = lx - si * tx, ly - si * ty, lz - si * tz
    bx, by, bz = vx - sr * tx, vy - sr * ty, vz - sr * tz
    na = math.sqrt(ax * ax + ay * ay + az * az)
    nb = math.sqrt(bx * bx + by * by + bz * bz)
    if na > 1e-9 and nb > 1e-9:
        cphi = (ax * bx + ay * by + az * bz) / (na * nb)
    else:
        cphi = 1.0
    return si, sr, th, td, math.sqrt(max(0.0, 0.5 * (1.0 + cphi)))


@njit(cache=True, inline="always", error_model="numpy")
def _terms(nx, ny, nz, tx, ty, tz, vx, vy, vz, lx, ly, lz, p):
    """(white specular part, coloured part per unit albedo) of the local BRDF."""
    if p[P_LAMB] > 0.5:
        return 0.0, 1.0 / math.pi
    si, sr, th, td, chalf = _fibre_angles(tx, ty, tz, lx, ly, lz, vx, vy, vz)
    eta = p[P_ETA]
    gs = p[P_GS]
    spec = p[P_WS] * _fresnel(eta, math.cos(td) * chalf) * chalf
    spec *= math.exp(-th * th / (2.0 * gs * gs)) * p[P_INS]
    gv = p[P_GV]
    kd = p[P_KD]
    ci = math.sqrt(max(0.0, 1.0 - si * si))
    cr = math.sqrt(max(0.0, 1.0 - sr * sr))
    lobe = math.exp(-th * th / (2.0 * gv * gv)) / max(ci + cr, 1e-6) * p[P_INV]
    cn_v = nx * vx + ny * vy + nz * vz
    cn_l = nx * lx + ny * ly + nz * lz
    tt = (1.0 - _fresnel(eta, cn_v)) * (1.0 - _fresnel(eta, cn_l))
    col = tt * (kd / math.pi + (1.0 - kd) * lobe)
    return spec, col


@njit(cache=True, nogil=True, error_model="numpy")
def _albedo_kernel(views, p, mode, n_theta, n_phi, out, start, stop):
    """Directional albedo into ``out``, frame n = z, t = x, for views ``start`` to ``stop`` of ``views (n, 3)``.

    mode 0: bare specular lobe ``chalf g_s``; 1: bare volume lobe
    ``g_v / (cos ti + cos tr)``; 2: the full local BRDF with unit albedo.
    """
    dt = 0.5 * math.pi / n_theta
    dp = 2.0 * math.pi / n_phi
    for iv in range(start, stop):
        vx, vy, vz = views[iv, 0], views[iv, 1], views[iv, 2]
        acc = 0.0
        for it in range(n_theta):
            th_l = (it + 0.5) * dt
            st, ct = math.sin(th_l), math.cos(th_l)
            for ip in range(n_phi):
                ph = (ip + 0.5) * dp
                lx, ly, lz = st * math.cos(ph), st * math.sin(ph), ct
                if mode == 2:
                    s, c = _terms(0.0, 0.0, 1.0, 1.0, 0.0, 0.0, vx, vy, vz, lx, ly, lz, p)
                    f = (s + c) * p[P_INK]
                else:
                    si = lx
                    sr = vx
                    ti = math.asin(min(max(si, -1.0), 1.0))
                    tr = math.asin(min(max(sr, -1.0), 1.0))
                    th = 0.5 * (ti + tr)
                    if mode == 0:
                        ay, az = ly, lz  # both projected onto the plane normal to the fibre (x = 0)
                        by, bz = vy, vz
                        na = math.sqrt(ay * ay + az * az)
                        nb = math.sqrt(by * by + bz * bz)
                        cphi = (ay * by + az * bz) / (na * nb) if na > 1e-9 and nb > 1e-9 else 1.0
                        gs = p[P_GS]
                        f = math.sqrt(max(0.0, 0.5 * (1.0 + cphi))) * math.exp(-th * th / (2 * gs * gs))
                    else:
                        gv = p[P_GV]
                        f = math.exp(-th * th / (2 * gv * gv)) / max(
                            math.cos(ti) + math.cos(tr), 1e-6
                        )
                acc += f * ct * st
        out[iv] = acc * dt * dp


def _norm_views() -> NDArray[np.float64]:
    th = np.radians(np.r_[np.arange(0.0, 86.0, 5.0), 88.0, 89.5])
    ph = np.radians(np.arange(0.0, 91.0, 7.5))
    T, P = np.meshgrid(th, ph, indexing="ij")
    return np.stack([np.sin(T) * np.cos(P), np.sin(T) * np.sin(P), np.cos(T)], -1).reshape(-1, 3)


class FibreLobes:
    """Scattering parameters of one yarn's fibres, as a kernel parameter row.

    Parameters
    ----------
    rgb
        Volume-scattering albedo (linear Rec. 709), each in [0, 1].
    specular
        Weight ``w_s`` of the white surface reflection (1 = Fresnel as is).
    gloss_width_deg
        ``gamma_s``: angular width of the surface-reflection lobe.
    sheen_width_deg
        ``gamma_v``: angular width of the coloured forward-scattering lobe.
    isotropic
        ``k_d`` in [0, 1]: fraction of the volume scattering that is
        isotropic (Lambertian).
    ior
        Refractive index of the fibre.
    """

    def __init__(
        self,
        rgb: tuple[float, float, float],
        *,
        specular: float,
        gloss_width_deg: float,
        sheen_width_deg: float,
        isotropic: float,
        ior: float,
    ) -> None:
        p = np.zeros(N_PARAM)
        p[P_R:P_B + 1] = rgb
        p[P_WS] = specular
        p[P_GS] = np.radians(gloss_width_deg)
        p[P_GV] = np.radians(sheen_width_deg)
        p[P_KD] = isotropic
        p[P_ETA] = ior
        p[P_INS] = p[P_INV] = p[P_INK] = 1.0
        ns, nv = lobe_norms(p)
        p[P_INS] = 1.0 / ns
        p[P_INV] = 1.0 / nv
        p[P_INK] = 1.0 / max(1.0, local_albedo_max(p))
        p.setflags(write=False)
        self.row = p

    @staticmethod
    def lambertian(rgb: tuple[float, float, float]) -> NDArray[np.float64]:
        """Kernel row of a Lambertian surface (the backing)."""
        p = np.zeros(N_PARAM)
        p[P_R:P_B + 1] = rgb
        p[P_LAMB] = 1.0
        p[P_INK] = 1.0
        p[P_ETA] = 1.5
        p[P_GS] = p[P_GV] = 1.0
        return p


def lobe_norms(p: NDArray[np.float64]) -> tuple[float, float]:
    """Largest directional albedo of the bare specular and volume lobes (x margin)."""
    views = _norm_views()
    ns = float(_albedo(views, p, 0).max())
    nv = float(_albedo(views, p, 1).max())
    return ns * _NORM_MARGIN, nv * _NORM_MARGIN


def local_albedo_max(p: NDArray[np.float64]) -> float:
    """Largest directional albedo of the local BRDF with unit colour (x margin)."""
    q = np.array(p, dtype=np.float64)
    q[P_R:P_B + 1] = 1.0
    q[P_INK] = 1.0
    a = _albedo(_norm_views(), q, 2)
    return float(a.max()) * _NORM_MARGIN


def _albedo(views: NDArray[np.float64], p: NDArray[np.float64], mode: int) -> NDArray[np.float64]:
    """:func:`_albedo_kernel` for every view, in threads."""
    from .._jit import run_split

    out = np.zeros(views.shape[0])
    run_split(_albedo_kernel, views.shape[0], views, p, mode, _ALBEDO_N_THETA, _ALBEDO_N_PHI, out, grain=4)
    return out
