"""Baking curvature maps: from a normal map, a height map, or a high-resolution mesh onto a low one's UVs.

Each baker makes a :class:`~cdbrdf.mesh.curvature_map.CurvatureMap` (slopes
and their derivatives per UV unit, prefiltered levels):

- :func:`bake_normal_map`: a tangent-space normal ``(a, b, c)`` is the normal
  of a height field with slopes ``p = a / c``, ``q = b / c``
  (:mod:`cdbrdf.mesh.normalmap` reads the file as data, OpenGL or DirectX
  green); their derivatives are central differences over the texels
  (periodic), per UV unit of the mesh. Independent of the UV scale.
- :func:`bake_height_map`: heights ``h = value x height_scale_mm`` (a grey
  image decoded as data, ``code / max``; a float image as it is), slopes
  ``p = -dh/dx = -(dh/du) / su`` at the UV scale ``su, sv`` (mm per UV
  unit): a height map's slopes depend on it, so the map records the scale it
  was baked at.
- :func:`bake_mesh`: the way Substance and Marmoset bake curvature from a
  high-resolution mesh onto a low-resolution one's UV layout, but signed and
  in 1/mm: at every texel centre of the low mesh's UV layout (the map covers
  the UVs' bounding box) the point on the low mesh, its closest point on the
  high mesh, and there the high mesh's shape operator (fitted over the
  neighbourhood, :func:`cdbrdf.mesh.surface_curvature`) expressed in the low
  mesh's tangent frame *minus* the low mesh's own: the signed normal-curvature
  difference the plug-in adds back to the low mesh's. The high mesh's normal
  in that frame gives the slopes that perturb the shading normal. Texels no
  triangle covers take the nearest covered texel's values (the usual gutter
  padding), so the prefiltered levels do not fade towards chart borders.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from os import PathLike
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import MeshError
from .attributes import SHAPE_ATTRIBUTES
from .curvature_map import NEIGHBOURHOOD_WIDTH_SHARE, CurvatureMap, pyramid
from .normalmap import NormalMap

__all__ = ["HeightMap", "read_height_map", "height_map_from_values", "bake_normal_map", "bake_height_map",
           "bake_mesh", "MESH_BAKE_TEXELS"]

_LOG = logging.getLogger(__name__)

#: Texels of a mesh bake along its longer side at most, and at least.
MESH_BAKE_TEXELS: tuple[int, int] = (64, 1024)

#: Nearest triangles (by centroid) of the high mesh tried per texel for its closest point.
_CANDIDATES = 12

#: Largest ``c`` clip of a slope (a normal tilted more than ~84 degrees is clipped there).
_MIN_NZ = 0.1


@dataclass(frozen=True)
class HeightMap:
    """A height (bump, displacement) map: values per texel, row 0 at the top (v = 1).

    Parameters
    ----------
    values
        ``(H, W)`` heights in units of the height scale (an integer image's
        codes over their maximum, 0 to 1; a float image's values).
    name
        What to call it in messages (its file).
    """

    values: NDArray[np.float64]
    name: str = "height map"


def height_map_from_values(values: ArrayLike, *, name: str = "height map") -> HeightMap:
    """A :class:`HeightMap` from ``(H, W)`` values (an ``(H, W, C)`` image: its Rec. 709 luminance).

    Parameters
    ----------
    values
        ``(H, W)`` heights in units of the height scale, or an image.
    name
        What to call it in messages.

    Returns
    -------
    HeightMap
        The heights, float64.
    """
    v = np.array(values, dtype=np.float64)
    if v.ndim == 3:
        if v.shape[2] >= 3:
            v = v[..., 0] * 0.2126 + v[..., 1] * 0.7152 + v[..., 2] * 0.0722
        else:
            v = v[..., 0]
    if v.ndim != 2 or v.shape[0] < 2 or v.shape[1] < 2:
        raise MeshError(f"{name}: expected an image of at least 2 x 2 texels, got shape {np.shape(values)}")
    if not np.isfinite(v).all():
        raise MeshError(f"{name}: has NaN or infinite texels")
    return HeightMap(v, name)


def read_height_map(path: str | PathLike[str]) -> HeightMap:
    """Read a height map (PNG or TIFF 8/16 bit, float TIFF or OpenEXR) as data (integer codes / their maximum).

    Parameters
    ----------
    path
        The image file.

    Returns
    -------
    HeightMap
        Its values (an RGB image's luminance).
    """
    from ..images import read_image

    px, info = read_image(path)
    v = px.astype(np.float64)
    if info.max_code is not None:
        v = v / float(info.max_code)
    return height_map_from_values(v, name=str(path))


def _d_cols(a: NDArray[np.float64]) -> NDArray[np.float64]:
    """d/dt_u per texture unit: central differences along the columns, periodic."""
    return (np.roll(a, -1, axis=1) - np.roll(a, 1, axis=1)) * (0.5 * a.shape[1])


def _d_rows(a: NDArray[np.float64]) -> NDArray[np.float64]:
    """d/dt_v per texture unit (row 0 is the top, t_v = 1): central differences along the rows, periodic."""
    return -(np.roll(a, -1, axis=0) - np.roll(a, 1, axis=0)) * (0.5 * a.shape[0])


def _from_slopes(p: NDArray[np.float64], q: NDArray[np.float64], transform: tuple[float, float, float, float],
                 **kw: Any) -> CurvatureMap:
    """A map of slopes ``p, q`` (texels) and their derivatives per mesh UV unit (the repeats folded in)."""
    ru, rv = transform[:2]
    base = np.empty(p.shape + (6,), np.float32)
    for i, x in enumerate((p, q, _d_cols(p) * ru, _d_rows(p) * rv, _d_cols(q) * ru, _d_rows(q) * rv)):
        base[..., i] = x
    return CurvatureMap(pyramid(base), transform=transform, **kw)


def _transform(transform: ArrayLike | None) -> tuple[float, float, float, float]:
    t = (1.0, 1.0, 0.0, 0.0) if transform is None else tuple(float(x) for x in np.ravel(transform))
    if len(t) != 4 or not all(math.isfinite(x) for x in t) or t[0] == 0 or t[1] == 0:
        raise MeshError(f"texture transform: expected (ru, rv, ou, ov), finite, non-zero repeats; got {transform!r}")
    return t[0], t[1], t[2], t[3]


def bake_normal_map(normal_map: NormalMap, *, transform: ArrayLike | None = None) -> CurvatureMap:
    """The curvature map of a tangent-space normal map (see the module's description).

    Parameters
    ----------
    normal_map
        The map (:func:`cdbrdf.mesh.read_normal_map`).
    transform
        ``(ru, rv, ou, ov)``: its texture transform (default: one repeat per UV unit).

    Returns
    -------
    CurvatureMap
        Slopes ``a / c``, ``b / c`` and their derivatives, prefiltered.
    """
    n = normal_map.normals
    c = np.maximum(n[..., 2], _MIN_NZ)
    return _from_slopes(n[..., 0] / c, n[..., 1] / c, _transform(transform), name=normal_map.name,
                        source="normal map")


def bake_height_map(height_map: HeightMap, *, height_scale_mm: float, uv_scale: tuple[float, float],
                    transform: ArrayLike | None = None) -> CurvatureMap:
    """The curvature map of a height map at ``uv_scale`` mm per UV unit (see the module's description).

    Parameters
    ----------
    height_map
        The map (:func:`read_height_map`).
    height_scale_mm
        Millimetres per unit of its values (an MTL ``-bm`` times the mesh's unit).
    uv_scale
        Mm per UV unit along u and v.
    transform
        ``(ru, rv, ou, ov)``: its texture transform.

    Returns
    -------
    CurvatureMap
        Slopes ``-dh/dx``, ``-dh/dy`` and their derivatives, prefiltered; it
        records ``uv_scale``.
    """
    hs = float(height_scale_mm)
    if not (math.isfinite(hs) and hs > 0):
        raise MeshError(f"{height_map.name}: the height scale must be a positive number of mm, got {height_scale_mm!r}")
    su, sv = (float(x) for x in uv_scale)
    t = _transform(transform)
    h = height_map.values * hs
    p = -_d_cols(h) * t[0] / su
    q = -_d_rows(h) * t[1] / sv
    return _from_slopes(p, q, t, name=height_map.name, source="height map", uv_scale=(su, sv))


# -- a high-resolution mesh onto a low one's UVs -------------------------------------------------------
def _closest_on_triangles(p: NDArray[np.float64], a: NDArray[np.float64], b: NDArray[np.float64],
                          c: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Closest points of triangles ``(a, b, c)`` to points ``p`` (row by row) and their barycentrics (Ericson 5.1.5)."""
    ab, ac, ap = b - a, c - a, p - a
    d1, d2 = np.einsum("...i,...i", ab, ap), np.einsum("...i,...i", ac, ap)
    bp = p - b
    d3, d4 = np.einsum("...i,...i", ab, bp), np.einsum("...i,...i", ac, bp)
    cp = p - c
    d5, d6 = np.einsum("...i,...i", ab, cp), np.einsum("...i,...i", ac, cp)
    va = d3 * d6 - d5 * d4
    vb = d5 * d2 - d1 * d6
    vc = d1 * d4 - d3 * d2
    with np.errstate(divide="ignore", invalid="ignore"):
        den = va + vb + vc
        v = np.where(den != 0, vb / den, 0.0)
        w = np.where(den != 0, vc / den, 0.0)
        bary = np.stack([1 - v - w, v, w], axis=-1)  # inside the face
        # edges and corners: the regions' tests in reverse order of precedence, each overriding the last
        t_ab = np.clip(d1 / np.where(d1 - d3 != 0, d1 - d3, 1.0), 0, 1)
        t_ac = np.clip(d2 / np.where(d2 - d6 != 0, d2 - d6, 1.0), 0, 1)
        t_bc = np.clip((d4 - d3) / np.where((d4 - d3) + (d5 - d6) != 0, (d4 - d3) + (d5 - d6), 1.0), 0, 1)
    regions = [
        ((va <= 0) & (d4 - d3 >= 0) & (d5 - d6 >= 0), np.stack([0 * t_bc, 1 - t_bc, t_bc], -1)),
        ((vb <= 0) & (d2 >= 0) & (d6 <= 0), np.stack([1 - t_ac, 0 * t_ac, t_ac], -1)),
        ((d6 >= 0) & (d5 <= d6), np.broadcast_to([0.0, 0.0, 1.0], bary.shape)),
        ((vc <= 0) & (d1 >= 0) & (d3 <= 0), np.stack([1 - t_ab, t_ab, 0 * t_ab], -1)),
        ((d3 >= 0) & (d4 <= d3), np.broadcast_to([0.0, 1.0, 0.0], bary.shape)),
        ((d1 <= 0) & (d2 <= 0), np.broadcast_to([1.0, 0.0, 0.0], bary.shape)),
    ]
    for mask, bc in regions:
        bary = np.where(mask[..., None], bc, bary)
    q = bary[..., 0:1] * a + bary[..., 1:2] * b + bary[..., 2:3] * c
    return q, bary


def _texel_points(uv: NDArray[np.float64], faces: NDArray[np.int64], size: tuple[int, int],
                  transform: tuple[float, float, float, float]) -> tuple[Any, Any, Any]:
    """The texel centres inside the UV triangles: flat texel index, face, barycentrics (first face wins)."""
    w, h = size
    ru, rv, ou, ov = transform
    t = np.c_[uv[:, 0] * ru + ou, uv[:, 1] * rv + ov]
    pix = np.c_[t[:, 0] * w - 0.5, (1.0 - t[:, 1]) * h - 0.5]  # texel-centre coordinates (column, row)
    tri = pix[faces]
    lo = np.clip(np.ceil(tri.min(axis=1)), 0, [w - 1, h - 1]).astype(np.int64)
    hi = np.clip(np.floor(tri.max(axis=1)), -1, [w - 1, h - 1]).astype(np.int64)
    n = np.maximum(hi - lo + 1, 0)
    counts = n[:, 0] * n[:, 1]
    out_t, out_f, out_b = [], [], []
    order = np.arange(faces.shape[0])
    chunk = 1 << 21
    start = 0
    while start < order.size:
        stop = start + 1
        total = counts[start]
        while stop < order.size and total + counts[stop] <= chunk:
            total += counts[stop]
            stop += 1
        f = np.repeat(order[start:stop], counts[start:stop])
        k = np.arange(f.size) - np.repeat(np.cumsum(counts[start:stop]) - counts[start:stop], counts[start:stop])
        col = lo[f, 0] + k % np.maximum(n[f, 0], 1)
        row = lo[f, 1] + k // np.maximum(n[f, 0], 1)
        a, b, c = tri[f, 0], tri[f, 1], tri[f, 2]
        p = np.c_[col, row].astype(np.float64)
        det = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (c[:, 0] - a[:, 0]) * (b[:, 1] - a[:, 1])
        ok = np.abs(det) > 1e-12
        d = np.where(ok, det, 1.0)
        l1 = ((p[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (c[:, 0] - a[:, 0]) * (p[:, 1] - a[:, 1])) / d
        l2 = ((b[:, 0] - a[:, 0]) * (p[:, 1] - a[:, 1]) - (p[:, 0] - a[:, 0]) * (b[:, 1] - a[:, 1])) / d
        l0 = 1.0 - l1 - l2
        eps = -1e-9
        inside = ok & (l0 >= eps) & (l1 >= eps) & (l2 >= eps)
        out_t.append(row[inside] * w + col[inside])
        out_f.append(f[inside])
        out_b.append(np.c_[l0, l1, l2][inside])
        start = stop
    texel = np.concatenate(out_t) if out_t else np.zeros(0, np.int64)
    face = np.concatenate(out_f) if out_f else np.zeros(0, np.int64)
    bary = np.concatenate(out_b) if out_b else np.zeros((0, 3))
    texel, first = np.unique(texel, return_index=True)
    return texel, face[first], bary[first]


def _face_tangents(v: NDArray[np.float64], f: NDArray[np.int64], uv: NDArray[np.float64]) -> NDArray[np.float64]:
    """dP/du of every face (model units per UV unit)."""
    p0, p1, p2 = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
    t0, t1, t2 = uv[f[:, 0]], uv[f[:, 1]], uv[f[:, 2]]
    du1, dv1 = t1[:, 0] - t0[:, 0], t1[:, 1] - t0[:, 1]
    du2, dv2 = t2[:, 0] - t0[:, 0], t2[:, 1] - t0[:, 1]
    det = du1 * dv2 - du2 * dv1
    d = np.where(np.abs(det) > 1e-300, det, 1.0)[:, None]
    return ((p1 - p0) * dv2[:, None] - (p2 - p0) * dv1[:, None]) / d


def _high_side(high: Any, units: Any, neighbourhood_mm: float, name: str) -> tuple[Any, Any, Any, Any]:
    """The high mesh's renderable vertices, faces, normals and world shape tensors (6 components, 1/mm)."""
    from .curvature import surface_curvature

    s = surface_curvature(high.vertices, high.faces, uv=None, normals=high.normals, units=units,
                          neighbourhood_mm=neighbourhood_mm, frame="principal", name=name)
    v = high.vertices[s.source]
    tens = np.einsum("n,ni,nj->nij", s.k1, s.d1, s.d1) + np.einsum("n,ni,nj->nij", s.k2, s.d2, s.d2)
    six = np.stack([tens[:, 0, 0], tens[:, 0, 1], tens[:, 0, 2], tens[:, 1, 1], tens[:, 1, 2], tens[:, 2, 2]], 1)
    return v, s.faces, s.normals, six


def bake_mesh(high: Any, low: Any, *, uv_scale: tuple[float, float], neighbourhood_mm: float,
              texels: int | None = None, name: str = "high-resolution mesh") -> CurvatureMap:
    """The signed curvature difference of a high-resolution mesh baked onto a low one's UVs (module description).

    Parameters
    ----------
    high
        The high-resolution :class:`~cdbrdf.mesh.Mesh`, in the low mesh's
        unit and place.
    low
        The low-resolution mesh as :func:`cdbrdf.mesh.prepare_mesh` made it
        (its own UVs, normals and the :data:`~cdbrdf.mesh.attributes.SHAPE_ATTRIBUTES`).
    uv_scale
        Mm per UV unit of the low mesh.
    neighbourhood_mm
        The neighbourhood the high mesh's curvature is fitted over.
    texels
        Texels along the map's longer side (default: the high mesh's median
        edge per texel, within :data:`MESH_BAKE_TEXELS`).
    name
        What to call it in messages.

    Returns
    -------
    CurvatureMap
        Covering the low mesh's UV bounding box; it records ``uv_scale``.
    """
    from scipy.ndimage import distance_transform_edt
    from scipy.spatial import cKDTree

    from .units import parse_units

    if low.uv is None or any(k not in low.attributes for k in SHAPE_ATTRIBUTES) or low.normals is None:
        raise MeshError(f"{name}: the low-resolution mesh needs its own UVs and its prepared curvature")
    units = parse_units(low.metadata.get("units", "mm"))
    su, sv = (float(x) for x in uv_scale)
    lo_uv, hi_uv = low.uv.min(axis=0), low.uv.max(axis=0)
    ext = np.maximum(hi_uv - lo_uv, 1e-12)
    tr = (1.0 / ext[0], 1.0 / ext[1], -lo_uv[0] / ext[0], -lo_uv[1] / ext[1])
    hv, hf, hn, hs = _high_side(high, units, neighbourhood_mm, name)
    if texels is None:
        e = np.linalg.norm(hv[hf[:, 1]] - hv[hf[:, 0]], axis=1)
        edge_mm = float(np.median(e)) * units.mm_per_unit
        texels = int(round(max(ext[0] * su, ext[1] * sv) / max(edge_mm, 1e-9)))
    texels = int(np.clip(texels, *MESH_BAKE_TEXELS))
    aspect = ext[1] * sv / max(ext[0] * su, 1e-30)
    w = texels if aspect <= 1 else max(2, int(round(texels / aspect)))
    h = texels if aspect >= 1 else max(2, int(round(texels * aspect)))
    tex, face, bary = _texel_points(low.uv, low.faces, (w, h), tr)
    if tex.size == 0:
        raise MeshError(f"{name}: the low-resolution mesh's UVs cover no texel")
    lf = low.faces[face]
    point = np.einsum("nk,nki->ni", bary, low.vertices[lf])
    nrm = np.einsum("nk,nki->ni", bary, low.normals[lf])
    nrm /= np.maximum(np.linalg.norm(nrm, axis=1, keepdims=True), 1e-300)
    x = _face_tangents(low.vertices, low.faces, low.uv)[face]
    x = x - np.einsum("ni,ni->n", x, nrm)[:, None] * nrm
    x /= np.maximum(np.linalg.norm(x, axis=1, keepdims=True), 1e-300)
    y = np.cross(nrm, x)
    s_low = [np.einsum("nk,nk->n", bary, low.attributes[k][lf]) for k in SHAPE_ATTRIBUTES]
    # the closest point on the high mesh, among the triangles of the nearest centroids
    tree = cKDTree(hv[hf].mean(axis=1))
    k = min(_CANDIDATES, hf.shape[0])
    best_d = np.full(tex.size, np.inf)
    best_f = np.zeros(tex.size, np.int64)
    best_b = np.zeros((tex.size, 3))
    for s in range(0, tex.size, 1 << 15):
        pts = point[s : s + (1 << 15)]
        _, cand = tree.query(pts, k=k)
        cand = cand.reshape(pts.shape[0], -1)
        tri = hv[hf[cand]]
        q, bc = _closest_on_triangles(pts[:, None, :], tri[:, :, 0], tri[:, :, 1], tri[:, :, 2])
        d = np.linalg.norm(q - pts[:, None, :], axis=2)
        j = np.argmin(d, axis=1)
        r = np.arange(pts.shape[0])
        best_d[s : s + pts.shape[0]] = d[r, j]
        best_f[s : s + pts.shape[0]] = cand[r, j]
        best_b[s : s + pts.shape[0]] = bc[r, j]
    hfs = hf[best_f]
    n_h = np.einsum("nk,nki->ni", best_b, hn[hfs])
    n_h /= np.maximum(np.linalg.norm(n_h, axis=1, keepdims=True), 1e-300)
    six = np.einsum("nk,nki->ni", best_b, hs[hfs])
    flip = np.where(np.einsum("ni,ni->n", n_h, nrm) < 0, -1.0, 1.0)  # a high mesh wound the other way
    n_h *= flip[:, None]
    six *= flip[:, None]
    t3 = np.empty((tex.size, 3, 3))
    for (i, j), c in zip(((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2)), range(6), strict=True):
        t3[:, i, j] = t3[:, j, i] = six[:, c]
    # normal curvatures of the high mesh along the low frame's axes, projected into its tangent plane
    xh = x - np.einsum("ni,ni->n", x, n_h)[:, None] * n_h
    yh = y - np.einsum("ni,ni->n", y, n_h)[:, None] * n_h
    xh /= np.maximum(np.linalg.norm(xh, axis=1, keepdims=True), 1e-300)
    yh /= np.maximum(np.linalg.norm(yh, axis=1, keepdims=True), 1e-300)
    kxx = np.einsum("ni,nij,nj->n", xh, t3, xh) - s_low[0]
    kxy = np.einsum("ni,nij,nj->n", xh, t3, yh) - s_low[1]
    kyy = np.einsum("ni,nij,nj->n", yh, t3, yh) - s_low[2]
    a, b = np.einsum("ni,ni->n", n_h, x), np.einsum("ni,ni->n", n_h, y)
    c = np.maximum(np.einsum("ni,ni->n", n_h, nrm), _MIN_NZ)
    vals = np.stack([a / c, b / c, kxx * su, kxy * sv, kxy * su, kyy * sv], axis=1)
    base: NDArray[np.float64] = np.zeros((h * w, 6))
    base[tex] = vals
    flat = np.zeros(h * w, bool)
    flat[tex] = True
    covered = flat.reshape(h, w)
    if not covered.all():  # gutter: the nearest covered texel's values
        idx = distance_transform_edt(~covered, return_distances=False, return_indices=True)
        base = base.reshape(h, w, 6)[idx[0], idx[1]]
    far = float(np.percentile(best_d, 99)) * units.mm_per_unit
    _LOG.info("%s: baked %d x %d texels (%d covered); 99%% of the points within %.3g mm of it", name, w, h,
              tex.size, far)
    return CurvatureMap(pyramid(base.reshape(h, w, 6)), name=name, source="high-resolution mesh", transform=tr,
                        uv_scale=(su, sv), prefiltered_mm=NEIGHBOURHOOD_WIDTH_SHARE * float(neighbourhood_mm))
