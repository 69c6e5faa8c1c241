"""The plug-in in Mitsuba's spectral and mono variants (and the variant checks).

Spectral variants upsample every table sample with Mitsuba's sRGB model and
blend the spectra (as Mitsuba's bitmap textures do); mono variants use the
luminance. A constant table renders as ``diffuse`` in both.
"""

from __future__ import annotations

import numpy as np
import pytest

from cdbrdf.colour import LUMINANCE_WEIGHTS
from cdbrdf.render import RenderSpec

from .render_helpers import constant_table, dr, glossy_table, mi, needs_llvm, vec

pytestmark = needs_llvm

LAMBDAS = (420.0, 510.0, 580.0, 660.0)


@pytest.fixture
def cr():
    import cdbrdf.render as cr

    yield cr
    cr.set_variant("llvm_ad_rgb")


def _si(cr_mod, wi, wavelengths=LAMBDAS):
    si = dr.zeros(mi.SurfaceInteraction3f, wi.shape[0])
    si.wi = vec(wi)
    if "spectral" in mi.variant():
        si.wavelengths = mi.Spectrum(*wavelengths)
    return si


def _dirs(rng, n):
    v = rng.normal(size=(n, 3))
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    v[:, 2] = np.abs(v[:, 2]) + 0.05
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def test_srgb_coefficients_are_mitsubas(cr):
    from cdbrdf.render._spectral import srgb_coefficients

    cr.set_variant("scalar_spectral")
    rng = np.random.default_rng(0)
    c = rng.random((1500, 3)).astype(np.float32)
    c[:200] **= 4  # dark colours
    c[200:250] = c[200:250, :1]  # greys
    c[250:260] = [[0, 0, 0], [1, 1, 1], [2, 2, 2], [1, 0, 0], [0, 0, 1], [1, 1, 0.999], [0.5] * 3, [1e-8, 0, 0],
                  [1.5, 0.2, -0.1], [0.3, 0.3, 0.30001]]
    ref = np.array([np.array(mi.srgb_model_fetch(mi.ScalarColor3f(*map(float, x)))) for x in c])
    np.testing.assert_array_equal(srgb_coefficients(c), ref.astype(np.float32))


def test_available_and_refused_variants(cr):
    have = cr.available_variants()
    assert {"llvm_ad_rgb", "llvm_ad_spectral", "llvm_ad_mono", "scalar_rgb", "scalar_spectral"} <= set(have)
    with pytest.raises(ValueError, match="llvm_ad_spectral_polarized' is not one of"):
        cr.set_variant("llvm_ad_spectral_polarized")
    mi.set_variant("llvm_ad_spectral_polarized")
    with pytest.raises(ValueError, match="polarised variants are not supported"):
        cr.register()


@pytest.mark.parametrize(("name", "kind"), [
    ("llvm_ad_spectral", "cdbrdf"), ("llvm_ad_mono", "cdbrdf"), ("llvm_ad_mono", "cdbtf"),
    pytest.param("llvm_ad_spectral", "cdbtf", marks=pytest.mark.slow)])
def test_constant_table_equals_diffuse(cr, name, kind):
    """A constant table, or a CD-BTF of constant texels, renders as ``diffuse`` (every variant takes both)."""
    from cdbrdf import CDBTF
    from cdbrdf.render.picture import render_scene
    from cdbrdf.render.scenes import sine_scene

    cr.set_variant(name)
    albedo = np.array([0.2, 0.5, 0.8])
    table = constant_table(albedo / np.pi)
    entry = {"type": "cdbrdf", "table": table, "sampling": "cosine"}
    if kind == "cdbtf":  # 3 x 2 texels equal to the table, sampled stochastically
        entry["table"] = CDBTF(table, np.zeros((2, 3, 0)), np.zeros(table.shape[:-1] + (0, 3)), repeat_mm=(1.0, 1.0))
        entry["uv_scale"] = 60.0
    spec = RenderSpec(size=(24, 16), spp=8, max_depth=3)
    ours = render_scene(sine_scene(table, spec, bsdf=entry), seed=3)
    diffuse = {"type": "diffuse", "reflectance": {"type": "rgb", "value": albedo.tolist()}}
    ref = render_scene(sine_scene(table, spec, bsdf=diffuse), seed=3)
    assert ours.mean() > 0.05
    np.testing.assert_allclose(ours, ref, rtol=2e-4, atol=2e-5)


