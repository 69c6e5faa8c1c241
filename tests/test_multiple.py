"""Multiple scattering in the fabric models (cdbrdf.synth.multiple) and the presets' colours (synth.colorants)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from cdbrdf.colour import lab_chroma_hue, linear_to_lab
from cdbrdf.spectral import reflectance_to_linear, reflectance_to_xyz
from cdbrdf.synth import colorants, multiple, presets
from cdbrdf.synth.metrics import luminance
from cdbrdf.synth.pile import PileModel, PileParams

PAPER_KAPPA = (-0.22, -0.13, 0.0, 0.13, 0.22)
FAST = dict(texels=48, points=377, tilt_samples=3)


# -- the direction grid --------------------------------------------------------------------
def test_hemisphere_grid_quadrature_and_interpolation():
    g = multiple.hemisphere_grid(6, 12)
    assert g.size == 72
    # Gauss-Legendre rings: the solid angle and the cosine-weighted one exactly
    assert g.weights.sum() == pytest.approx(2 * math.pi, rel=1e-12)
    assert (g.weights * g.dirs[:, 2]).sum() == pytest.approx(math.pi, rel=1e-12)
    # -w of every grid direction is on the grid below (its azimuth + 180 on the same ring)
    az = np.mod(np.degrees(np.arctan2(g.dirs[:, 1], g.dirs[:, 0])), 360)
    assert np.allclose(np.sort(np.mod(az + 180, 360)), np.sort(az))
    rng = np.random.default_rng(0)
    th, ph = np.radians(rng.uniform(0, 90, 200)), rng.uniform(0, 2 * math.pi, 200)
    w = np.stack([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)], -1)
    idx, wt = g.weights_at(w)
    np.testing.assert_allclose(wt.sum(axis=1), 1.0, rtol=1e-12)
    assert idx.min() >= 0 and idx.max() <= g.size
    # a grid direction gets itself; the pole gets the pole alone, whatever its azimuth
    idx, wt = g.weights_at(g.dirs[17:18])
    assert wt[0][idx[0] == 17].sum() == pytest.approx(1.0)
    idx, wt = g.weights_at(np.array([[0.0, 0.0, 1.0]]))
    assert wt[0][idx[0] == g.size].sum() == pytest.approx(1.0)


# -- the pile: adding-doubling ---------------------------------------------------------------
def _white_pile(**kw):
    return PileModel(presets.params("velvet", fibre_rgb=(1.0, 1.0, 1.0), ground_rgb=(1.0, 1.0, 1.0),
                                    fibre_specular=0.0, **kw))


def test_pile_white_furnace():
    """Strands and ground that absorb nothing reflect all the light (to the quadrature and the hot spot's
    excess over independent paths); single scattering alone loses most of it."""
    full = _white_pile()
    single = _white_pile(scattering="single")
    for k in (-0.22, 0.0, 0.22):
        a = full.albedo([0.0, 30.0, 60.0, 80.0], [0.0, 45.0, 90.0, 200.0], k, n_theta=16, n_phi=32)[:, 0]
        s = single.albedo([0.0, 30.0, 60.0, 80.0], [0.0, 45.0, 90.0, 200.0], k, n_theta=16, n_phi=32)[:, 0]
        assert np.all(a > 0.95) and np.all(a < 1.05), a
        assert np.all(s < 0.7)


def test_pile_further_orders_vanish_without_albedo_and_grow_as_density_squared():
    """Black strands on a black ground scatter once at most: the further orders are 0. For a thin,
    sparse pile they grow with the square of the density (two events), the first order linearly."""
    black = PileModel(PileParams(fibre_rgb=(0.0, 0.0, 0.0), ground_rgb=(0.0, 0.0, 0.0), fibre_specular=0.0))
    pile, ground = black.multiple_scattering(0.0)
    assert np.abs(pile).max() == 0.0 and np.abs(ground).max() == 0.0
    ratios = []
    for n in (0.25, 0.5):
        m = PileModel(PileParams(strands_per_mm2=n, strand_diameter_mm=0.01, fibre_rgb=(0.9, 0.9, 0.9),
                                 ground_rgb=(0.0, 0.0, 0.0), fibre_specular=0.0, spread_deg=30.0))
        ms = m.multiple_scattering(0.0)[0][..., 0][-13:-1, -13:-1].mean()  # views and lights on the top ring
        ss = m.evaluate_parts(np.full(50, 30.0), np.linspace(0, 350, 50), 40.0, 10.0)[0][:, 0].mean()
        ratios.append((ms, ss))
    assert ratios[1][0] / ratios[0][0] == pytest.approx(4.0, rel=0.05)
    assert ratios[1][1] / ratios[0][1] == pytest.approx(2.0, rel=0.05)


def test_pile_further_orders_are_symmetric_and_non_negative():
    m = presets.model("velvet")
    for k in (-0.13, 0.22):
        for f in m.multiple_scattering(k):
            assert np.all(f >= 0)
            np.testing.assert_array_equal(f, f.transpose(1, 0, 2))


# -- the woven cloth: the compensation -----------------------------------------------------------
def test_compensation_returns_the_missing_energy():
    """int f_ms(v, l) cos(theta_l) dl = fraction (1 - E(v)) F_ms (Kelemen & Szirmay-Kalos's identity)."""
    g = multiple.hemisphere_grid(6, 8)
    rng = np.random.default_rng(1)
    e = np.clip(0.55 + 0.1 * rng.standard_normal(g.size + 1), 0.0, 1.0)
    comp = multiple.compensation(e, g, np.array([1.0, 0.5, 0.1]), fraction=0.9)
    np.testing.assert_allclose(comp.colour[0], 1.0)  # a bounce of albedo 1: every bounce comes out
    nt, nphi = 120, 240
    th = (np.arange(nt) + 0.5) * (0.5 * math.pi / nt)
    ph = (np.arange(nphi) + 0.5) * (2 * math.pi / nphi)
    T, P = np.meshgrid(th, ph, indexing="ij")
    lights = np.stack([np.sin(T) * np.cos(P), np.sin(T) * np.sin(P), np.cos(T)], -1).reshape(-1, 3)
    dw = (np.cos(T) * np.sin(T)).reshape(-1) * (0.5 * math.pi / nt) * (2 * math.pi / nphi)
    views = g.dirs[[0, 20, 47]]
    for v in views:
        f = comp(np.broadcast_to(v, lights.shape), lights)
        albedo = (f * dw[:, None]).sum(axis=0)
        np.testing.assert_allclose(albedo, 0.9 * comp.one_minus(v[None])[0] * comp.colour, rtol=2e-3)
    # reciprocal
    a, b = lights[::97][:50], lights[::53][:50]
    np.testing.assert_array_equal(comp(a, b), comp(b, a))


@pytest.mark.parametrize("name", ["denim", pytest.param("shot", marks=pytest.mark.slow)])
def test_white_cloth_reflects_all_the_light(name):
    """With every albedo 1 the cloth reflects all the light (within the quadrature of E and of the
    test); single scattering alone loses a third or more of it."""
    white = dict(warp_rgb=(1, 1, 1), weft_rgb=(1, 1, 1), backing_rgb=(1, 1, 1))
    tv = np.array([0.0, 30.0, 60.0, 75.0])
    pv = np.array([0.0, 45.0, 90.0, 180.0])
    for k in (-0.22, 0.0, 0.22):
        a = presets.model(name, **FAST, **white).albedo(tv, pv, k, n_theta=16, n_phi=32)[:, 0]
        s = presets.model(name, **FAST, **white, scattering="single").albedo(tv, pv, k, n_theta=16, n_phi=32)[:, 0]
        assert 0.93 <= a.mean() <= 1.01 and a.max() <= 1.05, a
        assert s.mean() <= 0.8


# -- every preset ------------------------------------------------------------------------------
@pytest.mark.parametrize("name", ["denim", "shot", "velvet", pytest.param("towel", marks=pytest.mark.slow)])
def test_albedo_at_most_one_over_the_hemisphere(name):
    """Directional albedo <= 1 at views on a grid over the hemisphere, every curvature of the paper."""
    m = presets.model(name, **(FAST if name in ("denim", "shot") else {}))
    t, p = np.meshgrid([0.0, 30.0, 60.0, 75.0, 85.0], [0.0, 90.0, 180.0, 270.0], indexing="ij")
    for k in PAPER_KAPPA:
        a = m.albedo(t.ravel(), p.ravel(), k, n_theta=12, n_phi=24)
        assert np.all(a >= 0) and a.max() <= 1.0, (k, a.max())


@pytest.mark.parametrize("name", ["denim", "shot", "velvet", pytest.param("towel", marks=pytest.mark.slow)])
def test_reciprocal_with_the_further_orders(name):
    m = presets.model(name, **(FAST if name in ("denim", "shot") else {}))
    rng = np.random.default_rng(4)
    tv, tl = rng.uniform(0, 85, (2, 60))
    pv, pl = rng.uniform(0, 360, (2, 60))
    for k in (-0.13, 0.22):
        a, b = luminance(m.evaluate(tv, pv, tl, pl, k)), luminance(m.evaluate(tl, pl, tv, pv, k))
        np.testing.assert_allclose(a, b, rtol=1e-9)


# -- the colours ----------------------------------------------------------------------------------
def test_spectral_colour_known_answers():
    wl = np.arange(400.0, 701.0, 10.0)
    np.testing.assert_allclose(reflectance_to_linear(wl, np.ones(wl.size)), [1.0, 1.0, 1.0], rtol=1e-12)
    np.testing.assert_allclose(reflectance_to_linear(wl, np.full(wl.size, 0.25)), [0.25, 0.25, 0.25], rtol=1e-12)
    # D65 white, CIE 1931: X/Y = 0.9505, Z/Y = 1.0888 (CIE 15:2004, table T.3)
    np.testing.assert_allclose(reflectance_to_xyz(np.arange(360.0, 831.0, 5.0), np.ones(95)),
                               [0.9505, 1.0, 1.0888], atol=2e-4)
    # Kubelka-Munk: R_inf and K/S are each other's inverse
    r = np.linspace(0.01, 0.99, 50)
    np.testing.assert_allclose(colorants.ks_to_reflectance(colorants.reflectance_to_ks(r)), r, rtol=1e-12)


def test_dyed_fibres_have_their_named_colours():
    """The spectra give the colours the sources describe: dark indigo (blue, L* 20-35), a white bleached
    cotton (L* > 93), a golden yellow, a crimson."""
    def lch(name):
        lab = linear_to_lab(colorants.linear_rgb(name))
        c, h = lab_chroma_hue(lab)
        return lab[0], c, h

    L, c, h = lch("indigo_cotton_dark")
    assert 20 <= L <= 35 and c >= 25 and 260 <= h <= 285
    # indigo absorbs most at 660 nm
    r = colorants.reflectance("indigo_cotton_dark")
    assert abs(colorants.WAVELENGTHS_NM[np.argmin(r[colorants.WAVELENGTHS_NM <= 700])] - 660) <= 20
    L, c, _ = lch("bleached_cotton")
    assert L > 93 and c < 3
    L, c, h = lch("golden_yellow_silk")
    assert L > 70 and c > 40 and 70 <= h <= 100
    L, c, h = lch("crimson_viscose")
    assert L < 30 and c > 10 and (h >= 340 or h <= 20)


@pytest.mark.parametrize("key", [k for k, (_, how) in colorants.PRESET_COLOURS.items() if how == "surface"])
def test_preset_surface_colours_come_from_their_colorants(key):
    held = np.array(getattr(presets.params(key[0]), key[1]))
    np.testing.assert_allclose(held, colorants.preset_colour(*key), atol=5e-4)


@pytest.mark.slow
@pytest.mark.parametrize("key", [k for k, (_, how) in colorants.PRESET_COLOURS.items() if how == "strand"])
def test_preset_strand_colours_come_from_their_colorants(key):
    """A pile strand's albedo is the one whose thick layer reflects the material's R_inf (about a minute)."""
    held = np.array(getattr(presets.params(key[0]), key[1]))
    np.testing.assert_allclose(held, colorants.preset_colour(*key), atol=5e-4)
