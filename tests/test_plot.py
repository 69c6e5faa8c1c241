"""Tests of the cdbrdf.plot package as a whole: its names, the colour helpers it
re-exports, and that figures never touch pyplot or the backend."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from cdbrdf.plot import auto_exposure, kappa_label, luminance, srgb_encode

from .plot_helpers import png_size


# -- colour helpers ----------------------------------------------------------------------
def test_luminance_srgb_and_exposure_known_values():
    np.testing.assert_allclose(luminance([1.0, 0.0, 0.0]), 0.2126)
    np.testing.assert_allclose(luminance([[0.5, 0.5, 0.5]]), [0.5])
    np.testing.assert_allclose(luminance([2.0, 3.0, 4.0], channel="G", channels="RGB"), 3.0)
    np.testing.assert_allclose(srgb_encode([0.0, 0.001, 0.5, 1.0, 2.0]), [0, 0.01292, 0.7353569830524495, 1, 1])
    assert auto_exposure(np.full(1000, 0.25)) == pytest.approx(4.0)
    assert auto_exposure(np.zeros(10)) == 1.0
    with pytest.raises(ValueError, match="4 channels"):
        luminance(np.zeros((2, 4)))
    with pytest.raises(ValueError, match="out of range"):
        luminance(np.zeros((2, 3)), channel=3)
    assert kappa_label(0.13) == "\u03ba = +0.13 mm\u207b\u00b9 (convex)"
    assert kappa_label(-0.22).endswith("(concave)") and "\u22120.22" in kappa_label(-0.22)
    assert kappa_label(0.0) == "\u03ba = 0 mm\u207b\u00b9 (flat)"


def test_figures_do_not_touch_pyplot(tmp_path):
    code_ = (
        "import sys, numpy as np, cdbrdf, cdbrdf.cli\n"
        "cdbrdf.cli.build_parser()\n"
        "assert 'matplotlib' not in sys.modules, 'matplotlib imported by the CLI parser'\n"
        "from cdbrdf.plot import plot_mosaic\n"
        "g = cdbrdf.Grid.regular(theta_step_deg=25, phi_step_deg=90, kappa=[0.0, 0.1])\n"
        "plot_mosaic(cdbrdf.CDBRDF(np.ones(g.shape + (3,)), g)).savefig(sys.argv[1])\n"
        "assert 'matplotlib.pyplot' not in sys.modules\n"
    )
    out = tmp_path / "x.png"
    r = subprocess.run([sys.executable, "-W", "error", "-c", code_, str(out)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert png_size(out.read_bytes())[0] > 0


#: Every name cdbrdf.plot exported when it was one module, and the ones added since.
PUBLIC = [
    "Mosaic", "mosaic_arrays", "plot_mosaic", "plot_slice", "plot_hemisphere",
    "plot_render_comparison", "plot_curvature_map", "tonemap_srgb8", "luminance",
    "srgb_encode", "auto_exposure", "kappa_label", "EXPOSURE_PERCENTILE", "EXPOSURE_MODES",
    "KAPPA_ATOL", "SLICE_PLANES", "LUMINANCE_WEIGHTS",
    "DIFF_PERCENTILE", "plot_hidden", "plot_kappa_curves", "plot_weave", "save_figure", "FIGURE_FORMATS",
    "displayed_delta_e",
]


def test_public_names_and_one_owner_of_the_colour_rules():
    import cdbrdf.colour
    import cdbrdf.plot

    assert sorted(cdbrdf.plot.__all__) == sorted(PUBLIC)
    for name in PUBLIC:
        assert hasattr(cdbrdf.plot, name), name
    for name in ("srgb_encode", "auto_exposure", "tonemap_srgb8", "EXPOSURE_PERCENTILE",
                 "EXPOSURE_MODES", "LUMINANCE_WEIGHTS"):
        assert getattr(cdbrdf.plot, name) is getattr(cdbrdf.colour, name), name
    assert cdbrdf.plot.EXPOSURE_MODES == ("auto", "white")
    with pytest.raises(TypeError):
        cdbrdf.plot.SLICE_PLANES["diagonal"] = (45.0, 225.0)  # read-only


def test_importing_plot_is_light():
    code_ = (
        "import sys, cdbrdf.plot\n"
        "heavy = [m for m in ('matplotlib', 'cdbrdf.synth', 'cdbrdf.measure', 'cdbrdf.render', 'numba') "
        "if m in sys.modules]\n"
        "assert not heavy, heavy\n"
    )
    r = subprocess.run([sys.executable, "-W", "error", "-c", code_], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr


def test_no_figure_switches_the_backend(tmp_path):
    """The capture plan's figure once called matplotlib.use('Agg'); no figure may.

    The render comparison computes CIEDE2000 with colour-science, whose package imports
    ``matplotlib.pyplot`` (its plotting module) without choosing a backend: after it, the
    backend is still the caller's and pyplot holds no figure of ours.
    """
    code_ = (
        "import sys, numpy as np, matplotlib, cdbrdf\n"
        "matplotlib.use('svg')\n"
        "from cdbrdf.measure.stands import default_stand, hidden_mask\n"
        "from cdbrdf.plot import plot_hidden, plot_render_comparison, save_figure\n"
        "g = cdbrdf.Grid.regular(theta_step_deg=30, phi_step_deg=90, kappa=[-0.22, 0.0])\n"
        "hid = hidden_mask(g, [default_stand(float(k)) for k in g.kappa])\n"
        "save_figure(plot_hidden(g, hid), sys.argv[1] + '/h.png', dpi=30)\n"
        "assert 'matplotlib.pyplot' not in sys.modules\n"
        "img = np.ones((4, 5, 3))\n"
        "save_figure(plot_render_comparison(img, img), sys.argv[1] + '/r.png', dpi=30)\n"
        "assert matplotlib.get_backend() == 'svg', matplotlib.get_backend()\n"
        "assert sys.modules['matplotlib.pyplot'].get_fignums() == []\n"
    )
    r = subprocess.run([sys.executable, "-W", "error", "-c", code_, str(tmp_path)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert png_size((tmp_path / "h.png").read_bytes())[0] > 0