def test_spectral_sample_is_mitsubas_upsampling_of_pi_f(cr):
    """At a table sample: the spectrum is Mitsuba's model of pi f, over pi (rescaled above 1)."""
    cr.set_variant("llvm_ad_spectral")
    for rgb in ([0.05, 0.1, 0.2], [0.9, 0.3, 0.1]):  # a reflectance-like colour and a bright glossy one
        table = constant_table(np.asarray(rgb))
        b = cr.make_bsdf(table, curvature=0.0, sampling="cosine")
        wi = np.array([[0.0, 0.0, 1.0]])
        f = np.array(b.eval(mi.BSDFContext(), _si(cr, wi), vec(wi))).ravel()
        rho = np.pi * np.asarray(rgb)
        s = max(1.0, rho.max())
        cr.set_variant("scalar_spectral")
        coeff = mi.srgb_model_fetch(mi.ScalarColor3f(*(rho / s)))
        want = [s / np.pi * float(mi.srgb_model_eval(coeff, mi.Spectrum(lam, lam, lam, lam))[0]) for lam in LAMBDAS]
        cr.set_variant("llvm_ad_spectral")
        np.testing.assert_allclose(f, want, rtol=2e-5)


def test_spectral_vectorised_equals_scalar(cr):
    """Between samples both blend the samples' spectra (the scalar path through the reference lookup)."""
    table = glossy_table(theta_step=15.0, phi_step=30.0, ks=0.3)
    rng = np.random.default_rng(1)
    n = 12
    wi, wo = _dirs(rng, n), _dirs(rng, n)
    cr.set_variant("llvm_ad_spectral")
    b = cr.make_bsdf(table, curvature=0.07)
    vec_f = np.array(b.eval(mi.BSDFContext(), _si(cr, wi), vec(wo))).T
    cr.set_variant("scalar_spectral")
    b = cr.make_bsdf(table, curvature=0.07)
    for i in range(n):
        si = mi.SurfaceInteraction3f()
        si.wi = mi.Vector3f(*map(float, wi[i]))
        si.wavelengths = mi.Spectrum(*LAMBDAS)
        f = np.array(b.eval(mi.BSDFContext(), si, mi.Vector3f(*map(float, wo[i]))))
        np.testing.assert_allclose(f, vec_f[i], rtol=2e-4, atol=1e-7)


def test_mono_is_luminance(cr):
    table = glossy_table(theta_step=15.0, phi_step=30.0, ks=0.3)
    rng = np.random.default_rng(2)
    n = 2000
    wi, wo = _dirs(rng, n), _dirs(rng, n)
    cr.set_variant("llvm_ad_rgb")
    rgb = np.array(cr.make_bsdf(table, curvature=-0.1).eval(mi.BSDFContext(), _si(cr, wi), vec(wo))).T
    cr.set_variant("llvm_ad_mono")
    for storage in ("packed", "float"):
        b = cr.make_bsdf(table, curvature=-0.1, storage=storage)
        mono = np.array(b.eval(mi.BSDFContext(), _si(cr, wi), vec(wo))).ravel()
        np.testing.assert_allclose(mono, rgb @ LUMINANCE_WEIGHTS, rtol=2e-5, atol=1e-7)


@pytest.mark.parametrize("name", ["llvm_ad_spectral", "llvm_ad_mono"])
def test_table_sampling_in_every_variant(cr, name):
    from cdbrdf.render.picture import render_scene
    from cdbrdf.render.scenes import sine_scene

    cr.set_variant(name)
    t = glossy_table(theta_step=15.0, phi_step=30.0, ks=0.3)
    img = render_scene(sine_scene(t, RenderSpec(size=(12, 8), spp=4)), seed=0)
    assert np.isfinite(img).all() and img.max() > 0


