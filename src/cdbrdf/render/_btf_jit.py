"""A CD-BTF in the renderer: every texel's table on the device, and the texel lookup in Dr.Jit.

The plug-in (:mod:`cdbrdf.render._bsdf`) renders a :class:`cdbrdf.CDBTF`
from its decoded texels: each texel's table with the pole rule of
:mod:`cdbrdf.interp` applied (:func:`cdbrdf.interp.apply_pole_rule`, the
texels as leading axes), packed one after the other as one upload of
:mod:`cdbrdf.render._lookup_jit` (RGB fixed point, the luminance in mono
variants, one spectral record per sample in spectral variants: Mitsuba's
sRGB-model coefficients and a scale, :func:`cdbrdf.render._lookup_jit.records`,
as the CDBRDF's own upload, in the ``"records"`` layout), so a lane reads its
texel as one more index (``block``) of the same lookup. The 5-D cell
(indices and weights, :func:`~cdbrdf.render._lookup_jit.corners_jit`) is
computed once per lane and only the gathers repeat per texel.

The texel comes from the surface's UVs: ``u_mm = uv.x * uv_scale_u`` (likewise
v), periodic over the repeat. :data:`TEXEL_FILTERS`:

- ``bilinear``: the four nearest texel centres blended (four texel reads),
  exactly :meth:`cdbrdf.CDBTF.evaluate`;
- ``stochastic``: stochastic bilinear filtering (Pharr et al. 2024, "Filtering
  after shading with stochastic texture filtering"): one of the same four
  texels per evaluation, texel ``(i, j)`` with probability equal to its
  bilinear weight (v and u chosen independently, from two uniforms of a TEA
  hash of the UV's bits, :func:`texel_choice`), so the expected value is the
  bilinear one and a render converges to the bilinear render; one texel read;
- ``nearest``: the texel containing the point.

Importance sampling uses the tile mean's sampler (the plug-in's table is the
tile mean); the texel's value enters through ``eval``. The scalar variants
evaluate the exact bilinear blend for ``stochastic`` (:func:`scalar_texels`).
"""

from __future__ import annotations

import logging
import time
from typing import Any, NamedTuple

import numpy as np

from ..interp import LookupGrid, apply_pole_rule
from . import _lookup_jit as lj

__all__ = ["DEFAULT_TEXEL_FILTER", "TEXEL_FILTERS", "TexelUpload", "as_pair", "lookup", "scalar_texels",
           "scalar_value", "scalar_spectrum", "texel_choice", "upload", "upload_nbytes"]

_LOG = logging.getLogger(__name__)

#: Valid values of the plug-in's ``texel_filter``.
TEXEL_FILTERS: tuple[str, ...] = ("bilinear", "stochastic", "nearest")

#: The default ``texel_filter``: one texel read per evaluation (the render time of ``nearest``) and a
#: render that converges to the ``bilinear`` one (``docs/rendering.md``, "CD-BTF").
DEFAULT_TEXEL_FILTER = "stochastic"

#: Rounds of the TEA hash of :func:`texel_choice`.
_TEA_ROUNDS = 8

#: Texels whose spectral records are made at a time (bounds the float64 temporaries of the conversion).
_RECORD_CHUNK = 64


class TexelUpload(NamedTuple):
    """Every texel's prepared table on the device and what the lookup needs of the repeat."""

    grid: LookupGrid  # the axes (the tile mean's prepared grid: every texel has its shape)
    table: lj.TableUpload
    n_u: int
    n_v: int
    repeat_mm: tuple[float, float]
    uv_scale: tuple[float, float]
    texel_filter: str


def upload_nbytes(n_texels: int, shape5: tuple[int, ...], record: str) -> int:
    """Device bytes of :func:`upload` for ``n_texels`` tables of ``shape5`` samples with ``record`` records."""
    per = {"rgb": 8, "one": 4, "spectral": 16}[record]
    return int(n_texels * int(np.prod(shape5)) * per)


def _prepared(btf: Any) -> np.ndarray:
    """Every texel's table with the pole rule applied, texel-major: ``(n_v * n_u * n_kappa, ...)``."""
    dense = btf.decode()  # (n_v, n_u, kappa, phi_l, theta_l, phi_v, theta_v, channel)
    nv, nu = dense.shape[:2]
    g = btf.grid
    v, _, _ = apply_pole_rule(dense.reshape((nv * nu,) + dense.shape[2:]), g.theta_l, g.theta_v,
                              isotropic=g.isotropic)
    return np.asarray(v)


