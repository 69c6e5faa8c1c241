"""A curvature map in the renderer: its levels on the device, the lookup at a hit, the perturbed frame.

The plug-in (:mod:`cdbrdf.render._bsdf`) looks a
:class:`~cdbrdf.mesh.CurvatureMap` up at every shading point, by the rule of
:mod:`cdbrdf.mesh.curvature_map` (the NumPy reference, which the scalar
variants call):

1. the level from the footprint (:func:`level`): the pixel's, ``si.t x
   pixel_angle / max(|cos theta_v|, 1/8)`` in UV units through ``|dP/du|``,
   ``|dP/dv|`` (``pixel_angle``: the camera's, which cdbrdf's loaders give
   the plug-in), or Mitsuba's UV partials ``si.duv_dx``, ``si.duv_dy`` where
   an integrator computed them (Mitsuba 3.9's ``path`` does not: only
   ``SurfaceInteraction.compute_uv_partials(RayDifferential)`` fills them, and
   only the ``aov`` integrator calls it), never finer than the neighbourhood's level;
2. between the two levels around it (:func:`sample`, ``map_filter``):
   ``stochastic`` (the default) reads one of them, the coarser with
   probability equal to the fraction (a TEA hash of the UV's bits, as the
   CD-BTF's stochastic texel filter: the same point reads the same level in
   ``eval`` and ``sample``), so the expected value is the trilinear one with
   four packet gathers of a texel's six values (padded to eight floats);
   ``trilinear`` blends both (eight gathers); the scalar variants evaluate the
   trilinear value for both (the expectation);
3. the shape operator at the UV scale (:func:`detail`), in the shading frame
   (``s`` = dP/du projected, ``t = n x s``; a mirrored UV layout, where
   dP/dv points along ``-t``, flips ``q`` and ``kxy``), added to the mesh's
   own (the vertex attributes ``vertex_shape_xx``, ``_xy``, ``_yy``,
   interpolated): the curvature is the eigenvalue of larger magnitude of the
   sum (``max``) or its ``xx`` entry (``directional``);
4. the perturbed shading frame of the slopes (:func:`frame`), as Mitsuba's
   ``normalmap`` BSDF builds it: ``n' = (p, q, 1) / |.|`` in the shading frame
   (mirrored about the normal when it faces away from the viewer),
   ``s' = normalize(x - n' n'.x)``, ``t' = n' x s'``.
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple

import numpy as np

from ..mesh.curvature_map import CHANNELS, MIN_COS_VIEW, CurvatureMap
from ._params import MAP_PARAMETERS

__all__ = ["MapUpload", "SurfaceMap", "upload", "level", "level_choice", "sample", "detail", "frame", "Frame",
           "handedness", "principal", "scalar_values"]

#: Floats per texel on the device (the six channels, padded for packet gathers).
_STRIDE = 8


class MapUpload(NamedTuple):
    """A map's levels on the device and the constants of its lookup."""

    data: Any  # mi.Float: every level's texels, _STRIDE floats each
    offset: Any  # mi.UInt32: first texel of each level
    width: Any  # mi.UInt32 per level
    height: Any  # mi.UInt32 per level
    texels: tuple[int, int]  # level 0
    n_levels: int
    transform: tuple[float, float, float, float]
    uv_scale: tuple[float, float]
    min_level: float
    map_filter: str


def upload(mi: Any, cmap: CurvatureMap, *, uv_scale: tuple[float, float], min_level: float,
           map_filter: str = "stochastic") -> MapUpload:
    """Every level of ``cmap`` in one device buffer (vectorised variants)."""
    blocks, offsets, widths, heights = [], [], [], []
    n = 0
    for lv in cmap.levels:
        h, w = lv.shape[:2]
        pad = np.zeros((h * w, _STRIDE), np.float32)
        pad[:, : len(CHANNELS)] = lv.reshape(-1, len(CHANNELS))
        blocks.append(pad.reshape(-1))
        offsets.append(n)
        widths.append(w)
        heights.append(h)
        n += h * w
    UInt = mi.UInt32
    return MapUpload(mi.Float(np.concatenate(blocks)), UInt(offsets), UInt(widths), UInt(heights), cmap.texels,
                     cmap.n_levels, cmap.transform, (float(uv_scale[0]), float(uv_scale[1])), float(min_level),
                     str(map_filter))


