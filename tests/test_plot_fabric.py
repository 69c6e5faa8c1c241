"""Tests of cdbrdf.plot.fabric: the fabric model's figures."""

from __future__ import annotations

from cdbrdf.plot import plot_kappa_curves, plot_weave
from cdbrdf.synth import presets

#: Coarse model settings, as in test_synth.py: enough for a figure.
FAST = dict(texels=48, points=233, tilt_samples=3)


def test_figures_draw():
    m = presets.model("shot", **FAST)
    fig = plot_kappa_curves(m, kappa=[-0.2, 0.0, 0.2])
    assert len(fig.axes) == 4 and len(fig.axes[0].lines) >= 4
    fig = plot_weave(m)
    assert len(fig.axes) >= 6


def test_weave_panels_are_srgb_encoded_colours():
    m = presets.model("shot", **FAST)
    fig = plot_weave(m, kappa=[0.0])
    top = fig.axes[0].images[0].get_array()
    assert top.shape[-1] == 3 and 0.0 <= top.min() and top.max() <= 1.0
