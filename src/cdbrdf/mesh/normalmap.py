"""Wrinkles from textures: the curvature a tangent-space normal map draws, baked per vertex in mm^-1.

Garments from fashion CAD tools and scanned fabrics carry their fine folds
in a normal map, not in the mesh. A tangent-space normal ``(a, b, c)`` (in
the frame of dP/du, dP/dv and the normal; ``c > 0``) is the normal of a
height field ``h`` over the surface with slopes ``dh/dx = -a / c`` and
``dh/dy = -b / c`` (``x``, ``y``: arc length along dP/du and dP/dv, mm). The
curvature it adds is the derivative of the normal along the surface, the
shape operator ``-Hess(h)`` (positive where the detail is convex, as the
table's kappa, ``docs/conventions.md``)::

    K = [[ d(a/c)/dx,  d(a/c)/dy ],
         [ d(b/c)/dx,  d(b/c)/dy ]]   (symmetrised)

computed on the texels (the slopes filtered by a Gaussian of
:data:`FILTER_SHARE` x the neighbourhood, the scale at which the mesh's own
curvature is fitted), scaled per vertex by the mm per UV unit along u and v,
sampled at the vertices' UVs (bilinear, the map repeating) and added to the
mesh's shape operator (:func:`add_normal_map`). The texel values are
decoded as data (``2 code / max - 1``), never as sRGB; ``convention``
``"opengl"`` (+v up, green up: Blender, glTF) or ``"directx"`` (green down).

Baked per vertex, the detail is only as fine as the mesh: where the mesh's
median edge exceeds a quarter of the map's fold length (``2 pi rms(slope) /
rms(curvature)``, the wavelength of sine folds), the vertices sample its
folds sparsely and a note says so (subdivide the mesh). The map's shading
(its normals) is not applied to the renderer's normals: what it adds is
its curvature, looked up in the table.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from os import PathLike
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import MeshError

__all__ = ["NORMAL_MAP_CONVENTIONS", "FILTER_SHARE", "NormalMap", "read_normal_map", "normal_map_from_normals",
           "add_normal_map"]

#: Green-channel conventions of tangent-space normal maps: +v up (OpenGL, Blender, glTF) or down (DirectX).
NORMAL_MAP_CONVENTIONS: tuple[str, ...] = ("opengl", "directx")

#: Sigma of the Gaussian filter of the map's slopes, as a share of the neighbourhood's diameter: the
#: resolution of the mesh's own fit (a quadric weighted by a Gaussian of sigma = radius / 2), measured
#: on sine folds (``tests/test_normalmap.py``).
FILTER_SHARE = 0.125

#: Vertices per fold length at least for the folds of a map to be baked per vertex (else a note).
SAMPLES_PER_FOLD = 4.0

#: Smallest ``c`` (the normal's component along the surface normal) accepted: steeper texels are clipped.
_MIN_NZ = 0.1


@dataclass(frozen=True)
class NormalMap:
    """A tangent-space normal map.

    Parameters
    ----------
    normals
        ``(H, W, 3)`` unit normals, row 0 at the top (v = 1).
    name
        What to call it in messages (its file).
    """

    normals: NDArray[np.float64]
    name: str = "normal map"


def normal_map_from_normals(normals: ArrayLike, *, convention: str = "opengl", name: str = "normal map") -> NormalMap:
    """A :class:`NormalMap` from ``(H, W, 3)`` tangent-space normals (any length; normalised)."""
    if convention not in NORMAL_MAP_CONVENTIONS:
        raise MeshError(f"normal map convention: {convention!r} is not one of {', '.join(NORMAL_MAP_CONVENTIONS)}")
    n = np.array(normals, dtype=np.float64)
    if n.ndim != 3 or n.shape[2] < 3 or n.shape[0] < 2 or n.shape[1] < 2:
        raise MeshError(f"{name}: expected an RGB image of at least 2 x 2 texels, got shape {n.shape}")
    n = n[..., :3]
    if not np.isfinite(n).all():
        raise MeshError(f"{name}: has NaN or infinite texels")
    if convention == "directx":
        n[..., 1] = -n[..., 1]
    n[..., 2] = np.maximum(n[..., 2], _MIN_NZ)
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    return NormalMap(n, name)


def read_normal_map(path: str | PathLike[str], *, convention: str = "opengl") -> NormalMap:
    """Read a tangent-space normal map (PNG or TIFF 8/16 bit, float TIFF or OpenEXR) as data.

    Integer codes are decoded as ``2 code / max - 1`` (not as sRGB); float
    images hold the components directly.

    Parameters
    ----------
    path
        The image file.
    convention
        ``"opengl"`` (+y up, Blender, glTF) or ``"directx"`` (+y down), one
        of :data:`NORMAL_MAP_CONVENTIONS`.

    Returns
    -------
    NormalMap
        The unit normals.

    Raises
    ------
    MeshError
        For an image that is not RGB or a convention not in
        :data:`NORMAL_MAP_CONVENTIONS`; :class:`~cdbrdf.errors.ImageError`
        for a damaged file.
    """
    from ..images import read_image

    px, info = read_image(path)
    if px.ndim != 3 or px.shape[2] < 3:
        got = px.shape[2] if px.ndim == 3 else 1
        raise MeshError(f"{path}: a normal map must be an RGB image, got {got} channel(s)")
    v = px[..., :3].astype(np.float64)
    if info.max_code is not None:
        v = 2.0 * v / float(info.max_code) - 1.0
    return normal_map_from_normals(v, convention=convention, name=str(path))


def _uv_scales(positions: NDArray[np.float64], faces: NDArray[np.int64], uv: NDArray[np.float64],
               n: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Per vertex |dP/du| and |dP/dv| (model units per UV unit), area-weighted over its faces."""
    p0, p1, p2 = positions[faces[:, 0]], positions[faces[:, 1]], positions[faces[:, 2]]
    t0, t1, t2 = uv[faces[:, 0]], uv[faces[:, 1]], uv[faces[:, 2]]
    du1, dv1 = t1[:, 0] - t0[:, 0], t1[:, 1] - t0[:, 1]
    du2, dv2 = t2[:, 0] - t0[:, 0], t2[:, 1] - t0[:, 1]
    det = du1 * dv2 - du2 * dv1
    ok = np.abs(det) > 1e-12 * np.maximum(np.abs(du1 * dv2) + np.abs(du2 * dv1), 1e-300)
    d = np.where(ok, det, 1.0)[:, None]
    dpdu = ((p1 - p0) * dv2[:, None] - (p2 - p0) * dv1[:, None]) / d
    dpdv = ((p2 - p0) * du1[:, None] - (p1 - p0) * du2[:, None]) / d
    area = 0.5 * np.linalg.norm(np.cross(p1 - p0, p2 - p0), axis=1) * ok
    w = np.bincount(faces.reshape(-1), np.repeat(area, 3), n)
    su = np.bincount(faces.reshape(-1), np.repeat(area * np.linalg.norm(dpdu, axis=1) * ok, 3), n)
    sv = np.bincount(faces.reshape(-1), np.repeat(area * np.linalg.norm(dpdv, axis=1) * ok, 3), n)
    with np.errstate(invalid="ignore", divide="ignore"):
        return su / w, sv / w