def level(dr: Any, si: Any, texels: tuple[int, int], transform: tuple[float, ...], n_levels: int,
          min_level: float, pixel_angle: float) -> Any:
    """The (fractional) level of the footprint at ``si`` (any variant; see the module's description)."""
    w = si.t * pixel_angle / dr.maximum(dr.abs(si.wi.z), MIN_COS_VIEW)
    fu = dr.maximum(w / dr.maximum(dr.norm(si.dp_du), 1e-30), dr.maximum(dr.abs(si.duv_dx.x), dr.abs(si.duv_dy.x)))
    fv = dr.maximum(w / dr.maximum(dr.norm(si.dp_dv), 1e-30), dr.maximum(dr.abs(si.duv_dx.y), dr.abs(si.duv_dy.y)))
    t = dr.maximum(fu * (texels[0] * abs(transform[0])), fv * (texels[1] * abs(transform[1])))
    lv = dr.log2(dr.maximum(t, 1e-30))
    return dr.clip(dr.maximum(lv, min_level), 0.0, float(n_levels - 1))


def _bilinear(mi: Any, up: MapUpload, tu: Any, tv: Any, lvl: Any, active: Any) -> list[Any]:
    """The six values of level ``lvl`` (per lane) at texture coordinates ``tu, tv``, bilinear and periodic."""
    import drjit as dr

    from ._lookup_jit import _array_x

    Float, UInt = mi.Float, mi.UInt32
    Int = dr.int32_array_t(Float)
    w = dr.gather(UInt, up.width, lvl, active)
    h = dr.gather(UInt, up.height, lvl, active)
    off = dr.gather(UInt, up.offset, lvl, active)
    wf, hf = Float(w), Float(h)
    x = tu * wf - 0.5  # tu, tv: fractions in [0, 1] (row 0 at the top: tv is 1 - v)
    y = tv * hf - 0.5
    x0, y0 = dr.floor(x), dr.floor(y)
    fx, fy = x - x0, y - y0
    wi, hi = Int(w), Int(h)
    i0, j0 = Int(x0), Int(y0)
    i0 = dr.clip(dr.select(i0 < 0, i0 + wi, dr.select(i0 >= wi, i0 - wi, i0)), 0, wi - 1)  # never outside
    j0 = dr.clip(dr.select(j0 < 0, j0 + hi, dr.select(j0 >= hi, j0 - hi, j0)), 0, hi - 1)
    i1 = dr.select(i0 + 1 >= wi, 0, i0 + 1)
    j1 = dr.select(j0 + 1 >= hi, 0, j0 + 1)
    ArrayXf = _array_x(mi)
    acc = [Float(0.0) for _ in CHANNELS]
    for j, wj in ((j0, 1.0 - fy), (j1, fy)):
        for i, wi_ in ((i0, 1.0 - fx), (i1, fx)):
            pk = dr.gather(ArrayXf, up.data, off + UInt(j) * w + UInt(i), active, shape=(_STRIDE, 1))
            wt = wj * wi_
            for c in range(len(CHANNELS)):
                acc[c] = dr.fma(wt, pk[c], acc[c])
    return acc


