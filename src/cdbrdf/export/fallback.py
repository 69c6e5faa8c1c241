"""The standard glTF material fitted to a table's flat BRDF: what a viewer without the extension shows.

:func:`fit_fallback` fits glTF 2.0's metallic-roughness material (metallic
0: a dielectric of index 1.5) with ``KHR_materials_sheen`` and, where it
helps, ``KHR_materials_anisotropy`` to the table's kappa = 0 slice, the BRDF
of the flat fabric. :func:`gltf_brdf` is that material's BRDF as the glTF
specification states it (Appendix B and the two extensions):

- specular: GGX, ``alpha = roughness^2``, the height-correlated Smith
  visibility; anisotropic ``alpha_t = mix(alpha, 1, strength^2)`` along the
  anisotropy direction (the tangent turned by ``rotation``), ``alpha_b =
  alpha``; Fresnel-Schlick with ``F0 = 0.04``, mixed with the Lambertian
  base ``base_color / pi``;
- sheen: the Charlie distribution ``(2 + 1/a) sin(theta_h)^(1/a) / (2 pi)``,
  ``a = sheen_roughness^2``, with the sheen visibility of the extension's
  specification, times ``sheen_color``; the layer below is scaled by
  ``min(1 - max(sheen_color) E(n.v), 1 - max(sheen_color) E(n.l))``, ``E``
  the sheen's directional albedo (integrated here numerically).

The fit minimises the difference of ``f cos(theta_l)`` (the light each
sample reflects) over every stored direction, relative to the table's mean;
its error (:class:`FallbackFit`) is recorded in the exported asset. The
parameters are bounded to their valid ranges; a few starting points are
tried. A curvature-dependent material has no counterpart here: the fallback
is the flat fabric everywhere.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["FallbackFit", "gltf_brdf", "fit_fallback", "sheen_albedo"]

_F0 = 0.04
_MIN_ROUGHNESS = 0.03

#: Anisotropy is kept when it lowers the relative RMS error by at least this share.
ANISOTROPY_GAIN = 0.05


@dataclass(frozen=True)
class FallbackFit:
    """The fitted standard material and how well it matches the flat BRDF.

    Attributes
    ----------
    base_color
        Linear RGB ``baseColorFactor`` (metallic 0).
    roughness
        ``roughnessFactor``.
    sheen_color, sheen_roughness
        ``KHR_materials_sheen``'s ``sheenColorFactor`` and ``sheenRoughnessFactor``.
    anisotropy_strength, anisotropy_rotation
        ``KHR_materials_anisotropy``'s factors (strength 0: not used), rotation in radians.
    relative_rms_error
        ``sqrt(sum((f_fit - f) cos_l)^2 / sum(f cos_l)^2)`` over every
        stored direction of the kappa = 0 slice and every channel.
    median_relative_error
        The median of ``|f_fit - f| / f`` over the same samples.
    samples
        How many directions were fitted.
    """

    base_color: tuple[float, float, float]
    roughness: float
    sheen_color: tuple[float, float, float]
    sheen_roughness: float
    anisotropy_strength: float
    anisotropy_rotation: float
    relative_rms_error: float
    median_relative_error: float
    samples: int

    def as_json(self) -> dict[str, Any]:
        """The fit as JSON (rounded to 6 significant digits).

        Returns
        -------
        dict
            Its fields, camelCase, numbers rounded.
        """
        def r(x: Any) -> Any:
            return [r(y) for y in x] if isinstance(x, (tuple, list)) else float(f"{float(x):.6g}")

        names = {"base_color": "baseColorFactor", "roughness": "roughnessFactor", "sheen_color": "sheenColorFactor",
                 "sheen_roughness": "sheenRoughnessFactor", "anisotropy_strength": "anisotropyStrength",
                 "anisotropy_rotation": "anisotropyRotation", "relative_rms_error": "relativeRmsError",
                 "median_relative_error": "medianRelativeError"}
        out: dict[str, Any] = {names[k]: r(v) for k, v in asdict(self).items() if k in names}
        out["samples"] = self.samples
        return out


def _lambda_sheen(c: NDArray[np.float64], a: float) -> NDArray[np.float64]:
    """The sheen visibility's lambda (KHR_materials_sheen), ``c = |cos theta|``, ``a`` the sheen alpha."""
    t = (1.0 - a) ** 2

    def fit(x: NDArray[np.float64]) -> NDArray[np.float64]:
        p = [21.5473 + (25.3245 - 21.5473) * t, 3.82987 + (3.32435 - 3.82987) * t,
             0.19823 + (0.16801 - 0.19823) * t, -1.97760 + (-1.27393 + 1.97760) * t,
             -4.32054 + (-4.85967 + 4.32054) * t]
        return p[0] / (1.0 + p[1] * np.power(x, p[2])) + p[3] * x + p[4]

    c = np.clip(c, 1e-6, 1.0)
    return np.where(c < 0.5, np.exp(fit(c)), np.exp(2.0 * fit(np.full_like(c, 0.5)) - fit(1.0 - c)))


