"""Tests of cdbrdf.plot.slices and cdbrdf.plot.hemisphere."""

from __future__ import annotations

import io

import numpy as np
import pytest

import cdbrdf
from cdbrdf.plot import luminance, plot_hemisphere, plot_slice

from .plot_helpers import const_table, png_size


def test_plot_slice_curves_and_samples():
    g = cdbrdf.Grid.regular(theta_step_deg=15, phi_step_deg=30, kappa=[-0.2, 0.0, 0.2])
    v = (0.3 + g.mesh()["kappa"])[..., None] * np.ones(3)
    t = cdbrdf.CDBRDF(v, g, attrs={"quantity": "brdf"})
    fig = plot_slice(t, theta_l_deg=30, phi_l_deg=60, kappa=[-0.2, 0.1, 0.2])
    ax = fig.axes[0]
    curves = [ln for ln in ax.get_lines() if len(ln.get_xdata()) > 2]
    assert len(curves) == 3
    for ln, k in zip(curves, [-0.2, 0.1, 0.2]):
        np.testing.assert_allclose(ln.get_ydata(), 0.3 + k, rtol=1e-12)
        assert ln.get_xdata()[0] == -75 and ln.get_xdata()[-1] == 75
    # dots at the table samples on the plane for the two sampled curvatures:
    # 6 elevations on the mirror side + 5 on the light side, measured only
    dots = [c for c in ax.collections if len(c.get_offsets())]
    assert sum(len(c.get_offsets()) for c in dots) == 2 * 11
    assert "sr$^{-1}$" in ax.get_ylabel()
    with pytest.raises(ValueError, match="incidence, perpendicular"):
        plot_slice(t, plane="diagonal")
    with pytest.raises(ValueError, match="theta_l_deg"):
        plot_slice(t, theta_l_deg=95)
    fig = plot_slice(t, plane="perpendicular", channel="R")
    assert "channel R" in fig.axes[0].get_ylabel()


def test_plot_hemisphere_values_and_errors():
    t = const_table([0.2, 0.4, 0.6], kappa=[0.0])
    fig = plot_hemisphere(t, theta_l_deg=30, phi_l_deg=45, n_theta=10, n_phi=24)
    polar = [ax for ax in fig.axes if ax.name == "polar"]
    assert len(polar) == 1
    np.testing.assert_allclose(polar[0].collections[0].get_array(), luminance([0.2, 0.4, 0.6]))
    fig = plot_hemisphere(t, kappa=[0.0, 0.1], colour="rgb", exposure=1.0, n_theta=8, n_phi=12)
    assert len([ax for ax in fig.axes if ax.name == "polar"]) == 2
    buf = io.BytesIO()
    fig.savefig(buf, format="png")
    assert png_size(buf.getvalue())[0] > 0
    with pytest.raises(ValueError, match="luminance, rgb"):
        plot_hemisphere(t, colour="false")
    with pytest.raises(ValueError, match="exposure"):
        plot_hemisphere(t, colour="rgb", exposure=-2)