def upload(mi: Any, btf: Any, grid: LookupGrid, record: str, *, uv_scale: tuple[float, float],
           texel_filter: str) -> TexelUpload:
    """Decode, prepare and upload every texel of ``btf`` (``record``: ``"rgb"``, ``"one"`` or ``"spectral"``)."""
    t0 = time.perf_counter()
    v = _prepared(btf)
    nu, nv = btf.texels
    if record == "spectral":
        lj.check_range(v)
        rec = np.empty(v.shape[:-1] + (4,), dtype=np.float32)
        for s in range(0, v.shape[0], _RECORD_CHUNK):
            rec[s : s + _RECORD_CHUNK] = lj.records(v[s : s + _RECORD_CHUNK], "spectral")
        del v
        table = lj.TableUpload("records", "spectral", mi.Float(rec.reshape(-1)))
    else:
        stacked = grid._replace(values=v.reshape((-1,) + v.shape[2:]))  # texel t holds kappa t * nk ...
        del v
        table = lj.pack_table(mi, stacked, record)
    _LOG.info("CD-BTF: %d x %d texels uploaded as %s records, %.1f MB, in %.1f s", nu, nv, record,
              upload_nbytes(nu * nv, grid.values.shape[:5], record) / 1e6, time.perf_counter() - t0)
    return TexelUpload(grid, table, nu, nv, btf.repeat_mm, uv_scale, texel_filter)


def _wrap(dr: Any, x: Any, size: float, n: int) -> Any:
    """Texel coordinate of a position (mm) on a periodic axis of ``n`` texels: in [0, n)."""
    t = x * (1.0 / size)
    return (t - dr.floor(t)) * n


def texel_choice(mi: Any, uv: Any) -> tuple[Any, Any]:
    """Two uniforms in [0, 1) per lane: a TEA hash (8 rounds) of the bits of ``uv.x`` and ``uv.y``.

    The same point gives the same texel in ``eval`` and ``sample``; points
    a float32 step apart give independent choices (4 rounds do not: UVs a
    few float32 steps apart then read some texels 10 standard deviations too
    often; 8 rounds pass the binomial test of the texel frequencies).
    """
    import drjit as dr

    UInt = mi.UInt32
    a, b = mi.sample_tea_32(dr.reinterpret_array(UInt, uv.x), dr.reinterpret_array(UInt, uv.y), _TEA_ROUNDS)
    scale = 1.0 / 16777216.0  # 2^-24: the top 24 bits, exactly representable
    return mi.Float(a >> 8) * scale, mi.Float(b >> 8) * scale


def lookup(mi: Any, up: TexelUpload, uv: Any, theta_v: Any, phi_v: Any, theta_l: Any, phi_l: Any, kappa: Any,
           active: Any, wavelengths: Any) -> Any:
    """The CD-BTF at the lanes' UVs, directions (degrees) and curvatures, as :func:`lookup_jit` returns it."""
    import drjit as dr

    UInt = mi.UInt32
    Int = dr.int32_array_t(mi.Float)
    fu = _wrap(dr, uv.x * up.uv_scale[0], up.repeat_mm[0], up.n_u)
    fv = _wrap(dr, uv.y * up.uv_scale[1], up.repeat_mm[1], up.n_v)
    cell = lj.corners_jit(mi, up.grid, theta_v, phi_v, theta_l, phi_l, kappa)

    def at(block: Any) -> Any:
        return lj.gather_jit(mi, up.grid, up.table, cell, active, wavelengths, block=block)

    def wrap(i: Any, n: int) -> Any:  # i in [-1, n]
        i = dr.select(i < 0, i + n, i)
        return dr.select(i >= n, i - n, i)

    if up.texel_filter == "nearest":
        iu = wrap(Int(dr.floor(fu)), up.n_u)
        iv = wrap(Int(dr.floor(fv)), up.n_v)
        return at(UInt(iv * up.n_u + iu))
    fu, fv = fu - 0.5, fv - 0.5
    u0, v0 = dr.floor(fu), dr.floor(fv)
    tu, tv = fu - u0, fv - v0
    i0, j0 = wrap(Int(u0), up.n_u), wrap(Int(v0), up.n_v)
    i1, j1 = wrap(i0 + 1, up.n_u), wrap(j0 + 1, up.n_v)
    if up.texel_filter == "stochastic":
        xu, xv = texel_choice(mi, uv)
        i = dr.select(xu < tu, i1, i0)
        j = dr.select(xv < tv, j1, j0)
        return at(UInt(j * up.n_u + i))
    out = None
    for j, wj in ((j0, 1.0 - tv), (j1, tv)):
        for i, wi in ((i0, 1.0 - tu), (i1, tu)):
            f = at(UInt(j * up.n_u + i)) * (wj * wi)
            out = f if out is None else out + f
    return out