def _sheen(nl: NDArray[np.float64], nv: NDArray[np.float64], nh: NDArray[np.float64],
           roughness: float) -> NDArray[np.float64]:
    """The sheen BRDF for a white sheen colour."""
    a = max(roughness, _MIN_ROUGHNESS) ** 2
    sin2 = np.clip(1.0 - nh * nh, 0.0, 1.0)
    d = (2.0 + 1.0 / a) * np.power(sin2, 0.5 / a) / (2.0 * math.pi)
    vis = 1.0 / ((1.0 + _lambda_sheen(nv, a) + _lambda_sheen(nl, a)) * (4.0 * nv * nl))
    return d * vis


def sheen_albedo(roughness: ArrayLike, cos_theta: ArrayLike, *, n: int = 24) -> NDArray[np.float64]:
    """The directional albedo ``E`` of the white sheen BRDF (midpoint quadrature over the light's hemisphere).

    Parameters
    ----------
    roughness
        ``sheenRoughnessFactor`` values, shape ``(r,)`` (or a scalar).
    cos_theta
        Cosines of the view elevation, shape ``(m,)``.
    n
        Quadrature points per axis (elevation; twice as many in azimuth).

    Returns
    -------
    numpy.ndarray
        ``E``, shape ``(r, m)`` (``(m,)`` for a scalar roughness).
    """
    rough = np.atleast_1d(np.asarray(roughness, dtype=np.float64))
    mu = np.clip(np.asarray(cos_theta, dtype=np.float64).reshape(-1), 1e-4, 1.0)
    th = (np.arange(n) + 0.5) * (0.5 * math.pi / n)
    ph = (np.arange(2 * n) + 0.5) * (2.0 * math.pi / (2 * n))
    T, P = np.meshgrid(th, ph, indexing="ij")
    lz = np.cos(T).ravel()
    lx, ly = (np.sin(T) * np.cos(P)).ravel(), (np.sin(T) * np.sin(P)).ravel()
    dw = (np.sin(T) * (0.5 * math.pi / n) * (2.0 * math.pi / (2 * n))).ravel()
    vx = np.sqrt(1.0 - mu * mu)[:, None]
    hx, hy, hz = lx[None, :] + vx, np.broadcast_to(ly, (mu.size, ly.size)), lz[None, :] + mu[:, None]
    nh = hz / np.sqrt(hx * hx + hy * hy + hz * hz)
    nl = np.broadcast_to(lz, nh.shape)
    nv = np.broadcast_to(mu[:, None], nh.shape)
    out = np.stack([np.sum(_sheen(nl, nv, nh, float(r)) * (lz * dw)[None, :], axis=1) for r in rough])
    return out if np.ndim(roughness) else out[0]


