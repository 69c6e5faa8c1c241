"""Tests of cdbrdf.colour: sRGB, Rec. 709 luminance, exposure, 8-bit display."""

from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest

from cdbrdf import colour
from cdbrdf.colour import (
    LUMINANCE_WEIGHTS,
    auto_exposure,
    auto_exposure_ev,
    ev_to_factor,
    factor_to_ev,
    linear_to_srgb,
    luminance,
    resolve_exposure,
    srgb_encode,
    srgb_to_linear,
    tonemap_srgb8,
)


# -- sRGB ------------------------------------------------------------------------------
def test_srgb_reference_values():
    # IEC 61966-2-1: the line 12.92 x up to 0.0031308, then 1.055 x^(1/2.4) - 0.055
    x = np.array([0.0, 0.0031308, 0.5, 1.0])
    expected = [0.0, 0.0031308 * 12.92, 1.055 * 0.5 ** (1 / 2.4) - 0.055, 1.0]
    np.testing.assert_allclose(linear_to_srgb(x), expected, rtol=0, atol=1e-15)
    np.testing.assert_allclose(linear_to_srgb(0.5), 0.7353569830524495, rtol=1e-15)
    np.testing.assert_allclose(linear_to_srgb(0.0031308), 0.040449936, rtol=1e-12)
    np.testing.assert_allclose(srgb_to_linear([0.0, 0.04045, 0.5, 1.0]),
                               [0.0, 0.04045 / 12.92, 0.21404114048223255, 1.0], rtol=1e-14)
    # the two pieces meet at the knee (continuous to ~1e-8)
    assert abs(linear_to_srgb(np.nextafter(0.0031308, 1.0)) - linear_to_srgb(0.0031308)) < 1e-7


def test_srgb_round_trip():
    x = np.concatenate([np.linspace(0.0, 1.0, 10001), np.geomspace(1e-9, 1.0, 1000)])
    np.testing.assert_allclose(srgb_to_linear(linear_to_srgb(x)), x, rtol=1e-12, atol=1e-15)
    e = np.linspace(0.0, 1.0, 10001)
    np.testing.assert_allclose(linear_to_srgb(srgb_to_linear(e)), e, rtol=1e-12, atol=1e-15)
    # 8-bit codes survive decode -> encode
    codes = np.arange(256) / 255.0
    np.testing.assert_array_equal(np.rint(linear_to_srgb(srgb_to_linear(codes)) * 255), np.arange(256))


def test_srgb_encode_is_the_clipped_curve():
    """srgb_encode (figures) and linear_to_srgb (photographs) are one curve: bit for bit on [0, 1]."""
    x = np.concatenate([np.linspace(0.0, 1.0, 200001), [0.0031308, np.nextafter(0.0031308, 0), 5e-324]])
    np.testing.assert_array_equal(srgb_encode(x), linear_to_srgb(x))
    np.testing.assert_array_equal(srgb_encode(x.astype(np.float32)), linear_to_srgb(x.astype(np.float32)))
    np.testing.assert_allclose(srgb_encode([-1.0, 2.0, -np.inf, np.inf]), [0.0, 1.0, 0.0, 1.0], rtol=0, atol=2e-16)


def test_srgb_outside_the_unit_range_nan_and_inf():
    with np.errstate(all="raise"):  # no invalid-value warnings on negative or infinite input
        enc = linear_to_srgb([-0.5, 2.0, np.inf, -np.inf, np.nan])
        dec = srgb_to_linear([-0.5, 2.0, np.inf, -np.inf, np.nan])
        disp = srgb_encode([np.nan])
    np.testing.assert_allclose(enc[:2], [-0.5 * 12.92, 1.055 * 2.0 ** (1 / 2.4) - 0.055])
    assert enc[2] == np.inf and enc[3] == -np.inf and np.isnan(enc[4])
    np.testing.assert_allclose(dec[:2], [-0.5 / 12.92, (2.055 / 1.055) ** 2.4])
    assert dec[2] == np.inf and dec[3] == -np.inf and np.isnan(dec[4])
    assert np.isnan(disp[0])
    assert linear_to_srgb(np.zeros((2, 3), np.float32)).dtype == np.float64