def test_scalar_variant_samples_with_the_same_rule(cr):
    """scalar_rgb (debugging): table sampling through the NumPy rule, consistent and equal to llvm_ad_rgb's."""
    table = glossy_table(theta_step=15.0, phi_step=30.0, ks=0.3)
    rng = np.random.default_rng(3)
    n = 16
    wi = _dirs(rng, n)
    wi[n // 2:] *= [1.0, 1.0, -1.0]  # the back side too
    s1, s2 = rng.random(n).astype(np.float32), rng.random((n, 2)).astype(np.float32)
    cr.set_variant("llvm_ad_rgb")
    b = cr.make_bsdf(table, curvature=0.05)
    bs, w = b.sample(mi.BSDFContext(), _si(cr, wi), mi.Float(s1), mi.Point2f(s2[:, 0], s2[:, 1]))
    ref_wo, ref_w = np.array(bs.wo).T, np.array(w).T
    cr.set_variant("scalar_rgb")
    b = cr.make_bsdf(table, curvature=0.05)
    ctx = mi.BSDFContext()
    for i in range(n):
        si = mi.SurfaceInteraction3f()
        si.wi = mi.Vector3f(*map(float, wi[i]))
        bs, w = b.sample(ctx, si, float(s1[i]), mi.Point2f(float(s2[i, 0]), float(s2[i, 1])))
        wo = np.array(bs.wo)
        assert float(b.pdf(ctx, si, bs.wo)) == pytest.approx(float(bs.pdf), rel=1e-6)
        f = np.array(b.eval(ctx, si, bs.wo))
        np.testing.assert_allclose(np.array(w), f / float(bs.pdf), rtol=1e-5)
        np.testing.assert_allclose(wo, ref_wo[i], atol=2e-4)
        np.testing.assert_allclose(np.array(w), ref_w[i], rtol=2e-3)


def test_a_variant_this_machine_cannot_run_is_one_error(cr):
    if dr.has_backend(dr.JitBackend.CUDA):
        pytest.skip("this machine has a CUDA device")
    from cdbrdf.errors import OptionError

    with pytest.raises(OptionError, match="'cuda_ad_rgb' cannot be used on this machine"):
        cr.set_variant("cuda_ad_rgb")


def test_auto_storage_keeps_precision_on_a_huge_dynamic_range(cr):
    """A grazing peak 10^6 times the median: the fixed point keeps ~2 levels there, so auto takes float."""
    import cdbrdf
    from cdbrdf.frames import angles_from_direction
    from cdbrdf.render import _lookup_jit as lj

    cr.set_variant("llvm_ad_rgb")
    g = cdbrdf.Grid.paper(kappa=[0.0])
    v = 0.02 + 0.01 * np.random.default_rng(0).random(g.shape + (3,))
    smooth = cdbrdf.CDBRDF(v.copy(), g)
    v[:, :, -1, :, -1] = 2e4  # grazing light and view
    peaked = cdbrdf.CDBRDF(v, g)
    assert not lj.packing_is_fine(peaked.lookup_grid().values) and lj.packing_is_fine(smooth.lookup_grid().values)
    auto = cr.make_bsdf(peaked, curvature=0.0)
    packed = cr.make_bsdf(peaked, curvature=0.0, storage="packed")
    assert auto.packed.layout == "float" and packed.packed.layout == "packed"
    assert cr.make_bsdf(smooth, curvature=0.0).packed.layout == "packed"
    rng = np.random.default_rng(1)
    wi, wo = _dirs(rng, 200), _dirs(rng, 200)
    wi, wo = wi[wi[:, 2] > 0.5], wo[wi[:, 2] > 0.5]  # away from the peak's samples
    tv, pv = angles_from_direction(wi)
    tl, pl = angles_from_direction(wo)
    want = peaked.evaluate(tv, pv, tl, pl, 0.0) * wo[:, 2:3]
    keep = tl < 60  # both elevations below the peak's cells
    got = np.array(auto.eval(mi.BSDFContext(), _si(cr, wi), vec(wo))).T
    np.testing.assert_allclose(got[keep], want[keep], rtol=3e-5)
    coarse = np.array(packed.eval(mi.BSDFContext(), _si(cr, wi), vec(wo))).T
    assert np.abs(coarse[keep] / want[keep] - 1).max() > 1e-3  # what the packed layout would give
