"""The ``cdbrdf`` plug-in's variant-independent core: its settings, its table, the lookup and sampling rules.

:class:`BSDFCore` is everything the plug-in does whatever Mitsuba's variant:
it reads and checks its parameters (:data:`cdbrdf.render._params.PARAMETERS`,
:class:`Settings`), holds the table (its prepared grid, the importance
sampler's tables, a CD-BTF and a curvature map), finds the curvature and the
frame the table is read in at a hit, and implements Mitsuba's BSDF interface
(``eval``, ``pdf``, ``sample``, ...) on those. What differs per variant is a
thin layer (:mod:`cdbrdf.render._bsdf`): where the table lives (on the device
for the vectorised variants, in NumPy for the scalar ones), the lookup and
the sampler's kernels; the colour record (``rgb``, ``spectral``, ``one``)
follows from the variant's colour kind. The layer sets the class attributes
``_mi``, ``_dr`` (the modules), ``_colour`` and ``_ad``.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from types import SimpleNamespace
from typing import Any

import numpy as np

from ..errors import OptionError, TableError
from ..grid import Grid
from ..interp import LookupGrid, prepare
from ..mesh import CURVATURE_MODES, curvature_mode
from ..mesh.attributes import SHAPE_MESH_ATTRIBUTE
from . import _lookup_jit as lj
from . import _sampling
from ._params import PARAMETERS
from ._units import scene_units

__all__ = ["MODES", "SAMPLINGS", "STORAGES", "DEFAULT_CURVATURE_ATTRIBUTE", "Settings", "BSDFCore", "load_source",
           "load_table"]

#: Valid values of the ``mode`` parameter.
MODES: tuple[str, ...] = ("cdbrdf", "brdf")

#: Valid values of the ``sampling`` parameter.
SAMPLINGS: tuple[str, ...] = ("table", "cosine")

#: Valid values of ``storage``: how the table is held on the device (``auto``:
#: ``packed`` RGB fixed point; ``float`` when a gradient is requested, in spectral variants, or
#: when the table's dynamic range is too large for the fixed point, see
#: :func:`cdbrdf.render._lookup_jit.packing_is_fine`).
STORAGES: tuple[str, ...] = ("auto", "packed", "float")

#: Default name of the per-vertex curvature attribute (mm^-1).
DEFAULT_CURVATURE_ATTRIBUTE = CURVATURE_MODES["max"].mitsuba_attribute

_RAD2DEG = 180.0 / math.pi


def load_table(source: Any) -> Any:
    """A :class:`~cdbrdf.table.CDBRDF` from a table object or a file path (a CD-BTF gives its tile mean)."""
    return load_source(source)[0]


def load_source(source: Any) -> tuple[Any, Any]:
    """``(table, btf)``: a CDBRDF and None, or a CD-BTF's tile mean and the :class:`~cdbrdf.CDBTF`."""
    from ..btf import CDBTF
    from ..sources import open_source
    from ..table import CDBRDF

    if not isinstance(source, (CDBRDF, CDBTF, str, os.PathLike)):
        raise TypeError(f"cdbrdf BSDF: expected a CDBRDF or CDBTF table or a file name, got {type(source).__name__}")
    s = open_source(source)
    return s.flat, s.btf


def _choice(name: str, value: Any, choices: tuple[str, ...] | Mapping[str, Any]) -> str:
    v = str(value)
    if v not in choices:
        raise OptionError(f"cdbrdf BSDF: {name} {v!r} is not one of {', '.join(choices)}")
    return v


def _curvature(curvature: Any, curvature_mode_: Any) -> tuple[str | None, float]:
    """The attribute read (None for a constant) and the constant curvature, of ``curvature``/``curvature_mode``."""
    if curvature is not None and curvature_mode_ is not None:
        raise OptionError("cdbrdf BSDF: give either 'curvature' (an attribute name or a constant) or "
                          "'curvature_mode', not both")
    if curvature is None:
        return curvature_mode(str(curvature_mode_ or "max"), what="cdbrdf BSDF: curvature_mode").mitsuba_attribute, 0.0
    if isinstance(curvature, str):
        name = curvature.strip()
        if not name:
            raise OptionError("cdbrdf BSDF: curvature attribute name is empty")
        try:
            k = float(name)
        except ValueError:
            return name, 0.0
    else:
        k = float(curvature)
    if not math.isfinite(k):
        raise OptionError(f"cdbrdf BSDF: constant curvature must be finite, got {curvature}")
    return None, k


