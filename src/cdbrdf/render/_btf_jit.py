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
import math
import time
from typing import Any, NamedTuple

import numpy as np

from ..interp import LookupGrid, apply_pole_rule
from . import _lookup_jit as lj

__all__ = ["DEFAULT_TEXEL_FILTER", "TEXEL_FILTERS", "NeuralUpload", "TexelUpload", "as_pair", "evaluate", "lookup",
           "fraction", "lookup_neural", "modulation_basis", "scalar_texels", "scalar_value", "scalar_spectrum",
           "texel_choice", "upload", "upload_nbytes", "upload_neural"]

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
           texel_filter: str, pixel_angle: float = 0.0, mm_per_unit: float = 1.0) -> TexelUpload | NeuralUpload:
    """Upload ``btf`` (``record``: ``"rgb"``, ``"one"`` or ``"spectral"``).

    A neural CD-BTF without residual components: :func:`upload_neural` (the
    decoder runs per lookup, the footprint picks the pyramid level). Any
    other: every texel decoded, prepared and uploaded (no filtering across
    texels beyond ``texel_filter``).
    """
    if btf.neural is not None and btf.rank == 0:
        return upload_neural(mi, btf, grid, record, uv_scale=uv_scale, texel_filter=texel_filter,
                             pixel_angle=pixel_angle, mm_per_unit=mm_per_unit)
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


def evaluate(mi: Any, up: TexelUpload | NeuralUpload, si: Any, theta_v: Any, phi_v: Any, theta_l: Any, phi_l: Any,
             kappa: Any, active: Any, record: str) -> Any:
    """The CD-BTF at the lanes' hits ``si`` (:func:`lookup` or :func:`lookup_neural`)."""
    if isinstance(up, NeuralUpload):
        return lookup_neural(mi, up, si, theta_v, phi_v, theta_l, phi_l, kappa, active, si.wavelengths, record)
    return lookup(mi, up, si.uv, theta_v, phi_v, theta_l, phi_l, kappa, active, si.wavelengths)


def fraction(dr: Any, uv: Any, scale: float, offset: float = 0.0) -> Any:
    """``uv * scale + offset`` modulo 1, in [0, 1] (a periodic texture coordinate; the type of ``uv``).

    Computed in float64: a UV times a scale may overflow float32 (3.3e38 x 10 is inf; inf - floor(inf) is NaN,
    whose integer index would read outside the table), and a float32 product loses the fraction long before.
    A coordinate that is not finite even in float64 is 0.
    """
    F64 = dr.float64_array_t(type(uv))
    t = dr.fma(F64(uv), float(scale), float(offset))
    f = t - dr.floor(t)
    return dr.clip(type(uv)(dr.select(dr.isfinite(f), f, 0.0)), 0.0, 1.0)


def _wrap(dr: Any, uv: Any, scale: float, size: float, n: int) -> Any:
    """Texel coordinate of a UV on a periodic axis of ``n`` texels (``scale`` mm per UV unit, a repeat of
    ``size`` mm): in [0, n] (:func:`fraction`; the index rules wrap n to 0 and clamp)."""
    return fraction(dr, uv, float(scale) / float(size)) * n


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
    fu = _wrap(dr, uv.x, up.uv_scale[0], up.repeat_mm[0], up.n_u)
    fv = _wrap(dr, uv.y, up.uv_scale[1], up.repeat_mm[1], up.n_v)
    cell = lj.corners_jit(mi, up.grid, theta_v, phi_v, theta_l, phi_l, kappa)

    def at(block: Any) -> Any:
        return lj.gather_jit(mi, up.grid, up.table, cell, active, wavelengths, block=block)

    def wrap(i: Any, n: int) -> Any:  # i in [-1, n]; clamped, so that no index is ever outside the table
        i = dr.select(i < 0, i + n, i)
        return dr.clip(dr.select(i >= n, i - n, i), 0, n - 1)

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


def _in_repeat(uv: float, scale: float, size: float) -> float:
    """A UV's position in the repeat, mm in [0, size): the rule of :func:`_wrap` in Python floats."""
    t = float(uv) * (float(scale) / float(size))
    if not math.isfinite(t):
        return 0.0
    f = (t - math.floor(t)) * size
    return f if 0.0 <= f < size else 0.0


