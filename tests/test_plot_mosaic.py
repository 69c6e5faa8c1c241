"""Tests of cdbrdf.plot.mosaic (Fig. 7 mosaic arrays and figure) and ``cdbrdf mosaic``."""

from __future__ import annotations

import io

import numpy as np
import pytest

import cdbrdf
from cdbrdf.cli import main
from cdbrdf.errors import QueryError
from cdbrdf.plot import Mosaic, kappa_label, mosaic_arrays, plot_mosaic, srgb_encode

from .plot_helpers import KAPPA, PHI_L, PHI_V, THETA_L, THETA_V, code, const_table, index_table, png_size
from .plot_helpers import image_axes as _image_axes


# -- arrays ----------------------------------------------------------------------------
def test_layout_matches_fig7_definition():
    t = index_table()
    m = mosaic_arrays(t)
    assert isinstance(m, Mosaic)
    nr, nc_ = len(PHI_L) * len(THETA_L), len(PHI_V) * len(THETA_V)
    assert m.images.shape == (3, nr, nc_, 3)
    for k in range(3):
        for pl in range(len(PHI_L)):
            for tl in range(len(THETA_L)):
                for pv in range(len(PHI_V)):
                    for tv in range(len(THETA_V)):
                        r = pl * len(THETA_L) + tl
                        c = pv * len(THETA_V) + tv
                        np.testing.assert_array_equal(
                            m.images[k, r, c], [code(k, pl, tl, pv, tv, ch) for ch in range(3)]
                        )
    np.testing.assert_array_equal(m.images, t.fig7())
    # coordinates of rows and columns
    np.testing.assert_array_equal(m.row_phi_deg, [0, 0, 90, 90, 180, 180, 270, 270])
    np.testing.assert_array_equal(m.row_theta_deg, [0, 40] * 4)
    np.testing.assert_array_equal(m.col_phi_deg, [0, 0, 0, 120, 120, 120, 240, 240, 240])
    np.testing.assert_array_equal(m.col_theta_deg, [0, 30, 60] * 3)
    assert m.unit == "relative" and m.channels == ("R", "G", "B")


def test_filled_mask_layout():
    shape = (3, len(PHI_L), len(THETA_L), len(PHI_V), len(THETA_V))
    meas = np.ones(shape, bool)
    meas[0, 2, 1, 1, 2] = False  # kappa -0.1, phi_l 180, theta_l 40, phi_v 120, theta_v 60
    meas[2, 0, 0, 2, 1] = False
    m = mosaic_arrays(index_table(measured=meas))
    expected = np.zeros((3, 8, 9), bool)
    expected[0, 2 * 2 + 1, 1 * 3 + 2] = True
    expected[2, 0, 2 * 3 + 1] = True
    np.testing.assert_array_equal(m.filled, expected)
    np.testing.assert_array_equal(m.reference_filled, np.zeros((8, 9), bool))


def test_difference_against_sampled_zero():
    m = mosaic_arrays(index_table(), kappa=[0.2, -0.1])
    np.testing.assert_array_equal(m.kappa, [0.2, -0.1])
    np.testing.assert_array_equal(m.kappa_index, [2, 0])
    assert m.reference_kappa == 0.0 and m.reference_sampled
    # code() puts 10000 * kappa index into each value; the reference is index 1
    np.testing.assert_allclose(m.difference[0], 10000.0)
    np.testing.assert_allclose(m.difference[1], -10000.0)
    np.testing.assert_allclose(m.difference_luminance()[0], 10000.0)


def test_reference_interpolated_when_zero_not_sampled():
    g = cdbrdf.Grid.regular(theta_step_deg=30, phi_step_deg=120, theta_max_deg=60, kappa=[-0.1, 0.3])
    rng = np.random.default_rng(1)
    a = rng.uniform(0.1, 1.0, g.shape[1:] + (3,))
    b = rng.uniform(-1.0, 1.0, g.shape[1:] + (3,))
    v = a[None] + b[None] * g.kappa[:, None, None, None, None, None]
    meas = np.ones(g.shape, bool)
    meas[0, 1, 2, 0, 1] = False
    meas[1, 2, 1, 2, 2] = False
    t = cdbrdf.CDBRDF(v, g, measured=meas)
    m = mosaic_arrays(t)
    assert m.reference_kappa == 0.0 and not m.reference_sampled
    np.testing.assert_allclose(m.reference, a.reshape(9, 9, 3), rtol=1e-12)
    np.testing.assert_allclose(m.difference[1], 0.3 * b.reshape(9, 9, 3), rtol=1e-12)
    # agrees with the table's lookup at the sample directions off the pole
    mesh = g.mesh()
    sel = (slice(None), slice(1, None), slice(None), slice(1, None))
    look = t.evaluate(
        mesh["theta_v"][0][sel], mesh["phi_v"][0][sel], mesh["theta_l"][0][sel], mesh["phi_l"][0][sel], 0.0
    )
    ref = m.reference.reshape(g.shape[1:] + (3,))[sel]
    np.testing.assert_allclose(ref, look, rtol=1e-12)
    expected = np.zeros(g.shape[1:], bool)
    expected[1, 2, 0, 1] = expected[2, 1, 2, 2] = True
    np.testing.assert_array_equal(m.reference_filled, expected.reshape(9, 9))


