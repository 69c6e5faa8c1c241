"""The ``cdbrdf`` BSDF plug-in for Mitsuba 3 per variant (see :mod:`cdbrdf.render` and ``docs/rendering.md``).

The plug-in's class for a variant is :class:`~cdbrdf.render._bsdf_core.BSDFCore`
(its settings, table, curvature, frame and Mitsuba's BSDF interface: the
same code for every variant) with one thin layer of what differs:

- **vectorised** variants (``llvm_ad_*``, ``cuda_ad_*``; :class:`_VectorLayer`):
  the class is traced by Dr.Jit once per render; the table lives on the
  device (packed or float, :mod:`cdbrdf.render._lookup_jit`), the 5-D lookup
  and the importance sampler (:mod:`cdbrdf.render._sampling_jit`) become
  straight-line vector code, never a Python call per ray;
- **scalar** variants (debugging only; :class:`_ScalarLayer`): each call
  evaluates one query in NumPy with the same rules
  (:func:`cdbrdf.interp.evaluate`, :func:`cdbrdf.interp.evaluate_reference`,
  :mod:`cdbrdf.render._sampling`);
- **colour**: RGB variants use the table's linear RGB; spectral variants blend
  the spectra of the table samples upsampled with Mitsuba's sRGB model
  (:mod:`cdbrdf.render._spectral`); mono variants use the Rec. 709 luminance
  (the core's ``record``: ``rgb``, ``spectral`` or ``one``).
"""

from __future__ import annotations

from types import SimpleNamespace
from typing import Any, cast

import numpy as np

from ..errors import OptionError
from ..interp import prepare
from . import _lookup_jit as lj
from . import _sampling
from ._bsdf_core import MODES, SAMPLINGS, STORAGES, BSDFCore, Settings, load_table

