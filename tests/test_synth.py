"""The woven-cloth model (cdbrdf.synth): geometry, scattering, energy, targets."""

from __future__ import annotations

import numpy as np
import pytest

import cdbrdf
from cdbrdf.cli import main as cli_main
from cdbrdf.synth import ClothParams, presets
from cdbrdf.synth.cloth import MODEL_NAME
from cdbrdf.synth.fibre import FibreLobes, _terms, fresnel_dielectric, local_albedo_max
from cdbrdf.synth.metrics import chromaticity, in_plane_luminance, luminance
from cdbrdf.synth.weave import (
    BACKING,
    WARP,
    WEFT,
    YarnGeometry,
    build_heightfield,
    face_stretch,
    weave_matrix,
    x_of_xi,
)

PAPER_T = np.arange(0.0, 76.0, 15.0)
PAPER_P = np.arange(0.0, 360.0, 30.0)
FAST = dict(texels=48, rays=233, tilt_samples=3)
WHITE = dict(warp_rgb=(1, 1, 1), weft_rgb=(1, 1, 1), backing_rgb=(1, 1, 1),
             warp_specular=1.0, weft_specular=1.0)


@pytest.fixture(scope="module")
def denim():
    return presets.model("denim")


@pytest.fixture(scope="module")
def shot():
    return presets.model("shot")


# -- weave patterns and parameters -------------------------------------------------
def test_weave_registry_and_matrix():
    assert weave_matrix("plain").tolist() == [[1, 0], [0, 1]]
    t = weave_matrix("twill_3_1")
    assert t.shape == (4, 4)
    # 3/1 warp-faced twill: every weft is under three warps, over one; shifted rows.
    assert (t.sum(axis=1) == 3).all() and (t.sum(axis=0) == 3).all()
    assert all((np.roll(t[i], 1) == t[i + 1]).all() for i in range(3))
    assert weave_matrix([[0, 1, 1], [1, 0, 1], [1, 1, 0]]).shape == (3, 3)


@pytest.mark.parametrize(
    "bad, match",
    [
        ("herringbone", "valid names: .*plain"),
        ([1, 0, 1], "2-D"),
        ([[1, 0], [0, 2]], "0 .* or 1"),
        ([[1, 1], [0, 1]], "never changes sides"),
        ([[1, 0], [1, 0]], "never changes sides"),
        ([[1]], "at least 2 x 2"),
    ],
)
def test_bad_weave_is_rejected(bad, match):
    with pytest.raises(ValueError, match=match):
        weave_matrix(bad)
    with pytest.raises(ValueError, match="weave"):
        ClothParams(weave=bad)


def test_parameter_validation():
    with pytest.raises(ValueError, match="thickness_mm: must be a positive"):
        presets.params("denim", thickness_mm=-0.5)
    with pytest.raises(ValueError, match="warp_rgb"):
        presets.params("denim", warp_rgb=(0.1, 2.0, 0.1))
    with pytest.raises(ValueError, match="warp_along"):
        presets.params("denim", warp_along="z")
    with pytest.raises(ValueError, match=r"unknown cloth parameter.*'thicknes'.*valid names:.*thickness_mm"):
        presets.params("denim", thicknes=1.0)
    with pytest.raises(ValueError, match="rays: must be an integer"):
        presets.params("shot", rays=2.5)
    with pytest.raises(ValueError, match="unknown preset 'felt'; valid presets: denim, shot, towel, velvet"):
        presets.model("felt")
    p = presets.params("denim", thickness_mm=0.7)
    assert p.thickness_mm == 0.7 and p.name == "denim"
    assert ClothParams.parse_value("warp_rgb", "0.1,0.2,0.3") == (0.1, 0.2, 0.3)
    assert ClothParams.parse_value("weave", "10;01") == ((1, 0), (0, 1))
    assert ClothParams.parse_value("rays", "377") == 377


# -- geometry ------------------------------------------------------------------------
def test_face_stretch():
    assert face_stretch(0.2, 1.0) == pytest.approx(1.1)
    assert face_stretch(-0.2, 0.5) == pytest.approx(0.95)
    assert face_stretch(0.0, 3.0) == 1.0
    with pytest.raises(ValueError, match="tighter than its own thickness"):
        face_stretch(2.0, 0.6)
    with pytest.raises(ValueError, match="kappa"):
        presets.model("denim", **FAST).evaluate(0, 0, 0, 0, kappa=1.5)


