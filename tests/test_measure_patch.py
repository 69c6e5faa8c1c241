"""The N x N patch: exact placement, decoding, saturation, brackets, dark frames."""

from __future__ import annotations

import numpy as np
import pytest

from cdbrdf.colour import linear_to_srgb
from cdbrdf.images import ImageInfo, write_png, write_tiff
from cdbrdf.measure.patch import (
    decode_codes,
    merge_exposures,
    patch_statistics,
    patch_window,
    read_patch,
)


def _ringed(size_w, size_h, n, cx, cy, inside, outside, dtype=np.uint16):
    img = np.full((size_h, size_w, 3), outside, dtype=dtype)
    y0, x0 = cy - n // 2, cx - n // 2
    img[y0 : y0 + n, x0 : x0 + n] = inside
    return img


@pytest.mark.parametrize("w,h", [(15, 15), (16, 16), (17, 12), (980, 980)])
def test_default_centre_is_w_half_h_half(w, h):
    x0, y0, nx, ny = patch_window((w, h), n=7)
    assert (nx, ny) == (7, 7)
    assert (x0 + 3, y0 + 3) == (w // 2, h // 2)


def test_even_patch_convention():
    assert patch_window((20, 20), n=4, cx=10, cy=10) == (8, 8, 4, 4)


@pytest.mark.parametrize("n", [1, 3, 7])
@pytest.mark.parametrize("centre", [None, (5, 9)])
def test_patch_sees_exactly_its_pixels(tmp_path, n, centre):
    """Inside the N x N patch one value, a different ring just around it: the mean is exact."""
    w, h = 20, 16
    cx, cy = (w // 2, h // 2) if centre is None else centre
    img = _ringed(w, h, n, cx, cy, 30000, 60000)
    p = tmp_path / "r.png"
    write_png(p, img)
    kw = {} if centre is None else {"cx": cx, "cy": cy}
    v, sat = read_patch(p, n=n, linear=True, **kw)
    assert v.shape == (n, n, 3) and not sat.any()
    np.testing.assert_array_equal(v, 30000 / 65535)
    # one pixel larger would see the ring
    v2, _ = read_patch(p, n=n + 2, linear=True, **kw)
    assert v2.max() == pytest.approx(60000 / 65535)


def test_decode_srgb_and_linear():
    info16 = ImageInfo(1, 1, 3, 65535, False)
    lin = np.array([0.0, 0.01, 0.5])
    codes = np.round(linear_to_srgb(lin) * 65535).astype(np.uint16).reshape(1, 1, 3)
    v, sat = decode_codes(codes, info16)
    np.testing.assert_allclose(v.ravel(), lin, atol=2e-5)
    v, _ = decode_codes(codes, info16, linear=True)
    np.testing.assert_allclose(v.ravel(), codes.ravel() / 65535)
    info_f = ImageInfo(1, 1, 3, None, True)
    v, sat = decode_codes(np.array([[[2.5, np.inf, 0.1]]], np.float32), info_f)
    assert sat.all()


def test_saturated_pixels_flagged(tmp_path):
    img = np.full((9, 9, 3), 1000, np.uint16)
    img[4, 4, 1] = 65535
    write_tiff(tmp_path / "s.tif", img)
    v, sat = read_patch(tmp_path / "s.tif", n=3)
    assert sat.sum() == 1 and sat[1, 1]


def test_merge_uses_unsaturated_exposures_only():
    true = np.full((3, 3, 3), 0.3)  # radiance at exposure 1
    e = [4.0, 1.0]
    vals = [np.minimum(true * ei, 1.0) for ei in e]
    sats = [v[..., 0] >= 1.0 for v in vals]
    rad, ok = merge_exposures(vals, sats, e)
    assert ok.all()
    np.testing.assert_allclose(rad, true)  # long exposure saturated: only the short one used
    # partially saturated long exposure: per pixel
    vals[0] = true * 4
    vals[0][0, 0] = 1.0
    sats[0] = np.zeros((3, 3), bool)
    sats[0][0, 0] = True
    rad, ok = merge_exposures(vals, sats, e)
    np.testing.assert_allclose(rad, true)


def test_merge_all_saturated_invalidates():
    v = [np.ones((2, 2, 3))]
    s = [np.array([[True, False], [False, False]])]
    rad, ok = merge_exposures(v, s, [1.0])
    mean, std, good = patch_statistics(rad, ok)
    assert not good and np.isnan(mean).all()


def test_dark_subtraction():
    dark = np.full((2, 2, 3), 0.02)
    v = [np.full((2, 2, 3), 0.22)]
    rad, ok = merge_exposures(v, [np.zeros((2, 2), bool)], [2.0], [dark])
    np.testing.assert_allclose(rad, 0.1)


def test_statistics():
    rad = np.arange(9, dtype=float).reshape(3, 3, 1)
    mean, std, good = patch_statistics(rad, np.ones((3, 3), bool))
    assert good and mean[0] == 4.0 and std[0] == pytest.approx(np.std(np.arange(9), ddof=1))
