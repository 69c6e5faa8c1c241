"""The bundled materials (cdbrdf.materials): loading, regeneration, targets."""

from __future__ import annotations

import numpy as np
import pytest

import cdbrdf
from cdbrdf import materials
from cdbrdf.synth import presets
from cdbrdf.synth.metrics import chromaticity, in_plane_luminance, low_elevation_slice, luminance


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


def test_targets_on_bundled_tables(tables):
    d, s = tables["denim"], tables["shot"]
    # Denim lightens by >= 10 % when bent convexly (elevations <= 30 deg).
    y0 = luminance(low_elevation_slice(d, 0.0)).mean()
    yp = luminance(low_elevation_slice(d, 0.22)).mean()
    ym = luminance(low_elevation_slice(d, -0.22)).mean()
    assert yp >= 1.10 * y0 and abs(ym / y0 - 1) >= 0.03
    # Shot changes colour with curvature.
    c0 = chromaticity(low_elevation_slice(s, 0.0))
    c1 = chromaticity(low_elevation_slice(s, 0.22))
    assert np.abs(c1 - c0).max() >= 0.02
    # Shot changes colour with view azimuth (45 deg view, azimuth 0 vs 90).
    k0 = int(np.flatnonzero(s.kappa == 0)[0])
    it = int(np.flatnonzero(s.theta_v == 45)[0])
    a = chromaticity(s.values[k0][:, :, 0, it])
    b = chromaticity(s.values[k0][:, :, 3, it])
    assert np.abs(a - b).max() >= 0.01
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