def _uv_mm(bsdf: Any, si: Any) -> tuple[float, float]:
    """The hit's position in the repeat, mm (the rule of :func:`_wrap`, in Python floats)."""
    su, sv = bsdf.btf.repeat_mm
    return _in_repeat(si.uv.x, bsdf.uv_scale[0], su), _in_repeat(si.uv.y, bsdf.uv_scale[1], sv)


def scalar_value(bsdf: Any, si: Any, q: tuple[float, ...]) -> np.ndarray:
    """The CD-BTF at one query (scalar variants): :meth:`cdbrdf.CDBTF.evaluate` at the UV in mm."""
    u, v = _uv_mm(bsdf, si)
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

    u, v = _uv_mm(bsdf, si)
    q = q[:4] + ((0.0,) if bsdf.settings.mode == "brdf" else q[4:])
    if bsdf.btf.neural is not None and bsdf.btf.rank == 0:  # the tile mean's spectrum, modulated
        m = scalar_modulation_spectrum(bsdf.btf, u, v, q, lam)
        return np.asarray(evaluate_reference(lazy_table(bsdf.grid, bsdf._records, lam), *q), np.float64) * m
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


# -- the neural CD-BTF --------------------------------------------------------------------------------------------
class NeuralUpload(NamedTuple):
    """A neural CD-BTF on the device: the tile mean, the latent pyramid; the decoder's weights baked into the kernel."""

    grid: LookupGrid  # the tile mean's prepared grid
    mean_rgb: lj.TableUpload  # the tile mean in RGB records (the decoder's input and the modulated value)
    mean_spectral: lj.TableUpload | None  # spectral variants: the tile mean's spectral records
    latents: Any  # mi.Float: every level's codes, level after level, row-major, stride latent_dims
    levels: tuple[tuple[int, int, int], ...]  # (n_v, n_u, first code) of each level
    net: Any  # cdbrdf.btf._neural.Neural (its weights as Python floats in the kernel)
    clamp: tuple[float, float, float, float, bool]  # theta_v max, theta_l min, theta_l max, theta_v min, isotropic
    basis: Any  # spectral variants: (wavelength table start, step, mi.Float of 3 basis spectra interleaved)
    repeat_mm: tuple[float, float]
    uv_scale: tuple[float, float]
    texel_filter: str
    pixel_angle: float  # radians per pixel of the camera (0: no footprint, the finest level everywhere)
    mm_per_unit: float  # mm per unit of the scene (the hit distance's unit)

    @property
    def n_u(self) -> int:
        return self.levels[0][1]

    @property
    def n_v(self) -> int:
        return self.levels[0][0]


#: Wavelengths (nm) of the spectral basis of the modulation: start, step, count.
_BASIS_NM = (360.0, 1.0, 471)


def modulation_basis() -> np.ndarray:
    """``(n_wavelengths, 3)``: spectra ``s_c`` with ``sum_c s_c = 1`` whose RGB is about the unit colours.

    Mitsuba's sRGB model of pure red, green and blue, divided by their sum:
    a modulation ``m`` in RGB becomes ``sum_c m_c s_c(lambda)``, exactly 1 for
    ``m = (1, 1, 1)`` (the tile mean, far away).
    """
    import mitsuba as mi

    lam = _BASIS_NM[0] + _BASIS_NM[1] * np.arange(_BASIS_NM[2])
    out = np.empty((lam.size, 3))
    for c in range(3):
        rgb = [0.0, 0.0, 0.0]
        rgb[c] = 1.0
        coeff = np.asarray(mi.srgb_model_fetch(mi.ScalarColor3f(rgb)), dtype=np.float64).reshape(3)
        x = coeff[0] * lam * lam + coeff[1] * lam + coeff[2]
        out[:, c] = 0.5 + x / (2.0 * np.sqrt(1.0 + x * x))
    return out / out.sum(axis=1, keepdims=True)


