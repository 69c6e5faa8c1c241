"""The bundled materials (cdbrdf.materials): loading, regeneration, targets."""

from __future__ import annotations

import numpy as np
import pytest

import cdbrdf
from cdbrdf import materials
from cdbrdf.synth import presets
from cdbrdf.synth.metrics import bend_contrast, chromaticity, colour_45_0, in_plane_luminance, luminance


@pytest.fixture(scope="module")
def tables():
    return {n: materials.load(n) for n in materials.names()}


def test_names_and_unknown():
    from cdbrdf.errors import OptionError

    assert materials.names() == ["denim", "shot", "velvet", "towel"]
    for bad in ("felt", None, 3, ["denim"]):
        with pytest.raises(OptionError, match=r"material .*: unknown; valid names: denim, shot, velvet, towel"):
            materials.load(bad)
        with pytest.raises(OptionError):
            materials.path(bad)


@pytest.mark.parametrize("name", ["denim", "shot", "velvet", "towel"])
def test_bundled_table(tables, name):
    t = tables[name]
    assert t.grid == cdbrdf.Grid.paper()
    assert t.values.dtype == np.float32
    assert t.quantity == "brdf" and t.attrs["material"] == name
    assert t.attrs["provenance"]["parameters"] == presets.params(name).to_dict()
    assert np.all(t.values >= 0) and np.all(np.isfinite(t.values))
    assert materials.path(name).stat().st_size < 2_000_000


@pytest.mark.slow
@pytest.mark.parametrize("name", ["denim", "shot", "velvet", "towel"])
def test_regenerates_identically(tables, name):
    """A sub-grid recomputed from the preset equals the bundled values exactly."""
    t = tables[name]
    ik, il_t, il_p, iv_t, iv_p = [0, 2, 4], [0, 3], [1, 7], [2, 5], [0, 4, 8]
    sub = cdbrdf.Grid(
        kappa=t.kappa[ik], phi_l=t.phi_l[il_p], theta_l=t.theta_l[il_t],
        phi_v=t.phi_v[iv_p], theta_v=t.theta_v[iv_t],
    )
    fresh = presets.model(name).tabulate(sub)
    ref = t.values[np.ix_(ik, il_p, il_t, iv_p, iv_t)]
    assert np.array_equal(fresh.values, ref)
    assert fresh.attrs == t.attrs


def test_colorimetry_at_45_0(tables):
    """What a 45/0 colorimeter reads off the bundled tables (issue 35): denim is an indigo (L* 18-40,
    C*ab >= 12, hue 250-290 deg), the towel white (L* >= 85), velvet a dark crimson, shot an ochre."""
    L, _, _, c, h = colour_45_0(tables["denim"])
    assert 18 <= L <= 40 and c >= 12 and 250 <= h <= 290
    L, _, _, c, _ = colour_45_0(tables["towel"])
    assert L >= 85 and c < 5
    L, _, _, c, h = colour_45_0(tables["velvet"])
    assert L < 30 and c > 10 and (h > 340 or h < 30)
    L, _, _, c, h = colour_45_0(tables["shot"])
    assert 45 < L < 75 and c > 25 and 55 < h < 100
    # the table is the model: the same colour from the preset, at any curvature near 0
    assert colour_45_0(presets.model("towel"))[0] == pytest.approx(colour_45_0(tables["towel"])[0], abs=0.1)


def test_bend_contrast_targets(tables):
    """The colour change near the normal that bending makes (the median Delta E*ab
    of :func:`cdbrdf.synth.metrics.bend_contrast`): at least 6 for denim at +0.22
    and 4 for shot at +0.13 (6.5 before the further orders of scattering, whose
    diffuse light changes little with the bend, were added), in the direction
    real cloth shows: shot fabric turns lighter, more chromatic and yellower at
    +0.13; denim lightens when convex and darkens when concave (the weft shows
    or hides)."""
    s = bend_contrast(tables["shot"], 0.13)
    assert s.median_delta_e >= 4.0
    (c_bent, h_bent), (c_flat, h_flat) = s.chroma_hue()
    assert s.lightness_change > 0 and c_bent > c_flat and h_flat < h_bent <= 105.0
    d = bend_contrast(tables["denim"], 0.22)
    assert d.median_delta_e >= 6.0 and d.lightness_change > 0
    assert bend_contrast(tables["denim"], -0.22).lightness_change < 0


@pytest.mark.parametrize("name", ["denim", "shot", "velvet", "towel"])
def test_bundled_tables_are_reciprocal(tables, name):
    """Swapping light and view (the grid has the same directions for both):
    relative luminance difference median <= 0.5 %, 99th percentile <= 3 %."""
    t = tables[name]
    y = luminance(t.values)  # (kappa, phi_l, theta_l, phi_v, theta_v)
    swapped = y.transpose(0, 3, 4, 1, 2)
    lit = (y + swapped) > 1e-6 * y.max()
    rel = np.abs(y - swapped)[lit] / (0.5 * (y + swapped)[lit])
    assert np.median(rel) <= 0.005 and np.percentile(rel, 99) <= 0.03


def test_anisotropy_on_bundled_tables(tables):
    d, s = tables["denim"], tables["shot"]
    # Shot changes colour with view azimuth (45 deg view, azimuth 0 vs 90; rgb
    # chromaticity of the light slice).
    k0 = int(np.flatnonzero(s.kappa == 0)[0])
    it = int(np.flatnonzero(s.theta_v == 45)[0])
    a = chromaticity(s.values[k0][:, :, 0, it])
    b = chromaticity(s.values[k0][:, :, 3, it])
    assert np.abs(a - b).max() >= 0.005
    # Both anisotropic.
    for t in (d, s):
        x, y = in_plane_luminance(t, 0.0, 0.0), in_plane_luminance(t, 0.0, 90.0)
        assert abs(x - y) / max(x, y) >= 0.05


def test_regenerate_writes_loadable_file(tmp_path, monkeypatch):
    small = cdbrdf.Grid(kappa=[0.0, 0.2], theta_l=[0.0, 45.0], phi_l=[0.0, 180.0],
                        theta_v=[30.0], phi_v=[0.0, 90.0, 180.0, 270.0])
    real_build = materials.build
    monkeypatch.setattr(materials, "build", lambda name, grid=None, progress=None: real_build(name, small, progress=progress))
    seen = []
    paths = materials.regenerate(["shot"], out_dir=tmp_path, progress=lambda n, d, t: seen.append((n, d, t)))
    assert [p.name for p in paths] == ["shot.h5"]
    assert seen[-1] == ("shot", 2, 2)
    t = cdbrdf.load(paths[0])
    assert t.grid == small and t.attrs["material"] == "shot"
    with pytest.raises(ValueError, match="valid names"):
        materials.regenerate(["felt"], out_dir=tmp_path)