class _Albedo:
    """The sheen albedo tabulated over roughness and cosine once, interpolated bilinearly."""

    def __init__(self) -> None:
        self.rough = np.linspace(_MIN_ROUGHNESS, 1.0, 40)
        self.mu = np.linspace(0.0, 1.0, 33)
        self.table = sheen_albedo(self.rough, self.mu)

    def at(self, roughness: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """``(cosines, E)`` at one roughness."""
        j = float(np.interp(roughness, self.rough, np.arange(self.rough.size)))
        i = min(int(j), self.rough.size - 2)
        t = j - i
        return self.mu, (1.0 - t) * self.table[i] + t * self.table[i + 1]


def gltf_brdf(params: dict[str, Any], l_dir: NDArray[np.float64], v_dir: NDArray[np.float64],
              *, albedo: tuple[NDArray[np.float64], NDArray[np.float64]] | None = None) -> NDArray[np.float64]:
    """glTF's BRDF (without the cosine) of a dielectric with sheen and anisotropy (see the module's description).

    Parameters
    ----------
    params
        ``base_color``, ``roughness``, ``sheen_color``, ``sheen_roughness``,
        ``anisotropy_strength``, ``anisotropy_rotation`` (as :class:`FallbackFit`).
    l_dir, v_dir
        ``(n, 3)`` unit directions to the light and the viewer in the local
        frame (z the normal, x the tangent), both above the surface.
    albedo
        ``(cosines, E)`` of the sheen's directional albedo at this sheen
        roughness (:func:`sheen_albedo`), to interpolate; computed when None.

    Returns
    -------
    numpy.ndarray
        ``(n, 3)`` BRDF values, 1/sr.
    """
    base = np.asarray(params["base_color"], dtype=np.float64)
    sheen_c = np.asarray(params["sheen_color"], dtype=np.float64)
    alpha = max(float(params["roughness"]), _MIN_ROUGHNESS) ** 2
    s = float(params.get("anisotropy_strength", 0.0))
    rot = float(params.get("anisotropy_rotation", 0.0))
    at, ab = alpha + (1.0 - alpha) * s * s, alpha
    h = l_dir + v_dir
    h /= np.linalg.norm(h, axis=1, keepdims=True)
    nl, nv, nh = l_dir[:, 2], v_dir[:, 2], h[:, 2]
    c, si = math.cos(rot), math.sin(rot)
    t_dir, b_dir = np.array([c, si, 0.0]), np.array([-si, c, 0.0])
    th, bh = h @ t_dir, h @ b_dir
    d = 1.0 / (math.pi * at * ab * ((th / at) ** 2 + (bh / ab) ** 2 + nh * nh) ** 2)
    tv, bv, tl, bl = v_dir @ t_dir, v_dir @ b_dir, l_dir @ t_dir, l_dir @ b_dir
    vis = 0.5 / (nl * np.sqrt((at * tv) ** 2 + (ab * bv) ** 2 + nv * nv)
                 + nv * np.sqrt((at * tl) ** 2 + (ab * bl) ** 2 + nl * nl))
    vh = np.abs(np.einsum("ij,ij->i", v_dir, h))
    fres = _F0 + (1.0 - _F0) * (1.0 - vh) ** 5
    layer = (1.0 - fres)[:, None] * base[None, :] / math.pi + (fres * d * vis)[:, None]
    sr = float(params["sheen_roughness"])
    mx = float(sheen_c.max())
    if mx <= 0.0:
        return layer
    if albedo is None:
        mu = np.linspace(0.0, 1.0, 33)
        albedo = (mu, sheen_albedo(sr, mu))
    e_v = np.interp(nv, *albedo)
    e_l = np.interp(nl, *albedo)
    scaling = np.minimum(1.0 - mx * e_v, 1.0 - mx * e_l)
    return sheen_c[None, :] * _sheen(nl, nv, nh, sr)[:, None] + layer * scaling[:, None]


def _directions(table: Any) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """The flat slice's stored directions (local frame) and values ``(n, channels)``."""
    from ..frames import direction_from_angles

    g = table.grid
    k0 = int(np.argmin(np.abs(g.kappa)))
    m = g.mesh()
    sl = (k0,)
    tl, pl, tv, pv = (np.asarray(m[a][sl], dtype=np.float64).ravel() for a in ("theta_l", "phi_l", "theta_v", "phi_v"))
    f = np.asarray(table.values[k0], dtype=np.float64).reshape(-1, table.n_channels)
    if table.isotropic:  # phi_v holds the azimuth difference, phi_l = 0
        pl = np.zeros_like(pl)
    ok = (tl < 89.0) & (tv < 89.0)
    return direction_from_angles(tl[ok], pl[ok]), direction_from_angles(tv[ok], pv[ok]), f[ok]


def _terms(theta: NDArray[np.float64], l_dir: NDArray[np.float64], v_dir: NDArray[np.float64],
           albedo: _Albedo) -> tuple[NDArray[np.float64], ...]:
    """Per sample, the material's terms at the nonlinear parameters ``(roughness, sheen roughness[, strength,
    rotation])``: diffuse factor, specular, white sheen, sheen albedo at n.v and n.l."""
    rough, sr = float(theta[0]), float(theta[1])
    p = {"base_color": np.zeros(3), "roughness": rough, "sheen_color": np.zeros(3), "sheen_roughness": sr,
         "anisotropy_strength": float(theta[2]) if theta.size > 2 else 0.0,
         "anisotropy_rotation": float(theta[3]) if theta.size > 2 else 0.0}
    spec = gltf_brdf(p, l_dir, v_dir)[:, 0]  # base 0, no sheen: the specular lobe alone
    h = l_dir + v_dir
    h /= np.linalg.norm(h, axis=1, keepdims=True)
    vh = np.abs(np.einsum("ij,ij->i", v_dir, h))
    dfac = (1.0 - (_F0 + (1.0 - _F0) * (1.0 - vh) ** 5)) / math.pi
    sheen = _sheen(l_dir[:, 2], v_dir[:, 2], h[:, 2], sr)
    mu, e = albedo.at(sr)
    return dfac, spec, sheen, np.interp(v_dir[:, 2], mu, e), np.interp(l_dir[:, 2], mu, e)


def _box_lsq(a: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.float64]:
    """``argmin |a x - b|`` over ``x`` in [0, 1]^2, for a ``(n, 2)`` matrix and a ``(n, c)`` right-hand side.

    The unconstrained solution where it lies in the box, else the best of the solutions on the box's edges
    (one unknown at 0 or 1, the other solved and clipped).
    """
    g = a.T @ a
    r = a.T @ b  # (2, c)
    cands = []
    det = g[0, 0] * g[1, 1] - g[0, 1] ** 2
    if det > 1e-300:
        cands.append(np.linalg.solve(g, r))
    for i in (0, 1):
        j = 1 - i
        for fixed in (0.0, 1.0):
            x = np.empty_like(r)
            x[i] = fixed
            x[j] = np.clip((r[j] - g[j, i] * fixed) / g[j, j], 0.0, 1.0) if g[j, j] > 0 else 0.0
            cands.append(x)
    best = np.zeros_like(r)
    best_cost = np.full(r.shape[1], np.inf)
    for cand in cands:
        ok = np.all((cand >= -1e-12) & (cand <= 1 + 1e-12), axis=0)
        x = np.clip(cand, 0.0, 1.0)
        cost = np.einsum("ic,ij,jc->c", x, g, x) - 2.0 * np.einsum("ic,ic->c", x, r)
        better = ok & (cost < best_cost)
        best[:, better] = x[:, better]
        best_cost = np.where(better, cost, best_cost)
    return best


def _colours(terms: tuple[NDArray[np.float64], ...], f: NDArray[np.float64],
             w: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64], float]:
    """Base and sheen colours (each in [0, 1]) minimising the weighted error at fixed terms, and that error.

    Linear in both colours once the sheen's albedo scaling is fixed: solved per channel (2 unknowns, bounded)
    and the scaling updated from the sheen colour found, a few times.
    """
    dfac, spec, sheen, e_v, e_l = terms
    sc = np.zeros(3)
    for _ in range(3):
        scale = np.minimum(1.0 - sc.max() * e_v, 1.0 - sc.max() * e_l)
        a = np.stack([dfac * scale * w, sheen * w], axis=1)
        x = _box_lsq(a, (f - (spec * scale)[:, None]) * w[:, None])
        base, sc = x[0], x[1]
    scale = np.minimum(1.0 - sc.max() * e_v, 1.0 - sc.max() * e_l)
    model = sc[None, :] * sheen[:, None] + (dfac[:, None] * base[None, :] + spec[:, None]) * scale[:, None]
    return base, sc, float(np.sum(((model - f) * w[:, None]) ** 2))