# -- luminance -------------------------------------------------------------------------
def test_luminance_of_primaries_is_the_weights():
    np.testing.assert_array_equal(luminance(np.eye(3)), LUMINANCE_WEIGHTS)
    np.testing.assert_array_equal(LUMINANCE_WEIGHTS, [0.2126, 0.7152, 0.0722])
    assert math.fsum(LUMINANCE_WEIGHTS) == pytest.approx(1.0, abs=1e-15)
    assert luminance([1.0, 1.0, 1.0]) == pytest.approx(1.0)
    assert luminance(np.ones((4, 5, 3))).shape == (4, 5)
    with pytest.raises(ValueError):
        LUMINANCE_WEIGHTS[0] = 1.0  # read-only
    with pytest.raises(ValueError, match=r"rgb: expected linear RGB values \(\.\.\., 3\), got shape \(2, 4\)"):
        luminance(np.zeros((2, 4)))
    with pytest.raises(ValueError, match="rgb"):
        luminance(1.0)


def test_luminance_nan_and_inf():
    assert np.isnan(luminance([np.nan, 0.0, 0.0]))
    assert luminance([np.inf, 0.0, 0.0]) == np.inf
    assert luminance([0.0, -np.inf, 1.0]) == -np.inf
    with np.errstate(invalid="ignore"):
        assert np.isnan(luminance([np.inf, -np.inf, 0.0]))


# -- exposure --------------------------------------------------------------------------
def test_auto_exposure():
    assert colour.EXPOSURE_PERCENTILE == 99.5
    assert auto_exposure(np.full(1000, 0.25)) == pytest.approx(4.0)
    assert auto_exposure(np.full(10, 0.25), target=0.5) == pytest.approx(2.0)
    assert auto_exposure(np.arange(101.0), percentile=50) == pytest.approx(1 / 50)
    assert auto_exposure(np.zeros(10)) == 1.0
    assert auto_exposure([]) == 1.0
    assert auto_exposure([np.nan, np.inf, 0.5]) == pytest.approx(2.0)  # non-finite values ignored
    assert auto_exposure([np.nan, -np.inf]) == 1.0


def test_auto_exposure_ev():
    img = np.zeros((10, 10, 3))
    img[..., :] = 0.85 / 4  # every pixel's luminance 0.2125
    assert auto_exposure_ev(img) == pytest.approx(2.0)
    assert auto_exposure_ev(img, target=0.85 / 2) == pytest.approx(1.0)
    assert auto_exposure_ev(img, max_ev=1.5) == 1.5
    assert auto_exposure_ev(np.full((2, 2, 3), 1e6)) == colour.RENDER_EV_RANGE[0]
    assert auto_exposure_ev(np.zeros((3, 3, 3))) == 0.0
    rgba = np.concatenate([img, np.full((10, 10, 1), 123.0)], axis=-1)
    assert auto_exposure_ev(rgba) == pytest.approx(2.0)  # alpha ignored
    # the 99th percentile: one bright pixel in 1000 does not set the exposure
    img2 = np.full((10, 100, 3), 0.85)
    img2[0, 0] = 1000.0
    assert auto_exposure_ev(img2) == pytest.approx(0.0, abs=1e-12)
    assert ev_to_factor(2.0) == 4.0 and factor_to_ev(0.25) == -2.0
    assert ev_to_factor(factor_to_ev(3.0)) == pytest.approx(3.0)


def test_resolve_exposure():
    lum = np.full(100, 0.5)
    assert resolve_exposure(None, lum, "brdf") == (pytest.approx(2.0), "auto: 99.5th percentile → 1")
    assert resolve_exposure("auto", lum, "relative")[0] == pytest.approx(2.0)
    assert resolve_exposure("white", lum, "brdf") == (math.pi, "white: f = 1/π sr⁻¹ → 1")
    assert resolve_exposure(3, lum, "brdf") == (3.0, "given")
    with pytest.raises(ValueError, match="'white' needs an absolute table"):
        resolve_exposure("white", lum, "relative")
    with pytest.raises(ValueError, match="not a number nor one of auto, white"):
        resolve_exposure("bright", lum, "brdf")
    for bad in (0, -1.0, np.nan, np.inf):
        with pytest.raises(ValueError, match="exposure: must be a positive number"):
            resolve_exposure(bad, lum, "brdf")
    with pytest.raises(ValueError, match="expected a positive number"):
        resolve_exposure([1, 2], lum, "brdf")  # type: ignore[arg-type]


