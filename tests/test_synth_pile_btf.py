"""The pile model per texel: the tufts' layout, the shares of the model's light, the tile mean, the command."""

from __future__ import annotations

import math

import numpy as np
import pytest

from cdbrdf import Grid
from cdbrdf.btf import load
from cdbrdf.cli import main as cli_main
from cdbrdf.colour import LUMINANCE_WEIGHTS
from cdbrdf.errors import OptionError
from cdbrdf.synth import presets
from cdbrdf.synth.pile_texels import _density, tuft_layout
from cdbrdf.synth.texels import tabulate_btf

GRID = Grid.regular(theta_step_deg=30, phi_step_deg=90, kappa=[-0.22, 0.0, 0.22])


@pytest.fixture(scope="module", params=["velvet", "towel"])
def pile(request):
    return presets.model(request.param)


@pytest.fixture(scope="module")
def btf(pile):
    return tabulate_btf(pile, GRID, texels=8, max_error=0.0, method="pca")


def test_layout_follows_the_preset_density(pile):
    """Tufts per mm^2 = strands / 2 (a V-tuft's two legs) for cut pile, loops for loop pile; two per repeat."""
    p = pile.params
    lay = tuft_layout(pile)
    per_mm2 = p.strands_per_mm2 / (2.0 if p.kind == "cut" else 1.0)
    su, sv = lay.repeat_mm
    assert math.isclose(2.0 / (su * sv), per_mm2, rel_tol=1e-12)
    assert math.isclose(sv, 2.0 * su, rel_tol=1e-12) and math.isclose(lay.pitch_mm, su, rel_tol=1e-12)
    fwhm = 2.0 * math.sqrt(2.0 * math.log(2.0)) * lay.sigma_mm
    assert math.isclose(fwhm, max(su - p.correlation_mm, 0.25 * su), rel_tol=1e-12)


def test_density_has_mean_one_over_the_repeat(pile):
    """The tufts' relative density integrates to the repeat's area at any bundle width (periodic images)."""
    lay = tuft_layout(pile)
    su, sv = lay.repeat_mm
    n = 256
    u, v = np.meshgrid((np.arange(n) + 0.5) * su / n, (np.arange(n) + 0.5) * sv / n)
    for s in (0.3 * lay.sigma_mm, lay.sigma_mm, 3.0 * su):
        rho = _density(lay, u, v, np.full_like(u, s), np.full_like(u, s))
        assert rho.mean() == pytest.approx(1.0, rel=1e-6)
        assert rho.min() >= 0.0


def test_tile_mean_is_the_pile_models_cdbrdf(pile, btf):
    """The shares have mean one over the texels: the tile mean is exactly PileModel.tabulate."""
    ref = pile.tabulate(GRID).values
    np.testing.assert_allclose(btf.decode().mean(axis=(0, 1)), ref, rtol=1e-4, atol=1e-6 * ref.max())
    np.testing.assert_allclose(btf.mean().values, ref, rtol=1e-4, atol=1e-6 * ref.max())
    assert btf.compression["relative_rms_error"] < 1e-6
    assert btf.repeat_mm == tuft_layout(pile).repeat_mm
    assert btf.attrs["btf_tufts"]["pitch_mm"] == pytest.approx(tuft_layout(pile).pitch_mm)


def test_a_convex_bend_opens_the_tufts(pile, btf):
    """Seen from above, the texels' contrast (std / mean of the luminance) grows from concave to flat to convex.

    On a dark pile (velvet) the ground that a convex bend uncovers is what changes; the white towel's loops
    and ground scatter light among themselves (multiple scattering, pile model 2.0), so its contrast hardly
    changes with the bend: there only the tufts' showing is checked.
    """
    lum = btf.decode() @ LUMINANCE_WEIGHTS  # (v, u, kappa, phi_l, theta_l, phi_v, theta_v)
    top = lum[:, :, :, :, 1:3, 0, 0]  # view along the normal, lights at 30 and 60 degrees
    cv = np.median((top.std(axis=(0, 1)) / top.mean(axis=(0, 1))).reshape(3, -1), axis=1)
    if pile.params.name != "towel":
        assert cv[0] < cv[1] < cv[2]
    assert cv[1] > 0.2  # the tufts show on the flat fabric
    assert np.all(lum >= 0)


def test_texels_see_the_ground_in_the_gaps(pile):
    """From above, a texel in a gap between tufts shows more of the ground's colour than one on a tuft."""
    b = tabulate_btf(pile, Grid.regular(theta_step_deg=30, phi_step_deg=90, kappa=[0.0]), texels=16, method="pca")
    lay = tuft_layout(pile)
    rgb = b.evaluate(np.array([lay.centres_mm[0, 0], 0.5 * lay.repeat_mm[0]]),
                     np.array([lay.centres_mm[0, 1], lay.repeat_mm[1]]), 0.0, 0.0, 30.0, 0.0)
    ground = np.asarray(pile.params.ground_rgb)
    fibre = np.asarray(pile.params.fibre_rgb)
    # the projection of the colour on the ground-minus-fibre axis, per unit brightness
    axis = ground / ground.sum() - fibre / fibre.sum()
    share = (rgb / rgb.sum(axis=1, keepdims=True)) @ axis
    assert share[1] > share[0]
    assert rgb[0].sum() > 0 and rgb[1].sum() > 0


def test_points_per_texel_is_refused_for_a_pile(pile):
    with pytest.raises(OptionError, match="points_per_texel: only for woven cloth"):
        tabulate_btf(pile, GRID, texels=4, points_per_texel=16)


def test_synth_command_writes_a_pile_cdbtf(tmp_path, capsys):
    out = tmp_path / "velvet-btf.h5"
    assert cli_main(["--quiet", "synth", "velvet", "--btf", "6", "--grid", "regular:30,90", "--kappa", "0,0.2",
                     "-o", str(out)]) == 0
    b = load(out)
    assert b.texels == (6, 6) and b.attrs["material"] == "velvet"
    assert b.repeat_mm == tuft_layout(presets.model("velvet")).repeat_mm
    capsys.readouterr()
    assert cli_main(["synth", "towel", "--btf", "6", "--points-per-texel", "8", "-o",
                     str(tmp_path / "t.h5")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "only for woven cloth" in err[0]
    assert not (tmp_path / "t.h5").exists()
