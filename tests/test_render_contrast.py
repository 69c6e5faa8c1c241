"""The curvature seen per pixel and the crest/flat comparison of two renders (cdbrdf.render.contrast)."""

from __future__ import annotations

import numpy as np
import pytest

from cdbrdf.colour import delta_e_ab, linear_to_lab, srgb_encode
from cdbrdf.mesh import SineSheet
from cdbrdf.render import Picture
from cdbrdf.render._llvm import find_llvm, llvm_message
from cdbrdf.render.contrast import crest_contrast

_INFO = find_llvm()
needs_llvm = pytest.mark.skipif(not _INFO.ok, reason=llvm_message(_INFO))


def _picture(kappa, brdf, cdbrdf, ev=0.0):
    alpha = np.ones(kappa.shape + (1,), np.float32)
    images = {"brdf": np.concatenate([brdf, alpha], -1), "cdbrdf": np.concatenate([cdbrdf, alpha], -1)}
    return Picture(images=images, exposure_ev=ev, exposure_source="given", surface="test", lighting="paper",
                   light=(45.0, 0.0, np.pi), backdrop=False, curvature=kappa.astype(np.float32))


def test_crest_contrast_against_known_colours():
    """Crests differ by a known colour, flats not at all: the medians are that Delta E and 0."""
    kappa = np.tile(np.linspace(-0.2, 0.2, 41), (8, 1))
    kappa[0, :5] = np.nan                                   # sky
    grey, yellow = np.array([0.2, 0.2, 0.2]), np.array([0.45, 0.4, 0.05])
    brdf = np.broadcast_to(grey, kappa.shape + (3,)).copy()
    cd = brdf.copy()
    crest = kappa >= 0.155          # crest_fraction 0.775 of 0.2, off the grid of values
    trough = kappa <= -0.155
    cd[crest] = yellow
    cd[trough] = 0.5 * grey
    c = crest_contrast(_picture(kappa, brdf, cd), crest_fraction=0.775)
    expected = float(delta_e_ab(linear_to_lab(grey), linear_to_lab(yellow)))
    assert c.crest_delta_e == pytest.approx(expected, rel=1e-9)
    assert c.trough_delta_e == pytest.approx(float(delta_e_ab(linear_to_lab(grey), linear_to_lab(0.5 * grey))))
    assert c.flat_delta_e == 0.0
    assert c.crest_pixels == int(crest[np.isfinite(kappa)].sum())
    assert c.trough_pixels == int(trough[np.isfinite(kappa)].sum())
    assert c.kappa_max == pytest.approx(0.2, rel=1e-6)
    # the convex crest swatch is the yellow shown in sRGB; the flat swatch the grey
    np.testing.assert_allclose(c.crest_srgb["cdbrdf"], srgb_encode(yellow), rtol=1e-6)
    np.testing.assert_allclose(c.flat_srgb["brdf"], srgb_encode(grey), rtol=1e-6)
    # one stop more doubles the linear values before they are shown (and clipped at white)
    c2 = crest_contrast(_picture(kappa, brdf, cd, ev=1.0), crest_fraction=0.775)
    expected2 = float(delta_e_ab(linear_to_lab(2 * grey), linear_to_lab(np.minimum(2 * yellow, 1.0))))
    assert c2.crest_delta_e == pytest.approx(expected2, rel=1e-9)


def test_crest_contrast_errors():
    kappa = np.zeros((4, 4))
    img = np.full((4, 4, 3), 0.2)
    with pytest.raises(ValueError, match="nowhere curved"):
        crest_contrast(_picture(kappa, img, img))
    pic = _picture(np.ones((4, 4)), img, img)
    with pytest.raises(ValueError, match="crest_fraction"):
        crest_contrast(pic, crest_fraction=0.1, flat_fraction=0.5)
    with pytest.raises(ValueError, match="no spectral render"):
        crest_contrast(pic, modes=("brdf", "spectral"))
    bare = Picture(images=pic.images, exposure_ev=0.0, exposure_source="given", surface="t", lighting="paper",
                   light=None, backdrop=False)
    with pytest.raises(ValueError, match="curvature_image=True"):
        crest_contrast(bare)


@needs_llvm
def test_curvature_image_of_the_sine_sheet():
    """Pixels see the sheet's analytic curvature: up to the crest value, both signs, sky NaN."""
    import cdbrdf.materials
    from cdbrdf.render import RenderSpec, render_table

    sheet = SineSheet()
    pic = render_table(cdbrdf.materials.load("denim"), RenderSpec(surface=sheet, modes=("brdf",), size=(96, 72),
                                                                  spp=1, curvature_image=True))
    k = pic.curvature
    assert k.shape == (72, 96)
    seen = np.isfinite(k)
    # where the render's alpha says the sheet is seen (but at its edge, where a pixel's one
    # sample and its centre may fall on either side)
    assert np.mean(seen == (pic.images["brdf"][..., 3] > 0.5)) > 0.97
    crest = sheet.crest_curvature_mm
    assert np.nanmax(k) == pytest.approx(crest, rel=0.01)
    assert np.nanmin(k) == pytest.approx(-crest, rel=0.01)
    assert np.all(np.abs(k[seen]) <= crest * (1 + 1e-5))
    # a sine: about as many pixels convex as concave
    assert 0.35 < np.mean(k[seen] > 0) < 0.65