@dataclass(frozen=True)
class Settings:
    """The plug-in's parameters other than the table and ``scale``, validated.

    Attributes
    ----------
    mode
        One of :data:`MODES`.
    curvature_attribute
        Mesh attribute holding the curvature, or None for a constant.
    kappa_const
        The constant curvature (mm^-1) when ``curvature_attribute`` is None.
    curvature_scale
        Factor applied to the attribute's values (a shape's ``to_world`` scale
        and the scene unit, set by :func:`cdbrdf.render.load_file`).
    sampling
        One of :data:`SAMPLINGS`.
    cosine_weight
        Share of cosine sampling in the table sampler's mixture, in (0, 1].
    storage
        One of :data:`STORAGES`.
    """

    mode: str = "cdbrdf"
    curvature_attribute: str | None = DEFAULT_CURVATURE_ATTRIBUTE
    kappa_const: float = 0.0
    curvature_scale: float = 1.0
    sampling: str = "table"
    cosine_weight: float = _sampling.DEFAULT_COSINE_WEIGHT
    storage: str = "auto"

    @classmethod
    def parse(cls, *, mode: Any = "cdbrdf", curvature: Any = None, curvature_mode: Any = None,
              curvature_scale: Any = 1.0, sampling: Any = "table", cosine_weight: Any = None,
              storage: Any = "auto") -> Settings:
        """Validate parameters as Mitsuba or a dict gives them (strings, floats)."""
        mode = _choice("mode", mode, MODES)
        sampling = _choice("sampling", sampling, SAMPLINGS)
        storage = _choice("storage", storage, STORAGES)
        attr, k = _curvature(curvature, curvature_mode)
        cs = float(curvature_scale)
        if not (math.isfinite(cs) and cs > 0.0):
            raise OptionError(f"cdbrdf BSDF: curvature_scale must be finite and > 0, got {curvature_scale}")
        cw = _sampling.DEFAULT_COSINE_WEIGHT if cosine_weight is None else float(cosine_weight)
        if not (0.0 < cw <= 1.0):
            raise OptionError(f"cdbrdf BSDF: cosine_weight must lie in (0, 1], got {cosine_weight}")
        if mode == "brdf":
            # The plain BRDF does not depend on curvature: never read the attribute.
            attr, k = None, 0.0
        return cls(mode, attr, k, cs, sampling, cw, storage)


class _Prepared:
    """A table's axes and current values, prepared for lookup (what :func:`cdbrdf.interp.evaluate` needs)."""

    def __init__(self, grid: Grid, values: np.ndarray) -> None:
        self.grid = grid
        self.values = values
        self._lookup = prepare(grid, values)

    def lookup_grid(self) -> LookupGrid:
        return self._lookup


def _getter(props: Any, extras: dict[str, Any]) -> Callable[..., Any]:
    """``get(name, default)``: a parameter of :data:`PARAMETERS`, Python values first, then Mitsuba's."""

    def get(key: str, default: Any = None) -> Any:
        if key not in PARAMETERS:
            raise KeyError(f"cdbrdf BSDF: {key!r} is not a parameter of the plug-in's registry")
        return extras[key] if key in extras else props[key] if key in props else default

    return get


