"""The cloth model per texel: binning of the view rays, the tile mean, the command."""

from __future__ import annotations

import numpy as np
import pytest

import cdbrdf
from cdbrdf import Grid
from cdbrdf.btf import load
from cdbrdf.cli import main as cli_main
from cdbrdf.errors import OptionError
from cdbrdf.frames import direction_from_angles
from cdbrdf.synth import presets
from cdbrdf.synth.texels import tabulate_btf

GRID = Grid.regular(theta_step_deg=30, phi_step_deg=90, kappa=[0.0, 0.22])


@pytest.fixture(scope="module")
def shot():
    return presets.model("shot")


def _some_pairs():
    tv, pv = np.meshgrid([0.0, 30.0, 60.0], [0.0, 45.0, 200.0])
    v = direction_from_angles(tv.reshape(-1), pv.reshape(-1))
    l = direction_from_angles(np.full(v.shape[0], 40.0), np.full(v.shape[0], 170.0))
    return v, l


@pytest.mark.parametrize("kappa", [0.0, 0.22])
def test_texel_values_average_to_the_mean_over_the_same_rays(shot, monkeypatch, kappa):
    """Binning is exact: the mean over the texels is the one-bin mean over the same lattice of rays."""
    v, l = _some_pairs()
    texels = (6, 4)
    per_texel = shot._pairs(v, l, kappa, texels)
    assert per_texel.shape == (v.shape[0], 24, 3)
    monkeypatch.setattr(shot, "_points", lambda hf: shot._texel_points(hf, texels))
    whole = shot._pairs(v, l, kappa)
    np.testing.assert_allclose(per_texel.mean(axis=1), whole, rtol=1e-10, atol=1e-14)
    assert np.all(per_texel >= 0) and np.ptp(per_texel[:, :, 0], axis=1).max() > 0.1 * whole[:, 0].max()


def test_tile_mean_equals_the_cdbrdf_of_synth(shot):
    btf = tabulate_btf(shot, GRID, texels=16, max_error=0.03)
    ref = shot.tabulate(GRID)
    m, r = btf.mean().values, ref.values
    rel = np.abs(m - r) / np.maximum(np.abs(r), 1e-3 * r.max())
    assert np.median(rel) < 0.015, np.median(rel)
    assert btf.mean().attrs["material"] == "shot" and btf.mean().quantity == "brdf"
    assert btf.repeat_mm == pytest.approx(shot.heightfield(0.0).size_mm)
    c = btf.compression
    assert c["relative_rms_error"] <= 0.03 and max(c["relative_rms_error_per_kappa"]) <= 0.03


def test_texels_option_is_validated(shot):
    for bad in (0, 1000, (4,), 2.5, True):
        with pytest.raises(OptionError, match="texels"):
            tabulate_btf(shot, GRID, texels=bad)


@pytest.mark.slow
def test_synth_command_writes_a_cdbtf_file(tmp_path, capsys):
    out = tmp_path / "shot-btf.h5"
    assert cli_main(["--quiet", "synth", "shot", "--grid", "regular:30,90", "--kappa", "0", "--btf", "4",
                     "--max-error", "0.1", "-o", str(out)]) == 0
    btf = load(out)
    assert btf.texels == (4, 4) and btf.compression["max_error"] == 0.1
    assert cdbrdf.load(out) == btf.mean()
    capsys.readouterr()
    assert cli_main(["info", str(out)]) == 0
    text = capsys.readouterr().out
    assert "CD-BTF        4 x 4 texels" in text and f"rank {btf.rank}" in text
    assert cli_main(["synth", "shot", "--max-error", "0.1", "-o", str(tmp_path / "x.h5")]) == 2
    assert not (tmp_path / "x.h5").exists()