def sample(mi: Any, up: MapUpload, uv: Any, lv: Any, active: Any) -> list[Any]:
    """The six values at the lanes' UVs and levels, by the upload's ``map_filter`` (see the module's description)."""
    import drjit as dr

    from ._btf_jit import fraction

    ru, rv, ou, ov = up.transform
    tu = fraction(dr, uv.x, ru, ou)  # the texture coordinate, and 1 - the v one (row 0 at the top), in float64
    tv = fraction(dr, uv.y, -rv, 1.0 - ov)
    UInt = mi.UInt32
    if up.map_filter == "none":
        return _bilinear(mi, up, tu, tv, UInt(0), active)
    fl = dr.floor(lv)
    l0 = UInt(fl)
    l1 = dr.minimum(l0 + 1, up.n_levels - 1)
    f = lv - fl
    if up.map_filter == "stochastic":
        return _bilinear(mi, up, tu, tv, dr.select(level_choice(mi, uv) < f, l1, l0), active)
    a = _bilinear(mi, up, tu, tv, l0, active)
    b = _bilinear(mi, up, tu, tv, l1, active & (f > 0.0))
    return [dr.fma(f, y - x, x) for x, y in zip(a, b, strict=True)]


def level_choice(mi: Any, uv: Any) -> Any:
    """A uniform in [0, 1) per lane from the UV's bits (the CD-BTF's TEA hash of ``(v, u)``: not its texel's)."""
    from ._btf_jit import texel_choice

    return texel_choice(mi, mi.Point2f(uv.y, uv.x))[0]


def detail(dr: Any, values: list[Any], uv_scale: tuple[float, float], hand: Any) -> tuple[Any, ...]:
    """``(p, q, kxx, kxy, kyy)`` in the shading frame: the texel values at ``uv_scale``, ``hand`` = +-1."""
    su, sv = uv_scale
    p, q, dpdu, dpdv, dqdu, dqdv = values
    return p, q * hand, dpdu * (1.0 / su), (dpdv * (0.5 / sv) + dqdu * (0.5 / su)) * hand, dqdv * (1.0 / sv)


def handedness(mi: Any, dr: Any, si: Any) -> Any:
    """+1 where dP/dv points along ``t = n x s`` of the shading frame, -1 on a mirrored UV layout."""
    return dr.select(dr.dot(si.dp_dv, si.sh_frame.t) < 0.0, -1.0, 1.0)


class Frame(NamedTuple):
    """A perturbed shading frame: its axes in the local coordinates of ``si.sh_frame``."""

    s: Any
    t: Any
    n: Any

    def to_local(self, dr: Any, mi: Any, v: Any) -> Any:
        return mi.Vector3f(dr.dot(v, self.s), dr.dot(v, self.t), dr.dot(v, self.n))

    def to_shading(self, mi: Any, v: Any) -> Any:
        return self.s * v.x + self.t * v.y + self.n * v.z


def frame(mi: Any, dr: Any, p: Any, q: Any, wi: Any) -> Frame:
    """The frame of the normal ``(p, q, 1)`` (shading-frame coordinates), as Mitsuba's ``normalmap`` builds it."""
    n = dr.normalize(mi.Vector3f(p, q, 1.0))
    flip = wi.z * dr.dot(wi, n) <= 0.0
    n = mi.Vector3f(dr.select(flip, -n.x, n.x), dr.select(flip, -n.y, n.y), n.z)
    s = dr.normalize(mi.Vector3f(1.0 - n.x * n.x, -n.x * n.y, -n.x * n.z))
    return Frame(s, dr.cross(n, s), n)


def principal(dr: Any, sxx: Any, sxy: Any, syy: Any) -> Any:
    """The eigenvalue of larger magnitude of ``[[sxx, sxy], [sxy, syy]]`` (the rule of the mesh package)."""
    mean = 0.5 * (sxx + syy)
    half = dr.sqrt(dr.fma(0.25 * (sxx - syy), sxx - syy, sxy * sxy))
    return dr.select(mean >= 0.0, mean + half, mean - half)


def scalar_values(cmap: CurvatureMap, u: float, v: float, lv: float, map_filter: str) -> list[float]:
    """The six values at one point (scalar variants): :func:`cdbrdf.mesh.curvature_map.lookup`, trilinear
    for ``stochastic`` too (its expected value)."""
    from ..mesh.curvature_map import lookup

    g = lookup(cmap, u, v, 0.0 if map_filter == "none" else lv)
    return [float(x) for x in np.asarray(g).reshape(-1)]


