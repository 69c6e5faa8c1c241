"""Multiple scattering in the fabric models: what a single-scattering model leaves out.

Both fabric models compute the light scattered once (by a fibre, a yarn's
surface point, a cut end or the ground) exactly, with the shadowing and
masking of the structure. Light that scatters more than once is what makes
bright fabrics bright: a white terry towel reflects about 90 % of the
light, of which the loops' single scattering is less than half. This module
adds it, two ways, each reciprocal and energy-conserving:

- **The pile** (:func:`pile_multiple`): the pile is a layer of fibres over a
  Lambertian ground, so its multiple scattering is the radiative transfer
  of that layer. It is solved by the adding-doubling method (van de Hulst
  1980; Hansen & Travis 1974) on a discrete set of directions
  (:class:`HemisphereGrid`): every slab's reflection and transmission
  operators from a thin layer's exact single scattering, doubled to the
  slab, the slabs added from the top down, the ground added last. The
  fibres scatter as in the single-scattering model, a diffuse cylinder
  (``|l x t| |v x t|``) with the specular lobe's albedo added to it and the
  cut ends as Lambertian discs; the extinction is the model's own. What is
  kept is the difference between the whole solution and its own first
  order (computed in closed form with the same discrete medium), i.e.
  every path with two or more scattering events (fibre or ground), as a BRDF
  matrix over the grid's directions, made symmetric and interpolated.
- **The woven cloth** (:func:`compensation`): the yarn surfaces' inter-
  reflections and the light a yarn's fibres trap under their Fresnel
  surface are returned as an energy-compensation term after Kelemen &
  Szirmay-Kalos (2001) and Kulla & Conty (2017):
  ``f_ms(l, v) = F_ms (1 - E(l)) (1 - E(v)) / (pi (1 - E_avg))`` with
  ``E`` the directional albedo of the same cloth with every albedo 1 (what
  a cloth that absorbs nothing would reflect once), ``E_avg`` its cosine-
  weighted mean, and the colour ``F_ms = a^2 E_avg / (1 - a (1 - E_avg))``
  the sum over the further bounces, each of albedo ``a`` (the area-weighted
  colour of the yarn surfaces).

Reciprocity: both terms are symmetric matrices (functions) of the two
directions, interpolated by one rule for both, so ``f(l, v) = f(v, l)``
exactly. Energy: the adding-doubling solution conserves energy on its
grid; the compensation returns at most the energy the white cloth loses
(``1 - E``), scaled by ``F_ms <= 1``.

References
----------
H. C. van de Hulst, *Multiple Light Scattering*, Academic Press, 1980.
J. E. Hansen, L. D. Travis, "Light scattering in planetary atmospheres",
Space Science Reviews 16, 1974.
C. Kelemen, L. Szirmay-Kalos, "A microfacet based coupled specular-matte
BRDF model with importance sampling", Eurographics Short Presentations, 2001.
C. Kulla, A. Conty, "Revisiting physically based shading at Imageworks",
SIGGRAPH Course: Physically Based Shading in Theory and Practice, 2017.
A. Zinke, C. Yuksel, A. Weber, J. Keyser, "Dual scattering approximation
for fast multiple scattering in hair", ACM Transactions on Graphics 27(3), 2008.
T. Zeltner, B. Burley, M. J.-Y. Chiang, "Practical multiple-scattering sheen
using linearly transformed cosines", SIGGRAPH Talks, 2022.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

__all__ = ["SCATTERING", "HemisphereGrid", "hemisphere_grid", "PileMedium", "pile_multiple", "pile_reflectance",
           "Compensation", "compensation"]

#: How a model counts the light's scattering events (the parameter ``scattering`` of both models).
SCATTERING = {
    "multiple": "every order: single scattering exactly, the further orders added (reciprocal, energy-conserving)",
    "single": "single scattering only (a lower bound; the models before multiple scattering was added)",
}

#: Rings of the pile's direction grid (Gauss-Legendre in cos theta) and azimuths per ring.
PILE_RINGS = 6
PILE_AZIMUTHS = 12
#: Largest vertical optical thickness of the thin layer a slab is doubled from.
_THIN_TAU = 0.02


# -- the direction grid -------------------------------------------------------------------
@dataclass(frozen=True)
class HemisphereGrid:
    """Directions of the upper hemisphere on rings of constant ``cos theta``, and the pole.

    Attributes
    ----------
    mu
        ``(n_rings,)`` cosines of the rings' elevations, increasing.
    phi
        ``(n_phi,)`` azimuths of every ring, radians, ``(j + 1/2) 2 pi / n_phi``
        (``n_phi`` even, so that ``-w`` of every direction ``w`` is on the grid below).
    dirs
        ``(n_rings * n_phi, 3)`` unit directions, ring by ring.
    weights
        ``(n_rings * n_phi,)`` quadrature weights (sr); with the rings at the
        Gauss-Legendre nodes they integrate polynomials in ``cos theta``
        exactly (``sum w cos theta = pi``).
    """

    mu: NDArray[np.float64]
    phi: NDArray[np.float64]
    dirs: NDArray[np.float64]
    weights: NDArray[np.float64]

    @property
    def size(self) -> int:
        """Directions on the grid (the pole not included)."""
        return int(self.dirs.shape[0])

    def weights_at(self, w: NDArray[np.float64]) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
        """Interpolation of a function on the grid (and its pole, index :attr:`size`) at unit directions ``w``.

        Linear in ``cos theta`` between rings (clamped below the lowest ring,
        towards the pole value above the highest one) and linear, periodic
        in azimuth. Returns ``(index (n, 4), weight (n, 4))``; the weights sum
        to 1, and a direction at the pole gets the pole alone.
        """
        n_phi = self.phi.size
        mu = np.clip(w[:, 2], 0.0, 1.0)
        az = np.mod(np.arctan2(w[:, 1], w[:, 0]), 2.0 * math.pi)
        x = az / (2.0 * math.pi) * n_phi - 0.5
        j0 = np.floor(x).astype(np.int64)
        fp = x - j0
        j0 = np.mod(j0, n_phi)
        j1 = np.mod(j0 + 1, n_phi)
        r = np.searchsorted(self.mu, mu, side="right") - 1  # ring below (-1: under the lowest)
        top = r >= self.mu.size - 1
        lo = np.clip(r, 0, self.mu.size - 1)
        hi = np.clip(r + 1, 0, self.mu.size - 1)
        mu_hi = np.where(top, 1.0, self.mu[hi])
        span = mu_hi - self.mu[lo]
        t = np.where(r < 0, 0.0, np.clip((mu - self.mu[lo]) / np.where(span > 0, span, 1.0), 0.0, 1.0))
        idx = np.stack([lo * n_phi + j0, lo * n_phi + j1, hi * n_phi + j0, hi * n_phi + j1], axis=1)
        wt = np.stack([(1 - t) * (1 - fp), (1 - t) * fp, t * (1 - fp), t * fp], axis=1)
        # Above the highest ring the upper corners are the pole (index size), weight t in all.
        idx[top, 2] = self.size
        idx[top, 3] = self.size
        return idx, wt

    def extend(self, f: NDArray[np.float64]) -> NDArray[np.float64]:
        """A symmetric function of two directions ``(size, size, ...)`` with the pole appended on both axes.

        The pole's value is the mean over the highest ring's azimuths (the
        function is smooth there), so the result stays symmetric.
        """
        n_phi = self.phi.size
        ring = slice(self.size - n_phi, self.size)
        n = self.size
        out = np.zeros((n + 1, n + 1) + f.shape[2:])
        out[:n, :n] = f
        out[n, :n] = f[ring].mean(axis=0)
        out[:n, n] = out[n, :n]  # f is symmetric: the same mean, kept exactly symmetric
        out[n, n] = out[n, ring].mean(axis=0)
        return out


def hemisphere_grid(n_rings: int, n_phi: int) -> HemisphereGrid:
    """The grid with ``n_rings`` Gauss-Legendre rings in ``cos theta`` on (0, 1) and ``n_phi`` azimuths.

    Parameters
    ----------
    n_rings
        Rings (>= 1).
    n_phi
        Azimuths per ring (even, >= 2).

    Returns
    -------
    HemisphereGrid
        The grid.
    """
    if n_rings < 1 or n_phi < 2 or n_phi % 2:
        raise ValueError(f"hemisphere_grid: need n_rings >= 1 and an even n_phi >= 2, got {n_rings}, {n_phi}")
    x, wx = np.polynomial.legendre.leggauss(n_rings)
    mu = 0.5 * (x + 1.0)
    wmu = 0.5 * wx
    phi = (np.arange(n_phi) + 0.5) * 2.0 * math.pi / n_phi
    M, P = np.meshgrid(mu, phi, indexing="ij")
    s = np.sqrt(1.0 - M**2)
    dirs = np.stack([s * np.cos(P), s * np.sin(P), M], -1).reshape(-1, 3)
    weights = np.repeat(wmu * 2.0 * math.pi / n_phi, n_phi)
    return HemisphereGrid(mu=mu, phi=phi, dirs=np.ascontiguousarray(dirs), weights=weights)


def interpolate_pairs(grid: HemisphereGrid, table: NDArray[np.float64], v: NDArray[np.float64],
                      l: NDArray[np.float64]) -> NDArray[np.float64]:
    """A function of two directions given on the grid (``grid.extend``-ed, ``(size + 1, size + 1, c)``) at pairs.

    The same rule for both arguments, so a symmetric table gives a symmetric result.
    Returns ``(n, c)``.
    """
    iv, wv = grid.weights_at(v)
    il, wl = grid.weights_at(l)
    vals = table[iv[:, :, None], il[:, None, :]]  # (n, 4, 4, c)
    return np.einsum("na,nb,nabc->nc", wv, wl, vals)


# -- the pile: adding-doubling -------------------------------------------------------------
@dataclass(frozen=True)
class PileMedium:
    """A pile as the layer the radiative transfer is solved for (the flat cloth).

    Attributes
    ----------
    tangents
        ``(M, 3)`` strand directions (``t`` and ``-t`` are the same strand).
    weights
        ``(L, M)`` strand length per unit volume (mm / mm^3) per slab, bottom slab first.
    caps
        ``(L, M)`` area of cut ends facing ``+t`` per unit volume (mm^2 / mm^3).
    z_edges
        ``(L + 1,)`` slab boundaries, mm above the ground.
    diameter_mm
        Strand diameter.
    diffuse_rgb
        ``(3,)`` albedo a strand scatters with in the further orders: its
        diffuse colour plus the mean albedo of its (white) specular lobe,
        times the model's strand scale.
    cap_rgb
        ``(3,)`` albedo of the cut ends (Lambertian discs), times the scale.
    ground_rgb
        ``(3,)`` Lambertian albedo of the ground.
    """

    tangents: NDArray[np.float64]
    weights: NDArray[np.float64]
    caps: NDArray[np.float64]
    z_edges: NDArray[np.float64]
    diameter_mm: float
    diffuse_rgb: NDArray[np.float64]
    cap_rgb: NDArray[np.float64]
    ground_rgb: NDArray[np.float64]


@dataclass(frozen=True)
class _Ops:
    """Reflection and transmission operators of a layer, ``(c, N, N)`` each, on radiances.

    ``r_top``: down-going in at the top, up-going out at the top; ``t_down``:
    down-going in at the top, out at the bottom; ``r_bot``, ``t_up`` the same
    from below. Column ``k`` is the response to a unit radiance in direction
    ``k`` (its quadrature weight included).
    """

    r_top: NDArray[np.float64]
    t_down: NDArray[np.float64]
    r_bot: NDArray[np.float64]
    t_up: NDArray[np.float64]


def _add(a: _Ops, b: _Ops) -> _Ops:
    """Layer ``a`` on top of layer ``b`` (the adding equations; ``c`` channels at once)."""
    eye = np.eye(a.r_top.shape[-1])[None]
    # Down-going light between the layers: (I - R_a,bot R_b,top)^-1 T_a,down.
    down = np.linalg.solve(eye - a.r_bot @ b.r_top, a.t_down)
    up = np.linalg.solve(eye - b.r_top @ a.r_bot, b.t_up)
    return _Ops(r_top=a.r_top + a.t_up @ b.r_top @ down,
                t_down=b.t_down @ down,
                r_bot=b.r_bot + b.t_down @ a.r_bot @ up,
                t_up=a.t_up @ up)


def _thin(sig: NDArray[np.float64], mu: NDArray[np.float64], w: NDArray[np.float64],
          blocks: tuple[NDArray[np.float64], ...], dz: float) -> _Ops:
    """A thin homogeneous layer of thickness ``dz`` (mm) by the diamond (trapezoid) rule.

    The discrete transfer equation over the layer, its source terms taken as
    the mean of the two faces' radiances (second order in the layer's
    optical thickness; Wiscombe 1976's diamond initialisation).
    ``sig (N,)``: extinction per mm along each grid direction (the same for
    ``w`` and ``-w``); ``blocks``: the scattering per unit volume and sr,
    ``(c, N, N)``, [out, in], for (down in, up out), (down in, down out),
    (up in, down out), (up in, up out).
    """
    ud, dd, du, uu = blocks
    c = ud.shape[0]
    n = mu.size
    a = (0.5 * dz / mu)[None, :, None]
    ww = w[None, None, :]
    ext = np.diag(sig)[None]
    a_uu = a * (uu * ww - ext)
    a_dd = a * (dd * ww - ext)
    b_ud = a * ud * ww
    b_du = a * du * ww
    eye = np.broadcast_to(np.eye(n), (c, n, n))
    lhs = np.block([[eye - a_uu, -b_ud], [-b_du, eye - a_dd]])
    rhs = np.block([[eye + a_uu, b_ud], [b_du, eye + a_dd]])
    sol = np.linalg.solve(lhs, rhs)  # [x; y] = sol [p; q]: x up out at the top, y down out at the bottom
    return _Ops(r_top=sol[:, :n, n:], t_down=sol[:, n:, n:], r_bot=sol[:, n:, :n], t_up=sol[:, :n, :n])


def _double(op: _Ops, times: int) -> _Ops:
    for _ in range(times):
        op = _add(op, op)
    return op


def _slab_optics(medium: PileMedium, grid: HemisphereGrid, j: int, scale: float
                 ) -> tuple[NDArray[np.float64], tuple[NDArray[np.float64], ...]]:
    """Extinction ``(N,)`` and scattering blocks ``(3, N, N)`` of slab ``j`` with density factor ``scale``."""
    u = grid.dirs
    t = medium.tangents
    w = grid.weights
    wm = medium.weights[j] * scale * medium.diameter_mm
    cm = medium.caps[j] * scale
    keep = (wm > 0) | (cm > 0)
    t, wm, cm = t[keep], wm[keep], cm[keep]
    dot = u @ t.T  # (N, M)
    side = np.sqrt(np.clip(1.0 - dot**2, 0.0, None))  # |w x t|
    sig = side @ wm + np.abs(dot) @ cm
    # Diffuse strands: |l x t| |v x t| normalised on the grid so that each strand scatters
    # exactly its albedo times what it intercepts (sum_i w_i |w_i x t| is pi^2 for the exact integral).
    norm_s = 2.0 * (w @ side)  # (M,): the whole sphere (|-w x t| = |w x t|)
    kd = side * (wm / np.where(norm_s > 0, norm_s, 1.0))[None, :]
    strands = kd @ side.T  # symmetric, the same for every block (|-w x t| = |w x t|)
    # Cut ends: Lambertian discs across the strand, each side scattering back into its own
    # half-space (light meeting a disc from below is sent back down, as the strand under it would).
    plus, minus = np.clip(dot, 0.0, None), np.clip(-dot, 0.0, None)
    norm_c = w @ plus + w @ minus  # sum over the sphere of (w . t)+ = pi for the exact integral
    cw = (cm / np.where(norm_c > 0, norm_c, 1.0))[None, :]
    # in: down-going -u_k meets the +t side when (u_k . t) > 0; out: up u_i leaves the +t side
    # when (u_i . t) > 0, down-going -u_i when (u_i . t) < 0 (and the same for the -t side).
    same_up = (plus * cw) @ plus.T + (minus * cw) @ minus.T    # in down, out up / in up, out down
    cross = (minus * cw) @ plus.T + (plus * cw) @ minus.T      # in down, out down / in up, out up
    cap_ud = cap_du = same_up
    cap_dd = cap_uu = cross
    a_s = medium.diffuse_rgb[:, None, None]
    a_c = medium.cap_rgb[:, None, None]
    blocks = tuple(a_s * strands[None] + a_c * c[None] for c in (cap_ud, cap_dd, cap_du, cap_uu))
    return sig, blocks


def _first_order(sigs: list[NDArray[np.float64]], blocks: list[NDArray[np.float64]], dzs: NDArray[np.float64],
                 grid: HemisphereGrid, ground: NDArray[np.float64]) -> tuple[NDArray[np.float64],
                                                                             NDArray[np.float64]]:
    """Single scattering of the discrete medium, ``(3, N, N)`` on radiances: the strands', the ground's.

    ``sigs``, ``blocks``, ``dzs`` from the top slab down (blocks: down in, up out).
    """
    mu, w = grid.dirs[:, 2], grid.weights
    n = mu.size
    above = np.zeros(n)  # optical depth along the normal above the slab, per direction's extinction
    pile = np.zeros((3, n, n))
    for sig, ud, dz in zip(sigs, blocks, dzs, strict=True):
        a = sig / mu
        s = a[:, None] + a[None, :]
        path = -np.expm1(-s * dz) / np.where(s > 0, s, 1.0)
        path = np.where(s * dz > 1e-12, path, dz)
        att = np.exp(-(above[:, None] + above[None, :]))
        pile += ud * (w[None, :] / mu[:, None] * att * path)[None]
        above = above + a * dz
    gr = ground[:, None, None] / math.pi * (w * mu)[None, None, :] * np.exp(-(above[:, None] + above[None, :]))[None]
    return pile, gr


def _pile_ops(medium: PileMedium, layer_scale: NDArray[np.float64], grid: HemisphereGrid
              ) -> tuple[_Ops, list[NDArray[np.float64]], list[NDArray[np.float64]], list[float]]:
    """The pile's operators (slabs added from the top down); each slab's extinction, (down in, up out) block, height."""
    mu, w = grid.dirs[:, 2], grid.weights
    sigs, ud_blocks, dzs, ops = [], [], [], []
    for j in reversed(range(medium.weights.shape[0])):  # from the top down
        dz = float(medium.z_edges[j + 1] - medium.z_edges[j])
        sig, blocks = _slab_optics(medium, grid, j, float(layer_scale[j]))
        sigs.append(sig)
        ud_blocks.append(blocks[0])
        dzs.append(dz)
        tau = float(sig.max()) * dz
        times = max(0, math.ceil(math.log2(tau / _THIN_TAU))) if tau > _THIN_TAU else 0
        ops.append(_double(_thin(sig, mu, w, blocks, dz / 2**times), times))
    total = ops[0]
    for op in ops[1:]:
        total = _add(total, op)
    return total, sigs, ud_blocks, dzs


def pile_reflectance(medium: PileMedium, grid: HemisphereGrid, *, stacked: int = 1) -> NDArray[np.float64]:
    """Diffuse (bi-hemispherical) reflectance of ``stacked`` flat piles on each other, with no ground, ``(3,)``.

    With many piles stacked this is the Kubelka-Munk ``R_inf`` of the pile
    as a material: what an optically thick layer of its strands reflects
    under diffuse light (every order of scattering; the first order
    without the hot spot).
    """
    one, _, _, _ = _pile_ops(medium, np.ones(medium.weights.shape[0]), grid)
    total = one
    for _ in range(stacked - 1):
        total = _add(total, one)
    mu, w = grid.dirs[:, 2], grid.weights
    return np.einsum("i,cik->c", mu * w, total.r_top) / math.pi


def pile_multiple(medium: PileMedium, layer_scale: NDArray[np.float64], grid: HemisphereGrid
                  ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The pile's scattering of two or more events as BRDF matrices over ``grid`` (sr^-1).

    Parameters
    ----------
    medium
        The flat pile (:class:`PileMedium`).
    layer_scale
        ``(L,)`` density factor of each slab (the bend).
    grid
        The directions.

    Returns
    -------
    pile, ground : numpy.ndarray
        ``(size + 1, size + 1, 3)`` each (the pole appended,
        :meth:`HemisphereGrid.extend`), symmetric, >= 0, ``[view, light]``:
        the paths that never reach the ground, and those that reach it at
        least once (all but the ground's single scattering).
    """
    mu, w = grid.dirs[:, 2], grid.weights
    n = mu.size
    total, sigs, ud_blocks, dzs = _pile_ops(medium, layer_scale, grid)
    g = medium.ground_rgb[:, None, None] / math.pi * (w * mu)[None, None, :] * np.ones((1, n, 1))
    ground_op = _Ops(r_top=g, t_down=np.zeros_like(g), r_bot=np.zeros_like(g), t_up=np.zeros_like(g))
    with_ground = _add(total, ground_op).r_top
    first_pile, first_ground = _first_order(sigs, ud_blocks, np.array(dzs), grid, medium.ground_rgb)
    to_brdf = 1.0 / (w * mu)[None, None, :]
    pile = (total.r_top - first_pile) * to_brdf
    ground = (with_ground - total.r_top - first_ground) * to_brdf
    out = []
    for f in (pile, ground):
        f = np.clip(0.5 * (f + f.transpose(0, 2, 1)), 0.0, None)  # [c, view, light], reciprocal
        out.append(grid.extend(np.moveaxis(f, 0, -1)))
    return out[0], out[1]