def _balanced(stretch, texels=96, weft_width_mm=0.3):
    y = YarnGeometry(pitch_mm=0.3, width_mm=0.3, height_mm=0.1, crimp_mm=0.05, twist_deg=0.0)
    f = YarnGeometry(pitch_mm=0.3, width_mm=weft_width_mm, height_mm=0.1, crimp_mm=0.05, twist_deg=0.0)
    return build_heightfield(weave_matrix("plain"), y, f, warp_along="y", stretch_x=stretch, texels=texels)


def test_heightfield_plain_weave_is_balanced():
    hf = _balanced(1.0)
    cov = hf.coverage()
    assert sum(cov.values()) == pytest.approx(1.0)
    # Same yarns both ways: warp and weft show equally (up to texel rounding).
    assert cov["warp"] == pytest.approx(0.5, abs=0.02)
    assert cov["weft"] == pytest.approx(0.5, abs=0.02)
    assert hf.size_mm == pytest.approx((0.6, 0.6))
    n = hf.normal.reshape(-1, 3)
    t = hf.tangent.reshape(-1, 3)
    assert np.allclose(np.linalg.norm(n, axis=1), 1) and np.allclose(np.linalg.norm(t, axis=1), 1)
    assert np.abs(np.sum(n * t, axis=1)).max() < 1e-9  # fibres lie in the surface
    # Untwisted warp fibres run along y, weft along x (seen from above).
    assert np.abs(t[hf.kind.reshape(-1) == WARP][:, 0]).max() < 1e-9
    assert np.abs(t[hf.kind.reshape(-1) == WEFT][:, 1]).max() < 1e-9


def test_heightfield_gaps_open_when_stretched():
    flat, convex, concave = (_balanced(s, weft_width_mm=0.25) for s in (1.0, 1.1, 0.9))
    assert convex.size_mm[0] == pytest.approx(0.66)
    # Yarns keep their width: the warp (along y, spaced along x) covers less of
    # the wider repeat, and holes appear where no weft lies underneath.
    assert convex.coverage()["warp"] < flat.coverage()["warp"] - 0.02
    assert convex.coverage()["backing"] > 0.01 and flat.coverage()["backing"] == 0
    assert concave.coverage()["warp"] > flat.coverage()["warp"]
    assert np.mean(concave.kind == BACKING) == 0


def test_gap_opening_is_smooth_in_stretch():
    """Texels follow the yarn edges: the gap's area grows continuously, not in
    whole texels, and the texel layout maps x one-to-one."""
    s = np.linspace(1.0, 1.06, 13)
    holes = np.array([_balanced(v, texels=48, weft_width_mm=0.25).coverage()["backing"] for v in s])
    # Holes: gap (1 - 1/s of x) times the rows without weft (1 - 0.25/0.3 of y).
    expected = (1 - 1 / s) * (1 - 0.25 / 0.3)
    assert holes[0] == 0
    assert np.allclose(holes, expected, atol=0.1 * expected.max())
    # No texel-sized jumps (a whole texel column would be about 0.004 here).
    assert np.abs(np.diff(holes) - np.diff(expected)).max() < 0.0015
    hf = _balanced(1.03, texels=48)
    edges = np.concatenate([[0.0], np.cumsum(hf.texel_width_mm)])
    assert edges[-1] == pytest.approx(hf.size_mm[0])
    assert np.all(hf.texel_width_mm >= 0)
    assert np.allclose(x_of_xi(np.arange(hf.shape[1]) + 0.5, hf.xmap), hf.x_mm)
    # The gap texels sit in the gap: 9 mm / 1000 wide at stretch 1.03.
    assert hf.texel_width_mm.min() == pytest.approx(0.3 * 0.03 / 4, rel=1e-9)


# -- fibre scattering ----------------------------------------------------------------
def test_fresnel_known_values():
    assert fresnel_dielectric(1.5, 1.0) == pytest.approx(0.04)
    assert fresnel_dielectric(1.5, 0.0) == pytest.approx(1.0)
    assert 0.04 < fresnel_dielectric(1.5, 0.5) < 0.1