class SurfaceMap:
    """The plug-in's curvature map: its settings, its device copy, its lookup at a hit (any variant).

    Parameters
    ----------
    source
        The map, or a baker of a map file at a UV scale.
    uv_scale
        Mm per UV unit, or None until known (:meth:`set_uv_scale`: a scene's
        loader detects it from the shape).
    neighbourhood_mm
        The curvature's neighbourhood: the finest level used.
    pixel_angle
        The camera's angle per pixel (radians; 0: the neighbourhood alone).
    map_filter
        One of :data:`cdbrdf.mesh.curvature_map.MAP_FILTERS`.
    shading
        Whether the map tilts the shading normal.
    """

    def __init__(self, source: Any, *, uv_scale: tuple[float, float] | None, neighbourhood_mm: float,
                 pixel_angle: float, map_filter: str, shading: bool) -> None:
        self._source = source
        self.cmap: CurvatureMap | None = source if isinstance(source, CurvatureMap) else None
        self.name = self.cmap.name if self.cmap is not None else str(getattr(source, "map_name", "map"))
        self.neighbourhood_mm = float(neighbourhood_mm)
        self.pixel_angle = float(pixel_angle)
        self.pixel_angle_given = self.pixel_angle > 0
        self.map_filter = map_filter
        self.shading = bool(shading)
        self.uv_scale: tuple[float, float] | None = None
        self.min_level = 0.0
        self.up: MapUpload | None = None
        if uv_scale is not None:
            self.set_uv_scale(uv_scale)

    def set_uv_scale(self, uv_scale: tuple[float, float]) -> None:
        """Fix the UV scale (mm per UV unit), bake a map file at it, and the finest level.

        A map baked at another scale (a height map's, a mesh bake's) is refused.
        """
        from ..errors import OptionError
        from ..mesh.curvature_map import neighbourhood_level

        pair = (float(uv_scale[0]), float(uv_scale[1]))
        self.cmap = self._source if isinstance(self._source, CurvatureMap) else self._source(pair)
        baked = self.cmap.uv_scale
        if baked is not None and not np.allclose(baked, pair, rtol=1e-5):
            raise OptionError(f"cdbrdf BSDF: {self.cmap.name} was baked at {baked[0]:g}, {baked[1]:g} mm per UV unit; "
                              f"uv_scale is {pair[0]:g}, {pair[1]:g}")
        self.uv_scale = pair
        self.cmap = self.cmap.coarser(int(neighbourhood_level(self.cmap, pair, self.neighbourhood_mm)))
        self.min_level = neighbourhood_level(self.cmap, pair, self.neighbourhood_mm)
        self.up = None

    def values(self, mi: Any, si: Any, active: Any, scalar: bool) -> list[Any]:
        """The map's six values at ``si`` (its level from the footprint)."""
        import drjit as dr

        from ..errors import SceneError

        if self.uv_scale is None or self.cmap is None:
            raise SceneError(f"cdbrdf BSDF: the UV scale of {self.name} is unknown; give 'uv_scale' (mm per "
                             "UV unit) or load the scene with cdbrdf.render.load_file, which detects it")
        c = self.cmap
        lv = level(dr, si, c.texels, c.transform, c.n_levels, self.min_level, self.pixel_angle)
        if scalar:
            return scalar_values(c, float(si.uv.x), float(si.uv.y), float(lv), self.map_filter)
        if self.up is None:
            self.up = upload(mi, c, uv_scale=self.uv_scale, min_level=self.min_level, map_filter=self.map_filter)
        return sample(mi, self.up, si.uv, lv, active)


