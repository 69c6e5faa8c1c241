"""Curvature maps: a surface's fine bends per texel, prefiltered, and the rule that looks them up.

The bends that change how cloth looks (wrinkles of a few millimetres) are
finer than production meshes; they live in textures. A
:class:`CurvatureMap` holds, per texel, a detail height field ``h`` over the
surface in the form the renderer needs (:data:`CHANNELS`):

- its slopes ``p = -dh/dx``, ``q = -dh/dy`` (dimensionless; ``x`` along
  dP/du, ``y = n x x``, arc length): the tangent-space normal
  ``(p, q, 1) / |(p, q, 1)|`` that perturbs the shading normal;
- their derivatives per UV unit of the mesh, ``dp/du, dp/dv, dq/du, dq/dv``,
  from which the shape operator the detail adds follows at a UV scale of
  ``su, sv`` mm per UV unit (:func:`shape_operator`)::

      K = [[ (dp/du) / su,                      (dp/dv / sv + dq/du / su) / 2 ],
           [ (dp/dv / sv + dq/du / su) / 2,     (dq/dv) / sv                  ]]   (1/mm)

  positive where the detail is convex (``docs/conventions.md``), as
  ``-Hess(h)``.

The texels are laid by the mesh's UVs through the map's own texture
transform: texture coordinate ``t = (ru u + ou, rv v + ov)``, repeating
(``ru, rv``: repeats per UV unit, an MTL ``-s`` or glTF
``KHR_texture_transform``; negative mirrors), row 0 at the top (``t_v = 1``).
The derivatives are stored per UV unit of the *mesh* (the repeat folded
in), so one UV scale converts every map and the CD-BTF alike.

**Prefiltering** (:func:`pyramid`): level 0 is the map, level ``l + 1`` the
2 x 2 means of level ``l`` (an odd size first resampled by area to the
next even one). Every channel is linear in the height, so a level holds the
slopes and the shape operator of the height field box-filtered over its
texels: the exact prefiltered curvature, not a filtered eigenvalue.

**Lookup rule** (:func:`lookup`, the renderer's Dr.Jit copy in
:mod:`cdbrdf.render._maps_jit`): the level ``L = log2(w)`` of the footprint
``w`` in level-0 texels along the map's longer axis, clamped to
``[min_level, n_levels - 1]``; bilinear between the four nearest texel
centres of levels ``floor(L)`` and ``floor(L) + 1``, linear between them
(trilinear, as a GPU filters a mip-mapped texture; the renderer by default
reads one of the two levels, chosen with those weights: :data:`MAP_FILTERS`). The footprint
(:func:`footprint_uv`) is the pixel's on the surface, ``distance x
pixel_angle / max(|cos theta_v|, 1/8)``, in UV units through ``|dP/du|`` and
``|dP/dv|``; ``min_level`` (:func:`neighbourhood_level`) keeps the map no
finer than the curvature's neighbourhood, the scale at which the mesh's own
curvature is fitted and the table was measured (the weave inside it is in
the table already).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import MeshError

__all__ = [
    "CHANNELS",
    "NEIGHBOURHOOD_WIDTH_SHARE",
    "MIN_COS_VIEW",
    "MAP_FILTERS",
    "CurvatureMap",
    "pyramid",
    "shape_operator",
    "principal",
    "mesh_shape_operator",
    "footprint_uv",
    "footprint_level",
    "neighbourhood_level",
    "lookup",
    "averaged_share",
]

#: The channels of a curvature map's texel, in order.
CHANNELS: tuple[str, ...] = ("p", "q", "dp_du", "dp_dv", "dq_du", "dq_dv")

#: The footprint (mm) below which a map is not resolved, as a share of the curvature's neighbourhood
#: (its diameter): a mip level of footprint w filters like a Gaussian of sigma ~ w / 2 (box and
#: bilinear), the mesh's fit like one of sigma = 0.125 x the diameter (measured on sine folds).
NEIGHBOURHOOD_WIDTH_SHARE = 0.25

#: Smallest |cos| of the view angle used to stretch the footprint (at most 8 times the pixel's).
MIN_COS_VIEW = 0.125

#: Filters of the renderer's lookup, between the two levels around the footprint's: ``stochastic`` (the
#: default: one of them, the finer with probability 1 - the fraction, so the expected value is the trilinear
#: one; four texel reads), ``trilinear`` (both blended; eight) or ``none`` (the finest level kept, the
#: neighbourhood's, whatever the footprint: aliases where the map's features are below a pixel; for comparisons).
MAP_FILTERS: tuple[str, ...] = ("stochastic", "trilinear", "none")


@dataclass(frozen=True)
class CurvatureMap:
    """A baked curvature map and its prefiltered levels (see the module's description).

    Attributes
    ----------
    levels
        ``(H_l, W_l, 6)`` float32 arrays of :data:`CHANNELS`, level 0 first,
        the last 1 x 1.
    name
        What to call it in messages (its file).
    source
        What it was baked from: ``"normal map"``, ``"height map"`` or
        ``"high-resolution mesh"``.
    transform
        ``(ru, rv, ou, ov)``: texture coordinate ``t = (ru u + ou, rv v + ov)``.
    uv_scale
        The UV scale (mm per UV unit along u, v) its values depend on (a
        height map's slopes, a mesh bake's curvature), or None when they do
        not (a normal map's).
    prefiltered_mm
        The footprint (mm) it is already filtered at (a mesh bake: the
        neighbourhood of its fit); 0 for an image.
    """

    levels: tuple[NDArray[np.float32], ...]
    name: str = "curvature map"
    source: str = "normal map"
    transform: tuple[float, float, float, float] = (1.0, 1.0, 0.0, 0.0)
    uv_scale: tuple[float, float] | None = None
    prefiltered_mm: float = 0.0
    _stats: dict[str, float] = field(default_factory=dict, compare=False, repr=False)

    def __post_init__(self) -> None:
        if not self.levels or any(lv.ndim != 3 or lv.shape[2] != len(CHANNELS) for lv in self.levels):
            raise MeshError(f"{self.name}: a curvature map needs levels of shape (H, W, {len(CHANNELS)})")
        ru, rv = self.transform[:2]
        if not all(math.isfinite(x) for x in self.transform) or ru == 0 or rv == 0:
            raise MeshError(f"{self.name}: texture transform {self.transform} must be finite, with non-zero repeats")

    @property
    def texels(self) -> tuple[int, int]:
        """``(width, height)`` of level 0."""
        h, w = self.levels[0].shape[:2]
        return int(w), int(h)

    @property
    def n_levels(self) -> int:
        """Number of levels."""
        return len(self.levels)

    @property
    def nbytes(self) -> int:
        """Bytes of every level."""
        return int(sum(lv.nbytes for lv in self.levels))

    def coarser(self, k: int) -> CurvatureMap:
        """The same map without its ``k`` finest levels (levels a lookup never reads; what the map then is).

        Parameters
        ----------
        k
            Levels dropped, at most all but the last.

        Returns
        -------
        CurvatureMap
            Level ``k`` is its level 0: the map box-filtered to ``2**k`` texels.
        """
        k = min(max(int(k), 0), self.n_levels - 1)
        return replace(self, levels=self.levels[k:], _stats={}) if k else self

    def tile_mm(self, uv_scale: tuple[float, float]) -> tuple[float, float]:
        """The size (mm) one repeat of the map covers at ``uv_scale`` mm per UV unit.

        Parameters
        ----------
        uv_scale
            Mm per UV unit along u and v.

        Returns
        -------
        tuple of float
            Along u and v.
        """
        return abs(uv_scale[0] / self.transform[0]), abs(uv_scale[1] / self.transform[1])

    def texel_mm(self, uv_scale: tuple[float, float]) -> float:
        """The larger side (mm) of a level-0 texel at ``uv_scale``.

        Parameters
        ----------
        uv_scale
            Mm per UV unit along u and v.

        Returns
        -------
        float
            Mm.
        """
        (tu, tv), (w, h) = self.tile_mm(uv_scale), self.texels
        return max(tu / w, tv / h)

    def stats(self) -> dict[str, float]:
        """The map's rms slope and rms curvature per level (per UV unit), cached: what the checks use.

        Returns
        -------
        dict
            ``slope{i}``, ``du{i}``, ``dv{i}``, ``dx{i}`` of level ``i``: rms of
            ``(p, q)``, ``dp/du``, ``dq/dv`` and the symmetrised cross term.
        """
        if not self._stats:
            for i, lv in enumerate(self.levels):
                g = lv.astype(np.float64)
                self._stats[f"slope{i}"] = float(np.sqrt(np.mean(g[..., 0] ** 2 + g[..., 1] ** 2)))
                self._stats[f"du{i}"] = float(np.sqrt(np.mean(g[..., 2] ** 2)))
                self._stats[f"dv{i}"] = float(np.sqrt(np.mean(g[..., 5] ** 2)))
                self._stats[f"dx{i}"] = float(np.sqrt(np.mean(0.25 * (g[..., 3] + g[..., 4]) ** 2)))
        return self._stats


# -- the pyramid ---------------------------------------------------------------------------------
def _halve(a: NDArray[np.float32], axis: int) -> NDArray[np.float32]:
    """Means of pairs along ``axis``: an odd length first resampled to the next even one by area (mean kept)."""
    n = a.shape[axis]
    if n == 1:
        return a
    if n % 2:  # cell j of n + 1 covers [j, j + 1) * n / (n + 1) of the old cells: the integral's differences
        c = np.cumsum(a, axis=axis, dtype=np.float64)
        c = np.concatenate([np.zeros_like(np.take(c, [0], axis=axis)), c], axis=axis)
        edges = np.arange(n + 2) * n / (n + 1)
        i = np.minimum(np.floor(edges).astype(np.int64), n - 1)
        f = edges - i
        shape = [1] * a.ndim
        shape[axis] = n + 2
        f = f.reshape(shape)
        integral = np.take(c, i, axis=axis) * (1 - f) + np.take(c, i + 1, axis=axis) * f
        a = (np.diff(integral, axis=axis) * ((n + 1) / n)).astype(np.float32)
        n += 1
    return 0.5 * (np.take(a, np.arange(0, n, 2), axis=axis) + np.take(a, np.arange(1, n, 2), axis=axis))


def pyramid(base: ArrayLike) -> tuple[NDArray[np.float32], ...]:
    """The prefiltered levels of a map: ``base`` ``(H, W, C)`` and its 2 x 2 means down to 1 x 1.

    Parameters
    ----------
    base
        Level 0.

    Returns
    -------
    tuple of numpy.ndarray
        float32 levels, ``(H, W, C)`` first.
    """
    a = np.ascontiguousarray(base, dtype=np.float32)  # float32 throughout: a 8k map's levels are 2 GB
    out = [a]
    while a.shape[0] > 1 or a.shape[1] > 1:
        a = _halve(_halve(a, 0), 1)
        out.append(a)
    return tuple(out)


# -- shape operators -----------------------------------------------------------------------------
def shape_operator(values: ArrayLike, uv_scale: tuple[float, float],
                   ) -> tuple[NDArray[np.float64], ...]:
    """``(p, q, kxx, kxy, kyy)`` of texel values ``(..., 6)`` at ``uv_scale`` mm per UV unit (1/mm)."""
    g = np.asarray(values, dtype=np.float64)
    su, sv = float(uv_scale[0]), float(uv_scale[1])
    return (g[..., 0], g[..., 1], g[..., 2] / su, 0.5 * (g[..., 3] / sv + g[..., 4] / su), g[..., 5] / sv)


def principal(sxx: ArrayLike, sxy: ArrayLike, syy: ArrayLike) -> NDArray[np.float64]:
    """The principal curvature of larger magnitude, signed, of shape operators ``[[sxx, sxy], [sxy, syy]]``."""
    a, b, c = (np.asarray(x, dtype=np.float64) for x in (sxx, sxy, syy))
    mean = 0.5 * (a + c)
    half = np.sqrt(0.25 * (a - c) ** 2 + b * b)
    return np.where(mean >= 0.0, mean + half, mean - half)


def mesh_shape_operator(k1: NDArray[np.float64], k2: NDArray[np.float64], d1: NDArray[np.float64],
                        d2: NDArray[np.float64], tangent: NDArray[np.float64], normals: NDArray[np.float64],
                        ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """A mesh's shape operator per vertex in the frame ``x`` = the tangent (dP/du), ``y = n x x``.

    ``S = k1 d1 d1^T + k2 d2 d2^T`` in that frame (1/mm where the curvatures
    are); where the tangent is undefined (NaN, or along the normal) ``x = d1``.

    Returns
    -------
    sxx, sxy, syy
        ``(n,)`` each.
    """
    t = np.nan_to_num(np.asarray(tangent, dtype=np.float64))
    t = t - np.einsum("ij,ij->i", t, normals)[:, None] * normals
    tl = np.linalg.norm(t, axis=1, keepdims=True)
    ok = tl[:, 0] > 1e-9
    t = np.where(ok[:, None], t / np.maximum(tl, 1e-300), d1)
    b = np.cross(normals, t)
    c1t, c1b = np.einsum("ij,ij->i", d1, t), np.einsum("ij,ij->i", d1, b)
    c2t, c2b = np.einsum("ij,ij->i", d2, t), np.einsum("ij,ij->i", d2, b)
    return (k1 * c1t * c1t + k2 * c2t * c2t, k1 * c1t * c1b + k2 * c2t * c2b, k1 * c1b * c1b + k2 * c2b * c2b)


# -- the lookup rule -----------------------------------------------------------------------------
def footprint_uv(distance: ArrayLike, pixel_angle: float, cos_view: ArrayLike, dpdu_len: ArrayLike,
                 dpdv_len: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The pixel's footprint in UV units along u and v (see the module's description).

    Parameters
    ----------
    distance
        From the camera to the point (scene units).
    pixel_angle
        The camera's angle per pixel (radians; 0: no footprint).
    cos_view
        Cosine of the view direction to the normal.
    dpdu_len, dpdv_len
        ``|dP/du|``, ``|dP/dv|`` (scene units per UV unit).
    """
    c = np.maximum(np.abs(np.asarray(cos_view, dtype=np.float64)), MIN_COS_VIEW)
    w = np.asarray(distance, dtype=np.float64) * float(pixel_angle) / c
    return w / np.maximum(np.asarray(dpdu_len, dtype=np.float64), 1e-30), \
        w / np.maximum(np.asarray(dpdv_len, dtype=np.float64), 1e-30)


def neighbourhood_level(cmap: CurvatureMap, uv_scale: tuple[float, float], neighbourhood_mm: float) -> float:
    """The finest level used: the footprint :data:`NEIGHBOURHOOD_WIDTH_SHARE` x the neighbourhood.

    A map already filtered at ``prefiltered_mm`` needs only what is missing
    (widths add in quadrature, as the Gaussians they stand for).
    """
    want = NEIGHBOURHOOD_WIDTH_SHARE * float(neighbourhood_mm)
    extra = math.sqrt(max(want * want - cmap.prefiltered_mm ** 2, 0.0))
    texel = cmap.texel_mm(uv_scale)
    if not extra > texel:
        return 0.0
    return min(math.log2(extra / texel), float(cmap.n_levels - 1))


def footprint_level(cmap: CurvatureMap, fu: ArrayLike, fv: ArrayLike, min_level: float) -> NDArray[np.float64]:
    """The (fractional) level of footprints ``fu, fv`` in UV units: ``log2`` of the larger in level-0 texels."""
    w, h = cmap.texels
    ru, rv = abs(cmap.transform[0]), abs(cmap.transform[1])
    texels = np.maximum(np.asarray(fu, dtype=np.float64) * (w * ru), np.asarray(fv, dtype=np.float64) * (h * rv))
    lv = np.log2(np.maximum(texels, 1e-30))
    return np.clip(np.maximum(lv, min_level), 0.0, float(cmap.n_levels - 1))


def _bilinear(level: NDArray[np.float32], tu: NDArray[np.float64], tv: NDArray[np.float64]) -> NDArray[np.float64]:
    """Texel values at texture coordinates (periodic; row 0 at the top, t_v = 1)."""
    h, w = level.shape[:2]
    with np.errstate(invalid="ignore"):  # a coordinate that is not finite reads at 0 (the renderer's rule)
        fu, fv = tu - np.floor(tu), (1.0 - tv) - np.floor(1.0 - tv)
    x = np.where(np.isfinite(fu), fu, 0.0) * w - 0.5
    y = np.where(np.isfinite(fv), fv, 0.0) * h - 0.5
    x0, y0 = np.floor(x), np.floor(y)
    fx, fy = (x - x0)[..., None], (y - y0)[..., None]
    i0, j0 = x0.astype(np.int64) % w, y0.astype(np.int64) % h
    i1, j1 = (i0 + 1) % w, (j0 + 1) % h
    lv = level.astype(np.float64)
    return ((1 - fy) * ((1 - fx) * lv[j0, i0] + fx * lv[j0, i1]) + fy * ((1 - fx) * lv[j1, i0] + fx * lv[j1, i1]))


def lookup(cmap: CurvatureMap, u: ArrayLike, v: ArrayLike, level: ArrayLike | float = 0.0) -> NDArray[np.float64]:
    """The map's texel values at mesh UVs ``(u, v)`` and (fractional) levels: trilinear (the renderer's rule).

    Parameters
    ----------
    cmap
        The map.
    u, v
        Mesh UVs (broadcast).
    level
        Level per point, in ``[0, n_levels - 1]``.

    Returns
    -------
    numpy.ndarray
        ``(..., 6)`` values of :data:`CHANNELS`.
    """
    ru, rv, ou, ov = cmap.transform
    uu, vv, ll = np.broadcast_arrays(np.asarray(u, dtype=np.float64), np.asarray(v, dtype=np.float64),
                                     np.asarray(level, dtype=np.float64))
    tu, tv = uu * ru + ou, vv * rv + ov
    ll = np.clip(ll, 0.0, cmap.n_levels - 1)
    l0 = np.floor(ll).astype(np.int64)
    f = (ll - l0)[..., None]
    out = np.zeros(uu.shape + (len(CHANNELS),))
    for lv in np.unique(l0):
        at = l0 == lv
        a = _bilinear(cmap.levels[lv], tu[at], tv[at])
        if lv + 1 < cmap.n_levels:
            a = a * (1 - f[at]) + _bilinear(cmap.levels[lv + 1], tu[at], tv[at]) * f[at]
        out[at] = a
    return out


def averaged_share(cmap: CurvatureMap, level: float) -> float:
    """The rms curvature left at a (fractional) level, as a share of level 0's (1: nothing averaged away)."""
    s = cmap.stats()
    lv = min(max(level, 0.0), cmap.n_levels - 1)
    lo = int(math.floor(lv))
    hi = min(lo + 1, cmap.n_levels - 1)

    def rms(i: int) -> float:
        return math.sqrt(s[f"du{i}"] ** 2 + s[f"dv{i}"] ** 2 + 2 * s[f"dx{i}"] ** 2)

    base = rms(0)
    if not base > 0:
        return 1.0
    return ((1 - (lv - lo)) * rms(lo) + (lv - lo) * rms(hi)) / base
