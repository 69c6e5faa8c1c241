"""The plug-in with a CD-BTF: the texel at the UV, in the rgb, mono and spectral variants, vectorised and scalar."""

from __future__ import annotations

import numpy as np
import pytest

from cdbrdf import CDBTF, Grid
from cdbrdf.colour import LUMINANCE_WEIGHTS
from cdbrdf.errors import OptionError
from cdbrdf.mesh import MeshSurface
from cdbrdf.render import Camera, Light, RenderSpec, _btf_jit

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
    b = cr.make_bsdf(btf, curvature=kappa, uv_scale=UV_SCALE, texel_filter="bilinear")
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


@pytest.mark.parametrize("texel_filter", ["bilinear", "stochastic"])
def test_scalar_eval_equals_the_vectorised_one(cr, btf, texel_filter):
    """Scalar variants blend the four texels exactly, for ``stochastic`` too (its expected value)."""
    wi, tv, pv, wo, tl, pl, uv = _queries(8, seed=2)
    vec_f = np.array(cr.make_bsdf(btf, curvature=0.05, uv_scale=UV_SCALE, texel_filter="bilinear").eval(
        mi.BSDFContext(), _si(wi, uv), vec(wo))).T
    cr.set_variant("scalar_rgb")
    b = cr.make_bsdf(btf, curvature=0.05, uv_scale=UV_SCALE, texel_filter=texel_filter)
    for i in range(len(wi)):
        si = mi.SurfaceInteraction3f()
        si.wi = mi.Vector3f(*map(float, wi[i]))
        si.uv = mi.Point2f(*map(float, uv[i]))
        f = np.array(b.eval(mi.BSDFContext(), si, mi.Vector3f(*map(float, wo[i]))))
        np.testing.assert_allclose(f, vec_f[i], rtol=2e-4, atol=1e-6)


@pytest.mark.parametrize("texel_filter", ["bilinear", "stochastic"])
def test_mono_is_the_luminance(cr, btf, texel_filter):
    wi, tv, pv, wo, tl, pl, uv = _queries(1000, seed=3)
    rgb = np.array(cr.make_bsdf(btf, curvature=0.1, uv_scale=UV_SCALE, texel_filter=texel_filter).eval(
        mi.BSDFContext(), _si(wi, uv), vec(wo))).T
    cr.set_variant("llvm_ad_mono")
    mono = np.array(cr.make_bsdf(btf, curvature=0.1, uv_scale=UV_SCALE, texel_filter=texel_filter).eval(
        mi.BSDFContext(), _si(wi, uv), vec(wo))).ravel()
    np.testing.assert_allclose(mono, rgb @ LUMINANCE_WEIGHTS, rtol=2e-4, atol=1e-6)


@pytest.mark.slow
def test_brdf_mode_is_the_flat_texel(cr, btf):
    wi, tv, pv, wo, tl, pl, uv = _queries(500, seed=4)
    b = cr.make_bsdf(btf, mode="brdf", uv_scale=UV_SCALE, texel_filter="bilinear")
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
    assert dr is not None


def test_render_table_with_a_cdbtf(cr, btf):
    """Uniform texels render as their CDBRDF; varying texels average to it over the sheet."""
    from cdbrdf.mesh import SineSheet
    from cdbrdf.render import render_table

    sheet = SineSheet(width_mm=20.0, depth_mm=20.0, vertices_per_wavelength=16)
    spec = RenderSpec(surface=sheet, size=(32, 24), spp=64, exposure=0.0)
    ref = render_table(btf.mean(), spec).images["cdbrdf"][..., :3]
    flat = CDBTF(btf.mean(), np.zeros((6, 8, 0)), np.zeros(btf.mean().shape[:-1] + (0, 3)), repeat_mm=REPEAT)
    same = render_table(flat, spec).images["cdbrdf"][..., :3]
    np.testing.assert_allclose(same, ref, rtol=1e-4, atol=1e-5 * ref.max())
    woven = render_table(btf, spec).images["cdbrdf"][..., :3]
    assert np.abs(woven - ref).max() > 0.05 * ref.max()  # the texels show
    assert woven.mean() == pytest.approx(ref.mean(), rel=0.02)