def test_fibre_brdf_reciprocal_and_bounded():
    lobes = FibreLobes((1.0, 1.0, 1.0), specular=1.0, gloss_width_deg=5.0, sheen_width_deg=10.0,
                       isotropic=0.2, ior=1.55)
    p = lobes.row
    rng = np.random.default_rng(3)
    for _ in range(200):
        v, l = rng.normal(size=(2, 3))
        v[2], l[2] = abs(v[2]), abs(l[2])
        v /= np.linalg.norm(v)
        l /= np.linalg.norm(l)
        a = _terms(0.0, 0.0, 1.0, 1.0, 0.0, 0.0, *v, *l, p)
        b = _terms(0.0, 0.0, 1.0, 1.0, 0.0, 0.0, *l, *v, p)
        assert a == pytest.approx(b, rel=1e-12, abs=1e-15)
        assert min(a) >= 0
    # Normalised: the largest local albedo (unit colour) is at most 1.
    assert local_albedo_max(p) * p[10] <= 1.0 + 1e-9


# -- the cloth BRDF ------------------------------------------------------------------
def test_evaluate_broadcasts_nonnegative_finite(denim):
    f = denim.evaluate(PAPER_T[:, None], PAPER_P[None, :], 30.0, 200.0, kappa=0.13)
    assert f.shape == (6, 12, 3)
    assert np.all(np.isfinite(f)) and np.all(f >= 0) and f.max() > 0
    rng = np.random.default_rng(0)
    tv, tl = rng.uniform(0, 90, (2, 300))
    pv, pl = rng.uniform(-360, 720, (2, 300))
    k = rng.choice([-0.3, -0.05, 0.0, 0.1, 0.25], 300)
    g = presets.model("shot", **FAST).evaluate(tv, pv, tl, pl, k)
    assert g.shape == (300, 3) and np.all(np.isfinite(g)) and np.all(g >= 0)
    with pytest.raises(cdbrdf.QueryError, match="theta_v"):
        denim.evaluate(95.0, 0.0, 10.0, 0.0)
    # Azimuth is periodic; at elevation 0 the azimuth does not matter.
    a = denim.evaluate([30.0, 30.0], [10.0, 370.0], 20.0, 100.0)
    assert np.array_equal(a[0], a[1])
    b = denim.evaluate(0.0, [0.0, 123.0], 20.0, 100.0)
    assert np.array_equal(b[0], b[1])


def test_flat_limit_equals_unbent_model(denim):
    """At kappa = 0 neither the thickness (stretch) nor the footprint (tilt) acts."""
    rng = np.random.default_rng(5)
    tv, tl = rng.uniform(0, 80, (2, 64))
    pv, pl = rng.uniform(0, 360, (2, 64))
    f0 = denim.evaluate(tv, pv, tl, pl, 0.0)
    other = presets.model("denim", thickness_mm=0.3, footprint_mm=5.0, tilt_samples=7)
    assert np.array_equal(f0, other.evaluate(tv, pv, tl, pl, 0.0))
    hf = denim.heightfield(0.0)
    warp, weft = denim.params.yarns()
    ref = build_heightfield(denim.params.weave_matrix, warp, weft, warp_along="y", stretch_x=1.0,
                            texels=denim.params.texels)
    assert np.array_equal(hf.height, ref.height)
    # Continuous at kappa = 0.
    f1 = denim.evaluate(tv, pv, tl, pl, 1e-5)
    assert np.allclose(f1, f0, rtol=0.05, atol=1e-4)


def test_deterministic_and_thread_independent(monkeypatch):
    import cdbrdf._jit

    m = presets.model("shot", **FAST)
    rng = np.random.default_rng(9)
    args = [rng.uniform(0, 80, 50), rng.uniform(0, 360, 50), rng.uniform(0, 80, 50), rng.uniform(0, 360, 50)]
    a = m.evaluate(*args, 0.13)
    for threads in (1, 3):  # the kernels' ranges split over 1 and over 3 threads
        monkeypatch.setattr(cdbrdf._jit, "cpu_count", lambda threads=threads: threads)
        b = presets.model("shot", **FAST).evaluate(*args, 0.13)
        assert np.array_equal(a, b)
    # The same pair gives the same value whatever else is in the query.
    c = m.evaluate(args[0][:5], args[1][:5], args[2][:5], args[3][:5], 0.13)
    assert np.array_equal(a[:5], c)


