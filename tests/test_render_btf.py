"""The plug-in with a CD-BTF: the texel at the UV, in the rgb and mono variants, vectorised and scalar."""

from __future__ import annotations

import numpy as np
import pytest

from cdbrdf import CDBTF, Grid
from cdbrdf.colour import LUMINANCE_WEIGHTS
from cdbrdf.errors import OptionError

from .render_helpers import dr, local_si, mi, needs_llvm, unit, vec

pytestmark = needs_llvm

GRID = Grid.regular(theta_step_deg=15, phi_step_deg=30, kappa=[-0.2, 0.0, 0.2])
REPEAT = (2.0, 1.5)
UV_SCALE = (10.0, 6.0)  # mm per UV unit


@pytest.fixture
def cr():
    import cdbrdf.render as cr

    cr.set_variant("llvm_ad_rgb")
    yield cr
    cr.set_variant("llvm_ad_rgb")


@pytest.fixture(scope="module")
def btf():
    """Texels with a low-rank glossy structure varying over the repeat and with curvature."""
    rng = np.random.default_rng(3)
    m = GRID.mesh()
    h = unit(m["theta_l"], m["phi_l"]) + unit(m["theta_v"], m["phi_v"])
    h /= np.linalg.norm(h, axis=-1, keepdims=True)
    base = (0.05 + 0.5 * np.clip(h[..., 2], 0, 1) ** 20 * (1 + m["kappa"]))[..., None] * [1.0, 0.7, 0.4]
    tilt = (0.1 * h[..., 0] * (1 + m["kappa"]))[..., None] * [0.2, 0.3, 0.6]
    w = rng.uniform(-1, 1, (6, 8, 1))
    vals = base[None, None] * (1 + 0.5 * w[..., None, None, None, None, None]) + w[..., None, None, None, None, None] * tilt
    return CDBTF.from_values(np.maximum(vals, 0.0), GRID, repeat_mm=REPEAT, max_error=1e-4)


def _queries(n, seed=0):
    rng = np.random.default_rng(seed)
    def dirs():
        t, p = np.degrees(np.arccos(rng.uniform(0.1, 1.0, n))), rng.uniform(0, 360, n)
        return unit(t, p), t, p
    (wi, tv, pv), (wo, tl, pl) = dirs(), dirs()
    uv = rng.uniform(-2, 2, (n, 2))
    return wi, tv, pv, wo, tl, pl, uv


def _si(wi, uv):
    si = local_si(wi)
    si.uv = mi.Point2f(np.ascontiguousarray(uv[:, 0], np.float32), np.ascontiguousarray(uv[:, 1], np.float32))
    return si


def _reference(btf, tv, pv, tl, pl, uv, kappa):
    u, v = uv[:, 0] * UV_SCALE[0], uv[:, 1] * UV_SCALE[1]
    return btf.evaluate(u, v, tv, pv, tl, pl, kappa) * np.cos(np.radians(tl))[:, None]


@pytest.mark.parametrize("kappa", [0.2, pytest.param(-0.1, marks=pytest.mark.slow),
                                   pytest.param(0.0, marks=pytest.mark.slow)])
def test_vectorised_eval_is_the_texel_at_the_uv(cr, btf, kappa):
    wi, tv, pv, wo, tl, pl, uv = _queries(3000)
    b = cr.make_bsdf(btf, curvature=kappa, uv_scale=UV_SCALE)
    got = np.array(b.eval(mi.BSDFContext(), _si(wi, uv), vec(wo))).T
    want = _reference(btf, tv, pv, tl, pl, uv, kappa)
    np.testing.assert_allclose(got, want, rtol=2e-4, atol=2e-5 * want.max())


def test_nearest_filter_reads_the_texel_centre(cr, btf):
    wi, tv, pv, wo, tl, pl, uv = _queries(500, seed=1)
    b = cr.make_bsdf(btf, curvature=0.1, uv_scale=UV_SCALE, texel_filter="nearest")
    got = np.array(b.eval(mi.BSDFContext(), _si(wi, uv), vec(wo))).T
    (nu, nv), (su, sv) = btf.texels, btf.repeat_mm
    centre = np.stack([(np.floor(uv[:, 0] * UV_SCALE[0] / su * nu) + 0.5) * su / nu / UV_SCALE[0],
                       (np.floor(uv[:, 1] * UV_SCALE[1] / sv * nv) + 0.5) * sv / nv / UV_SCALE[1]], -1)
    want = _reference(btf, tv, pv, tl, pl, centre, 0.1)
    ok = np.abs(np.mod(uv * UV_SCALE / np.array(REPEAT) * [nu, nv], 1.0) - 0.5).max(axis=1) < 0.49  # not on an edge
    np.testing.assert_allclose(got[ok], want[ok], rtol=2e-4, atol=2e-5 * want.max())