def test_reference_clamped_when_zero_outside_range():
    m = mosaic_arrays(index_table(kappa=[0.1, 0.2, 0.3]))
    assert m.reference_kappa == 0.1 and m.reference_sampled
    np.testing.assert_allclose(m.difference[2], 20000.0)


def test_kappa_selection_errors():
    t = index_table()
    with pytest.raises(QueryError, match=r"0\.13 mm\^-1 is not a curvature.*available: -0\.1, 0, 0\.2"):
        mosaic_arrays(t, kappa=[0.0, 0.13])
    with pytest.raises(QueryError, match="twice"):
        mosaic_arrays(t, kappa=[0.2, 0.2])
    with pytest.raises(QueryError, match="not a curvature"):
        mosaic_arrays(t, kappa=float("nan"))
    with pytest.raises(ValueError, match="kappa"):
        mosaic_arrays(t, kappa="flat")
    with pytest.raises(ValueError, match="kappa"):
        mosaic_arrays(t, kappa=[])
    with pytest.raises(TypeError, match="CDBRDF"):
        mosaic_arrays(np.zeros((1, 1, 1, 1, 1, 3)))


def test_kappa_selection_tolerates_float32_rounding():
    t = index_table(kappa=np.array([-0.13, 0.0, 0.13], dtype=np.float32))
    m = mosaic_arrays(t, kappa=0.13)
    assert m.kappa_index.tolist() == [2]


def test_arrays_are_read_only_copies():
    t = index_table()
    m = mosaic_arrays(t)
    with pytest.raises(ValueError):
        m.images[0, 0, 0, 0] = 1.0
    assert not np.shares_memory(m.images, t.values)


# -- the mosaic figure -------------------------------------------------------------------------
def test_plot_mosaic_png_size_and_layout():
    fig = plot_mosaic(index_table(), dpi=80)
    buf = io.BytesIO()
    fig.savefig(buf, format="png")
    w_in, h_in = fig.get_size_inches()
    assert png_size(buf.getvalue()) == (round(w_in * 80), round(h_in * 80))
    # 3 mosaics + 2 differences (the reference's own difference panel holds the notes)
    axes = _image_axes(fig)
    assert len(axes) == 5
    titles = [ax.get_title() for ax in axes]
    assert titles[:3] == [kappa_label(k) for k in KAPPA]
    assert "\u0394Y" in titles[3] and "0.2" in titles[4]
    assert axes[0].get_ylabel().startswith("light direction")
    assert axes[-1].get_xlabel().startswith("view direction")
    # azimuth group labels at the group centres
    ticks = axes[0].get_yticks(minor=True)
    np.testing.assert_array_equal(ticks, [1, 3, 5, 7])
    assert [t.get_text() for t in axes[0].get_yticklabels(minor=True)] == ["0\u00b0", "90\u00b0", "180\u00b0", "270\u00b0"]
    np.testing.assert_array_equal(axes[-1].get_xticks(minor=True), [1.5, 4.5, 7.5])