def test_approximately_reciprocal():
    """Reciprocal in the continuum; the estimator is within its integration error."""
    m = presets.model("denim")
    rng = np.random.default_rng(2)
    tv, tl = rng.uniform(0, 70, (2, 80))
    pv, pl = rng.uniform(0, 360, (2, 80))
    for k in (0.0, 0.22):
        a = m.evaluate(tv, pv, tl, pl, k)
        b = m.evaluate(tl, pl, tv, pv, k)
        rel = np.abs(a - b).sum(-1) / (a + b).sum(-1) * 2
        assert np.median(rel) < 0.1
        assert abs(a.mean() - b.mean()) / a.mean() < 0.02


@pytest.mark.parametrize("name, extra", [("denim", {}), ("shot", {}), ("denim", WHITE), ("shot", WHITE)])
def test_energy_conservation(name, extra):
    """Directional albedo <= 1 for every view direction and curvature (hemisphere quadrature)."""
    m = presets.model(name, **FAST, **extra)
    tv = np.array([0.0, 30.0, 60.0, 75.0, 85.0, 89.0])
    pv = np.array([0.0, 45.0, 90.0, 180.0, 270.0, 10.0])
    for k in (-0.22, 0.0, 0.22):
        a = m.albedo(tv, pv, k, n_theta=16, n_phi=32)
        assert np.all(a >= 0)
        assert a.max() <= 1.0
        if extra:
            assert a.max() > 0.3  # a white cloth reflects a good part of the light


def test_tabulate_attrs_and_nodes(denim):
    g = cdbrdf.Grid(kappa=[-0.13, 0.0, 0.22], theta_l=[0.0, 40.0], phi_l=[0.0, 120.0, 240.0],
                    theta_v=[10.0, 70.0], phi_v=[0.0, 180.0])
    calls = []
    t = denim.tabulate(g, progress=lambda d, n: calls.append((d, n)))
    assert calls == [(1, 3), (2, 3), (3, 3)]
    assert t.values.dtype == np.float32 and t.shape == g.shape + (3,)
    assert t.quantity == "brdf" and t.attrs["material"] == "denim"
    assert t.attrs["model"] == MODEL_NAME and t.attrs["model_version"]
    par = t.attrs["provenance"]["parameters"]
    assert par["thickness_mm"] == denim.params.thickness_mm and par["weave"] == "twill_3_1"
    assert set(par) == set(ClothParams.names())
    m = g.mesh()
    direct = denim.evaluate(m["theta_v"], m["phi_v"], m["theta_l"], m["phi_l"], m["kappa"])
    assert np.array_equal(t.values, direct.astype(np.float32))


# -- the targets of the presets (on the paper's grid) ---------------------------------------
def _low_grid(kappas):
    t = PAPER_T[PAPER_T <= 30]
    return cdbrdf.Grid(kappa=kappas, theta_l=t, phi_l=PAPER_P, theta_v=t, phi_v=PAPER_P)


def test_denim_lightens_when_bent_convexly(denim):
    t = denim.tabulate(_low_grid([-0.22, 0.0, 0.22]))
    y = luminance(t.values).mean(axis=(1, 2, 3, 4))
    assert y[2] >= 1.10 * y[1]
    # Concave: visibly different (darker: the warp closes over the weft).
    assert abs(y[0] / y[1] - 1) >= 0.03
    per_sample = np.abs(luminance(t.values[0]) / luminance(t.values[1]) - 1)
    assert np.median(per_sample) > 0.03


def test_shot_colour_changes_with_curvature_and_azimuth(shot):
    t = shot.tabulate(_low_grid([0.0, 0.22]))
    d = np.abs(chromaticity(t.values[1]) - chromaticity(t.values[0]))
    assert d.max() >= 0.02
    TL, PL = np.meshgrid(PAPER_T, PAPER_P, indexing="ij")
    c0 = chromaticity(shot.evaluate(45.0, 0.0, TL, PL, 0.0))
    c90 = chromaticity(shot.evaluate(45.0, 90.0, TL, PL, 0.0))
    assert np.abs(c0 - c90).max() >= 0.01


