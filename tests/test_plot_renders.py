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
    # the difference as shown: CIEDE2000 of the two exposed, tone-mapped pictures, only where they differ
    assert diff[2, 3] == pytest.approx(_ciede2000_shown(a[2, 3], b[2, 3], 1.0), abs=0.02) and diff[2, 3] > 10
    assert diff.sum() == pytest.approx(diff[2, 3])
    for suffix, magic in ((".png", b"\x89PNG"), (".pdf", b"%PDF"), (".svg", b"<?xml")):
        out = save_figure(fig, tmp_path / f"c{suffix}")
        assert out.read_bytes()[: len(magic)] == magic
    with pytest.raises(ValueError, match=r"c\.jpg: cannot tell the figure format from '\.jpg'; use one of \.png, \.pdf, \.svg"):
        save_figure(fig, tmp_path / "c.jpg")
    with pytest.raises(ValueError, match="two .* images of one shape"):
        plot_render_comparison(a, b[:3])
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c.pdf", "c.png", "c.svg"]


def _ciede2000_shown(rgb_a, rgb_b, exposure_ev):
    """CIEDE2000 of two linear colours as an sRGB display shows them, by colour-science's own chain.

    Independent of cdbrdf.colour: colour-science decodes the sRGB codes and converts them with its own
    sRGB matrix (from the primaries; ours is the standard's 4-digit one, so the two agree to ~0.01).
    """
    import colour as colour_science

    from cdbrdf.colour import tonemap_srgb8

    def lab(rgb):
        codes = tonemap_srgb8(np.asarray(rgb, dtype=np.float64), exposure_ev=exposure_ev) / 255.0
        return colour_science.XYZ_to_Lab(colour_science.sRGB_to_XYZ(codes))

    return float(colour_science.difference.delta_E_CIE2000(lab(rgb_a), lab(rgb_b)))


@pytest.mark.parametrize("metric, label", [("2000", "CIEDE2000"), ("ab", "CIE 1976"),
                                           ("2000-textiles", "CIEDE2000 (2:1:1)")])
def test_compare_heat_map_is_the_colour_difference_as_shown(metric, label):
    """Panel (c) is Delta E of the displayed pictures, at every pixel, with a colour bar naming the metric."""
    from cdbrdf.colour import delta_e, srgb_to_lab, tonemap_srgb8
    from cdbrdf.plot import displayed_delta_e, plot_render_comparison

    rng = np.random.default_rng(4)
    a = rng.uniform(0.0, 0.6, (5, 7, 3))
    b = a * rng.uniform(0.7, 1.3, (5, 7, 3))
    b[0, 0] = a[0, 0]  # one pixel the same
    ev = -0.5
    fig = plot_render_comparison(a, b, exposure_ev=ev, delta_e=metric)
    panels = [ax for ax in fig.axes if ax.images and ax.get_label() != "<colorbar>"]
    heat = np.asarray(panels[2].images[0].get_array())
    shown_a, shown_b = tonemap_srgb8(a, exposure_ev=ev), tonemap_srgb8(b, exposure_ev=ev)
    want = delta_e(srgb_to_lab(shown_a), srgb_to_lab(shown_b), metric=metric)
    np.testing.assert_allclose(heat, want, rtol=1e-6)
    np.testing.assert_allclose(displayed_delta_e(a, b, exposure_ev=ev, metric=metric), want)
    assert heat[0, 0] == 0.0
    if metric == "2000":  # against colour-science's own sRGB -> L*a*b* chain, at a few pixels
        for i, j in ((1, 2), (3, 5), (4, 0)):
            assert heat[i, j] == pytest.approx(_ciede2000_shown(a[i, j], b[i, j], ev), abs=0.02)
    bars = [ax for ax in fig.axes if ax.get_label() == "<colorbar>"]
    assert len(bars) == 1
    assert bars[0].get_ylabel().startswith(label) and "Delta E" in bars[0].get_ylabel()
    assert label.split(" (")[0] in panels[2].get_title()
    assert panels[2].images[0].get_clim()[0] == 0.0


def test_compare_heat_map_scale_and_metric_refused():
    from cdbrdf.plot import plot_render_comparison

    a = np.full((4, 4, 3), 0.2)
    b = a * 1.001  # below a just-noticeable difference: the scale stays at the floor, the map dark
    fig = plot_render_comparison(a, b)
    panels = [ax for ax in fig.axes if ax.images and ax.get_label() != "<colorbar>"]
    assert panels[2].images[0].get_clim() == (0.0, 1.0)
    with pytest.raises(ValueError, match=r"delta E metric: 'cmc' is not one of 2000, 2000-textiles, ab"):
        plot_render_comparison(a, b, delta_e="cmc")
