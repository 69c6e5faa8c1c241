"""Importance sampling of the plug-in (cdbrdf.render._sampling, ._sampling_jit).

The sampling tables follow the lookup rule (cell means equal the mean of
``CDBRDF.evaluate`` over the cell; the conditioning weights are the lookup's);
the density integrates to 1; ``sample`` and ``pdf`` agree (Mitsuba's
chi-square test on a strong lobe, which rejects a wrong density); the Dr.Jit
copy agrees with the NumPy rule; the weight is eval / pdf.
"""

from __future__ import annotations

import numpy as np
import pytest

import cdbrdf
from cdbrdf.render import _sampling

from .render_helpers import (
    constant_table,
    dr,
    glossy_table,
    hemisphere_quadrature,
    local_si,
    mi,
    needs_llvm,
    sheet_scene_dict,
    vec,
)


@pytest.fixture(scope="module", params=["anisotropic", "isotropic"])
def glossy(request):
    return glossy_table(symmetry=request.param)


@pytest.fixture(scope="module")
def glossy_tables(glossy):
    return _sampling.build_sampler(glossy.lookup_grid())


@pytest.fixture
def variant():
    import cdbrdf.render as cr

    cr.set_variant("llvm_ad_rgb")
    return cr


# -- the tables follow the lookup rule (NumPy only) ---------------------------------------------
def test_cell_means_are_means_of_the_lookup(glossy):
    lg = glossy.lookup_grid()
    nx, ny = 24, 16
    cells = _sampling.cell_means(lg, nx, ny)
    sub = (np.arange(8) + 0.5) / 8
    rng = np.random.default_rng(0)
    for _ in range(6):
        ik, it, ip = rng.integers(lg.kappa.size), rng.integers(lg.theta_v.size), rng.integers(lg.values.shape[3])
        j, i = rng.integers(ny), rng.integers(nx)
        u1 = (i + sub[:, None] + 0 * sub[None, :]) / nx
        u2 = (j + 0 * sub[:, None] + sub[None, :]) / ny
        tl = np.degrees(np.arcsin(np.sqrt(u2)))
        if lg.isotropic:  # u1 runs along the azimuth difference; the view azimuth is any
            ip = 0
            pv = 77.0
            pl = pv - (lg.phi_v0 + 360.0 * u1)
        else:
            pl = lg.phi_l0 + 360.0 * u1
            pv = lg.phi_v0 + ip * lg.phi_v_step
        f = glossy.evaluate(lg.theta_v[it], pv, tl, pl, lg.kappa[ik])
        want = (f @ cdbrdf.colour.LUMINANCE_WEIGHTS).mean()
        assert cells[ik, it, ip, j, i] == pytest.approx(want, rel=1e-12)


def test_conditioning_weights_are_the_lookup_rule():
    """A table that depends only on (kappa, theta_v, phi_v): the blended slice masses are the lookup."""
    g = cdbrdf.Grid(kappa=[-0.2, 0.05, 0.3], theta_l=[0.0, 40.0], phi_l=[0.0, 180.0],
                    theta_v=[0.0, 20.0, 50.0, 70.0], phi_v=np.arange(0.0, 360.0, 60.0) + 15.0)
    rng = np.random.default_rng(1)
    base = 0.1 + rng.random((3, 1, 1, 6, 4, 1))
    t = cdbrdf.CDBRDF(np.broadcast_to(base, g.shape + (1,)).copy(), g)
    tables = _sampling.build_sampler(t.lookup_grid())
    n = 500
    tv = np.concatenate([rng.uniform(0, 90, n - 20), np.zeros(10), np.full(10, 85.0)])
    pv = rng.uniform(-400, 400, n)
    k = rng.uniform(-0.5, 0.5, n)
    idx, w = _sampling.slice_weights(tables, tv, pv, k)
    got = (w * tables.mass[idx]).sum(axis=1)
    want = t.evaluate(tv, pv, 30.0, 77.0, k)[:, 0]
    np.testing.assert_allclose(got, want, rtol=1e-9)
    np.testing.assert_allclose(w.sum(axis=1), 1.0, rtol=1e-12)


@pytest.mark.parametrize("query", [(0.0, 0.0, 0.0), (40.0, 30.0, 0.1), (70.0, -100.0, -0.3), (37.0, 200.0, 0.05),
                                   (89.0, 10.0, 0.5)])
def test_pdf_integrates_to_one(glossy_tables, query):
    d, dw = hemisphere_quadrature(300)
    p = _sampling.pdf(glossy_tables, *query, d)
    assert (p * dw).sum() == pytest.approx(1.0, abs=2e-3)
    assert np.all(p > 0)  # the cosine share: no direction of the hemisphere is left out
    assert np.all(_sampling.pdf(glossy_tables, *query, d * [1, 1, -1]) == 0)


