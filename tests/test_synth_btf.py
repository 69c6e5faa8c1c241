"""The cloth model per texel: binning of the surface points, the tile mean, the command."""

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
from cdbrdf.synth.texels import tabulate_btf, texel_model
from cdbrdf.synth.weave import WARP, WEFT

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
def test_texel_values_average_to_the_cdbrdf_over_the_same_points(shot, kappa):
    """Binning is exact: the mean over the texels is the one-bin integral over the same points."""
    v, l = _some_pairs()
    fine = texel_model(shot, (6, 4), points_per_texel=16)
    assert fine.params.points == 16 * 24
    per_texel = fine._pairs(v, l, kappa, (6, 4))
    assert per_texel.shape == (v.shape[0], 24, 3)
    whole = fine._pairs(v, l, kappa)
    np.testing.assert_allclose(per_texel.mean(axis=1), whole, rtol=1e-10, atol=1e-14)
    assert np.all(per_texel >= 0) and np.ptp(per_texel[:, :, 0], axis=1).max() > 0.1 * whole[:, 0].max()


def test_tile_mean_is_reciprocal_and_texels_nest(shot):
    """The tile mean is reciprocal (the texels are not: they follow the view); a coarse
    texel is the mean of the fine texels it holds (the same points, binned the same)."""
    v, l = _some_pairs()
    fine = texel_model(shot, (6, 4), points_per_texel=16)
    a = fine._pairs(v, l, 0.0, (6, 4))
    b = fine._pairs(l, v, 0.0, (6, 4))
    np.testing.assert_allclose(a.mean(axis=1), b.mean(axis=1), rtol=1e-10, atol=1e-14)
    assert np.abs(a - b).max() > 0.1 * a.max()
    split = fine._pairs(v, l, 0.0, (12, 8)).reshape(-1, 4, 2, 6, 2, 3)
    np.testing.assert_allclose(split.mean(axis=(2, 4)).reshape(a.shape), a, rtol=1e-10, atol=1e-14)


def test_texels_seen_from_above_show_the_yarn_under_them(shot):
    """Seen along the normal a texel shows the surface right under it: the red warp's
    texels are redder than the yellow weft's (the shot preset's two yarns)."""
    n = 16
    fine = texel_model(shot, n, points_per_texel=16)
    v = np.array([[0.0, 0.0, 1.0]])
    l = direction_from_angles(np.array([40.0]), np.array([170.0]))
    rgb = fine._pairs(v, l, 0.0, (n, n))[0].reshape(n, n, 3)
    hf = fine.heightfield(0.0)
    cx = (np.arange(n) + 0.5) / n * hf.size_mm[0]
    cy = (np.arange(n) + 0.5) / n * hf.size_mm[1]
    col = np.searchsorted(np.cumsum(hf.texel_width_mm), cx)
    row = np.floor(cy / hf.size_mm[1] * hf.shape[0]).astype(int)
    kind = hf.kind[np.ix_(row, col)]
    lit = rgb[..., 0] > 0
    assert lit.mean() > 0.8
    green_over_red = rgb[..., 1] / np.where(lit, rgb[..., 0], 1.0)
    warp, weft = green_over_red[lit & (kind == WARP)], green_over_red[lit & (kind == WEFT)]
    assert warp.size > 10 and weft.size > 10
    # the yarns' own green/red ratios are 0.27 (warp) and 0.57 (weft): the texels keep most of that
    # difference (the white surface reflection and the light scattered between yarns mix the rest)
    assert np.median(warp) < 0.75 * np.median(weft), (np.median(warp), np.median(weft))


def test_points_per_texel_is_recorded_and_validated(shot):
    btf = tabulate_btf(shot, Grid.regular(theta_step_deg=45, phi_step_deg=180, kappa=[0.0]), texels=4,
                       points_per_texel=8, max_error=0.1, method="pca")
    attrs = btf.mean().attrs
    assert attrs["btf_points_per_texel"] == 8 and attrs["btf_texels"] == [4, 4]
    assert attrs["provenance"]["parameters"]["points"] == 8 * 16
    for bad in (0, -3, 2.5, True):
        with pytest.raises(OptionError, match="points_per_texel"):
            tabulate_btf(shot, GRID, texels=4, points_per_texel=bad)


@pytest.mark.slow
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
                     "--points-per-texel", "8", "--max-error", "0.1", "-o", str(out)]) == 0
    btf = load(out)
    assert btf.texels == (4, 4) and btf.compression["max_error"] == 0.1
    assert btf.mean().attrs["btf_points_per_texel"] == 8
    assert cdbrdf.load(out) == btf.mean()
    capsys.readouterr()
    assert cli_main(["info", str(out)]) == 0
    text = capsys.readouterr().out
    assert "CD-BTF        4 x 4 texels" in text and f"rank {btf.rank}" in text
    assert cli_main(["synth", "shot", "--max-error", "0.1", "-o", str(tmp_path / "x.h5")]) == 2
    assert cli_main(["synth", "shot", "--points-per-texel", "8", "-o", str(tmp_path / "x.h5")]) == 2
    assert not (tmp_path / "x.h5").exists()


@pytest.mark.slow
def test_default_encoding_is_close_to_a_much_tighter_one():
    """8 x 8 denim texels: the default encoding (neural, 3 %) within 3.5 % RMS of one at --max-error 0.002."""
    from cdbrdf.btf import CDBTF
    from cdbrdf.synth.texels import tabulate_texels

    denim = presets.model("denim")
    grid = Grid.regular(theta_step_deg=30, phi_step_deg=90, kappa=[0.0, 0.22])
    dense = tabulate_texels(denim, grid, texels=8, points_per_texel=16)
    repeat = denim.heightfield(0.0).size_mm
    default = CDBTF.from_values(dense, grid, repeat_mm=repeat, method="neural")
    tight = CDBTF.from_values(dense, grid, repeat_mm=repeat, method="neural", max_error=0.002)
    for btf, target in ((default, 0.03), (tight, 0.002)):
        c = btf.compression
        assert c["relative_rms_error"] <= target and max(c["relative_rms_error_per_kappa"]) <= target
        err = np.sqrt(np.sum((btf.decode() - dense) ** 2) / np.sum(dense ** 2))
        assert err == pytest.approx(c["relative_rms_error"], rel=1e-3, abs=1e-6)
    a, b = default.decode(), tight.decode()
    assert np.sqrt(np.sum((a - b) ** 2) / np.sum(b ** 2)) <= 0.035
