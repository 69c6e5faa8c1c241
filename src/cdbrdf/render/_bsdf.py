"""The ``cdbrdf`` BSDF plug-in for Mitsuba 3 (see :mod:`cdbrdf.render`).

The Python class is traced by Dr.Jit once per render in the ``llvm_ad_rgb``
variant: the 5-D lookup (:func:`cdbrdf.render._lookup_jit.lookup_jit`)
becomes straight-line vector code (compares, selects and 32 gathers of an RGB
triple from the flattened table), never a Python call per ray. In
``scalar_rgb`` (debugging only) each call evaluates one query with
:func:`cdbrdf.interp.evaluate`.
"""

from __future__ import annotations

import math
import os
from typing import Any

import numpy as np

from ..interp import LookupGrid
from ._lookup_jit import lookup_jit, pack_table

__all__ = ["MODES", "PLUGIN_NAME", "bsdf_class", "load_table"]

#: Name under which the plug-in is registered with Mitsuba.
PLUGIN_NAME = "cdbrdf"

#: Valid values of the ``mode`` parameter.
MODES: tuple[str, ...] = ("cdbrdf", "brdf")

#: Default name of the per-vertex curvature attribute (mm^-1).
DEFAULT_CURVATURE_ATTRIBUTE = "vertex_curvature"

_RAD2DEG = 180.0 / math.pi


def load_table(source: Any):
    """A :class:`~cdbrdf.table.CDBRDF` from a table object or a file path."""
    from ..table import CDBRDF

    if isinstance(source, CDBRDF):
        return source
    if isinstance(source, (str, os.PathLike)):
        from ..table import load

        return load(source)
    raise TypeError(
        f"cdbrdf BSDF: expected a CDBRDF table or a file name, got {type(source).__name__}"
    )


def _mode_grid(table, mode: str) -> LookupGrid:
    if mode not in MODES:
        raise ValueError(f"cdbrdf BSDF: mode {mode!r} is not one of {', '.join(MODES)}")
    if mode == "brdf":
        table = table.brdf()
    return table.lookup_grid()


# -- the plug-in class (one per Mitsuba variant) ------------------------------------
_CLASSES: dict[str, type] = {}


def bsdf_class():
    """The plug-in class for the current Mitsuba variant (created on first use)."""
    import mitsuba as mi

    variant = mi.variant()
    if variant is None:
        raise RuntimeError(
            "cdbrdf BSDF: no Mitsuba variant is set; call cdbrdf.render.set_variant() first"
        )
    if "_rgb" not in variant:
        raise ValueError(
            f"cdbrdf BSDF: Mitsuba variant {variant!r} is not supported; the table is RGB, "
            "use llvm_ad_rgb (or scalar_rgb for debugging)"
        )
    cls = _CLASSES.get(variant)
    if cls is None:
        cls = _make_class(mi)
        _CLASSES[variant] = cls
    return cls