def upload_neural(mi: Any, btf: Any, grid: LookupGrid, record: str, *, uv_scale: tuple[float, float],
                  texel_filter: str, pixel_angle: float = 0.0, mm_per_unit: float = 1.0) -> NeuralUpload:
    """The tile mean (RGB records, and spectral records in spectral variants) and the latent pyramid on the device."""
    t0 = time.perf_counter()
    net = btf.neural
    rgb = lj.float_table(mi, grid, "rgb")
    spec = lj.float_table(mi, grid, "spectral") if record == "spectral" else None
    flat, levels, start = [], [], 0
    for z in net.latents:
        flat.append(np.asarray(z, np.float32).reshape(-1))
        levels.append((int(z.shape[0]), int(z.shape[1]), start))
        start += int(z.shape[0] * z.shape[1])
    g = btf.grid
    clamp = (float(g.theta_v[-1]), float(g.theta_l[0]), float(g.theta_l[-1]), float(g.theta_v[0]), bool(g.isotropic))
    basis = None
    if record == "spectral":
        basis = (_BASIS_NM[0], _BASIS_NM[1], mi.Float(modulation_basis().astype(np.float32).reshape(-1)))
    _LOG.info("CD-BTF (neural): %d x %d texels, %d levels of %d-dimensional codes, layers %s, uploaded in %.2f s",
              btf.texels[0], btf.texels[1], len(levels), net.latent_dims, net.layers, time.perf_counter() - t0)
    return NeuralUpload(grid, rgb, spec, mi.Float(np.concatenate(flat)), tuple(levels), net, clamp, basis,
                        btf.repeat_mm, uv_scale, texel_filter, float(pixel_angle), float(mm_per_unit))


def _level_pick(dr: Any, lev: Any, values: list[Any]) -> Any:
    """``values[lev]`` per lane (a chain of selects over the few pyramid levels)."""
    out = values[-1]
    for i in range(len(values) - 2, -1, -1):
        out = dr.select(lev <= i, values[i], out)
    return out


def _codes(mi: Any, up: NeuralUpload, fu: Any, fv: Any, lev: Any, active: Any, xu: Any, xv: Any) -> list[Any]:
    """The code at fractions ``(fu, fv)`` of the repeat on level ``lev`` (per lane): bilinear between the level's
    texel centres, or one texel (``xu, xv`` uniforms: stochastic; None: nearest or bilinear)."""
    import drjit as dr

    UInt = mi.UInt32
    Int = dr.int32_array_t(mi.Float)
    L = up.net.latent_dims
    ArrayXf = lj._array_x(mi)
    nv = _level_pick(dr, lev, [mi.Float(a) for a, _, _ in up.levels])
    nu = _level_pick(dr, lev, [mi.Float(b) for _, b, _ in up.levels])
    first = _level_pick(dr, lev, [UInt(c) for _, _, c in up.levels])
    Nu, Nv = Int(nu), Int(nv)

    def wrap(i: Any, n: Any) -> Any:  # i in [-1, n]; clamped, so that no index is ever outside the level
        i = dr.select(i < 0, i + n, i)
        return dr.clip(dr.select(i >= n, i - n, i), 0, n - 1)

    def at(i: Any, j: Any) -> Any:
        idx = first + UInt(j * Nu + i)  # records of L floats: the index counts records
        return dr.gather(ArrayXf, up.latents, idx, active, shape=(L, 1))

    if up.texel_filter == "nearest":
        z = at(wrap(Int(dr.floor(fu * nu)), Nu), wrap(Int(dr.floor(fv * nv)), Nv))
        return [z[i] for i in range(L)]
    x, y = fu * nu - 0.5, fv * nv - 0.5
    x0, y0 = dr.floor(x), dr.floor(y)
    tu, tv = x - x0, y - y0
    i0, j0 = wrap(Int(x0), Nu), wrap(Int(y0), Nv)
    i1, j1 = wrap(i0 + 1, Nu), wrap(j0 + 1, Nv)
    if xu is not None:
        z = at(dr.select(xu < tu, i1, i0), dr.select(xv < tv, j1, j0))
        return [z[i] for i in range(L)]
    out = [mi.Float(0.0) for _ in range(L)]
    for j, wj in ((j0, 1.0 - tv), (j1, tv)):
        for i, wi in ((i0, 1.0 - tu), (i1, tu)):
            z, w = at(i, j), wj * wi
            for k in range(L):
                out[k] = dr.fma(w, z[k], out[k])
    return out