class BSDFCore:
    """The plug-in's code for every variant (see the module's description); mixed into the variant's class."""

    _mi: Any
    _dr: Any
    _colour: str
    _ad: bool
    packed: Any  # the vectorised layer's table on the device

    # -- set-up ---------------------------------------------------------------------------------------
    def _setup(self, props: Any, table: Any, extras: dict[str, Any]) -> None:
        """Read the parameters, load the table (``filename`` or ``table``) and put it where the variant holds it."""
        mi = self._mi
        self.btf: Any
        self.filename: str | None = None
        if table is None:
            table = self._load_file(props)
        else:
            table, self.btf = load_source(table)
        get = _getter(props, extras)
        self.units = scene_units(get("unit", "mm"))
        #: whether cdbrdf's loaders applied the scene's unit with the shapes' to_world scales
        self.scene_scale_applied = bool(get("scene_scale_applied", False))
        self.settings = Settings.parse(
            mode=get("mode", "cdbrdf"), curvature=get("curvature"), curvature_mode=get("curvature_mode"),
            curvature_scale=get("curvature_scale", 1.0), sampling=get("sampling", "table"),
            cosine_weight=get("cosine_weight"), storage=get("storage", "auto"))
        if table.n_channels not in (1, 3):
            raise TableError(f"cdbrdf BSDF: the table has {table.n_channels} channels; the renderer needs 1 or 3")
        self.table = table
        self._eval_table = table.brdf() if self.settings.mode == "brdf" else table
        lj.check_range(self._eval_table.values)
        self._reflectance_scale(props)
        self.record = ("one" if self._colour == "mono" or table.n_channels == 1
                       else "spectral" if self._colour == "spectral" else "rgb")
        if self.settings.storage == "packed" and self.record == "spectral":
            raise OptionError("cdbrdf BSDF: storage 'packed' holds RGB or grey values; spectral variants "
                              "use 'float' (or 'auto')")
        self.values = mi.TensorXf(np.ascontiguousarray(self._eval_table.values, dtype=np.float32))
        self._maps: Any = None
        self._upload(np.asarray(self._eval_table.values, dtype=np.float64), differentiable=False)
        self.texels: Any = None
        uv_scale = get("uv_scale")
        if self.btf is not None:
            from ._btf_jit import DEFAULT_TEXEL_FILTER

            self._upload_btf(1.0 if uv_scale is None else uv_scale, get("texel_filter", DEFAULT_TEXEL_FILTER),
                             float(get("pixel_angle", 0.0)))
        self.surface = self._surface_map(get, extras, uv_scale)
        flags = (mi.BSDFFlags.DiffuseReflection | mi.BSDFFlags.FrontSide | mi.BSDFFlags.BackSide
                 | mi.BSDFFlags.Anisotropic)
        self.m_components = [flags]
        self.m_flags = flags

    def _load_file(self, props: Any) -> Any:
        """The table of the ``filename`` parameter, found through Mitsuba's file resolver."""
        if "filename" not in props:
            raise OptionError("cdbrdf BSDF: give 'filename' (a CDBRDF file), or build the BSDF from a table with "
                              "cdbrdf.render.make_bsdf(table)")
        name = str(props["filename"])
        path = self._mi.file_resolver().resolve(name)
        if not os.path.isfile(str(path)):
            raise FileNotFoundError(f"cdbrdf BSDF: table file {name!r} not found (looked next to the scene file and "
                                    "in the folders of Mitsuba's file resolver)")
        table, self.btf = load_source(str(path))
        self.filename = str(path)
        return table

    def _reflectance_scale(self, props: Any) -> None:
        """The ``scale`` parameter: a number (``self.scale``) or a texture (``self.scale_texture``)."""
        mi = self._mi
        self.scale_texture = None
        self.scale = mi.Float(1.0)
        if "scale" not in props:
            return
        if props.type("scale") in (mi.Properties.Type.Float, mi.Properties.Type.Integer):
            s = float(props["scale"])
            if not (math.isfinite(s) and s >= 0):
                raise OptionError(f"cdbrdf BSDF: scale must be finite and >= 0, got {s}")
            self.scale = mi.Float(s)
        else:
            self.scale_texture = props.get_texture("scale")

    # -- settings as attributes (read by check_scene and the tests) -----------------------------------
    @property
    def mode(self) -> str:
        return self.settings.mode

    @property
    def curvature_attribute(self) -> str | None:
        return self.settings.curvature_attribute

    @property
    def kappa_const(self) -> float:
        return self.settings.kappa_const

    @property
    def sampling(self) -> str:
        return self.settings.sampling

    # -- the table --------------------------------------------------------------------------------------
    def _upload(self, values: np.ndarray, *, differentiable: bool) -> None:
        """(Re)build the prepared table and the sampler from raw ``values``; the layer puts them where it reads them."""
        if not np.all(np.isfinite(values)):
            raise TableError("cdbrdf BSDF: the table values are not all finite")
        lj.check_range(values)
        self.prepared = _Prepared(self._eval_table.grid, values)
        self.grid = self.prepared.lookup_grid()
        self.sampler_tables: _sampling.SamplerTables | None = (
            _sampling.build_sampler(self.grid) if self.settings.sampling == "table" else None)
        self._hold_table(values, differentiable)

    def _upload_btf(self, uv_scale: Any, texel_filter: Any, pixel_angle: float) -> None:
        """A CD-BTF: its UV scale, texel filter and footprint; the layer holds its texels (:mod:`._btf_jit`)."""
        from . import _btf_jit

        self.uv_scale = _btf_jit.as_pair("uv_scale", uv_scale)
        if not (math.isfinite(pixel_angle) and pixel_angle >= 0.0):
            raise OptionError(f"cdbrdf BSDF: pixel_angle must be finite and >= 0 (radians), got {pixel_angle}")
        self.pixel_angle = pixel_angle
        self.texel_filter = _choice("texel_filter", texel_filter, _btf_jit.TEXEL_FILTERS)
        self._texel_cache: dict[tuple[int, int], tuple[LookupGrid, np.ndarray]] = {}
        self._hold_texels()

    def traverse(self, callback: Any) -> None:
        callback.put("values", self.values, self._mi.ParamFlags.Differentiable)
        scale = self.scale_texture if self.scale_texture is not None else self.scale
        callback.put("scale", scale, self._mi.ParamFlags.Differentiable)

    def parameters_changed(self, keys: Any = None) -> None:
        if keys and "values" not in keys:
            return
        if self.btf is not None:
            raise OptionError("cdbrdf BSDF: the texels of a CD-BTF cannot be changed through 'values'")
        shape = tuple(self._eval_table.values.shape)
        if tuple(self.values.shape) != shape:
            raise TableError(f"cdbrdf BSDF: 'values' must keep the table's shape {shape}, "
                             f"got {tuple(self.values.shape)}")
        grad = self._ad and bool(self._dr.grad_enabled(self.values))
        host = np.asarray(self._dr.detach(self.values), dtype=np.float64).reshape(shape)
        self._upload(host, differentiable=grad)

    # -- the curvature and the frame at a hit -------------------------------------------------------------
    def _kappa(self, si: Any, active: Any) -> Any:
        st = self.settings
        if st.curvature_attribute is None:
            return self._mi.Float(st.kappa_const)
        k = si.shape.eval_attribute_1(st.curvature_attribute, si, active)
        return k * st.curvature_scale if st.curvature_scale != 1.0 else k

    def _clamped(self, kappa: Any) -> Any:
        """Any curvature as the lookup takes it: NaN (a damaged attribute) as 0, else clamped to the axis.

        The table's rule clamps too; clamping here first keeps every
        value the kernels see (lookup and sampler) a finite number
        inside the axis, whatever a mesh, a scale or a unit made of it.
        """
        dr = self._dr
        k = dr.select(dr.isnan(kappa), 0.0, kappa)
        return dr.clip(k, float(self.grid.kappa[0]), float(self.grid.kappa[-1]))

    def _surface_map(self, get: Any, extras: dict[str, Any], uv_scale: Any) -> Any:
        """The curvature map of the parameters (:mod:`cdbrdf.render._maps_jit`), or None."""
        from ..mesh.curvature import neighbourhood_from_table
        from . import _maps_jit
        from ._btf_jit import as_pair

        nb, _ = neighbourhood_from_table(getattr(self.table, "attrs", None))
        pair = None if uv_scale is None else as_pair("uv_scale", uv_scale)
        m = _maps_jit.surface_from_props(get, extras, lambda n: self._mi.file_resolver().resolve(n),
                                         neighbourhood_mm=nb, uv_scale=pair)
        attr = self.settings.curvature_attribute
        modes = {c.mitsuba_attribute: c.name for c in CURVATURE_MODES.values()}
        if m is not None and attr is not None and attr not in modes:
            raise OptionError(f"cdbrdf BSDF: a curvature map adds to the mesh's shape operator "
                              f"({SHAPE_MESH_ATTRIBUTE}); the curvature attribute {attr!r} cannot be combined "
                              "with it")
        self.map_mode = modes.get(attr or "", "max")
        c = get("curvature")  # a constant curvature (the rule of Settings.parse); else the mesh's, in either mode
        self._mesh_shape = c is None or Settings.parse(curvature=c).curvature_attribute is not None
        return m

    def _shading(self, si: Any, active: Any) -> tuple[Any, Any, Any]:
        """The view direction in the frame the table sees (a map tilts it), the curvature, that frame (or None)."""
        if self.surface is None:
            return si.wi, self._kappa(si, active), None
        from . import _maps_jit as mj

        p, q, *k3 = self._map_detail(si, active)
        k = self._mi.Float(0.0) if self.settings.mode == "brdf" else self._with_mesh(si, active, k3, self.map_mode)
        if not self.surface.shading:
            return si.wi, k, None
        fr = mj.frame(self._mi, self._dr, p, q, si.wi)
        return fr.to_local(self._dr, self._mi, si.wi), k, fr

    def _map_detail(self, si: Any, active: Any) -> tuple[Any, ...]:
        """The map's ``(p, q, kxx, kxy, kyy)`` at ``si`` in the shading frame (:mod:`cdbrdf.render._maps_jit`)."""
        from . import _maps_jit as mj

        vals = self.surface.values(self._mi, si, active, self._scalar)
        return mj.detail(self._dr, vals, self.surface.uv_scale, mj.handedness(self._mi, self._dr, si))

    def _with_mesh(self, si: Any, active: Any, k3: list[Any], mode: str) -> Any:
        """The curvature of the mesh's shape operator plus the map's ``(kxx, kxy, kyy)``, by ``mode``."""
        from . import _maps_jit as mj

        st, mi = self.settings, self._mi
        if self._mesh_shape:
            a = si.shape.eval_attribute_3(SHAPE_MESH_ATTRIBUTE, si, active)
            mesh = [a.x * st.curvature_scale, a.y * st.curvature_scale, a.z * st.curvature_scale]
        else:  # a constant: a cylinder bent along x
            mesh = [mi.Float(st.kappa_const), mi.Float(0.0), mi.Float(0.0)]
        sxx, sxy, syy = (m + k for m, k in zip(mesh, k3, strict=True))
        return sxx if mode == "directional" else mj.principal(self._dr, sxx, sxy, syy)

    def curvature_at(self, si: Any, active: Any = True, mode: str | None = None) -> Any:
        """The curvature (mm^-1) at ``si`` relative to its shading normal, a map's added, before clamping.

        ``mode``: ``"max"`` or ``"directional"`` (default: the plug-in's),
        in either render mode (the plain BRDF renders without it).
        """
        if self.surface is None:
            return self._kappa(si, active)
        return self._with_mesh(si, active, list(self._map_detail(si, active)[2:]), mode or self.map_mode)

    def _front(self, si: Any, active: Any) -> tuple[Any, Any, Any, Any]:
        """The view direction in the front frame (turned about x on the back side), the side's sign, kappa, the
        map's frame (None without one)."""
        wi0, k, fr = self._shading(si, active)
        sign = self._dr.select(wi0.z < 0.0, -1.0, 1.0)
        wi = self._mi.Vector3f(wi0.x, sign * wi0.y, sign * wi0.z)
        return wi, sign, self._clamped(sign * k), fr

    # -- the table at a query -------------------------------------------------------------------------------
    def _scale(self, si: Any, active: Any) -> Any:
        if self.scale_texture is not None:
            return self.scale_texture.eval(si, active)
        return self.scale

    def _f(self, si: Any, tv: Any, pv: Any, tl: Any, pl: Any, kappa: Any, valid: Any) -> Any:
        """The table at view (tv, pv) and light (tl, pl) (front frame, degrees), as a spectrum, times ``scale``."""
        return self._lookup(si, tv, pv, tl, pl, kappa, valid) * self._scale(si, valid)

    def _angles(self, d: Any) -> tuple[Any, Any]:
        dr = self._dr
        return (dr.acos(dr.clip(d.z, -1.0, 1.0)) * _RAD2DEG, dr.atan2(d.y, d.x) * _RAD2DEG)

    def _query(self, ctx: Any, si: Any, wo: Any, active: Any) -> SimpleNamespace:
        mi, dr = self._mi, self._dr
        wi, sign, kappa, fr = self._front(si, active)
        valid = active & (wi.z > 0.0)
        if fr is not None:  # in the map's frame; not where it and the shading frame disagree (as normalmap)
            w = fr.to_local(dr, mi, wo)
            valid = valid & (wo.z * w.z > 0.0)
            wo = w
        wl = mi.Vector3f(wo.x, sign * wo.y, sign * wo.z)
        valid = valid & (wl.z > 0.0)
        tv, pv = self._angles(wi)
        tl, pl = self._angles(wl)
        return SimpleNamespace(wi=wi, wl=wl, sign=sign, kappa=kappa, valid=valid, tv=tv, pv=pv, tl=tl, pl=pl,
                               importance=self._importance(ctx), frame=fr)

    def _importance(self, ctx: Any) -> bool:
        return ctx is not None and ctx.mode == self._mi.TransportMode.Importance

    def _value(self, si: Any, q: SimpleNamespace) -> Any:
        """eval: f * cos(theta_l), with view and light swapped in importance transport."""
        if q.importance:
            f = self._f(si, q.tl, q.pl, q.tv, q.pv, q.kappa, q.valid)
        else:
            f = self._f(si, q.tv, q.pv, q.tl, q.pl, q.kappa, q.valid)
        return self._dr.select(q.valid, f * q.wl.z, 0.0)

    # -- sampling: the table's sampler (the layer's kernels), else cosine ------------------------------------
    def _table_sampling(self, q: SimpleNamespace) -> bool:
        return self.sampler_tables is not None and not q.importance

    def _pdf(self, q: SimpleNamespace, cond: Any) -> Any:
        if not self._table_sampling(q):
            return self._dr.select(q.valid, self._mi.warp.square_to_cosine_hemisphere_pdf(q.wl), 0.0)
        return self._table_pdf(q, cond)

    def _conditioning(self, q: SimpleNamespace, active: Any) -> Any:
        if not self._table_sampling(q):
            return None
        return self._table_conditioning(q, active)

    def _sample(self, ctx: Any, si: Any, view: SimpleNamespace, sample1: Any, sample2: Any, active: Any,
                cond: Any) -> tuple[Any, Any]:
        """Sample the light direction for the view of ``view`` (``wi, sign, kappa, tv, pv, frame``)."""
        mi, dr = self._mi, self._dr
        sign = view.sign
        q = SimpleNamespace(wi=view.wi, sign=sign, kappa=view.kappa, tv=view.tv, pv=view.pv,
                            importance=self._importance(ctx))
        ok = active & (view.wi.z > 0.0)
        if not self._table_sampling(q):
            wl = mi.warp.square_to_cosine_hemisphere(sample2)
        else:
            wl, cond = self._table_sample(q, sample1, sample2, ok, cond)
        q.wl = wl
        q.valid = ok & (wl.z > 0.0)
        wo = mi.Vector3f(wl.x, sign * wl.y, sign * wl.z)
        if view.frame is not None:  # back to the shading frame
            w = view.frame.to_shading(mi, wo)
            q.valid = q.valid & (w.z * wo.z > 0.0)
            wo = w
        q.tl, q.pl = self._angles(wl)
        pdf = self._pdf(q, cond)
        q.valid = q.valid & (pdf > 0.0)
        value = self._value(si, q)
        bs = dr.zeros(mi.BSDFSample3f)
        bs.wo = wo
        bs.pdf = dr.select(q.valid, pdf, 0.0)
        bs.eta = 1.0
        bs.sampled_type = mi.UInt32(+mi.BSDFFlags.DiffuseReflection)
        bs.sampled_component = mi.UInt32(0)
        return bs, dr.select(q.valid, value / dr.select(q.valid, pdf, 1.0), 0.0)

    # -- Mitsuba's BSDF interface ----------------------------------------------------------------------------
    def eval(self, ctx: Any, si: Any, wo: Any, active: Any = True) -> Any:
        return self._value(si, self._query(ctx, si, wo, active))

    def pdf(self, ctx: Any, si: Any, wo: Any, active: Any = True) -> Any:
        q = self._query(ctx, si, wo, active)
        return self._pdf(q, self._conditioning(q, q.valid))

    def eval_pdf(self, ctx: Any, si: Any, wo: Any, active: Any = True) -> tuple[Any, Any]:
        q = self._query(ctx, si, wo, active)
        return self._value(si, q), self._pdf(q, self._conditioning(q, q.valid))

    def sample(self, ctx: Any, si: Any, sample1: Any, sample2: Any, active: Any = True) -> tuple[Any, Any]:
        wi, sign, kappa, fr = self._front(si, active)
        tv, pv = self._angles(wi)
        q = SimpleNamespace(wi=wi, sign=sign, kappa=kappa, tv=tv, pv=pv, frame=fr)
        return self._sample(ctx, si, q, sample1, sample2, active, None)

    def eval_pdf_sample(self, ctx: Any, si: Any, wo: Any, sample1: Any, sample2: Any,
                        active: Any = True) -> tuple[Any, Any, Any, Any]:
        # One curvature read and one conditioning for the light direction and the sampled one.
        q = self._query(ctx, si, wo, active)
        ok = active & (q.wi.z > 0.0)
        cond = self._conditioning(q, ok)
        bs, value = self._sample(ctx, si, q, sample1, sample2, active, cond)
        return self._value(si, q), self._pdf(q, cond), bs, value

    def eval_diffuse_reflectance(self, si: Any, active: Any = True) -> Any:
        # Albedo-like estimate for AOVs: the table at normal incidence times pi.
        kappa = self._front(si, active)[2]
        zero = self._mi.Float(0.0)
        return self._f(si, zero, zero, zero, zero, kappa, active) * math.pi

    def to_string(self) -> str:
        st = self.settings
        k = (f"attribute {st.curvature_attribute!r} x {st.curvature_scale:g}" if st.curvature_attribute
             else f"constant {st.kappa_const:g} mm^-1")
        scale = ("texture" if self.scale_texture is not None
                 else f"{float(np.asarray(self.scale, dtype=np.float64).reshape(-1)[0]):g}")
        return (
            f"CDBRDFBSDF[material={self.table.attrs.get('material', '?')!r}, "
            f"mode={st.mode!r}, curvature={k}, scale={scale}, sampling={st.sampling!r}, "
            f"storage={getattr(self, 'packed', None) and self.packed.layout!r}, shape={self.table.shape}"
            + (f", btf={self.btf!r}, uv_scale={self.uv_scale}, texel_filter={self.texel_filter!r}"
               if self.btf is not None else "")
            + (f", map={self.surface.name!r}, map uv_scale={self.surface.uv_scale}]" if self.surface else "]")
        )

    # -- the variant's layer (:mod:`cdbrdf.render._bsdf`) -----------------------------------------------------
    _scalar: bool

    def _hold_table(self, values: np.ndarray, differentiable: bool) -> None:
        raise NotImplementedError

    def _hold_texels(self) -> None:
        raise NotImplementedError

    def _lookup(self, si: Any, tv: Any, pv: Any, tl: Any, pl: Any, kappa: Any, valid: Any) -> Any:
        raise NotImplementedError

    def _table_pdf(self, q: SimpleNamespace, cond: Any) -> Any:
        raise NotImplementedError

    def _table_conditioning(self, q: SimpleNamespace, active: Any) -> Any:
        raise NotImplementedError

    def _table_sample(self, q: SimpleNamespace, sample1: Any, sample2: Any, ok: Any, cond: Any) -> tuple[Any, Any]:
        """The sampled light direction (front frame) and the conditioning it used (None: the scalar variants)."""
        raise NotImplementedError