def surface_from_props(get: Any, extras: dict[str, Any], resolve: Any, *, neighbourhood_mm: float,
                       uv_scale: tuple[float, float] | None) -> SurfaceMap | None:
    """The plug-in's :class:`SurfaceMap` from its parameters (``get(key, default)``), or None without a map.

    ``curvature_map`` (a :class:`~cdbrdf.mesh.CurvatureMap`, from Python),
    ``normal_map`` or ``height_map`` (files found through ``resolve``; baked
    when the UV scale is known, since a height map's slopes and a
    ``map_size`` depend on it).
    """
    from ..errors import OptionError
    from ..mesh.curvature_map import MAP_FILTERS

    cmap = extras.get("curvature_map")
    nfile, hfile = get("normal_map"), get("height_map")
    given = [k for k, x in (("curvature_map", cmap), ("normal_map", nfile), ("height_map", hfile)) if x is not None]
    if not given:
        # pixel_angle serves a CD-BTF's footprint too; the others only a map
        stray = [k for k in MAP_PARAMETERS if k not in ("curvature_map", "normal_map", "neighbourhood", "pixel_angle")
                 and get(k) is not None]
        if stray:
            raise OptionError(f"cdbrdf BSDF: {stray[0]} is for a map; give normal_map, height_map or curvature_map")
        return None
    if len(given) > 1:
        raise OptionError(f"cdbrdf BSDF: give one of curvature_map, normal_map, height_map (got {', '.join(given)})")
    if cmap is not None and not isinstance(cmap, CurvatureMap):
        raise OptionError(f"cdbrdf BSDF: curvature_map must be a cdbrdf.mesh.CurvatureMap, got {type(cmap).__name__}")
    map_filter = str(get("map_filter", MAP_FILTERS[0]))
    if map_filter not in MAP_FILTERS:
        raise OptionError(f"cdbrdf BSDF: map_filter {map_filter!r} is not one of {', '.join(MAP_FILTERS)}")
    nb = float(get("neighbourhood", neighbourhood_mm))
    pa = float(get("pixel_angle", 0.0))
    if not (math.isfinite(nb) and nb > 0 and math.isfinite(pa) and pa >= 0):
        raise OptionError(f"cdbrdf BSDF: neighbourhood (mm) must be > 0 and pixel_angle (radians) >= 0, got {nb}, {pa}")
    source: Any = cmap
    if cmap is None:
        source = _file_source(get, resolve, nfile, hfile)
    return SurfaceMap(source, uv_scale=uv_scale, neighbourhood_mm=nb, pixel_angle=pa, map_filter=map_filter,
                      shading=bool(get("shading_normals", True)))


def _file_source(get: Any, resolve: Any, nfile: Any, hfile: Any) -> Any:
    """A baker of the map file at a UV scale (``uv_scale -> CurvatureMap``)."""
    import os

    from ..errors import OptionError
    from ..mesh import bake_height_map, bake_normal_map, read_height_map, read_normal_map
    from ._btf_jit import as_pair

    name = str(nfile if nfile is not None else hfile)
    path = str(resolve(name))
    if not os.path.isfile(path):
        raise FileNotFoundError(f"cdbrdf BSDF: map file {name!r} not found (looked next to the scene file and in the "
                                "folders of Mitsuba's file resolver)")
    size = get("map_size")
    size_mm = None if size is None else as_pair("map_size", size)
    if nfile is not None:
        nm = read_normal_map(path, convention=str(get("normal_map_convention", "opengl")))
    else:
        hm = read_height_map(path)
        scale = get("height_scale")
        if scale is None:
            raise OptionError(f"cdbrdf BSDF: height_map {name!r} needs its height_scale (mm per unit of its values)")

    def bake(uv_scale: tuple[float, float]) -> CurvatureMap:
        tr = None if size_mm is None else (uv_scale[0] / size_mm[0], uv_scale[1] / size_mm[1], 0.0, 0.0)
        if nfile is not None:
            return bake_normal_map(nm, transform=tr)
        return bake_height_map(hm, height_scale_mm=float(scale), uv_scale=uv_scale, transform=tr)

    bake.map_name = path  # type: ignore[attr-defined]
    return bake
