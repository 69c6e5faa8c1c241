"""A CD-BTF in the renderer: every texel's table on the device, and the texel lookup in Dr.Jit.

The plug-in (:mod:`cdbrdf.render._bsdf`) renders a :class:`cdbrdf.CDBTF`
from its decoded texels: each texel's table with the pole rule of
:mod:`cdbrdf.interp` applied (:func:`cdbrdf.interp.apply_pole_rule`, the
texels as leading axes), packed one after the other as one upload of
:mod:`cdbrdf.render._lookup_jit` (RGB fixed point, or the luminance in mono
variants), so a lane looks up its texel with :func:`~cdbrdf.render._lookup_jit.lookup_jit`
and ``block`` = the texel. The texel comes from the surface's UVs: ``u_mm =
uv.x * uv_scale_u`` (likewise v), periodic over the repeat; ``bilinear``
blends the four nearest texel centres (four lookups, as
:meth:`cdbrdf.CDBTF.evaluate`), ``nearest`` reads one. Importance sampling
uses the tile mean's sampler (the plug-in's table is the tile mean).
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np

from ..interp import LookupGrid, apply_pole_rule
from . import _lookup_jit as lj

__all__ = ["TEXEL_FILTERS", "TexelUpload", "as_pair", "upload", "lookup"]

#: Valid values of the plug-in's ``texel_filter``.
TEXEL_FILTERS: tuple[str, ...] = ("bilinear", "nearest")


class TexelUpload(NamedTuple):
    """Every texel's prepared table on the device and what the lookup needs of the repeat."""

    grid: LookupGrid  # the axes (the tile mean's prepared grid: every texel has its shape)
    table: lj.TableUpload
    n_u: int
    n_v: int
    repeat_mm: tuple[float, float]
    uv_scale: tuple[float, float]
    bilinear: bool


def upload(mi: Any, btf: Any, grid: LookupGrid, record: str, *, uv_scale: tuple[float, float],
           texel_filter: str) -> TexelUpload:
    """Decode, prepare and upload every texel of ``btf`` (``record``: ``"rgb"`` or ``"one"``)."""
    dense = btf.decode()  # (n_v, n_u, kappa, phi_l, theta_l, phi_v, theta_v, channel)
    nv, nu = dense.shape[:2]
    g = btf.grid
    v, _, _ = apply_pole_rule(dense.reshape((nv * nu,) + dense.shape[2:]), g.theta_l, g.theta_v,
                              isotropic=g.isotropic)
    stacked = grid._replace(values=v.reshape((-1,) + v.shape[2:]))  # texel-major: texel t holds kappa t * nk ...
    del dense, v
    table = lj.pack_table(mi, stacked, record)
    return TexelUpload(grid, table, nu, nv, btf.repeat_mm, uv_scale, texel_filter == "bilinear")


def _wrap(dr: Any, Float: Any, x: Any, size: float, n: int) -> Any:
    """Texel coordinate of a position (mm) on a periodic axis of ``n`` texels: in [0, n)."""
    t = x * (1.0 / size)
    return (t - dr.floor(t)) * n


def lookup(mi: Any, up: TexelUpload, uv: Any, theta_v: Any, phi_v: Any, theta_l: Any, phi_l: Any, kappa: Any,
           active: Any, wavelengths: Any) -> Any:
    """The CD-BTF at the lanes' UVs, directions (degrees) and curvatures, as :func:`lookup_jit` returns it."""
    import drjit as dr

    Float, UInt = mi.Float, mi.UInt32
    Int = dr.int32_array_t(Float)
    fu = _wrap(dr, Float, uv.x * up.uv_scale[0], up.repeat_mm[0], up.n_u)
    fv = _wrap(dr, Float, uv.y * up.uv_scale[1], up.repeat_mm[1], up.n_v)

    def args(block: Any) -> Any:
        return lj.lookup_jit(mi, up.grid, up.table, theta_v, phi_v, theta_l, phi_l, kappa, active, wavelengths,
                             block=block)

    def wrap(i: Any, n: int) -> Any:  # i in [-1, n]
        i = dr.select(i < 0, i + n, i)
        return dr.select(i >= n, i - n, i)

    if not up.bilinear:
        iu = wrap(Int(dr.floor(fu)), up.n_u)
        iv = wrap(Int(dr.floor(fv)), up.n_v)
        return args(UInt(iv * up.n_u + iu))
    fu, fv = fu - 0.5, fv - 0.5
    u0, v0 = dr.floor(fu), dr.floor(fv)
    tu, tv = fu - u0, fv - v0
    i0, j0 = wrap(Int(u0), up.n_u), wrap(Int(v0), up.n_v)
    i1, j1 = wrap(i0 + 1, up.n_u), wrap(j0 + 1, up.n_v)
    out = None
    for j, wj in ((j0, 1.0 - tv), (j1, tv)):
        for i, wi in ((i0, 1.0 - tu), (i1, tu)):
            f = args(UInt(j * up.n_u + i)) * (wj * wi)
            out = f if out is None else out + f
    return out


def as_pair(name: str, value: Any) -> tuple[float, float]:
    """``uv_scale`` as two positive finite numbers: a number (both), two numbers, or text ``"su, sv"``."""
    from ..errors import OptionError

    try:
        if isinstance(value, str):
            parts = [float(x) for x in value.replace(",", " ").split()]
        elif isinstance(value, (int, float)):
            parts = [float(value)]
        else:
            parts = [float(x) for x in value]
    except (TypeError, ValueError):
        parts = []
    if len(parts) == 1:
        parts = parts * 2
    if len(parts) != 2 or not all(np.isfinite(parts)) or min(parts) <= 0:
        raise OptionError(f"cdbrdf BSDF: {name} must be one or two positive finite numbers (mm per UV unit), "
                          f"got {value!r}")
    return parts[0], parts[1]