def _bilinear(img: NDArray[np.float64], uv: NDArray[np.float64]) -> NDArray[np.float64]:
    """Texel values at UVs (the map repeating; v = 1 is row 0's top edge)."""
    h, w = img.shape[:2]
    x = np.mod(uv[:, 0], 1.0) * w - 0.5
    y = np.mod(1.0 - uv[:, 1], 1.0) * h - 0.5
    x0, y0 = np.floor(x), np.floor(y)
    fx, fy = (x - x0)[:, None], (y - y0)[:, None]
    x0i, y0i = x0.astype(np.int64) % w, y0.astype(np.int64) % h
    x1i, y1i = (x0i + 1) % w, (y0i + 1) % h
    flat = img.reshape(h, w, -1)
    out = ((1 - fx) * (1 - fy) * flat[y0i, x0i] + fx * (1 - fy) * flat[y0i, x1i]
           + (1 - fx) * fy * flat[y1i, x0i] + fx * fy * flat[y1i, x1i])
    return out.reshape((-1,) + img.shape[2:])


def add_normal_map(
    normal_map: NormalMap,
    *,
    positions: NDArray[np.float64],
    faces: NDArray[np.int64],
    uv: NDArray[np.float64],
    normals: NDArray[np.float64],
    tangent: NDArray[np.float64],
    k1: NDArray[np.float64],
    k2: NDArray[np.float64],
    d1: NDArray[np.float64],
    d2: NDArray[np.float64],
    mm_per_unit: float,
    neighbourhood_mm: float,
) -> tuple[dict[str, Any], list[str]]:
    """The mesh's curvature with the normal map's added, per vertex (see the module's description).

    Parameters
    ----------
    normal_map
        The map (:func:`read_normal_map`).
    positions, faces, uv, normals
        The renderable mesh: ``(n, 3)`` positions in model units, its
        triangles, ``(n, 2)`` UVs and unit normals.
    tangent
        ``(n, 3)`` unit dP/du directions (the material's x axis).
    k1, k2, d1, d2
        The mesh's principal curvatures (mm^-1) and directions.
    mm_per_unit
        The mesh's unit.
    neighbourhood_mm
        The curvature's neighbourhood (the filter is :data:`FILTER_SHARE` of it).

    Returns
    -------
    arrays, notes
        ``{"k1", "k2", "d1", "d2", "kappa", "directional", "detail"}``: the
        combined principal curvatures and directions, the paper's kappa, the
        normal curvature along the tangent, and the map's own largest
        curvature (mm^-1); and what the user should know.
    """
    from scipy.ndimage import gaussian_filter

    nm = normal_map.normals
    hgt, wid = nm.shape[:2]
    n = positions.shape[0]
    su, sv = _uv_scales(positions, faces, uv, n)
    su, sv = su * mm_per_unit, sv * mm_per_unit  # mm per UV unit
    good = np.isfinite(su) & np.isfinite(sv) & (su > 0) & (sv > 0)
    if not good.any():
        raise MeshError(f"{normal_map.name}: the mesh's UVs give no scale (degenerate UVs)")
    mu, mv = float(np.median(su[good])), float(np.median(sv[good]))
    sigma_mm = FILTER_SHARE * neighbourhood_mm
    p = nm[..., 0] / nm[..., 2]  # -dh/dx
    q = nm[..., 1] / nm[..., 2]  # -dh/dy
    sig = (sigma_mm * hgt / mv, sigma_mm * wid / mu)  # texels along rows (v), columns (u)
    p = gaussian_filter(p, sig, mode="wrap")
    q = gaussian_filter(q, sig, mode="wrap")
    # derivatives per UV unit: d/du = W d/dcol, d/dv = -H d/drow (row 0 at the top, v = 1)
    dp_di, dp_dj = np.gradient(np.pad(p, 1, mode="wrap"))
    dq_di, dq_dj = np.gradient(np.pad(q, 1, mode="wrap"))
    grads = np.stack([dp_dj * wid, -dp_di * hgt, dq_dj * wid, -dq_di * hgt], -1)[1:-1, 1:-1]
    g = _bilinear(grads, uv)
    with np.errstate(invalid="ignore", divide="ignore"):
        kxx = g[:, 0] / su
        kxy = 0.5 * (g[:, 1] / sv + g[:, 2] / su)
        kyy = g[:, 3] / sv
    kxx, kxy, kyy = (np.where(good, k, 0.0) for k in (kxx, kxy, kyy))
    # the frame: x along dP/du, y = n x x; the mesh's shape operator in it, plus the map's
    t = np.nan_to_num(tangent)
    t = t - np.einsum("ij,ij->i", t, normals)[:, None] * normals
    tl = np.linalg.norm(t, axis=1, keepdims=True)
    ok = (tl[:, 0] > 1e-9) & good
    t = np.where(ok[:, None], t / np.maximum(tl, 1e-300), d1)
    b = np.cross(normals, t)
    c1t, c1b = np.einsum("ij,ij->i", d1, t), np.einsum("ij,ij->i", d1, b)
    c2t, c2b = np.einsum("ij,ij->i", d2, t), np.einsum("ij,ij->i", d2, b)
    sxx = k1 * c1t * c1t + k2 * c2t * c2t + np.where(ok, kxx, 0.0)
    sxy = k1 * c1t * c1b + k2 * c2t * c2b + np.where(ok, kxy, 0.0)
    syy = k1 * c1b * c1b + k2 * c2b * c2b + np.where(ok, kyy, 0.0)
    mean = 0.5 * (sxx + syy)
    half = np.sqrt(0.25 * (sxx - syy) ** 2 + sxy**2)
    n1, n2 = mean + half, mean - half
    th = 0.5 * np.arctan2(2.0 * sxy, sxx - syy)
    e1 = np.cos(th)[:, None] * t + np.sin(th)[:, None] * b
    e2 = -np.sin(th)[:, None] * t + np.cos(th)[:, None] * b
    kappa = np.where(np.abs(n1) >= np.abs(n2), n1, n2)
    dmean = 0.5 * (kxx + kyy)
    dhalf = np.sqrt(0.25 * (kxx - kyy) ** 2 + kxy**2)
    detail = np.where(np.abs(dmean + dhalf) >= np.abs(dmean - dhalf), dmean + dhalf, dmean - dhalf)
    notes = [f"{normal_map.name}: {wid} x {hgt} texels over {mu:.4g} x {mv:.4g} mm (median), "
             f"filtered at {sigma_mm:.3g} mm; its curvature is up to {float(np.abs(detail).max()):.3g} 1/mm "
             f"(median {float(np.median(np.abs(detail))):.3g})"]
    # the folds' length: 2 pi rms(slope) / rms(curvature) (the wavelength of a sine fold)
    k_tex = np.hypot(grads[..., 0] / mu, grads[..., 3] / mv)
    slope_rms, k_rms = float(np.sqrt(np.mean(p * p + q * q))), float(np.sqrt(np.mean(k_tex * k_tex)))
    fold_mm = 2 * math.pi * slope_rms / k_rms if k_rms > 0 else math.inf
    edge = _median_edge_mm(positions, faces, mm_per_unit)
    if edge > fold_mm / SAMPLES_PER_FOLD:
        notes.append(f"the mesh (median edge {edge:.3g} mm) is coarse for the normal map's folds (about "
                     f"{fold_mm:.3g} mm long): baked per vertex, they are sampled sparsely; subdivide the mesh to "
                     f"{fold_mm / SAMPLES_PER_FOLD:.2g} mm edges")
    arrays = {"k1": n1, "k2": n2, "d1": e1, "d2": e2, "kappa": kappa, "directional": sxx, "detail": detail}
    return arrays, notes


def _median_edge_mm(v: NDArray[np.float64], f: NDArray[np.int64], mm_per_unit: float) -> float:
    if f.size == 0:
        return math.nan
    return float(np.median(np.linalg.norm(v[f[:, [1, 2, 0]]] - v[f], axis=2))) * mm_per_unit