def _mlp(dr: Any, net: Any, x: list[Any]) -> list[Any]:
    """The decoder on a list of ``mi.Float`` inputs, weights as literals: ReLU hidden layers, linear output."""
    n = len(net.weights)
    for li, (w, b) in enumerate(zip(net.weights, net.biases)):
        w64 = np.asarray(w, np.float64)
        y = []
        for j in range(w64.shape[1]):
            acc = x[0] * float(w64[0, j]) + float(b[j])
            for i in range(1, w64.shape[0]):
                acc = dr.fma(x[i], float(w64[i, j]), acc)
            y.append(dr.maximum(acc, 0.0) if li < n - 1 else acc)
        x = y
    return x


def _features(mi: Any, up: NeuralUpload, tv: Any, pv: Any, tl: Any, pl: Any, kappa: Any, mean: Any) -> list[Any]:
    """:func:`cdbrdf.btf._neural.features` in Dr.Jit (the query clamped as the lookup rule clamps it)."""
    import drjit as dr

    tv_max, tl_min, tl_max, tv_min, iso = up.clamp
    tv = dr.clip(tv, tv_min, tv_max)
    tl = dr.clip(tl, tl_min, tl_max)
    if iso:
        pv, pl = pv - pl, mi.Float(0.0)
    d2r = np.pi / 180.0
    stv, ctv = dr.sincos(tv * d2r)
    spv, cpv = dr.sincos(pv * d2r)
    stl, ctl = dr.sincos(tl * d2r)
    spl, cpl = dr.sincos(pl * d2r)
    l = [stl * cpl, stl * spl, ctl]
    v = [stv * cpv, stv * spv, ctv]
    h = [a + b for a, b in zip(l, v)]
    inv = dr.rsqrt(dr.maximum(h[0] * h[0] + h[1] * h[1] + h[2] * h[2], 1e-24))
    ks, eps, off = up.net.constants
    lum = 0.2126 * mean[0] + 0.7152 * mean[1] + 0.0722 * mean[2]
    lm = dr.log(dr.maximum(lum, 0.0) + eps) - off
    return l + v + [x * inv for x in h] + [kappa * (1.0 / ks), lm]


def _footprint_level(mi: Any, up: NeuralUpload, si: Any, tv: Any) -> tuple[Any, Any, Any] | None:
    """``(level, t, fade)`` per lane from the footprint (:func:`cdbrdf.btf._neural.level_weights`), or None when
    the footprint is off (``pixel_angle`` 0 and no UV partials).

    The footprint is the UV partials' (a ray differential, where the
    integrator gives one), else the pixel's cone at the hit distance,
    ``t * pixel_angle``, stretched by ``1 / cos(theta_v)`` (at most 10).
    """
    import drjit as dr

    if up.pixel_angle <= 0.0:
        return None
    su, sv = up.uv_scale
    texel = max(up.repeat_mm[0] / up.n_u, up.repeat_mm[1] / up.n_v)
    cone = si.t * (up.pixel_angle * up.mm_per_unit) / dr.maximum(dr.cos(tv * (np.pi / 180.0)), 0.1)
    du = dr.maximum(dr.abs(si.duv_dx.x * su) + dr.abs(si.duv_dy.x * su), dr.abs(si.duv_dx.y * sv)
                    + dr.abs(si.duv_dy.y * sv))
    fp = dr.select(du > 0.0, du, cone) * (1.0 / texel)
    fp = dr.select(dr.isfinite(fp), fp, 0.0)
    lam = dr.log2(dr.maximum(fp, 1.0))
    n = len(up.levels)
    lev = dr.minimum(dr.floor(lam), n - 1.0)
    t = dr.select(lev < n - 1.0, lam - lev, 0.0)
    fade = dr.clip(n - lam, 0.0, 1.0)
    return mi.UInt32(lev), t, fade