def test_plot_mosaic_shared_exposure_and_srgb():
    t = const_table([0.25, 0.25, 0.25])
    fig = plot_mosaic(t, kappa=[-0.13, 0.13], diff=False)
    for ax in _image_axes(fig):
        np.testing.assert_allclose(ax.images[0].get_array(), 1.0)  # 99.5th pct -> 1
    texts = " ".join(t.get_text() for t in fig.texts)
    assert "\u00d74 " in texts
    fig = plot_mosaic(t, exposure=2.0, diff=False)
    for ax in _image_axes(fig):
        np.testing.assert_allclose(ax.images[0].get_array(), 0.7353569830524495)
    assert "\u00d72 (given)" in " ".join(t.get_text() for t in fig.texts)
    # one exposure for all panels: the brighter slice saturates the dimmer's scale
    g = cdbrdf.Grid.regular(theta_step_deg=25, phi_step_deg=90, kappa=[0.0, 0.1])
    v = np.ones(g.shape + (3,))
    v[0] *= 0.1
    v[1] *= 0.4
    fig = plot_mosaic(cdbrdf.CDBRDF(v, g), diff=False)
    a0, a1 = (ax.images[0].get_array() for ax in _image_axes(fig))
    np.testing.assert_allclose(a1, 1.0)
    np.testing.assert_allclose(a0, srgb_encode(0.25))


def test_plot_mosaic_white_exposure():
    t = const_table([0.1, 0.1, 0.1], quantity="brdf")
    fig = plot_mosaic(t, exposure="white", diff=False)
    for ax in _image_axes(fig):
        np.testing.assert_allclose(ax.images[0].get_array(), srgb_encode(0.1 * np.pi))
    assert "\u00d73.142 (white" in " ".join(t.get_text() for t in fig.texts)
    with pytest.raises(ValueError, match="quantity 'brdf'"):
        plot_mosaic(const_table(0.1, quantity="relative"), exposure="white")
    with pytest.raises(ValueError, match="auto, white"):
        plot_mosaic(t, exposure="bright")


def test_plot_mosaic_difference_panel_values_and_colourbar():
    g = cdbrdf.Grid.regular(theta_step_deg=25, phi_step_deg=90, kappa=[0.0, 0.1])
    v = np.zeros(g.shape + (3,))
    v[0] = [0.1, 0.2, 0.3]
    v[1] = [0.3, 0.2, 0.1]
    fig = plot_mosaic(cdbrdf.CDBRDF(v, g, attrs={"quantity": "brdf"}))
    axes = _image_axes(fig)
    assert len(axes) == 3
    dy = 0.2126 * 0.2 + 0.7152 * 0.0 + 0.0722 * (-0.2)
    np.testing.assert_allclose(axes[2].images[0].get_array(), dy)
    cbars = [ax for ax in fig.axes if ax.get_label() == "<colorbar>"]
    assert len(cbars) == 1 and "sr$^{-1}$" in cbars[0].get_ylabel()
    assert axes[2].images[0].norm.vmin == pytest.approx(-abs(dy))


def test_plot_mosaic_marks_filled_samples():
    from matplotlib.patches import PathPatch

    shape = (3, len(PHI_L), len(THETA_L), len(PHI_V), len(THETA_V))
    meas = np.ones(shape, bool)
    meas[0, 1, 1, 2, 0:2] = False
    fig = plot_mosaic(index_table(measured=meas))
    axes = _image_axes(fig)
    patches = [p for p in axes[0].patches if isinstance(p, PathPatch)]
    assert len(patches) == 1 and patches[0].get_hatch()
    # the filled run: row phi_l 90 / theta_l 40 = 3, columns 6..8 (phi_v 240, theta_v 0, 30)
    verts = patches[0].get_path().vertices
    np.testing.assert_array_equal(verts.min(0), [6, 3])
    np.testing.assert_array_equal(verts.max(0), [8, 4])
    assert not [p for p in axes[1].patches if isinstance(p, PathPatch)]
    legend_texts = [t.get_text() for ax in fig.axes if ax.get_legend() for t in ax.get_legend().get_texts()]
    assert "filled (not measured)" in legend_texts
    fig = plot_mosaic(index_table(measured=meas), mark_filled=False)
    assert not _image_axes(fig)[0].patches


def test_plot_mosaic_single_kappa_and_options():
    t = const_table(0.2, kappa=[0.0])
    fig = plot_mosaic(t)
    assert len(_image_axes(fig)) == 1  # the reference alone: no difference row
    fig = plot_mosaic(mosaic_arrays(index_table(), kappa=[0.2]))
    assert len(_image_axes(fig)) == 2  # one mosaic, one difference
    fig = plot_mosaic(index_table(), channel="G", title="")
    assert fig._suptitle is None or fig._suptitle.get_text() == ""
    with pytest.raises(ValueError, match="exposure"):
        plot_mosaic(t, exposure=0)
    with pytest.raises(ValueError, match="diff_limit"):
        plot_mosaic(t, diff_limit=-1)
    with pytest.raises(ValueError, match="mosaic_arrays"):
        plot_mosaic(mosaic_arrays(t), kappa=0.0)
    with pytest.raises(QueryError, match="available: 0"):
        plot_mosaic(t, kappa=0.5)


