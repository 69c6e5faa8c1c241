"""The ``cdbrdf`` BSDF plug-in for Mitsuba 3 (see :mod:`cdbrdf.render` and ``docs/rendering.md``).

The Python class is traced by Dr.Jit once per render in the vectorised
variants (``llvm_ad_*``, ``cuda_ad_*``): the 5-D lookup
(:func:`cdbrdf.render._lookup_jit.lookup_jit`) and the importance sampler
(:mod:`cdbrdf.render._sampling_jit`) become straight-line vector code, never
a Python call per ray. In the scalar variants (debugging only) each call
evaluates one query in NumPy with the same rules (:func:`cdbrdf.interp.evaluate`,
:func:`cdbrdf.interp.evaluate_reference`, :mod:`cdbrdf.render._sampling`).

Colour: RGB variants use the table's linear RGB; spectral variants blend the
spectra of the table samples upsampled with Mitsuba's sRGB model
(:mod:`cdbrdf.render._spectral`); mono variants use the Rec. 709 luminance.
"""

from __future__ import annotations

import logging
import math
import os
from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType, SimpleNamespace
from typing import Any, cast

import numpy as np

from ..errors import OptionError, TableError
from ..grid import Grid
from ..interp import LookupGrid, prepare
from ..mesh import ATTRIBUTES
from ..mesh.curvature_map import SHAPE_MESH_ATTRIBUTE
from . import _lookup_jit as lj
from . import _sampling
from ._units import scene_units

__all__ = [
    "CURVATURE_MODES",
    "MODES",
    "PLUGIN_NAME",
    "SAMPLINGS",
    "STORAGES",
    "SUPPORTED_VARIANTS",
    "Settings",
    "bsdf_class",
    "check_variant",
    "load_table",
]

_LOG = logging.getLogger(__name__)

#: Name under which the plug-in is registered with Mitsuba.
PLUGIN_NAME = "cdbrdf"

#: Valid values of the ``mode`` parameter.
MODES: tuple[str, ...] = ("cdbrdf", "brdf")

#: Valid values of the ``sampling`` parameter.
SAMPLINGS: tuple[str, ...] = ("table", "cosine")

#: ``curvature_mode`` -> the mesh attribute it reads (mm^-1, written by ``cdbrdf curvature``):
#: ``max`` the principal curvature of larger magnitude, signed; ``directional`` the normal
#: curvature along the material's x axis (owned by :data:`cdbrdf.mesh.ATTRIBUTES`).
CURVATURE_MODES: Mapping[str, str] = MappingProxyType(dict(ATTRIBUTES))

#: Valid values of ``storage``: how the table is held on the device (``auto``:
#: ``packed`` RGB fixed point; ``float`` when a gradient is requested, in spectral variants, or
#: when the table's dynamic range is too large for the fixed point, see
#: :func:`cdbrdf.render._lookup_jit.packing_is_fine`).
STORAGES: tuple[str, ...] = ("auto", "packed", "float")

#: Mitsuba variants the plug-in supports (those of the installed Mitsuba are
#: listed by :func:`cdbrdf.render.available_variants`); polarised variants are not.
SUPPORTED_VARIANTS: tuple[str, ...] = (
    "llvm_ad_rgb", "llvm_ad_spectral", "llvm_ad_mono",
    "cuda_ad_rgb", "cuda_ad_spectral", "cuda_ad_mono",
    "scalar_rgb", "scalar_spectral", "scalar_mono",
)

#: Default name of the per-vertex curvature attribute (mm^-1).
DEFAULT_CURVATURE_ATTRIBUTE = CURVATURE_MODES["max"]

_RAD2DEG = 180.0 / math.pi


def load_table(source: Any) -> Any:
    """A :class:`~cdbrdf.table.CDBRDF` from a table object or a file path (a CD-BTF gives its tile mean)."""
    return load_source(source)[0]