@pytest.mark.parametrize("name", ["denim", "shot"])
def test_anisotropic(name, denim, shot):
    """Turning view and light azimuths together by 90 deg changes the luminance:
    the plane of incidence along x (phi 0/180) versus along y (phi 90/270)."""
    m = denim if name == "denim" else shot
    g = cdbrdf.Grid(kappa=[0.0], theta_l=PAPER_T, phi_l=[0.0, 90.0, 180.0, 270.0],
                    theta_v=PAPER_T, phi_v=[0.0, 90.0, 180.0, 270.0])
    t = m.tabulate(g)
    a, b = in_plane_luminance(t, 0.0, 0.0), in_plane_luminance(t, 0.0, 90.0)
    assert abs(a - b) / max(a, b) >= 0.05


# -- command line --------------------------------------------------------------------
@pytest.mark.parametrize("setting", ["thickness_mm=1e308", "thickness_mm=-1", "rays=0"])
def test_cli_synth_bad_setting_is_the_only_line(tmp_path, capsys, setting):
    """Refused before any work: no progress bar (or anything else) before the error, without -q."""
    out = tmp_path / "s.h5"
    assert cli_main(["synth", "denim", "-o", str(out), "--set", setting]) == 2
    cap = capsys.readouterr()
    assert cap.out == "" and cap.err.count("\n") == 1 and cap.err.startswith("cdbrdf synth: error: ")
    assert setting.split("=")[0].split("_")[0] in cap.err and not out.exists()


def test_cli_synth(tmp_path, capsys):
    out = tmp_path / "s.h5"
    rc = cli_main(["-q", "synth", "shot", "--grid", "regular:45,90", "--kappa", "0,0.22",
                   "--set", "rays=233", "--set", "texels=48", "--set", "warp_rgb=0.6,0.1,0.1", "-o", str(out)])
    assert rc == 0
    t = cdbrdf.load(out)
    assert t.shape == (2, 4, 2, 4, 2, 3) and t.attrs["material"] == "shot"
    assert t.attrs["provenance"]["parameters"]["warp_rgb"] == [0.6, 0.1, 0.1]
    assert t.attrs["provenance"]["parameters"]["rays"] == 233
    rc = cli_main(["synth", "denim", "--set", "thicknes=1", "-o", str(tmp_path / "x.h5")])
    assert rc == 2
    assert "valid names" in capsys.readouterr().err
    rc = cli_main(["synth", "denim", "--set", "thickness_mm=-1", "-o", str(tmp_path / "x.h5")])
    assert rc == 2
    assert "thickness_mm" in capsys.readouterr().err
    assert not (tmp_path / "x.h5").exists()
    with pytest.raises(SystemExit):
        cli_main(["synth", "felt", "-o", str(tmp_path / "x.h5")])



# -- bend contrast (the colour difference bending makes near the normal) ---------------------
def test_bend_contrast_against_a_direct_computation():
    """bend_contrast is the median Delta E*ab of the scaled evaluations; zero for the same curvature."""
    import cdbrdf.materials
    from cdbrdf.colour import delta_e_ab, linear_to_lab
    from cdbrdf.synth.metrics import bend_contrast, near_normal_pairs

    table = cdbrdf.materials.load("denim")
    assert bend_contrast(table, 0.0).median_delta_e == 0.0
    c = bend_contrast(table, 0.22, n_pairs=500, seed=3)
    tv, pv, tl, pl = near_normal_pairs(500, seed=3)
    assert np.all((tv <= 30.0) & (tl <= 30.0) & (tv >= 0.0))
    bent, flat = table.evaluate(tv, pv, tl, pl, 0.22), table.evaluate(tv, pv, tl, pl, 0.0)
    s = 0.3 / np.median(luminance(flat))
    expected = np.median(delta_e_ab(linear_to_lab(bent * s), linear_to_lab(flat * s)))
    assert c.median_delta_e == pytest.approx(expected, rel=1e-12)
    with pytest.raises(ValueError, match="reference_luminance"):
        bend_contrast(table, 0.1, reference_luminance=-1.0)