def scalar_texels(u_mm: float, v_mm: float, texels: tuple[int, int], repeat_mm: tuple[float, float],
                  texel_filter: str) -> list[tuple[int, int, float]]:
    """``(j, i, weight)`` of the texels a scalar evaluation blends (``stochastic``: the exact bilinear blend).

    The rule of :meth:`cdbrdf.CDBTF.texel_weights` (periodic bilinear between
    texel centres) or, for ``nearest``, the texel containing the point.
    """
    (nu, nv), (su, sv) = texels, repeat_mm
    fu = (u_mm % su) / su * nu
    fv = (v_mm % sv) / sv * nv
    if texel_filter == "nearest":
        return [(int(np.floor(fv)) % nv, int(np.floor(fu)) % nu, 1.0)]
    fu, fv = fu - 0.5, fv - 0.5
    u0, v0 = np.floor(fu), np.floor(fv)
    tu, tv = fu - u0, fv - v0
    i0, j0 = int(u0) % nu, int(v0) % nv
    i1, j1 = (i0 + 1) % nu, (j0 + 1) % nv
    out = [(j0, i0, (1 - tu) * (1 - tv)), (j0, i1, tu * (1 - tv)), (j1, i0, (1 - tu) * tv), (j1, i1, tu * tv)]
    return [(j, i, float(w)) for j, i, w in out if w > 0.0]


def scalar_value(bsdf: Any, si: Any, q: tuple[float, ...]) -> np.ndarray:
    """The CD-BTF at one query (scalar variants): :meth:`cdbrdf.CDBTF.evaluate` at the UV in mm."""
    import math

    u, v = float(si.uv.x) * bsdf.uv_scale[0], float(si.uv.y) * bsdf.uv_scale[1]
    if bsdf.texel_filter == "nearest":  # the centre of the texel
        (nu, nv), (su, sv) = bsdf.btf.texels, bsdf.btf.repeat_mm
        u = (math.floor(u / su * nu) + 0.5) * su / nu
        v = (math.floor(v / sv * nv) + 0.5) * sv / nv
    kappa = 0.0 if bsdf.settings.mode == "brdf" else q[4]
    return np.asarray(bsdf.btf.evaluate(u, v, *q[:4], kappa)).reshape(-1)


def scalar_spectrum(bsdf: Any, si: Any, q: tuple[float, ...], lam: np.ndarray) -> np.ndarray:
    """The CD-BTF's spectrum at one query (scalar spectral variants): the texels' spectra blended.

    Each texel's samples are upsampled (:func:`cdbrdf.render._lookup_jit.records`) and their
    spectra interpolated, as the vectorised lookup does; ``stochastic`` is the exact bilinear blend.
    The texels read are kept on ``bsdf`` (decoded once).
    """
    from ..interp import evaluate_reference, prepare
    from ._spectral import lazy_table

    u, v = float(si.uv.x) * bsdf.uv_scale[0], float(si.uv.y) * bsdf.uv_scale[1]
    q = q[:4] + ((0.0,) if bsdf.settings.mode == "brdf" else q[4:])
    out = np.zeros(lam.size)
    cache = bsdf._texel_cache
    for j, i, w in scalar_texels(u, v, bsdf.btf.texels, bsdf.btf.repeat_mm, bsdf.texel_filter):
        if (j, i) not in cache:
            if not cache:  # decode once, keep the texels read
                bsdf._dense = bsdf.btf.decode()
            g = prepare(bsdf.btf.grid, bsdf._dense[j, i])
            cache[(j, i)] = (g, lj.records(g.values, "spectral"))
        g, rec = cache[(j, i)]
        out += w * np.asarray(evaluate_reference(lazy_table(g, rec, lam), *q), dtype=np.float64)
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
