"""A curvature map for the viewer's GPU: its prefiltered levels as one texture, the UV layout's handedness.

The page (``assets/viewer.js``) looks a :class:`cdbrdf.mesh.CurvatureMap` up
per fragment by the rule of :mod:`cdbrdf.mesh.curvature_map` (the level of the
pixel's footprint, bilinear between texel centres, linear between levels),
reading the map's own prefiltered levels with ``texelFetch``: every level in
one RGBA float texture (:func:`map_atlas`), not WebGL's mip maps (its box
filter halves odd sizes by dropping a texel, where the map's levels resample
them by area, and a float32 texture is not filterable everywhere). It adds
the map's shape operator to the mesh's own per vertex, in the frame x =
dP/du, y = n x dP/du, as the renderer does (:mod:`cdbrdf.render._maps_jit`);
a mirrored UV layout flips y (:func:`uv_handedness`).
"""

from __future__ import annotations

import logging
from pathlib import PurePath
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["MAX_MAP_LEVELS", "map_atlas", "uv_handedness"]

_LOG = logging.getLogger(__name__)

#: Levels of a curvature map the page's shader holds (a uniform array); finer ones are dropped first.
MAX_MAP_LEVELS = 16

#: RGBA texels per texel of a curvature map in its texture: ``(p, q, dp/du, dp/dv)``, ``(dq/du, dq/dv, 0, 0)``.
_MAP_STRIDE = 2


def map_atlas(cmap: Any, *, uv_scale: Any, neighbourhood_mm: float, max_width: int = 2048,
              max_texels: int = 2048 * 2048) -> tuple[dict[str, Any], NDArray[np.float32]]:
    """A curvature map's levels as one RGBA texture for the page, and its header.

    The levels finer than the neighbourhood's are dropped, as the renderer
    drops them (:func:`cdbrdf.mesh.curvature_map.neighbourhood_level`), then
    the finest further ones while the texture exceeds ``max_texels`` or
    :data:`MAX_MAP_LEVELS` (said in a warning and the header's ``note``).
    Each texel of each level, level 0 first, row 0 at the top, is two RGBA
    texels ``(p, q, dp/du, dp/dv), (dq/du, dq/dv, 0, 0)`` at index
    ``2 (offset + row * width + column)`` of the texture, read row by row
    (texel ``i`` at ``(i % W, i // W)``).

    Parameters
    ----------
    cmap
        The :class:`cdbrdf.mesh.CurvatureMap`.
    uv_scale
        Mm per UV unit (one number or two) the map is laid at.
    neighbourhood_mm
        The curvature's neighbourhood: the finest level used.
    max_width
        The texture's widest row (texels).
    max_texels
        The largest texture (RGBA texels). The defaults: what WebGL2
        guarantees (:data:`cdbrdf.view.asset.WEBGL2_MIN_LIMITS`).

    Returns
    -------
    header : dict
        ``name`` (the file's name without its folders), ``source``,
        ``texels`` (the finest level kept, ``[w, h]``), ``levels``
        (``[w, h, offset]`` per level), ``transform``, ``uv_scale_mm``,
        ``min_level`` (fractional), ``neighbourhood_mm``, ``tile_mm``,
        ``texel_mm``, ``dropped_levels`` (for the texture's size),
        ``note`` and ``atlas`` (``width``, ``height``).
    atlas : numpy.ndarray
        float32 ``(height, width, 4)``.
    """
    from ..mesh import as_uv_scale
    from ..mesh.curvature_map import neighbourhood_level

    pair = as_uv_scale(uv_scale)
    nb = float(neighbourhood_mm)
    label = PurePath(str(cmap.name)).name or "map"  # a file's name, never its folders (an export is published)
    cmap = cmap.coarser(int(neighbourhood_level(cmap, pair, nb)))  # as the renderer (render/_maps_jit.SurfaceMap)
    dropped = 0

    def size(c: Any) -> int:
        return _MAP_STRIDE * sum(int(lv.shape[0] * lv.shape[1]) for lv in c.levels)

    while cmap.n_levels > 1 and (size(cmap) > max_texels or cmap.n_levels > MAX_MAP_LEVELS):
        cmap, dropped = cmap.coarser(1), dropped + 1
    note = None
    if dropped:
        note = (f"{label}: the viewer keeps its levels from {cmap.texels[0]} x {cmap.texels[1]} texels "
                f"({cmap.texel_mm(pair):.3g} mm; WebGL2 guarantees textures of {max_texels:,} texels): "
                "finer detail is averaged there")
        _LOG.warning("%s", note)
    min_level = neighbourhood_level(cmap, pair, nb)
    total = size(cmap)
    width = min(total, int(max_width))
    height = -(-total // width)
    flat = np.zeros((width * height, 4), dtype=np.float32)
    levels, off = [], 0
    for lv in cmap.levels:
        h, w = lv.shape[:2]
        x = np.asarray(lv, dtype=np.float32).reshape(-1, 6)
        i = _MAP_STRIDE * off + _MAP_STRIDE * np.arange(w * h)
        flat[i] = x[:, :4]
        flat[i + 1, :2] = x[:, 4:]
        levels.append([int(w), int(h), int(off)])
        off += w * h
    tu, tv = cmap.tile_mm(pair)
    header = {"name": label, "source": str(cmap.source), "texels": list(cmap.texels), "levels": levels,
              "transform": [float(x) for x in cmap.transform], "uv_scale_mm": [pair[0], pair[1]],
              "min_level": float(min_level), "neighbourhood_mm": nb, "tile_mm": [tu, tv],
              "texel_mm": cmap.texel_mm(pair), "dropped_levels": dropped, "note": note,
              "atlas": {"width": width, "height": height, "format": "RGBA"}}
    return header, flat.reshape(height, width, 4)


def uv_handedness(v: NDArray[np.float64], f: NDArray[np.int64], uv: NDArray[np.float64],
                n: NDArray[np.float64]) -> NDArray[np.float64]:
    """+1 per vertex where dP/dv points along ``n x dP/du`` (as the renderer's ``t``), -1 on a mirrored UV layout.

    Per face ``(n x dP/du) . dP/dv = (n . n_face) |e1 x e2| / det(UV)``: the
    sign of the UV triangle's area times the side of its vertex normals;
    each vertex takes the area-weighted vote of its faces (+1 without any).
    """
    e1, e2 = v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]]
    cr = np.cross(e1, e2)
    d1, d2 = uv[f[:, 1]] - uv[f[:, 0]], uv[f[:, 2]] - uv[f[:, 0]]
    det = d1[:, 0] * d2[:, 1] - d2[:, 0] * d1[:, 1]
    side = np.einsum("ij,ij->i", cr, n[f].sum(axis=1))
    vote = np.sign(det) * np.sign(side) * np.linalg.norm(cr, axis=1)
    acc = np.zeros(v.shape[0])
    for c in range(3):
        np.add.at(acc, f[:, c], vote)
    return np.where(acc < 0.0, -1.0, 1.0)
