"""Tests of cdbrdf.plot.renders: render comparison and curvature maps."""

from __future__ import annotations

import numpy as np
import pytest


def test_curvature_map_draws_each_surface(tmp_path):
    from cdbrdf.plot import plot_curvature_map

    x, y = np.meshgrid(np.linspace(0, 1, 5), np.linspace(0, 1, 5), indexing="ij")
    v = np.stack([x.ravel(), y.ravel(), np.zeros(25)], axis=1)
    i, j = np.meshgrid(np.arange(4), np.arange(4), indexing="ij")
    a = (i * 5 + j).ravel()
    f = np.concatenate([np.stack([a, a + 5, a + 6], 1), np.stack([a, a + 6, a + 1], 1)])
    k = np.linspace(-0.2, 0.2, 25)
    fig = plot_curvature_map([("a", v, f, k), ("b", v, f, -k)])
    assert len([ax for ax in fig.axes if ax.name == "3d"]) == 2
    fig.savefig(tmp_path / "c.png")
    assert (tmp_path / "c.png").stat().st_size > 1000
    with pytest.raises(ValueError, match="surfaces: give at least one"):
        plot_curvature_map([])


def test_render_comparison_panels_and_difference(tmp_path):
    from cdbrdf.colour import tonemap_srgb8
    from cdbrdf.plot import plot_render_comparison, save_figure

    a = np.full((6, 8, 3), 0.25)
    b = a.copy()
    b[2, 3] = [0.25, 0.65, 0.25]
    fig = plot_render_comparison(a, b, exposure_ev=1.0, title="t")
    panels = [ax for ax in fig.axes if ax.images and ax.get_label() != "<colorbar>"]
    assert len(panels) == 3
    np.testing.assert_array_equal(panels[0].images[0].get_array(), tonemap_srgb8(a, exposure_ev=1.0))
    np.testing.assert_array_equal(panels[1].images[0].get_array(), tonemap_srgb8(b, exposure_ev=1.0))
    diff = panels[2].images[0].get_array()
    assert diff[2, 3] == pytest.approx(0.4) and diff.sum() == pytest.approx(0.4)
    for suffix, magic in ((".png", b"\x89PNG"), (".pdf", b"%PDF"), (".svg", b"<?xml")):
        out = save_figure(fig, tmp_path / f"c{suffix}")
        assert out.read_bytes()[: len(magic)] == magic
    with pytest.raises(ValueError, match=r"c\.jpg: cannot tell the figure format from '\.jpg'; use one of \.png, \.pdf, \.svg"):
        save_figure(fig, tmp_path / "c.jpg")
    with pytest.raises(ValueError, match="two .* images of one shape"):
        plot_render_comparison(a, b[:3])
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c.pdf", "c.png", "c.svg"]