def load_source(source: Any) -> tuple[Any, Any]:
    """``(table, btf)``: a CDBRDF and None, or a CD-BTF's tile mean and the :class:`~cdbrdf.CDBTF`."""
    from ..btf import CDBTF, is_btf
    from ..btf import load as load_btf
    from ..table import CDBRDF

    if isinstance(source, CDBRDF):
        return source, None
    if isinstance(source, CDBTF):
        return source.mean(), source
    if isinstance(source, (str, os.PathLike)):
        from ..table import load

        if is_btf(source):
            btf = load_btf(source)
            return btf.mean(), btf
        return load(source), None
    raise TypeError(
        f"cdbrdf BSDF: expected a CDBRDF or CDBTF table or a file name, got {type(source).__name__}"
    )


def _choice(name: str, value: Any, choices: tuple[str, ...] | Mapping[str, str]) -> str:
    v = str(value)
    if v not in choices:
        raise OptionError(f"cdbrdf BSDF: {name} {v!r} is not one of {', '.join(choices)}")
    return v


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
        if curvature is not None and curvature_mode is not None:
            raise OptionError("cdbrdf BSDF: give either 'curvature' (an attribute name or a constant) or "
                             "'curvature_mode', not both")
        attr: str | None
        k = 0.0
        if curvature is None:
            attr = CURVATURE_MODES[_choice("curvature_mode", curvature_mode or "max", CURVATURE_MODES)]
        elif isinstance(curvature, str):
            name = curvature.strip()
            if not name:
                raise OptionError("cdbrdf BSDF: curvature attribute name is empty")
            try:
                k = float(name)
                attr = None
            except ValueError:
                attr = name
        else:
            k = float(curvature)
            attr = None
        if attr is None and not math.isfinite(k):
            raise OptionError(f"cdbrdf BSDF: constant curvature must be finite, got {curvature}")
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


# -- variants ---------------------------------------------------------------------------------
def check_variant(variant: str | None) -> str:
    """The variant's colour kind (``"rgb"``, ``"spectral"``, ``"mono"``), or a ValueError."""
    if variant is None:
        raise RuntimeError(
            "cdbrdf BSDF: no Mitsuba variant is set; call cdbrdf.render.set_variant() first"
        )
    if variant not in SUPPORTED_VARIANTS:
        raise OptionError(
            f"cdbrdf BSDF: Mitsuba variant {variant!r} is not supported; use one of "
            f"{', '.join(SUPPORTED_VARIANTS)} (polarised variants are not supported)"
        )
    return variant.split("_")[-1]


_CLASSES: dict[str, type] = {}


def bsdf_class() -> type:
    """The plug-in class for the current Mitsuba variant (created on first use)."""
    import mitsuba as mi

    variant = str(check_variant(mi.variant()) and mi.variant())
    cls = _CLASSES.get(variant)
    if cls is None:
        cls = _make_class(mi)
        _CLASSES[variant] = cls
    return cls


# -- the table as the renderer holds it ---------------------------------------------------------------
class _Prepared:
    """A table's axes and current values, prepared for lookup (what :func:`cdbrdf.interp.evaluate` needs)."""

    def __init__(self, grid: Grid, values: np.ndarray) -> None:
        self.grid = grid
        self.values = values
        self._lookup = prepare(grid, values)

    def lookup_grid(self) -> LookupGrid:
        return self._lookup