def _fit_once(l_dir: NDArray[np.float64], v_dir: NDArray[np.float64], f: NDArray[np.float64],
              starts: list[NDArray[np.float64]]) -> tuple[dict[str, Any], float]:
    """The best fit from ``starts`` of the nonlinear parameters (Nelder-Mead, clipped to their ranges)."""
    from scipy.optimize import minimize

    w = l_dir[:, 2]
    albedo = _Albedo()
    total = float(np.sum((f * w[:, None]) ** 2))
    lo = np.array([_MIN_ROUGHNESS, _MIN_ROUGHNESS, 0.0, -math.pi])
    hi = np.array([1.0, 1.0, 1.0, math.pi])

    def clip(x: NDArray[np.float64]) -> NDArray[np.float64]:
        return np.clip(x, lo[: x.size], hi[: x.size])

    def cost(x: NDArray[np.float64]) -> float:
        return _colours(_terms(clip(x), l_dir, v_dir, albedo), f, w)[2] / total

    best_x, best = starts[0], math.inf
    for x0 in starts:
        r = minimize(cost, x0, method="Nelder-Mead", options={"xatol": 2e-3, "fatol": 1e-6, "maxfev": 120})
        if r.fun < best:
            best_x, best = clip(r.x), float(r.fun)
    base, sc, _ = _colours(_terms(best_x, l_dir, v_dir, albedo), f, w)
    aniso = best_x.size > 2
    params = {"base_color": base, "roughness": float(best_x[0]), "sheen_color": sc, "sheen_roughness": float(best_x[1]),
              "anisotropy_strength": float(best_x[2]) if aniso else 0.0,
              "anisotropy_rotation": float(best_x[3]) if aniso else 0.0}
    return params, math.sqrt(best)