# -- the woven cloth: energy compensation ----------------------------------------------------
@dataclass(frozen=True)
class Compensation:
    """The energy-compensation term of a woven cloth at one curvature.

    Attributes
    ----------
    grid
        The directions ``E`` is known at.
    albedo
        ``(size + 1,)`` ``E``: the directional albedo of the cloth with every
        albedo 1 (single scattering), on the grid and at the pole (last).
    albedo_mean
        ``E_avg``, the cosine-weighted mean of ``E`` over the hemisphere.
    colour
        ``(3,)`` ``F_ms``: the colour of the further bounces.
    fraction
        Share of the missing energy returned (1 but for the quadrature margin).
    """

    grid: HemisphereGrid
    albedo: NDArray[np.float64]
    albedo_mean: float
    colour: NDArray[np.float64]
    fraction: float

    def one_minus(self, w: NDArray[np.float64]) -> NDArray[np.float64]:
        """``1 - E(w)`` at unit directions ``(n, 3)`` (>= 0), ``E`` taken as its largest value at the
        grid directions around ``w`` (so that the term never returns more than the white cloth loses
        where ``E`` varies faster than the grid resolves)."""
        idx, wt = self.grid.weights_at(w)
        e = np.where(wt > 0.0, self.albedo[idx], 0.0).max(axis=1)
        return np.clip(1.0 - e, 0.0, None)

    def __call__(self, v: NDArray[np.float64], l: NDArray[np.float64]) -> NDArray[np.float64]:
        """``f_ms(v, l)`` ``(n, 3)``, sr^-1, at unit direction pairs in the cloth's flat frame."""
        if self.albedo_mean >= 1.0:
            return np.zeros((v.shape[0], 3))
        k = self.fraction / (math.pi * (1.0 - self.albedo_mean))
        return (self.one_minus(v) * self.one_minus(l) * k)[:, None] * self.colour[None, :]