def test_numpy_sample_returns_its_pdf_and_follows_the_lobe(glossy_tables):
    rng = np.random.default_rng(2)
    n = 20000
    d, p = _sampling.sample(glossy_tables, 40.0, 30.0, 0.1, rng.random(n), rng.random((n, 2)))
    np.testing.assert_array_equal(p, _sampling.pdf(glossy_tables, 40.0, 30.0, 0.1, d))
    assert np.all(d[:, 2] > 0) and np.allclose(np.linalg.norm(d, axis=1), 1.0)
    # most samples near the mirror direction (theta 40, phi 210)
    mirror = np.array([np.sin(np.radians(40)) * np.cos(np.radians(210)),
                       np.sin(np.radians(40)) * np.sin(np.radians(210)), np.cos(np.radians(40))])
    assert np.mean(d @ mirror > np.cos(np.radians(25))) > 0.6


def test_constant_table_samples_the_cosine():
    t = constant_table([0.1, 0.2, 0.3])
    tables = _sampling.build_sampler(t.lookup_grid())
    d, _ = hemisphere_quadrature(50)
    np.testing.assert_allclose(_sampling.pdf(tables, 33.0, 12.0, 0.05, d), d[:, 2] / np.pi, rtol=1e-6)


def test_black_slices_fall_back_to_cosine():
    g = cdbrdf.Grid.paper(kappa=[0.0])
    t = cdbrdf.CDBRDF(np.zeros(g.shape + (3,)), g)
    tables = _sampling.build_sampler(t.lookup_grid())
    assert np.all(tables.mass == 0)
    d, _ = hemisphere_quadrature(40)
    np.testing.assert_allclose(_sampling.pdf(tables, 20.0, 0.0, 0.0, d), d[:, 2] / np.pi, rtol=1e-6)


def test_resolution_is_capped():
    from types import SimpleNamespace

    big = SimpleNamespace(values=np.empty((9, 72, 45, 72, 45, 1), dtype=np.float32))
    nx, ny = _sampling.default_resolution(big)
    assert 9 * 45 * 72 * nx * ny <= _sampling.MAX_CELLS and nx >= 8 and ny >= 8
    assert _sampling.default_resolution(constant_table([0.1] * 3).lookup_grid()) == (24, 20)
    one = SimpleNamespace(values=np.empty((1, 1, 7, 1, 7, 3)))
    assert _sampling.default_resolution(one) == (1, 24)
    iso = SimpleNamespace(values=np.empty((5, 1, 6, 12, 6, 3)), isotropic=True)  # u1 along the difference
    assert _sampling.default_resolution(iso) == (24, 20)


# -- the Dr.Jit copy and the plug-in ------------------------------------------------------------------
@needs_llvm
def test_jit_pdf_and_sample_agree_with_numpy(variant, glossy_tables):
    from cdbrdf.render import _sampling_jit as sj

    up = sj.upload(mi, glossy_tables)
    rng = np.random.default_rng(3)
    n = 20000
    tv, pv, k = rng.uniform(0, 89, n), rng.uniform(-180, 180, n), rng.uniform(-0.4, 0.4, n)
    F = lambda x: mi.Float(np.asarray(x, dtype=np.float32))  # noqa: E731
    tv, pv, k = [np.asarray(x, dtype=np.float32).astype(np.float64) for x in (tv, pv, k)]
    cond = sj.conditioning(mi, up, F(tv), F(pv), F(k))
    s1, s2 = rng.random(n).astype(np.float32), rng.random((n, 2)).astype(np.float32)
    d = np.array(sj.sample(mi, up, cond, F(s1), mi.Point2f(F(s2[:, 0]), F(s2[:, 1])), 0.1)).T
    d_ref, _ = _sampling.sample(glossy_tables, tv, pv, k, s1, s2)
    close = np.all(np.abs(d - d_ref) < 2e-4, axis=1)
    assert close.mean() > 0.999, close.mean()
    wl = vec(d_ref)
    pl = np.degrees(np.arctan2(d_ref[:, 1], d_ref[:, 0])).astype(np.float32)
    p = np.array(sj.pdf(mi, up, cond, wl, F(pl), 0.1))
    p_ref = _sampling.pdf(glossy_tables, tv, pv, k, d_ref)
    ok = np.isclose(p, p_ref, rtol=1e-4)
    assert ok.mean() > 0.999, ok.mean()  # the rest: directions on a cell boundary in float32


def _chi2(b, wi, *, pdf_override=None, sample_count=200_000):
    from mitsuba.chi2 import ChiSquareTest, SphericalDomain

    def sample(s):
        si = dr.zeros(mi.SurfaceInteraction3f, dr.width(s))
        si.wi = mi.Vector3f(*wi)
        bs, w = b.sample(mi.BSDFContext(), si, s[0], mi.Point2f(s[1], s[2]))
        return bs.wo, dr.select(dr.all(w == 0), 0.0, 1.0)

    def pdf(wo):
        si = dr.zeros(mi.SurfaceInteraction3f, dr.width(wo))
        si.wi = mi.Vector3f(*wi)
        return (pdf_override or b).pdf(mi.BSDFContext(), si, wo)

    # ires=16: the density is piecewise constant on its cells, and the test's default integration
    # of the pdf over each histogram bin (ires=4) is not accurate enough across the cells' jumps.
    test = ChiSquareTest(domain=SphericalDomain(), sample_func=sample, pdf_func=pdf, sample_dim=3,
                         sample_count=sample_count, res=41, ires=16)
    return test