# -- 8-bit display ---------------------------------------------------------------------
def test_tonemap_srgb8():
    x = np.array([0.0, 0.0031308, 0.18, 0.5, 1.0, 2.0])
    assert tonemap_srgb8(x).tolist() == [0, 10, 118, 188, 255, 255]
    assert tonemap_srgb8(x).dtype == np.uint8
    assert tonemap_srgb8([np.nan, -1.0, np.inf, -np.inf]).tolist() == [0, 0, 255, 0]
    assert tonemap_srgb8([0.25], exposure_ev=1.0)[0] == tonemap_srgb8([0.5])[0]
    np.testing.assert_array_equal(tonemap_srgb8(x), np.rint(srgb_encode(x) * 255))


def test_import_is_numpy_only():
    code_ = "import sys, cdbrdf.colour\nassert 'matplotlib' not in sys.modules and 'scipy' not in sys.modules and 'colour' not in sys.modules\n"
    r = subprocess.run([sys.executable, "-W", "error", "-c", code_], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr


# -- CIELAB and colour differences -------------------------------------------------------
def test_lab_reference_values():
    """CIE 1976 L*a*b* of known colours (D65, white = RGB 1).

    The primaries' values are the published ones for sRGB (L*, a*, b* of
    red 53.24, 80.09, 67.20; green 87.73, -86.18, 83.18; blue 32.30, 79.19,
    -107.86); the tolerance 0.05 covers the 4-digit matrix of IEC 61966-2-1
    that both use, rounded differently.
    """
    lab = colour.linear_to_lab(np.eye(3))
    np.testing.assert_allclose(lab, [[53.24, 80.09, 67.20], [87.73, -86.18, 83.18], [32.30, 79.19, -107.86]],
                               atol=0.05)
    # White is L* 100 with no colour, black 0; the mid-grey L* = 50 has
    # Y = ((50 + 16) / 116)^3 = 0.18419 (exact by the definition).
    np.testing.assert_allclose(colour.linear_to_lab([1.0, 1.0, 1.0]), [100.0, 0.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(colour.linear_to_lab([0.0, 0.0, 0.0]), [0.0, 0.0, 0.0], atol=1e-12)
    y50 = ((50.0 + 16.0) / 116.0) ** 3
    np.testing.assert_allclose(colour.linear_to_lab([y50] * 3), [50.0, 0.0, 0.0], atol=1e-12)
    # Below the CIE's epsilon the linear segment: L* = kappa Y = 903.3 Y.
    np.testing.assert_allclose(colour.linear_to_lab([0.001] * 3)[0], 24389.0 / 27.0 * 0.001, rtol=1e-12)
    assert colour.D65_WHITE_XYZ[1] == pytest.approx(1.0, abs=1e-12)
    np.testing.assert_array_equal(colour.RGB_TO_XYZ[1], LUMINANCE_WEIGHTS)


def test_delta_e_chroma_hue():
    assert colour.delta_e_ab([50.0, 0.0, 0.0], [53.0, 4.0, 0.0]) == pytest.approx(5.0)
    d = colour.delta_e_ab(np.zeros((4, 3)), [[3.0, 4.0, 0.0]])
    np.testing.assert_allclose(d, 5.0)
    c, h = colour.lab_chroma_hue([[50.0, 0.0, 10.0], [50.0, -3.0, -4.0], [70.0, 10.0, 0.0]])
    np.testing.assert_allclose(c, [10.0, 5.0, 10.0])
    np.testing.assert_allclose(h, [90.0, np.degrees(np.arctan2(-4.0, -3.0)) + 360.0, 0.0])
    with pytest.raises(ValueError, match="lab"):
        colour.delta_e_ab([1.0, 2.0], [1.0, 2.0, 3.0])
    with pytest.raises(ValueError, match="rgb"):
        colour.linear_to_lab([1.0, 2.0])


# -- CIEDE2000 (colour-science) against the published test data ----------------------------
#: Sharma, Wu and Dalal (2005), Table 1: the 34 pairs (L*, a*, b* of each) and their CIEDE2000
#: (kL = kC = kH = 1), published to 4 decimals. They probe the formula's hue-angle and mean-hue
#: corners (pairs 7-16), the rotation term in the blue (1-6, 25-34) and large differences (17-20).
SHARMA_2005 = [
    ((50.0000, 2.6772, -79.7751), (50.0000, 0.0000, -82.7485), 2.0425),
    ((50.0000, 3.1571, -77.2803), (50.0000, 0.0000, -82.7485), 2.8615),
    ((50.0000, 2.8361, -74.0200), (50.0000, 0.0000, -82.7485), 3.4412),
    ((50.0000, -1.3802, -84.2814), (50.0000, 0.0000, -82.7485), 1.0000),
    ((50.0000, -1.1848, -84.8006), (50.0000, 0.0000, -82.7485), 1.0000),
    ((50.0000, -0.9009, -85.5211), (50.0000, 0.0000, -82.7485), 1.0000),
    ((50.0000, 0.0000, 0.0000), (50.0000, -1.0000, 2.0000), 2.3669),
    ((50.0000, -1.0000, 2.0000), (50.0000, 0.0000, 0.0000), 2.3669),
    ((50.0000, 2.4900, -0.0010), (50.0000, -2.4900, 0.0009), 7.1792),
    ((50.0000, 2.4900, -0.0010), (50.0000, -2.4900, 0.0010), 7.1792),
    ((50.0000, 2.4900, -0.0010), (50.0000, -2.4900, 0.0011), 7.2195),
    ((50.0000, 2.4900, -0.0010), (50.0000, -2.4900, 0.0012), 7.2195),
    ((50.0000, -0.0010, 2.4900), (50.0000, 0.0009, -2.4900), 4.8045),
    ((50.0000, -0.0010, 2.4900), (50.0000, 0.0010, -2.4900), 4.8045),
    ((50.0000, -0.0010, 2.4900), (50.0000, 0.0011, -2.4900), 4.7461),
    ((50.0000, 2.5000, 0.0000), (50.0000, 0.0000, -2.5000), 4.3065),
    ((50.0000, 2.5000, 0.0000), (73.0000, 25.0000, -18.0000), 27.1492),
    ((50.0000, 2.5000, 0.0000), (61.0000, -5.0000, 29.0000), 22.8977),
    ((50.0000, 2.5000, 0.0000), (56.0000, -27.0000, -3.0000), 31.9030),
    ((50.0000, 2.5000, 0.0000), (58.0000, 24.0000, 15.0000), 19.4535),
    ((50.0000, 2.5000, 0.0000), (50.0000, 3.1736, 0.5854), 1.0000),
    ((50.0000, 2.5000, 0.0000), (50.0000, 3.2972, 0.0000), 1.0000),
    ((50.0000, 2.5000, 0.0000), (50.0000, 1.8634, 0.5757), 1.0000),
    ((50.0000, 2.5000, 0.0000), (50.0000, 3.2592, 0.3350), 1.0000),
    ((60.2574, -34.0099, 36.2677), (60.4626, -34.1751, 39.4387), 1.2644),
    ((63.0109, -31.0961, -5.8663), (62.8187, -29.7946, -4.0864), 1.2630),
    ((61.2901, 3.7196, -5.3901), (61.4292, 2.2480, -4.9620), 1.8731),
    ((35.0831, -44.1164, 3.7933), (35.0232, -40.0716, 1.5901), 1.8645),
    ((22.7233, 20.0904, -46.6940), (23.0331, 14.9730, -42.5619), 2.0373),
    ((36.4612, 47.8580, 18.3852), (36.2715, 50.5065, 21.2231), 1.4146),
    ((90.8027, -2.0831, 1.4410), (91.1528, -1.6435, 0.0447), 1.4441),
    ((90.9257, -0.5406, -0.9208), (88.6381, -0.8985, -0.7239), 1.5381),
    ((6.7747, -0.2908, -2.4247), (5.8714, -0.0985, -2.2286), 0.6377),
    ((2.0776, 0.0795, -1.1350), (0.9033, -0.0636, -0.5514), 0.9082),
]


def test_ciede2000_matches_the_published_test_pairs():
    lab1 = np.array([p[0] for p in SHARMA_2005])
    lab2 = np.array([p[1] for p in SHARMA_2005])
    published = np.array([p[2] for p in SHARMA_2005])
    d = colour.delta_e(lab1, lab2)
    assert d.shape == (34,)
    np.testing.assert_allclose(d, published, atol=5e-5)  # the table's 4 decimals
    # symmetric, and one pair at a time gives the same (broadcast over any leading shape)
    np.testing.assert_allclose(colour.delta_e(lab2, lab1), published, atol=5e-5)
    assert colour.delta_e(lab1[0], lab2[0]) == pytest.approx(2.0425, abs=5e-5)
    np.testing.assert_allclose(colour.delta_e(lab1.reshape(2, 17, 3), lab2.reshape(2, 17, 3)),
                               published.reshape(2, 17), atol=5e-5)
    # Delta E*ab of the same pairs is their Euclidean distance; the textile weighting (kL = 2)
    # halves a pure lightness difference (pair 33: L* 6.77 vs 5.87 mostly differs in lightness)
    np.testing.assert_allclose(colour.delta_e(lab1, lab2, metric="ab"), np.linalg.norm(lab1 - lab2, axis=1))
    pure_l = colour.delta_e([50.0, 0.0, 0.0], [54.0, 0.0, 0.0])
    assert colour.delta_e([50.0, 0.0, 0.0], [54.0, 0.0, 0.0], metric="2000-textiles") == pytest.approx(pure_l / 2)
    with pytest.raises(ValueError, match=r"delta E metric: 'cmc' is not one of 2000, 2000-textiles, ab"):
        colour.delta_e(lab1, lab2, metric="cmc")
    with pytest.raises(ValueError, match="lab"):
        colour.delta_e([1.0, 2.0], [1.0, 2.0, 3.0])


def test_srgb_to_lab_known_values():
    """Display sRGB -> L*a*b* (D65): 8-bit codes and encoded floats, the chain a textile team reads.

    Published values (sRGB, D65): red 255, 0, 0 -> 53.24, 80.09, 67.20; the mid code 128 (grey)
    -> L* 53.59 (its linear value 0.2158); white -> 100; black -> 0.
    """
    codes = np.array([[255, 0, 0], [128, 128, 128], [255, 255, 255], [0, 0, 0]], dtype=np.uint8)
    lab = colour.srgb_to_lab(codes)
    np.testing.assert_allclose(lab[0], [53.24, 80.09, 67.20], atol=0.05)
    np.testing.assert_allclose(lab[1], [53.585, 0.0, 0.0], atol=2e-3)
    np.testing.assert_allclose(lab[2], [100.0, 0.0, 0.0], atol=1e-9)
    np.testing.assert_allclose(lab[3], [0.0, 0.0, 0.0], atol=1e-9)
    np.testing.assert_allclose(colour.srgb_to_lab(codes / 255.0), lab, atol=1e-12)  # floats: encoded values
    # the same chain as linear_to_lab after the sRGB decoding
    np.testing.assert_allclose(lab, colour.linear_to_lab(colour.srgb_to_linear(codes / 255.0)), atol=1e-12)
    with pytest.raises(ValueError, match="srgb"):
        colour.srgb_to_lab([1, 2])


def test_colour_science_is_imported_only_when_a_difference_is_computed():
    code_ = ("import sys, cdbrdf, cdbrdf.colour, cdbrdf.plot, cdbrdf.render\n"
             "assert 'colour' not in sys.modules, 'imported at import time'\n"
             "cdbrdf.colour.delta_e([50, 0, 0], [51, 0, 0])\n"
             "assert sys.modules['colour'].__name__ == 'colour' and hasattr(sys.modules['colour'], 'XYZ_to_Lab')\n")
    r = subprocess.run([sys.executable, "-W", "error", "-c", code_], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