def _make_class(mi):  # noqa: C901 - the plug-in is one class
    import drjit as dr

    scalar = mi.variant().startswith("scalar")

    class CDBRDFBSDF(mi.BSDF):
        """Mitsuba BSDF of a curvature-dependent BRDF table (see :mod:`cdbrdf.render`)."""

        def __init__(self, props, *, table=None):
            mi.BSDF.__init__(self, props)
            if table is None:
                if not ("filename" in props):
                    raise ValueError(
                        "cdbrdf BSDF: give 'filename' (a CDBRDF file), or build the "
                        "BSDF from a table with cdbrdf.render.make_bsdf(table)"
                    )
                table = load_table(str(props["filename"]))
            else:
                table = load_table(table)
            mode = str(props["mode"]) if ("mode" in props) else "cdbrdf"
            curv = props["curvature"] if ("curvature" in props) else DEFAULT_CURVATURE_ATTRIBUTE
            scale = float(props["scale"]) if ("scale" in props) else 1.0
            if not (math.isfinite(scale) and scale >= 0):
                raise ValueError(f"cdbrdf BSDF: scale must be finite and >= 0, got {scale}")
            if table.n_channels not in (1, 3):
                raise ValueError(
                    f"cdbrdf BSDF: the table has {table.n_channels} channels; "
                    "the RGB renderer needs 1 or 3"
                )
            self.table = table
            self.mode = mode
            self.grid = _mode_grid(table, mode)
            self._eval_table = table.brdf() if mode == "brdf" else table
            self.scale = scale
            k = None
            if isinstance(curv, str):
                name = curv.strip()
                if not name:
                    raise ValueError("cdbrdf BSDF: curvature attribute name is empty")
                try:
                    k = float(name)
                except ValueError:
                    self.kappa_const = None
                    self.curvature_attribute = name
            else:
                k = float(curv)
            if k is not None:
                if not math.isfinite(k):
                    raise ValueError(f"cdbrdf BSDF: constant curvature must be finite, got {curv}")
                self.kappa_const = k
                self.curvature_attribute = None
            if mode == "brdf":
                # The plain BRDF does not depend on curvature: never read the attribute.
                self.curvature_attribute = None
                self.kappa_const = 0.0
            if not scalar:
                self.packed = pack_table(mi, self.grid)
            flags = (
                mi.BSDFFlags.DiffuseReflection | mi.BSDFFlags.FrontSide
                | mi.BSDFFlags.BackSide | mi.BSDFFlags.Anisotropic
            )
            self.m_components = [flags]
            self.m_flags = flags

        # -- helpers -------------------------------------------------------------
        def _kappa(self, si, active):
            if self.curvature_attribute is None:
                return mi.Float(self.kappa_const)
            return si.shape.eval_attribute_1(self.curvature_attribute, si, active)

        def _local(self, si, wo, active):
            """Directions in the front frame (flipped about x on the back side) and kappa."""
            back = mi.Frame3f.cos_theta(si.wi) < 0.0
            sign = dr.select(back, -1.0, 1.0)
            wi = mi.Vector3f(si.wi.x, sign * si.wi.y, sign * si.wi.z)
            wl = mi.Vector3f(wo.x, sign * wo.y, sign * wo.z)
            kappa = sign * self._kappa(si, active)
            valid = active & (wi.z > 0.0) & (wl.z > 0.0)
            return wi, wl, kappa, valid, sign

        def _f(self, wi, wl, kappa, valid, ctx=None):
            """The table at view ``wi`` and light ``wl`` (front frame), times scale.

            In importance transport (``ctx.mode`` Importance) Mitsuba's ``wi``
            points to the light and ``wo`` to the camera: the roles swap.
            """
            if ctx is not None and ctx.mode == mi.TransportMode.Importance:
                wi, wl = wl, wi
            tv = dr.acos(dr.clip(wi.z, -1.0, 1.0)) * _RAD2DEG
            pv = dr.atan2(wi.y, wi.x) * _RAD2DEG
            tl = dr.acos(dr.clip(wl.z, -1.0, 1.0)) * _RAD2DEG
            pl = dr.atan2(wl.y, wl.x) * _RAD2DEG
            if scalar:
                if not valid:
                    return mi.Color3f(0.0)
                from ..interp import evaluate

                v = evaluate(self._eval_table, float(tv), float(pv), float(tl), float(pl), float(kappa),
                             on_invalid="nan")
                v = np.broadcast_to(v, (3,)) if v.size == 1 else v
                return mi.Color3f(*(float(x) * self.scale for x in v))
            f = lookup_jit(mi, self.grid, self.packed, tv, pv, tl, pl, kappa, valid)
            return dr.select(valid, f * self.scale, 0.0)

        # -- the BSDF interface ---------------------------------------------------
        def eval(self, ctx, si, wo, active=True):
            wi, wl, kappa, valid, _ = self._local(si, wo, active)
            f = self._f(wi, wl, kappa, valid, ctx)
            return dr.select(valid, f * wl.z, 0.0)

        def pdf(self, ctx, si, wo, active=True):
            wi, wl, kappa, valid, _ = self._local(si, wo, active)
            return dr.select(valid, mi.warp.square_to_cosine_hemisphere_pdf(wl), 0.0)

        def eval_pdf(self, ctx, si, wo, active=True):
            wi, wl, kappa, valid, _ = self._local(si, wo, active)
            f = self._f(wi, wl, kappa, valid, ctx)
            return (
                dr.select(valid, f * wl.z, 0.0),
                dr.select(valid, mi.warp.square_to_cosine_hemisphere_pdf(wl), 0.0),
            )

        def sample(self, ctx, si, sample1, sample2, active=True):
            back = mi.Frame3f.cos_theta(si.wi) < 0.0
            sign = dr.select(back, -1.0, 1.0)
            kappa = sign * self._kappa(si, active)
            return self._sample(ctx, si, sample2, sign, kappa, active)

        def eval_pdf_sample(self, ctx, si, wo, sample1, sample2, active=True):
            # One curvature read for the light direction and the sampled one.
            wi, wl, kappa, valid, sign = self._local(si, wo, active)
            f = self._f(wi, wl, kappa, valid, ctx)
            bs, value = self._sample(ctx, si, sample2, sign, kappa, active)
            return (
                dr.select(valid, f * wl.z, 0.0),
                dr.select(valid, mi.warp.square_to_cosine_hemisphere_pdf(wl), 0.0),
                bs,
                value,
            )

        def _sample(self, ctx, si, sample2, sign, kappa, active):
            wl = mi.warp.square_to_cosine_hemisphere(sample2)
            pdf = mi.warp.square_to_cosine_hemisphere_pdf(wl)
            wi = mi.Vector3f(si.wi.x, sign * si.wi.y, sign * si.wi.z)
            valid = active & (wi.z > 0.0) & (pdf > 0.0)
            bs = dr.zeros(mi.BSDFSample3f)
            bs.wo = mi.Vector3f(wl.x, sign * wl.y, sign * wl.z)
            bs.pdf = dr.select(valid, pdf, 0.0)
            bs.eta = 1.0
            bs.sampled_type = mi.UInt32(+mi.BSDFFlags.DiffuseReflection)
            bs.sampled_component = mi.UInt32(0)
            f = self._f(wi, wl, kappa, valid, ctx)
            # value = f * cos / pdf = f * pi for cosine-weighted sampling.
            value = dr.select(valid, f * math.pi, 0.0)
            return (bs, value)

        def eval_diffuse_reflectance(self, si, active=True):
            # Albedo-like estimate for AOVs: the table at normal incidence times pi.
            back = mi.Frame3f.cos_theta(si.wi) < 0.0
            kappa = dr.select(back, -1.0, 1.0) * self._kappa(si, active)
            z = mi.Vector3f(0.0, 0.0, 1.0)
            return self._f(z, z, kappa, active) * math.pi

        def to_string(self):
            k = (f"attribute {self.curvature_attribute!r}" if self.curvature_attribute
                 else f"constant {self.kappa_const:g} mm^-1")
            return (
                f"CDBRDFBSDF[material={self.table.attrs.get('material', '?')!r}, "
                f"mode={self.mode!r}, curvature={k}, scale={self.scale:g}, "
                f"shape={self.table.shape}]"
            )

    CDBRDFBSDF.__name__ = "CDBRDFBSDF"
    return CDBRDFBSDF