@needs_llvm
@pytest.mark.parametrize("wi,kappa", [([0.0, 0.0, 1.0], 0.2), ([0.6, 0.0, 0.8], -0.1),
                                      ([0.3, 0.4, -float(np.sqrt(0.75))], 0.15)])
def test_chi2_strong_lobe(variant, glossy, wi, kappa, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # a rejected test writes chi2_data.py into the working folder
    b = variant.make_bsdf(glossy, curvature=kappa)
    test = _chi2(b, wi)
    assert test.run(), test.messages
    # The test has the power to tell: the cosine density (the old sampler) is rejected for these samples.
    cosine = variant.make_bsdf(glossy, curvature=kappa, sampling="cosine")
    wrong = _chi2(b, wi, pdf_override=cosine)
    assert not wrong.run()


@needs_llvm
def test_weight_is_eval_over_pdf_on_a_strong_lobe(variant, glossy):
    b = variant.make_bsdf(glossy, curvature=0.1)
    rng = np.random.default_rng(5)
    n = 20000
    wi = rng.normal(size=(n, 3))
    wi /= np.linalg.norm(wi, axis=1, keepdims=True)
    si = local_si(wi)
    ctx = mi.BSDFContext()
    bs, w = b.sample(ctx, si, mi.Float(rng.random(n).astype(np.float32)),
                     mi.Point2f(np.ascontiguousarray(rng.random((2, n)), dtype=np.float32)))
    f, p = b.eval_pdf(ctx, si, bs.wo)
    f, p, w, bp = np.array(f).T, np.array(p), np.array(w).T, np.array(bs.pdf)
    ok = bp > 0
    assert ok.mean() > 0.999
    np.testing.assert_allclose(p[ok], bp[ok], rtol=1e-6)
    np.testing.assert_allclose(w[ok], f[ok] / p[ok, None], rtol=1e-4)
    # the weights stay bounded (the table sampler follows f cos): max / mean much below cosine sampling's
    ws = w[ok].sum(axis=1)
    assert ws.max() < 20 * ws.mean()


@needs_llvm
def test_pdf_integrates_to_one_in_the_plugin(variant, glossy):
    b = variant.make_bsdf(glossy, curvature=-0.05)
    d, dw = hemisphere_quadrature(500)  # the density jumps at cell edges: a fine midpoint rule
    for wi in ([0.0, 0.0, 1.0], [0.5, -0.5, np.sqrt(0.5)], [0.2, 0.1, -0.97]):
        wi = np.asarray(wi) / np.linalg.norm(wi)
        dd = d * (1 if wi[2] > 0 else np.array([1.0, -1.0, -1.0]))
        si = local_si(np.broadcast_to(wi, dd.shape))
        p = np.array(b.pdf(mi.BSDFContext(), si, vec(dd)))
        assert (p * dw).sum() == pytest.approx(1.0, abs=3e-3)


@needs_llvm
def test_importance_transport_samples_the_cosine(variant, glossy):
    b = variant.make_bsdf(glossy, curvature=0.0)
    rng = np.random.default_rng(6)
    wi = np.tile([0.3, 0.0, np.sqrt(0.91)], (1000, 1))
    ctx = mi.BSDFContext(mi.TransportMode.Importance)
    bs, _ = b.sample(ctx, local_si(wi), mi.Float(0.5), mi.Point2f(np.ascontiguousarray(rng.random((2, 1000)),
                                                                                      dtype=np.float32)))
    wo = np.array(bs.wo).T
    np.testing.assert_allclose(np.array(bs.pdf), wo[:, 2] / np.pi, rtol=1e-5)


@needs_llvm
def test_table_sampling_renders_the_same_as_cosine(variant, tmp_path):
    """Same expected image with both samplers (equal up to noise), a glossy table under a sky."""
    from cdbrdf.render.picture import render_scene

    env = tmp_path / "sky.exr"
    sky = np.ones((16, 32, 3), dtype=np.float32)
    sky[:4] = 5.0  # a bright band near the zenith
    mi.Bitmap(sky).write(str(env))
    t = glossy_table(exponent=20.0, ks=0.5, kd=0.05, theta_step=15.0, phi_step=30.0)
    emitter = {"type": "envmap", "filename": str(env), "to_world": mi.ScalarTransform4f().rotate([1, 0, 0], 90.0)}
    imgs = []
    for seed, sampling in ((1, "table"), (2, "cosine")):
        d = sheet_scene_dict(tmp_path, {"type": "cdbrdf", "table": t, "sampling": sampling}, emitter=emitter,
                             spp=512)
        imgs.append(render_scene(variant.load_dict(d), seed=seed))
    a, b = imgs
    assert a.mean() > 0.01
    assert abs(a.mean() - b.mean()) < 0.02 * a.mean()