__all__ = [
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

#: Name under which the plug-in is registered with Mitsuba.
PLUGIN_NAME = "cdbrdf"

#: Mitsuba variants the plug-in supports (those of the installed Mitsuba are
#: listed by :func:`cdbrdf.render.available_variants`); polarised variants are not.
SUPPORTED_VARIANTS: tuple[str, ...] = (
    "llvm_ad_rgb", "llvm_ad_spectral", "llvm_ad_mono",
    "cuda_ad_rgb", "cuda_ad_spectral", "cuda_ad_mono",
    "scalar_rgb", "scalar_spectral", "scalar_mono",
)

#: Rec. 709 luminance of an RGB value (the mono record of the scalar variants).
_LUMINANCE = np.array([0.2126, 0.7152, 0.0722])


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


def _make_class(mi: Any) -> type:
    """The plug-in's class for the active variant: Mitsuba's BSDF with the core's and the variant layer's methods.

    Mitsuba's classes take one base class (nanobind), so the methods of
    :class:`~cdbrdf.render._bsdf_core.BSDFCore` and of the layer are put
    into the class itself, the layer's over the core's.
    """
    import drjit as dr

    variant = mi.variant()
    layer: type = _ScalarLayer if variant.startswith("scalar") else _VectorLayer

    def __init__(self: Any, props: Any, *, table: Any = None, extras: dict[str, Any] | None = None) -> None:
        mi.BSDF.__init__(self, props)
        self._setup(props, table, extras or {})

    namespace: dict[str, Any] = {}
    for klass in reversed(layer.__mro__[:-1]):  # the core, then the layer
        namespace.update({k: v for k, v in vars(klass).items() if k not in _CLASS_KEYS})
    namespace.update(__init__=__init__, __doc__="Mitsuba BSDF of a curvature-dependent BRDF table "
                     "(see :mod:`cdbrdf.render`).", __module__=__name__, _mi=mi, _dr=dr,
                     _colour=check_variant(variant), _ad="_ad_" in variant)
    return type("CDBRDFBSDF", (mi.BSDF,), namespace)


#: What a Python class has of its own beside its methods (not carried over to the plug-in's class).
_CLASS_KEYS = frozenset({"__dict__", "__weakref__", "__module__", "__qualname__", "__doc__", "__annotations__",
                         "__init_subclass__", "__parameters__", "__orig_bases__"})


class _VectorLayer(BSDFCore):
    """The vectorised variants: the table and the sampler on the device, the Dr.Jit kernels."""

    _scalar = False

    def _hold_table(self, values: np.ndarray, differentiable: bool) -> None:
        """The table on the device: float32 packets (differentiable), float or packed fixed point; the sampler."""
        mi, st = self._mi, self.settings
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

    def _hold_texels(self) -> None:
        from . import _btf_jit

        full = self.grid if self.settings.mode == "cdbrdf" else prepare(self.btf.grid, self.btf.mean().values)
        self.texels = _btf_jit.upload(self._mi, self.btf, full, self.record, uv_scale=self.uv_scale,
                                      texel_filter=self.texel_filter, pixel_angle=self.pixel_angle,
                                      mm_per_unit=self.units.mm_per_unit)

    def _lookup(self, si: Any, tv: Any, pv: Any, tl: Any, pl: Any, kappa: Any, valid: Any) -> Any:
        mi = self._mi
        if self.texels is not None:
            from . import _btf_jit

            f = _btf_jit.evaluate(mi, self.texels, si, tv, pv, tl, pl, kappa, valid, self.record)
        else:
            f = lj.lookup_jit(mi, self.grid, self.packed, tv, pv, tl, pl, kappa, valid, si.wavelengths)
        return mi.UnpolarizedSpectrum(f) if self.record == "one" else f

    def _table_pdf(self, q: SimpleNamespace, cond: Any) -> Any:
        from . import _sampling_jit

        return _sampling_jit.pdf(self._mi, self.sampler, cond, q.wl, q.pl, self.settings.cosine_weight, q.valid)

    def _table_conditioning(self, q: SimpleNamespace, active: Any) -> Any:
        from . import _sampling_jit

        return _sampling_jit.conditioning(self._mi, self.sampler, q.tv, q.pv, q.kappa, active)

    def _table_sample(self, q: SimpleNamespace, sample1: Any, sample2: Any, ok: Any, cond: Any) -> tuple[Any, Any]:
        from . import _sampling_jit

        if cond is None:
            cond = _sampling_jit.conditioning(self._mi, self.sampler, q.tv, q.pv, q.kappa, ok)
        wl = _sampling_jit.sample(self._mi, self.sampler, cond, sample1, sample2, self.settings.cosine_weight, ok)
        return wl, cond


class _ScalarLayer(BSDFCore):
    """The scalar variants: one query at a time in NumPy, by the rules the kernels copy."""

    _scalar = True

    def _hold_table(self, values: np.ndarray, differentiable: bool) -> None:
        if self.record == "spectral":
            self._records = lj.records(self.grid.values, "spectral")

    def _hold_texels(self) -> None:
        """The texels stay in the CD-BTF: each query decodes its own (:func:`cdbrdf.render._btf_jit.scalar_value`)."""

    def _lookup(self, si: Any, tv: Any, pv: Any, tl: Any, pl: Any, kappa: Any, valid: Any) -> Any:
        from ..interp import evaluate, evaluate_reference
        from . import _btf_jit
        from ._spectral import lazy_table

        mi = self._mi
        if not valid:
            return self._dr.zeros(mi.UnpolarizedSpectrum)
        q = (float(tv), float(pv), float(tl), float(pl), float(kappa))
        if self.record == "spectral":
            lam = np.array(si.wavelengths, dtype=np.float64).reshape(-1)
            if self.btf is not None:
                v = _btf_jit.scalar_spectrum(self, si, q, lam)
            else:
                v = evaluate_reference(lazy_table(self.grid, self._records, lam), *q)
            return mi.UnpolarizedSpectrum(*map(float, v))
        v = _btf_jit.scalar_value(self, si, q) if self.btf is not None else evaluate(self.prepared, *q,
                                                                                      on_invalid="nan")
        if self.record == "one":
            return mi.UnpolarizedSpectrum(float(v[0]) if v.size == 1 else float(v @ _LUMINANCE))
        return mi.UnpolarizedSpectrum(*map(float, v))

    def _table_pdf(self, q: SimpleNamespace, cond: Any) -> Any:
        if not q.valid:
            return 0.0
        tables = cast(_sampling.SamplerTables, self.sampler_tables)
        p = _sampling.pdf(tables, float(q.tv), float(q.pv), float(q.kappa),
                          np.array([[float(q.wl.x), float(q.wl.y), float(q.wl.z)]]),
                          cosine_weight=self.settings.cosine_weight)
        return float(p[0])

    def _table_conditioning(self, q: SimpleNamespace, active: Any) -> Any:
        return None

    def _table_sample(self, q: SimpleNamespace, sample1: Any, sample2: Any, ok: Any, cond: Any) -> tuple[Any, Any]:
        if not ok:  # a view below the surface or not a direction (NaN): nothing to sample
            return self._mi.Vector3f(0.0, 0.0, 1.0), None
        tables = cast(_sampling.SamplerTables, self.sampler_tables)
        d, _ = _sampling.sample(tables, float(q.tv), float(q.pv), float(q.kappa), float(sample1),
                                np.array([[float(sample2.x), float(sample2.y)]]),
                                cosine_weight=self.settings.cosine_weight)
        return self._mi.Vector3f(*map(float, d[0])), None