def test_render_command_takes_uv_scale_and_texel_filter(cr, btf, tmp_path, capsys):
    """--uv-scale / --texel-filter reach the plug-in for a CD-BTF; a CDBRDF file or a scene file refuses them."""
    import cdbrdf.render.picture as picture
    from cdbrdf.cli import main as cli_main

    path = tmp_path / "b.h5"
    btf.save(path)
    seen = {}
    real = picture._btf_entry

    def spy(b, mode, curvature_mode, uv_scale, texel_filter):
        seen.update(uv_scale=uv_scale, texel_filter=texel_filter)
        return real(b, mode, curvature_mode, uv_scale, texel_filter)

    small = ["--size", "16x12", "--spp", "2"]
    try:
        picture._btf_entry = spy
        assert cli_main(["--quiet", "render", str(path), "--scene", "sine", "--uv-scale", "3,4", "--texel-filter", "nearest",
                         "-o", str(tmp_path / "a.png"), *small]) == 0
        assert seen == {"uv_scale": (3.0, 4.0), "texel_filter": "nearest"}
        assert cli_main(["--quiet", "render", str(path), "--scene", "sine", "--uv-scale", "2.5", "-o", str(tmp_path / "b.png"),
                         *small]) == 0
        assert seen == {"uv_scale": (2.5, 2.5), "texel_filter": None}
    finally:
        picture._btf_entry = real
    assert (tmp_path / "a.png").stat().st_size > 0
    table = tmp_path / "t.h5"
    btf.mean().save(table)
    capsys.readouterr()
    assert cli_main(["render", str(table), "--scene", "sine", "--texel-filter", "nearest", "-o",
                     str(tmp_path / "c.png"), *small]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--texel-filter: only for a CD-BTF file" in err[0]
    with pytest.raises(SystemExit) as exc:  # argparse: one line, exit 2
        cli_main(["render", str(path), "--scene", "sine", "--uv-scale", "0", "-o", str(tmp_path / "d.png")])
    assert exc.value.code == 2
    assert "--uv-scale" in capsys.readouterr().err.strip().splitlines()[-1]
    assert not (tmp_path / "c.png").exists() and not (tmp_path / "d.png").exists()


# -- the stochastic texel filter ----------------------------------------------------------------------
def _neighbourhood(uv0, n, seed):
    """``n`` UVs within 1e-4 UV units of ``uv0`` (under 1 % of a texel): nearly one set of bilinear weights.

    Wide enough in float32 steps that the lanes' UVs are (nearly all) distinct
    points, so the texel choices are ``n`` independent draws.
    """
    rng = np.random.default_rng(seed)
    uv = np.asarray(uv0) + rng.uniform(-1e-4, 1e-4, (n, 2))
    return uv.astype(np.float32).astype(np.float64)  # the UVs the renderer sees


def _bilinear_weights(uv, texels, repeat):
    """``(n, n_v, n_u)`` texel weights of the periodic bilinear rule (CDBTF.evaluate's)."""
    (nu, nv), n = texels, uv.shape[0]
    fu = np.mod(uv[:, 0] * UV_SCALE[0], repeat[0]) / repeat[0] * nu - 0.5
    fv = np.mod(uv[:, 1] * UV_SCALE[1], repeat[1]) / repeat[1] * nv - 0.5
    i0, j0 = np.floor(fu).astype(int), np.floor(fv).astype(int)
    tu, tv = fu - i0, fv - j0
    w = np.zeros((n, nv, nu))
    rows = np.arange(n)
    for dj, wj in ((0, 1 - tv), (1, tv)):
        for di, wi in ((0, 1 - tu), (1, tu)):
            np.add.at(w, (rows, (j0 + dj) % nv, (i0 + di) % nu), wj * wi)
    return w


def test_stochastic_texel_probabilities_are_the_bilinear_weights(cr):
    """Texels of distinct constant values: how often each is read is its bilinear weight (binomial bounds)."""
    g = Grid.regular(theta_step_deg=30, phi_step_deg=90, kappa=[0.0])
    nv, nu = 3, 4
    code = 1.0 + np.arange(nv * nu, dtype=np.float64).reshape(nv, nu)  # texel (j, i) reflects code[j, i]
    vals = np.broadcast_to(code[:, :, None, None, None, None, None, None], (nv, nu) + g.shape + (3,))
    flat = CDBTF.from_values(vals, g, repeat_mm=REPEAT, max_error=1e-7)
    n = 40000
    wi = np.tile([[0.0, 0.0, 1.0]], (n, 1))
    b = cr.make_bsdf(flat, curvature=0.0, uv_scale=UV_SCALE, texel_filter="stochastic")
    for k, uv0 in enumerate(([0.031, 0.047], [0.19, 0.23], [-0.06, 0.11])):
        uv = _neighbourhood(uv0, n, seed=k)
        f = np.array(b.eval(mi.BSDFContext(), _si(wi, uv), vec(wi))).T[:, 0]
        got = np.rint(f).astype(int) - 1  # the texel read (values are exact to ~1e-6)
        assert np.abs(f - (got + 1)).max() < 1e-3
        p = _bilinear_weights(uv, (nu, nv), REPEAT).mean(axis=0).reshape(-1)
        freq = np.bincount(got, minlength=nu * nv) / n
        # each count is binomial(n, p): 5 standard deviations, fixed UVs (a deterministic test)
        np.testing.assert_array_less(np.abs(freq - p), 5 * np.sqrt(p * (1 - p) / n) + 1e-12)
        assert np.all(freq[p == 0] == 0)  # never a texel outside the four


def test_stochastic_mean_is_the_bilinear_value(cr, btf):
    """At fixed directions and a fixed UV neighbourhood the mean of many evaluations is the bilinear one."""
    rng = np.random.default_rng(7)
    n = 20000
    sto = cr.make_bsdf(btf, curvature=0.1, uv_scale=UV_SCALE, texel_filter="stochastic")
    bil = cr.make_bsdf(btf, curvature=0.1, uv_scale=UV_SCALE, texel_filter="bilinear")
    for k in range(4):
        wi = np.tile(unit(rng.uniform(10, 70), rng.uniform(0, 360)), (n, 1))
        wo = np.tile(unit(rng.uniform(10, 70), rng.uniform(0, 360)), (n, 1))
        uv = _neighbourhood(rng.uniform(-1, 1, 2), n, seed=10 + k)
        s = np.array(sto.eval(mi.BSDFContext(), _si(wi, uv), vec(wo))).T
        want = np.array(bil.eval(mi.BSDFContext(), _si(wi, uv), vec(wo))).T.mean(axis=0)
        tol = 5 * s.std(axis=0) / np.sqrt(n) + 1e-6 * np.abs(want)  # 5 standard errors of the mean
        np.testing.assert_array_less(np.abs(s.mean(axis=0) - want), tol)
        assert s.std(axis=0).max() > 0  # the texels differ here: the test has power


@pytest.mark.slow
def test_stochastic_render_converges_to_the_bilinear_one(cr, btf):
    """A close-up (texels over several pixels) rendered with both filters: the same picture within noise."""
    from cdbrdf.mesh import SineSheet
    from cdbrdf.render import render_table

    sheet = SineSheet(width_mm=6.0, depth_mm=6.0, vertices_per_wavelength=16)
    imgs = {}
    for f in ("bilinear", "stochastic"):
        spec = RenderSpec(surface=sheet, size=(24, 24), spp=256, exposure=0.0, texel_filter=f)
        imgs[f] = render_table(btf, spec).images["cdbrdf"][..., :3].astype(np.float64)
    a, b = imgs["bilinear"], imgs["stochastic"]
    assert abs(b.mean() / a.mean() - 1) < 0.01
    assert np.abs(b - a).mean() < 0.05 * a.mean()


# -- spectral variants -------------------------------------------------------------------------------
LAMBDAS = (420.0, 510.0, 580.0, 660.0)


def _spectral_si(wi, uv):
    si = _si(wi, uv)
    si.wavelengths = mi.Spectrum(*LAMBDAS)
    return si


def _spectrum(rgb):
    """Spectra at LAMBDAS of BRDF values ``(n, 3)`` as the plug-in converts a table sample (Mitsuba's model)."""
    from cdbrdf.render._spectral import spectral_records

    r = spectral_records(rgb).astype(np.float64)
    lam = np.asarray(LAMBDAS)
    x = (r[:, :1] * lam + r[:, 1:2]) * lam + r[:, 2:3]
    return r[:, 3:] * np.maximum(0.0, 0.5 * x / np.sqrt(x * x + 1.0) + 0.5)


@pytest.mark.parametrize("texel_filter", [pytest.param("bilinear", marks=pytest.mark.slow), "stochastic",
                                          pytest.param("nearest", marks=pytest.mark.slow)])
def test_spectral_uniform_texels_are_the_cdbrdf(cr, btf, texel_filter):
    """Every texel equal to a CDBRDF: the spectral eval is the CDBRDF's (vectorised)."""
    flat = CDBTF(btf.mean(), np.zeros((6, 8, 0)), np.zeros(btf.mean().shape[:-1] + (0, 3)), repeat_mm=REPEAT)
    wi, tv, pv, wo, tl, pl, uv = _queries(2000, seed=5)
    cr.set_variant("llvm_ad_spectral")
    want = np.array(cr.make_bsdf(flat.mean(), curvature=0.1).eval(mi.BSDFContext(), _spectral_si(wi, uv), vec(wo)))
    b = cr.make_bsdf(flat, curvature=0.1, uv_scale=UV_SCALE, texel_filter=texel_filter)
    got = np.array(b.eval(mi.BSDFContext(), _spectral_si(wi, uv), vec(wo)))
    assert want.max() > 0
    assert dr.width(b.texels.table.buffer) * 4 == _btf_jit.upload_nbytes(6 * 8, GRID.shape, "spectral")
    np.testing.assert_allclose(got, want, rtol=1e-5, atol=1e-7 * want.max())


def test_spectral_texels_at_the_samples(cr, btf):
    """At table samples the spectrum is the texels' values (CDBTF.evaluate at their centres) converted and blended."""
    rng = np.random.default_rng(6)
    n = 400
    idx = [rng.integers(1, GRID.theta_v.size, n), rng.integers(0, GRID.phi_v.size, n),
           rng.integers(1, GRID.theta_l.size, n), rng.integers(0, GRID.phi_l.size, n)]
    tv, pv, tl, pl = GRID.theta_v[idx[0]], GRID.phi_v[idx[1]], GRID.theta_l[idx[2]], GRID.phi_l[idx[3]]
    wi, wo = unit(tv, pv), unit(tl, pl)
    uv = rng.uniform(-1, 1, (n, 2))
    w = _bilinear_weights(uv, btf.texels, REPEAT)
    cu, cv = btf.texel_centres_mm()
    want = np.zeros((n, len(LAMBDAS)))
    for j, i in zip(*np.nonzero(w.sum(axis=0))):  # every texel some query reads
        rgb = btf.evaluate(cu[i], cv[j], tv, pv, tl, pl, 0.2)  # the texel's samples (queries at nodes)
        want += w[:, j, i][:, None] * _spectrum(rgb)
    want *= np.cos(np.radians(tl))[:, None]
    cr.set_variant("llvm_ad_spectral")
    b = cr.make_bsdf(btf, curvature=0.2, uv_scale=UV_SCALE, texel_filter="bilinear")
    got = np.array(b.eval(mi.BSDFContext(), _spectral_si(wi, uv), vec(wo))).T
    np.testing.assert_allclose(got, want, rtol=2e-4, atol=2e-5 * want.max())


@pytest.mark.parametrize("texel_filter", [pytest.param("bilinear", marks=pytest.mark.slow), "nearest"])
def test_scalar_spectral_equals_the_vectorised_one(cr, btf, texel_filter):
    """Between samples too: both blend the texels' spectra (scalar through the reference lookup)."""
    wi, tv, pv, wo, tl, pl, uv = _queries(8, seed=8)
    uv[:, 1] += 0.01  # away from texel edges (nearest)
    cr.set_variant("llvm_ad_spectral")
    vec_f = np.array(cr.make_bsdf(btf, curvature=-0.05, uv_scale=UV_SCALE, texel_filter=texel_filter).eval(
        mi.BSDFContext(), _spectral_si(wi, uv), vec(wo))).T
    cr.set_variant("scalar_spectral")
    b = cr.make_bsdf(btf, curvature=-0.05, uv_scale=UV_SCALE, texel_filter=texel_filter)
    for i in range(len(wi)):
        si = mi.SurfaceInteraction3f()
        si.wi = mi.Vector3f(*map(float, wi[i]))
        si.uv = mi.Point2f(*map(float, uv[i]))
        si.wavelengths = mi.Spectrum(*LAMBDAS)
        f = np.array(b.eval(mi.BSDFContext(), si, mi.Vector3f(*map(float, wo[i]))))
        np.testing.assert_allclose(f, vec_f[i], rtol=2e-4, atol=1e-7)


@pytest.mark.slow
def test_spectral_render_of_uniform_texels_is_the_cdbrdfs(cr, btf):
    from cdbrdf.mesh import SineSheet
    from cdbrdf.render import render_table

    sheet = SineSheet(width_mm=20.0, depth_mm=20.0, vertices_per_wavelength=16)
    spec = RenderSpec(surface=sheet, size=(24, 16), spp=32, exposure=0.0, variant="llvm_ad_spectral")
    flat = CDBTF(btf.mean(), np.zeros((6, 8, 0)), np.zeros(btf.mean().shape[:-1] + (0, 3)), repeat_mm=REPEAT)
    ref = render_table(btf.mean(), spec).images["cdbrdf"][..., :3]
    same = render_table(flat, spec).images["cdbrdf"][..., :3]
    assert ref.max() > 0
    np.testing.assert_allclose(same, ref, rtol=1e-4, atol=1e-5 * ref.max())


def test_a_mesh_without_its_own_uvs_renders_the_tile_mean_and_says_so(cr, btf):
    """prepare_mesh's per-face UVs follow no fabric: the CD-BTF is not laid by them (as in the viewer)."""
    from cdbrdf.render import render_table

    from .test_viewer_btf_mesh import flat_grid

    kw = {"size": (32, 24), "spp": 16, "exposure": 0.0, "light": Light(direction=(50.0, 0.0)),
          "camera": Camera(view=(60.0, -90.0))}
    bare_spec = RenderSpec(surface=MeshSurface(flat_grid(20.0, 20.0, uv=False), units="mm"), **kw)
    bare = render_table(btf, bare_spec)
    mean = render_table(btf.mean(), bare_spec)
    # the same scene and table: equal up to the order of float32 sums in the render (1e-7 seen)
    np.testing.assert_allclose(bare.images["cdbrdf"], mean.images["cdbrdf"], rtol=1e-5, atol=1e-6)
    assert "no UVs of its own: the CD-BTF's tile mean is rendered on it" in bare.mesh.metadata["notes"]
    woven = render_table(btf, RenderSpec(surface=MeshSurface(flat_grid(20.0, 20.0), units="mm"), **kw))  # own UVs
    assert np.abs(woven.images["cdbrdf"] - mean.images["cdbrdf"]).max() > 0.02 * mean.images["cdbrdf"].max()
    assert not any("tile mean" in n for n in woven.mesh.metadata.get("notes", []))


# -- a neural CD-BTF: the decoder in Dr.Jit ------------------------------------------------------------
@pytest.fixture(scope="module")
def neural(btf):
    from cdbrdf.btf._neural import FitOptions

    return CDBTF.from_values(btf.decode(), GRID, repeat_mm=REPEAT, method="neural", max_error=0.9,
                             fit=FitOptions(steps=40, latent_dims=5, hidden=(16, 8)))


def _far_si(wi, uv, t):
    si = _si(wi, uv)
    si.t = mi.Float(np.full(len(uv), t, np.float32))
    return si


@pytest.mark.parametrize("texel_filter", ["bilinear", "nearest"])
def test_neural_eval_is_evaluate_at_every_footprint(cr, neural, texel_filter):
    """The Dr.Jit decoder equals CDBTF.evaluate: footprint 0, between levels, and the tile mean from far away."""
    assert neural.neural is not None and neural.rank == 0
    wi, tv, pv, wo, tl, pl, uv = _queries(1500, seed=8)
    angle = 1e-3
    b = cr.make_bsdf(neural, curvature=0.1, uv_scale=UV_SCALE, texel_filter=texel_filter, pixel_angle=angle)
    assert isinstance(b.texels, _btf_jit.NeuralUpload)
    u, v = uv[:, 0] * UV_SCALE[0], uv[:, 1] * UV_SCALE[1]
    if texel_filter == "nearest":  # the containing texel of each level: compare at the texel centres
        nu, nv = neural.texels
        u = (np.floor(u / REPEAT[0] * nu) + 0.5) * REPEAT[0] / nu
        v = (np.floor(v / REPEAT[1] * nv) + 0.5) * REPEAT[1] / nv
        uv = np.stack([u / UV_SCALE[0], v / UV_SCALE[1]], axis=1)
    cos_l = np.cos(np.radians(tl))[:, None]
    for t in (0.0, 300.0, 1e5):  # the hit distance, mm: footprint 0, about a texel and more, the whole repeat
        fp = t * angle / np.maximum(np.cos(np.radians(tv)), 0.1)
        got = np.array(b.eval(mi.BSDFContext(), _far_si(wi, uv, t), vec(wo))).T
        want = neural.evaluate(u, v, tv, pv, tl, pl, 0.1, footprint_mm=fp) * cos_l
        if texel_filter == "nearest" and t > 0:  # levels above 0 are read at their own texels: only far away
            continue
        np.testing.assert_allclose(got, want, rtol=3e-4, atol=3e-5 * want.max())
    mean = neural.mean().evaluate(tv, pv, tl, pl, 0.1) * cos_l
    np.testing.assert_allclose(got, mean, rtol=3e-4, atol=3e-5 * mean.max())


def test_neural_mono_is_the_luminance_and_spectral_far_away_is_the_cdbrdf(cr, neural):
    wi, tv, pv, wo, tl, pl, uv = _queries(800, seed=9)
    rgb = np.array(cr.make_bsdf(neural, curvature=0.1, uv_scale=UV_SCALE).eval(
        mi.BSDFContext(), _si(wi, uv), vec(wo))).T
    cr.set_variant("llvm_ad_mono")
    y = np.array(cr.make_bsdf(neural, curvature=0.1, uv_scale=UV_SCALE).eval(mi.BSDFContext(), _si(wi, uv), vec(wo)))
    np.testing.assert_allclose(y.reshape(-1), rgb @ LUMINANCE_WEIGHTS, rtol=1e-4, atol=1e-6)
    cr.set_variant("llvm_ad_spectral")
    want = np.array(cr.make_bsdf(neural.mean(), curvature=0.1).eval(mi.BSDFContext(), _spectral_si(wi, uv), vec(wo)))
    b = cr.make_bsdf(neural, curvature=0.1, uv_scale=UV_SCALE, pixel_angle=1.0)
    si = _spectral_si(wi, uv)
    si.t = mi.Float(np.full(len(uv), 1e4, np.float32))
    got = np.array(b.eval(mi.BSDFContext(), si, vec(wo)))
    np.testing.assert_allclose(got, want, rtol=1e-5, atol=1e-7 * want.max())
    near = np.array(b.eval(mi.BSDFContext(), _spectral_si(wi, uv), vec(wo)))  # t = 0: the texels
    assert np.all(np.isfinite(near)) and np.abs(near - want).max() > 1e-3 * want.max()


def test_neural_scalar_eval_equals_the_vectorised_one(cr, neural):
    wi, tv, pv, wo, tl, pl, uv = _queries(40, seed=10)
    want = np.array(cr.make_bsdf(neural, curvature=0.1, uv_scale=UV_SCALE, texel_filter="bilinear").eval(
        mi.BSDFContext(), _si(wi, uv), vec(wo))).T
    cr.set_variant("scalar_rgb")
    b = cr.make_bsdf(neural, curvature=0.1, uv_scale=UV_SCALE, texel_filter="bilinear")
    for i in range(len(uv)):
        si = mi.SurfaceInteraction3f()
        si.wi = mi.Vector3f(*map(float, wi[i]))
        si.sh_frame = mi.Frame3f(mi.Vector3f(0, 0, 1))
        si.n = mi.Normal3f(0, 0, 1)
        si.uv = mi.Point2f(float(uv[i, 0]), float(uv[i, 1]))
        got = np.array(b.eval(mi.BSDFContext(), si, mi.Vector3f(*map(float, wo[i])))).reshape(-1)
        np.testing.assert_allclose(got, want[i], rtol=1e-3, atol=1e-5 * want.max())