def fit_fallback(table: Any) -> FallbackFit:
    """Fit the standard glTF material to a table's kappa = 0 slice (see the module's description).

    Parameters
    ----------
    table
        A :class:`~cdbrdf.CDBRDF` (1 or 3 channels; a grey table fits grey colours).

    Returns
    -------
    FallbackFit
        The material and its errors.
    """
    l_dir, v_dir, f = _directions(table)
    if f.shape[1] == 1:
        f = np.repeat(f, 3, axis=1)
    f = f[:, :3]
    p, err = _fit_once(l_dir, v_dir, f, [np.array([r, sr]) for r in (0.4, 0.9) for sr in (0.3, 0.8)])
    if not table.isotropic:
        x0 = [p["roughness"], p["sheen_roughness"]]
        pa, err_an = _fit_once(l_dir, v_dir, f, [np.array([*x0, 0.5, rot]) for rot in (0.0, 0.5 * math.pi)])
        if err_an < (1.0 - ANISOTROPY_GAIN) * err:
            p, err = pa, err_an
    fit = gltf_brdf(p, l_dir, v_dir)
    pos = f > 0
    med = float(np.median(np.abs(fit - f)[pos] / f[pos])) if pos.any() else 0.0
    return FallbackFit(
        base_color=tuple(float(c) for c in p["base_color"]),  # type: ignore[arg-type]
        roughness=float(p["roughness"]),
        sheen_color=tuple(float(c) for c in p["sheen_color"]),  # type: ignore[arg-type]
        sheen_roughness=float(p["sheen_roughness"]),
        anisotropy_strength=float(p["anisotropy_strength"]),
        anisotropy_rotation=float(p["anisotropy_rotation"]),
        relative_rms_error=err,
        median_relative_error=med,
        samples=int(f.shape[0]),
    )