def _make_class(mi: Any) -> type:  # noqa: C901 - the plug-in is one class
    import drjit as dr

    variant = mi.variant()
    colour = check_variant(variant)
    scalar = variant.startswith("scalar")
    ad = "_ad_" in variant

    class CDBRDFBSDF(mi.BSDF):
        """Mitsuba BSDF of a curvature-dependent BRDF table (see :mod:`cdbrdf.render`)."""

        def __init__(self, props: Any, *, table: Any = None, extras: dict[str, Any] | None = None) -> None:
            mi.BSDF.__init__(self, props)
            extras = extras or {}
            if table is None:
                if "filename" not in props:
                    raise OptionError(
                        "cdbrdf BSDF: give 'filename' (a CDBRDF file), or build the "
                        "BSDF from a table with cdbrdf.render.make_bsdf(table)"
                    )
                name = str(props["filename"])
                path = mi.file_resolver().resolve(name)
                if not os.path.isfile(str(path)):
                    raise FileNotFoundError(
                        f"cdbrdf BSDF: table file {name!r} not found (looked next to the scene file and in "
                        "the folders of Mitsuba's file resolver)")
                table, self.btf = load_source(str(path))
                self.filename: str | None = str(path)
            else:
                table, self.btf = load_source(table)
                self.filename = None

            def get(key: str, default: Any = None) -> Any:  # Python values (pairs, objects) first, then Mitsuba's
                return extras[key] if key in extras else props[key] if key in props else default

            self.units = scene_units(get("unit", "mm"))
            #: whether cdbrdf's loaders applied the scene's unit with the shapes' to_world scales
            self.scene_scale_applied = bool(get("scene_scale_applied", False))
            self.settings = Settings.parse(
                mode=get("mode", "cdbrdf"), curvature=get("curvature"), curvature_mode=get("curvature_mode"),
                curvature_scale=get("curvature_scale", 1.0), sampling=get("sampling", "table"),
                cosine_weight=get("cosine_weight"), storage=get("storage", "auto"))
            if table.n_channels not in (1, 3):
                raise TableError(
                    f"cdbrdf BSDF: the table has {table.n_channels} channels; the renderer needs 1 or 3"
                )
            self.table = table
            self._eval_table = table.brdf() if self.settings.mode == "brdf" else table
            lj.check_range(self._eval_table.values)
            self.scale_texture = None
            self.scale = mi.Float(1.0)
            if "scale" in props:
                if props.type("scale") in (mi.Properties.Type.Float, mi.Properties.Type.Integer):
                    s = float(props["scale"])
                    if not (math.isfinite(s) and s >= 0):
                        raise OptionError(f"cdbrdf BSDF: scale must be finite and >= 0, got {s}")
                    self.scale = mi.Float(s)
                else:
                    self.scale_texture = props.get_texture("scale")
            self.record = ("one" if colour == "mono" or table.n_channels == 1
                           else "spectral" if colour == "spectral" else "rgb")
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
            flags = (
                mi.BSDFFlags.DiffuseReflection | mi.BSDFFlags.FrontSide
                | mi.BSDFFlags.BackSide | mi.BSDFFlags.Anisotropic
            )
            self.m_components = [flags]
            self.m_flags = flags

        # -- settings as attributes (read by check_scene and the tests) -----------------------
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

        # -- the table on the device ------------------------------------------------------------
        def _upload(self, values: np.ndarray, *, differentiable: bool) -> None:
            """(Re)build the prepared table, its device copy and the sampler from raw ``values``."""
            if not np.all(np.isfinite(values)):
                raise TableError("cdbrdf BSDF: the table values are not all finite")
            lj.check_range(values)
            self.prepared = _Prepared(self._eval_table.grid, values)
            self.grid = self.prepared.lookup_grid()
            st = self.settings
            self.sampler_tables: _sampling.SamplerTables | None = (
                _sampling.build_sampler(self.grid) if st.sampling == "table" else None)
            if scalar:
                if self.record == "spectral":
                    self._records = lj.records(self.grid.values, "spectral")
                return
            if differentiable:
                if self.record == "spectral":
                    raise OptionError("cdbrdf BSDF: gradients with respect to the table are available in the "
                                     "rgb and mono variants (spectral upsampling is not differentiable)")
                if self._maps is None:
                    g = self._eval_table.grid
                    self._maps = lj.packet_maps(values.shape, g.theta_l, g.theta_v, self.record,
                                                isotropic=self.grid.isotropic)
                self.packed = lj.linear_upload(mi, self.values.array, self._maps, self.record)
            elif (st.storage == "float" or self.record == "spectral"
                  or (st.storage == "auto" and self.record == "rgb" and not lj.packing_is_fine(self.grid.values))):
                self.packed = lj.float_table(mi, self.grid, self.record)
            else:
                self.packed = lj.pack_table(mi, self.grid, self.record)
            if self.sampler_tables is not None:
                from . import _sampling_jit

                self.sampler = _sampling_jit.upload(mi, self.sampler_tables)

        def _upload_btf(self, uv_scale: Any, texel_filter: Any, pixel_angle: float) -> None:
            """A CD-BTF: its texels on the device (:mod:`cdbrdf.render._btf_jit`); the tile mean samples."""
            from . import _btf_jit

            self.uv_scale = _btf_jit.as_pair("uv_scale", uv_scale)
            if not (math.isfinite(pixel_angle) and pixel_angle >= 0.0):
                raise OptionError(f"cdbrdf BSDF: pixel_angle must be finite and >= 0 (radians), got {pixel_angle}")
            self.texel_filter = _choice("texel_filter", texel_filter, _btf_jit.TEXEL_FILTERS)
            self._texel_cache: dict[tuple[int, int], tuple[LookupGrid, np.ndarray]] = {}
            if not scalar:
                full = self.grid if self.settings.mode == "cdbrdf" else prepare(self.btf.grid, self.btf.mean().values)
                self.texels = _btf_jit.upload(mi, self.btf, full, self.record, uv_scale=self.uv_scale,
                                              texel_filter=self.texel_filter, pixel_angle=pixel_angle,
                                              mm_per_unit=self.units.mm_per_unit)

        def traverse(self, callback: Any) -> None:
            callback.put("values", self.values, mi.ParamFlags.Differentiable)
            if self.scale_texture is not None:
                callback.put("scale", self.scale_texture, mi.ParamFlags.Differentiable)
            else:
                callback.put("scale", self.scale, mi.ParamFlags.Differentiable)

        def parameters_changed(self, keys: Any = None) -> None:
            if keys and "values" not in keys:
                return
            if self.btf is not None:
                raise OptionError("cdbrdf BSDF: the texels of a CD-BTF cannot be changed through 'values'")
            shape = tuple(self._eval_table.values.shape)
            if tuple(self.values.shape) != shape:
                raise TableError(f"cdbrdf BSDF: 'values' must keep the table's shape {shape}, "
                                 f"got {tuple(self.values.shape)}")
            grad = ad and bool(dr.grad_enabled(self.values))
            host = np.asarray(dr.detach(self.values), dtype=np.float64).reshape(shape)
            self._upload(host, differentiable=grad)

        # -- helpers ----------------------------------------------------------------------------
        def _kappa(self, si: Any, active: Any) -> Any:
            st = self.settings
            if st.curvature_attribute is None:
                return mi.Float(st.kappa_const)
            k = si.shape.eval_attribute_1(st.curvature_attribute, si, active)
            return k * st.curvature_scale if st.curvature_scale != 1.0 else k

        def _clamped(self, kappa: Any) -> Any:
            """Any curvature as the lookup takes it: NaN (a damaged attribute) as 0, else clamped to the axis.

            The table's rule clamps too; clamping here first keeps every
            value the kernels see (lookup and sampler) a finite number
            inside the axis, whatever a mesh, a scale or a unit made of it.
            """
            k = dr.select(dr.isnan(kappa), 0.0, kappa)
            return dr.clip(k, float(self.grid.kappa[0]), float(self.grid.kappa[-1]))

        def _surface_map(self, get: Any, extras: dict[str, Any], uv_scale: Any) -> Any:
            """The curvature map of the parameters (:mod:`cdbrdf.render._maps_jit`), or None."""
            from ..mesh.curvature import neighbourhood_from_table
            from . import _maps_jit
            from ._btf_jit import as_pair

            nb, _ = neighbourhood_from_table(getattr(self.table, "attrs", None))
            pair = None if uv_scale is None else as_pair("uv_scale", uv_scale)
            m = _maps_jit.surface_from_props(get, extras, lambda n: mi.file_resolver().resolve(n),
                                             neighbourhood_mm=nb, uv_scale=pair)
            attr = self.settings.curvature_attribute
            if m is not None and attr not in (None, *CURVATURE_MODES.values()):
                raise OptionError(f"cdbrdf BSDF: a curvature map adds to the mesh's shape operator "
                                  f"({SHAPE_MESH_ATTRIBUTE}); the curvature attribute {attr!r} cannot be combined "
                                  "with it")
            self.map_mode = "directional" if attr == CURVATURE_MODES["directional"] else "max"
            c = get("curvature")  # a constant curvature (the rule of Settings.parse); else the mesh's, in either mode
            self._mesh_shape = c is None or Settings.parse(curvature=c).curvature_attribute is not None
            return m

        def _shading(self, si: Any, active: Any) -> tuple[Any, Any, Any]:
            """The view direction in the frame the table sees (a map tilts it), the curvature, that frame (or None)."""
            if self.surface is None:
                return si.wi, self._kappa(si, active), None
            from . import _maps_jit as mj

            p, q, *k3 = self._map_detail(si, active)
            k = mi.Float(0.0) if self.settings.mode == "brdf" else self._with_mesh(si, active, k3, self.map_mode)
            if not self.surface.shading:
                return si.wi, k, None
            fr = mj.frame(mi, dr, p, q, si.wi)
            return fr.to_local(dr, mi, si.wi), k, fr

        def _map_detail(self, si: Any, active: Any) -> tuple[Any, ...]:
            """The map's ``(p, q, kxx, kxy, kyy)`` at ``si`` in the shading frame (:mod:`cdbrdf.render._maps_jit`)."""
            from . import _maps_jit as mj

            vals = self.surface.values(mi, si, active, scalar)
            return mj.detail(dr, vals, self.surface.uv_scale, mj.handedness(mi, dr, si))

        def _with_mesh(self, si: Any, active: Any, k3: list[Any], mode: str) -> Any:
            """The curvature of the mesh's shape operator plus the map's ``(kxx, kxy, kyy)``, by ``mode``."""
            from . import _maps_jit as mj

            st = self.settings
            if self._mesh_shape:
                a = si.shape.eval_attribute_3(SHAPE_MESH_ATTRIBUTE, si, active)
                mesh = [a.x * st.curvature_scale, a.y * st.curvature_scale, a.z * st.curvature_scale]
            else:  # a constant: a cylinder bent along x
                mesh = [mi.Float(st.kappa_const), mi.Float(0.0), mi.Float(0.0)]
            sxx, sxy, syy = (m + k for m, k in zip(mesh, k3, strict=True))
            return sxx if mode == "directional" else mj.principal(dr, sxx, sxy, syy)

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
            sign = dr.select(wi0.z < 0.0, -1.0, 1.0)
            wi = mi.Vector3f(wi0.x, sign * wi0.y, sign * wi0.z)
            return wi, sign, self._clamped(sign * k), fr

        def _scale(self, si: Any, active: Any) -> Any:
            if self.scale_texture is not None:
                return self.scale_texture.eval(si, active)
            return self.scale

        def _f(self, si: Any, tv: Any, pv: Any, tl: Any, pl: Any, kappa: Any, valid: Any) -> Any:
            """The table at view (tv, pv) and light (tl, pl) (front frame, degrees), as a spectrum."""
            if scalar:
                return self._f_scalar(si, tv, pv, tl, pl, kappa, valid)
            if self.texels is not None:
                from . import _btf_jit

                f = _btf_jit.evaluate(mi, self.texels, si, tv, pv, tl, pl, kappa, valid, self.record)
            else:
                f = lj.lookup_jit(mi, self.grid, self.packed, tv, pv, tl, pl, kappa, valid, si.wavelengths)
            if self.record == "one":
                f = mi.UnpolarizedSpectrum(f)
            return f * self._scale(si, valid)

        def _f_scalar(self, si: Any, tv: Any, pv: Any, tl: Any, pl: Any, kappa: Any, valid: Any) -> Any:
            from ..interp import evaluate, evaluate_reference
            from . import _btf_jit
            from ._spectral import lazy_table

            if not valid:
                return dr.zeros(mi.UnpolarizedSpectrum)
            q = (float(tv), float(pv), float(tl), float(pl), float(kappa))
            if self.record == "spectral":
                lam = np.array(si.wavelengths, dtype=np.float64).reshape(-1)
                if self.btf is not None:
                    v = _btf_jit.scalar_spectrum(self, si, q, lam)
                else:
                    v = evaluate_reference(lazy_table(self.grid, self._records, lam), *q)
                f = mi.UnpolarizedSpectrum(*map(float, v))
            else:
                if self.btf is not None:
                    v = _btf_jit.scalar_value(self, si, q)
                else:
                    v = evaluate(self.prepared, *q, on_invalid="nan")
                if self.record == "one":
                    y = float(v[0]) if v.size == 1 else float(v @ np.array([0.2126, 0.7152, 0.0722]))
                    f = mi.UnpolarizedSpectrum(y)
                else:
                    f = mi.UnpolarizedSpectrum(*map(float, v))
            return f * self._scale(si, valid)

        def _angles(self, d: Any) -> tuple[Any, Any]:
            return (dr.acos(dr.clip(d.z, -1.0, 1.0)) * _RAD2DEG, dr.atan2(d.y, d.x) * _RAD2DEG)

        def _query(self, ctx: Any, si: Any, wo: Any, active: Any) -> SimpleNamespace:
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
            return ctx is not None and ctx.mode == mi.TransportMode.Importance

        def _value(self, si: Any, q: SimpleNamespace) -> Any:
            """eval: f * cos(theta_l), with view and light swapped in importance transport."""
            if q.importance:
                f = self._f(si, q.tl, q.pl, q.tv, q.pv, q.kappa, q.valid)
            else:
                f = self._f(si, q.tv, q.pv, q.tl, q.pl, q.kappa, q.valid)
            return dr.select(q.valid, f * q.wl.z, 0.0)

        def _table_sampling(self, q: SimpleNamespace) -> bool:
            return self.sampler_tables is not None and not q.importance

        def _pdf(self, q: SimpleNamespace, cond: Any) -> Any:
            if not self._table_sampling(q):
                return dr.select(q.valid, mi.warp.square_to_cosine_hemisphere_pdf(q.wl), 0.0)
            if scalar:
                if not q.valid:
                    return 0.0
                tables = cast(_sampling.SamplerTables, self.sampler_tables)
                p = _sampling.pdf(tables, float(q.tv), float(q.pv), float(q.kappa),
                                  np.array([[float(q.wl.x), float(q.wl.y), float(q.wl.z)]]),
                                  cosine_weight=self.settings.cosine_weight)
                return float(p[0])
            from . import _sampling_jit

            return _sampling_jit.pdf(mi, self.sampler, cond, q.wl, q.pl, self.settings.cosine_weight, q.valid)

        def _conditioning(self, q: SimpleNamespace, active: Any) -> Any:
            if scalar or not self._table_sampling(q):
                return None
            from . import _sampling_jit

            return _sampling_jit.conditioning(mi, self.sampler, q.tv, q.pv, q.kappa, active)

        # -- the BSDF interface -------------------------------------------------------------------
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

        def _sample(self, ctx: Any, si: Any, view: SimpleNamespace, sample1: Any, sample2: Any, active: Any,
                    cond: Any) -> tuple[Any, Any]:
            """Sample the light direction for the view of ``view`` (``wi, sign, kappa, tv, pv, frame``)."""
            sign, kappa, tv, pv = view.sign, view.kappa, view.tv, view.pv
            q = SimpleNamespace(wi=view.wi, sign=sign, kappa=kappa, tv=tv, pv=pv, importance=self._importance(ctx))
            ok = active & (view.wi.z > 0.0)
            if not self._table_sampling(q):
                wl = mi.warp.square_to_cosine_hemisphere(sample2)
            elif scalar and not ok:  # a view below the surface or not a direction (NaN): nothing to sample
                wl = mi.Vector3f(0.0, 0.0, 1.0)
            elif scalar:
                tables = cast(_sampling.SamplerTables, self.sampler_tables)
                d, _ = _sampling.sample(tables, float(tv), float(pv), float(kappa), float(sample1),
                                        np.array([[float(sample2.x), float(sample2.y)]]),
                                        cosine_weight=self.settings.cosine_weight)
                wl = mi.Vector3f(*map(float, d[0]))
            else:
                from . import _sampling_jit

                if cond is None:
                    cond = _sampling_jit.conditioning(mi, self.sampler, tv, pv, kappa, ok)
                wl = _sampling_jit.sample(mi, self.sampler, cond, sample1, sample2, self.settings.cosine_weight, ok)
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

        def eval_diffuse_reflectance(self, si: Any, active: Any = True) -> Any:
            # Albedo-like estimate for AOVs: the table at normal incidence times pi.
            kappa = self._front(si, active)[2]
            zero = mi.Float(0.0)
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

    CDBRDFBSDF.__name__ = "CDBRDFBSDF"
    return CDBRDFBSDF