def compensation(albedo: NDArray[np.float64], grid: HemisphereGrid, bounce_rgb: NDArray[np.float64], *,
                 fraction: float = 1.0) -> Compensation:
    """The compensation term from the white cloth's directional albedo on ``grid`` and its pole.

    Parameters
    ----------
    albedo
        ``(size + 1,)`` ``E`` on the grid's directions and at the pole, clipped to [0, 1].
    grid
        The directions.
    bounce_rgb
        ``(3,)`` albedo ``a`` of one further bounce, in [0, 1].
    fraction
        Share of the missing energy returned, in [0, 1].

    Returns
    -------
    Compensation
        The term.
    """
    e = np.clip(np.asarray(albedo, dtype=np.float64), 0.0, 1.0)
    # E_avg = (1 / pi) int E(w) cos theta dw, by a fine midpoint rule over E as the term takes it
    # (Compensation.one_minus), so that int (1 - E(l)) cos dl / pi = 1 - E_avg.
    nt, nphi = 96, 4 * grid.phi.size
    th = (np.arange(nt) + 0.5) * (0.5 * math.pi / nt)
    ph = (np.arange(nphi) + 0.5) * (2.0 * math.pi / nphi)
    T, P = np.meshgrid(th, ph, indexing="ij")
    d = np.stack([np.sin(T) * np.cos(P), np.sin(T) * np.sin(P), np.cos(T)], -1).reshape(-1, 3)
    cw = (np.cos(T) * np.sin(T)).reshape(-1) * (0.5 * math.pi / nt) * (2.0 * math.pi / nphi) / math.pi
    idx, wt = grid.weights_at(d)
    e_avg = float(np.sum(np.where(wt > 0.0, e[idx], 0.0).max(axis=1) * cw) / np.sum(cw))
    a = np.clip(np.asarray(bounce_rgb, dtype=np.float64), 0.0, 1.0)
    colour = a * a * e_avg / np.maximum(1.0 - a * (1.0 - e_avg), 1e-12)
    return Compensation(grid=grid, albedo=e, albedo_mean=e_avg, colour=colour, fraction=float(fraction))