def lookup_neural(mi: Any, up: NeuralUpload, si: Any, theta_v: Any, phi_v: Any, theta_l: Any, phi_l: Any,
                  kappa: Any, active: Any, wavelengths: Any, record: str) -> Any:
    """The neural CD-BTF at the lanes' hits: ``max(0, M (1 + fade o))`` (RGB; luminance for ``"one"``; the
    spectrum ``M(lambda) sum_c max(0, 1 + fade o_c) s_c(lambda)`` in spectral variants)."""
    import drjit as dr

    cell = lj.corners_jit(mi, up.grid, theta_v, phi_v, theta_l, phi_l, kappa)
    mean = lj.gather_jit(mi, up.grid, up.mean_rgb, cell, active)
    uv = si.uv
    fu = _wrap(dr, uv.x, up.uv_scale[0], up.repeat_mm[0], 1)
    fv = _wrap(dr, uv.y, up.uv_scale[1], up.repeat_mm[1], 1)
    xu = xv = None
    if up.texel_filter == "stochastic":
        xu, xv = texel_choice(mi, uv)
    lv = _footprint_level(mi, up, si, theta_v)
    if lv is None:
        z = _codes(mi, up, fu, fv, mi.UInt32(0), active, xu, xv)
        fade = None
    else:
        lev, t, fade = lv
        if xu is not None:  # one level: the coarser with probability t (a third uniform, from the hash of v, u)
            xl = texel_choice(mi, mi.Point2f(uv.y, uv.x))[0]
            lev = dr.select(xl < t, dr.minimum(lev + 1, len(up.levels) - 1), lev)
            z = _codes(mi, up, fu, fv, lev, active, xu, xv)
        else:
            z0 = _codes(mi, up, fu, fv, lev, active, None, None)
            z1 = _codes(mi, up, fu, fv, dr.minimum(lev + 1, len(up.levels) - 1), active, None, None)
            z = [a + t * (b - a) for a, b in zip(z0, z1)]
    o = _mlp(dr, up.net, z + _features(mi, up, theta_v, phi_v, theta_l, phi_l, kappa, mean))
    if fade is not None:
        o = [x * fade for x in o]
    m = [dr.maximum(1.0 + x, 0.0) for x in o]
    if record == "spectral":
        start, step, buf = up.basis
        assert up.mean_spectral is not None  # uploaded for spectral records
        spec = lj.gather_jit(mi, up.grid, up.mean_spectral, cell, active, wavelengths)
        mod = []
        for k in range(len(wavelengths)):
            x = dr.clip((wavelengths[k] - start) * (1.0 / step), 0.0, _BASIS_NM[2] - 1.001)
            i = mi.UInt32(x)
            w = x - mi.Float(i)
            acc = mi.Float(0.0)
            for c in range(3):
                a = dr.gather(mi.Float, buf, i * 3 + c, active)
                b = dr.gather(mi.Float, buf, (i + 1) * 3 + c, active)
                acc = dr.fma(m[c], a + w * (b - a), acc)
            mod.append(acc)
        return spec * mi.Spectrum(*mod)
    rgb = mi.Color3f(mean[0] * m[0], mean[1] * m[1], mean[2] * m[2])
    if record == "one":
        y = 0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2]
        return y if wavelengths is not None else mi.Color3f(y)
    return rgb


def scalar_modulation_spectrum(btf: Any, u_mm: float, v_mm: float, query: tuple[float, ...],
                               wavelengths: np.ndarray) -> np.ndarray:
    """A neural CD-BTF's modulation at one query as a spectrum (scalar spectral variants): ``sum_c m_c s_c``.

    ``m = max(0, 1 + o)`` of :func:`cdbrdf.btf._neural.neural_at` (the finest
    level), ``s_c`` of :func:`modulation_basis`; the tile mean's spectrum times
    this is what :func:`lookup_neural` gives in the vectorised variants.
    """
    from ..btf._neural import neural_at

    su, sv = btf.repeat_mm
    mean = btf.mean().evaluate(*query)
    q = [np.array([x], dtype=np.float64) for x in query]
    rgb = neural_at(btf.neural, btf.grid, np.array([(u_mm % su) / su]), np.array([(v_mm % sv) / sv]),
                    np.zeros(1), q, mean.reshape(1, -1))[0]
    with np.errstate(divide="ignore", invalid="ignore"):
        m = np.where(mean > 0, rgb / mean, 1.0)
    basis = modulation_basis()
    x = np.clip((np.asarray(wavelengths, np.float64) - _BASIS_NM[0]) / _BASIS_NM[1], 0.0, _BASIS_NM[2] - 1.001)
    i = x.astype(np.int64)
    s = basis[i] + (x - i)[:, None] * (basis[i + 1] - basis[i])
    return s @ m