def test_scalar_eval_equals_the_vectorised_one(cr, btf):
    wi, tv, pv, wo, tl, pl, uv = _queries(8, seed=2)
    vec_f = np.array(cr.make_bsdf(btf, curvature=0.05, uv_scale=UV_SCALE).eval(
        mi.BSDFContext(), _si(wi, uv), vec(wo))).T
    cr.set_variant("scalar_rgb")
    b = cr.make_bsdf(btf, curvature=0.05, uv_scale=UV_SCALE)
    for i in range(len(wi)):
        si = mi.SurfaceInteraction3f()
        si.wi = mi.Vector3f(*map(float, wi[i]))
        si.uv = mi.Point2f(*map(float, uv[i]))
        f = np.array(b.eval(mi.BSDFContext(), si, mi.Vector3f(*map(float, wo[i]))))
        np.testing.assert_allclose(f, vec_f[i], rtol=2e-4, atol=1e-6)


def test_mono_is_the_luminance(cr, btf):
    wi, tv, pv, wo, tl, pl, uv = _queries(1000, seed=3)
    rgb = np.array(cr.make_bsdf(btf, curvature=0.1, uv_scale=UV_SCALE).eval(
        mi.BSDFContext(), _si(wi, uv), vec(wo))).T
    cr.set_variant("llvm_ad_mono")
    mono = np.array(cr.make_bsdf(btf, curvature=0.1, uv_scale=UV_SCALE).eval(
        mi.BSDFContext(), _si(wi, uv), vec(wo))).ravel()
    np.testing.assert_allclose(mono, rgb @ LUMINANCE_WEIGHTS, rtol=2e-4, atol=1e-6)


@pytest.mark.slow
def test_brdf_mode_is_the_flat_texel(cr, btf):
    wi, tv, pv, wo, tl, pl, uv = _queries(500, seed=4)
    b = cr.make_bsdf(btf, mode="brdf", uv_scale=UV_SCALE)
    got = np.array(b.eval(mi.BSDFContext(), _si(wi, uv), vec(wo))).T
    np.testing.assert_allclose(got, _reference(btf, tv, pv, tl, pl, uv, 0.0), rtol=2e-4, atol=2e-5)


def test_file_and_options(cr, btf, tmp_path):
    path = tmp_path / "b.h5"
    btf.save(path)
    b = cr.make_bsdf(str(path), uv_scale=2.5)
    assert b.btf is not None and b.uv_scale == (2.5, 2.5) and "btf=" in b.to_string()
    for bad in ("0", "a, b", (1.0, -1.0)):
        with pytest.raises(OptionError, match="uv_scale"):
            cr.make_bsdf(btf, uv_scale=bad)
    with pytest.raises(OptionError, match="texel_filter"):
        cr.make_bsdf(btf, texel_filter="cubic")
    cr.set_variant("llvm_ad_spectral")
    with pytest.raises(OptionError, match="rgb and mono"):
        cr.make_bsdf(btf)
    assert dr is not None


def test_render_table_with_a_cdbtf(cr, btf):
    """Uniform texels render as their CDBRDF; varying texels average to it over the sheet."""
    from cdbrdf.mesh import SineSheet
    from cdbrdf.render import render_table

    sheet = SineSheet(width_mm=20.0, depth_mm=20.0, vertices_per_wavelength=16)
    kw = {"size": (32, 24), "spp": 64, "exposure": 0.0}
    ref = render_table(btf.mean(), sheet, **kw).images["cdbrdf"][..., :3]
    flat = CDBTF(btf.mean(), np.zeros((6, 8, 0)), np.zeros(btf.mean().shape[:-1] + (0, 3)), repeat_mm=REPEAT)
    same = render_table(flat, sheet, **kw).images["cdbrdf"][..., :3]
    np.testing.assert_allclose(same, ref, rtol=1e-4, atol=1e-5 * ref.max())
    woven = render_table(btf, sheet, **kw).images["cdbrdf"][..., :3]
    assert np.abs(woven - ref).max() > 0.05 * ref.max()  # the texels show
    assert woven.mean() == pytest.approx(ref.mean(), rel=0.02)
