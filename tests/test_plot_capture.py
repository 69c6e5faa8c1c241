"""Tests of cdbrdf.plot.capture: the samples a capture plan's stands hide."""

from __future__ import annotations

import numpy as np
import pytest

import cdbrdf
from cdbrdf.measure.stands import default_stand, hidden_mask
from cdbrdf.plot import plot_hidden, save_figure

from .plot_helpers import png_size


def test_plot_hidden_one_panel_per_curvature(tmp_path):
    g = cdbrdf.Grid.regular(theta_step_deg=15, phi_step_deg=30, kappa=[-0.22, 0.0, 0.22])
    hid = hidden_mask(g, [default_stand(float(k)) for k in g.kappa])
    fig = plot_hidden(g, hid)
    assert len(fig.axes) == 3
    for ax, k, h in zip(fig.axes, g.kappa, hid):
        np.testing.assert_array_equal(ax.images[0].get_array(), h.reshape(72, 72))
        assert ax.get_title() == f"kappa = {k:g} 1/mm\n{int((h > 0).sum())} hidden"
    assert int((hid[0] > 0).sum()) > 0  # the concave stand hides something
    out = save_figure(fig, tmp_path / "plan.png", dpi=40)
    assert png_size(out.read_bytes()) == (round(fig.get_figwidth() * 40), round(fig.get_figheight() * 40))
    with pytest.raises(ValueError, match="hidden: expected the grid's shape"):
        plot_hidden(g, hid[:2])