def test_plot_mosaic_one_and_four_channels():
    g = cdbrdf.Grid.regular(theta_step_deg=25, phi_step_deg=90, kappa=[0.0, 0.1])
    grey = cdbrdf.CDBRDF(np.full(g.shape + (1,), 0.5), g)
    fig = plot_mosaic(grey, exposure=1.0)
    np.testing.assert_allclose(_image_axes(fig)[0].images[0].get_array(), srgb_encode(0.5))
    four = cdbrdf.CDBRDF(np.full(g.shape + (4,), 0.5), g)
    with pytest.raises(ValueError, match="4 channels"):
        plot_mosaic(four)
    plot_mosaic(four, channel=3)


# -- command line ---------------------------------------------------------------------------------
@pytest.fixture
def table_file(tmp_path):
    shape = (3, len(PHI_L), len(THETA_L), len(PHI_V), len(THETA_V))
    meas = np.ones(shape, bool)
    meas[0, 1, 1, 2, 0] = False
    path = tmp_path / "t.h5"
    index_table(measured=meas, attrs={"material": "index test"}).save(path)
    return path


@pytest.mark.parametrize("suffix, magic", [(".png", b"\x89PNG"), (".pdf", b"%PDF"), (".svg", b"<?xml")])
def test_cli_mosaic_formats(table_file, tmp_path, capsys, suffix, magic):
    out = tmp_path / f"m{suffix}"
    assert main(["mosaic", str(table_file), "-o", str(out), "--dpi", "60"]) == 0
    assert out.read_bytes()[: len(magic)] == magic
    assert f"wrote {out}" in capsys.readouterr().out
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(["t.h5", out.name])


def test_cli_mosaic_options(table_file, tmp_path):
    a, b = tmp_path / "a.png", tmp_path / "b.png"
    assert main(["-q", "mosaic", str(table_file), "-o", str(a), "--dpi", "50"]) == 0
    assert main(["-q", "mosaic", str(table_file), "-o", str(b), "--dpi", "50", "--kappa", "0.2", "-0.1",
                 "--no-diff", "--exposure", "0.5", "--channel", "1", "--no-marks"]) == 0
    wa, ha = png_size(a.read_bytes())
    wb, hb = png_size(b.read_bytes())
    assert wb < wa and hb < ha


@pytest.mark.parametrize(
    "args, message",
    [
        (["{f}", "-o", "{d}/m.jpg"], "m.jpg: cannot tell the output format from '.jpg'; use one of .png, .pdf, .svg"),
        (["{f}", "-o", "{d}/m"], "use one of .png"),
        (["{f}", "-o", "{d}/nowhere/m.png"], "the folder"),
        (["{d}/missing.h5", "-o", "{d}/m.png"], "missing.h5"),
        (["{d}/bad.h5", "-o", "{d}/m.png"], "bad.h5"),
        (["{f}", "-o", "{d}/m.png", "--kappa", "0.13"], "0.13 mm^-1 is not a curvature of the table; available: -0.1, 0, 0.2"),
        (["{f}", "-o", "{d}/m.png", "--channel", "Q"], "'Q' is not one of R, G, B"),
        (["{f}", "-o", "{d}/m.png", "--exposure", "white"], "exposure: 'white' needs an absolute table"),
    ],
)
def test_cli_mosaic_errors(table_file, tmp_path, capsys, args, message):
    (tmp_path / "bad.h5").write_text("not a table\n")
    argv = ["mosaic"] + [a.format(f=table_file, d=tmp_path) for a in args]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("cdbrdf mosaic: error:") and message in err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert not list(tmp_path.glob("m*")) and not list(tmp_path.glob(".m*"))


def test_cli_mosaic_usage_errors(table_file, tmp_path, capsys):
    with pytest.raises(SystemExit) as e:
        main(["mosaic", str(table_file)])
    assert e.value.code == 2 and "-o/--output" in capsys.readouterr().err
    with pytest.raises(SystemExit) as e:
        main(["mosaic", str(table_file), "-o", str(tmp_path / "m.png"), "--exposure", "-1"])
    assert e.value.code == 2 and "positive" in capsys.readouterr().err
    with pytest.raises(SystemExit) as e:
        main(["mosaic", str(table_file), "-o", str(tmp_path / "m.png"), "--exposure", "bright"])
    assert e.value.code == 2 and "auto, white" in capsys.readouterr().err
