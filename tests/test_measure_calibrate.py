"""From patches to the table (cdbrdf.measure.calibrate): white reference, dark frames, brackets, fill."""

from __future__ import annotations

import math

import numpy as np
import pytest

from cdbrdf import Grid
from cdbrdf.measure import CaptureError, measure
from cdbrdf.measure.capture import read_capture

from .measure_helpers import (
    ALBEDO,
    GRID,
    SCALE,
    SMALL,
    WHITE,
    make_capture,
    pixel,
    truth,
    write_csv,
    write_image,
)


@pytest.mark.parametrize("kind,rtol", [("png16", 3e-4), ("png8", 2e-2), ("tif16", 3e-4),
                                       ("tiff32", 1e-6), ("exr", 1e-6)])
def test_white_reference_gives_brdf(tmp_path, kind, rtol):
    make_capture(tmp_path, GRID, pixel, kind=kind, white=WHITE, settings={"white_albedo": ALBEDO})
    table, rep = measure(tmp_path)
    assert table.quantity == "brdf" and rep.quantity == "brdf"
    assert table.measured.all() and rep.n_measured == table.measured.size
    np.testing.assert_allclose(table.values, truth(), rtol=rtol)
    assert rep.n_white == GRID.theta_l.size * GRID.phi_l.size


def test_albedo_option_scales(tmp_path):
    make_capture(tmp_path, GRID, pixel, kind="exr", white=WHITE)
    t1, _ = measure(tmp_path)  # albedo 1 by default
    t2, _ = measure(tmp_path, white_albedo=0.5)
    np.testing.assert_allclose(t1.values, truth() / ALBEDO, rtol=1e-6)
    np.testing.assert_allclose(t2.values, t1.values * 0.5, rtol=1e-12)


def test_relative_without_white(tmp_path):
    make_capture(tmp_path, GRID, pixel, kind="png16")
    table, rep = measure(tmp_path)
    assert table.quantity == "relative"
    np.testing.assert_allclose(table.values, truth() * SCALE, rtol=3e-4)  # divided by cos(theta_l)
    assert table.std is not None and np.all(table.std < 1e-3)


def test_linear_flag_and_encoding_column(tmp_path):
    lin = lambda *a: np.full(3, 0.3)  # noqa: E731
    rows = make_capture(tmp_path, Grid(kappa=[0.0], theta_l=[0.0], phi_l=[0.0], theta_v=[0.0],
                                       phi_v=[0.0]), lin, kind="png16")
    srgb, _ = measure(tmp_path)
    raw, _ = measure(tmp_path, linear=True)
    assert srgb.values[0, 0, 0, 0, 0, 0] == pytest.approx(0.3, rel=1e-4)
    code = round((1.055 * 0.3 ** (1 / 2.4) - 0.055) * 65535) / 65535
    assert raw.values[0, 0, 0, 0, 0, 0] == pytest.approx(code, rel=1e-12)
    rows[0]["encoding"] = "linear"
    write_csv(tmp_path / "capture.csv", rows)
    col, _ = measure(tmp_path)
    assert col.values[0, 0, 0, 0, 0, 0] == raw.values[0, 0, 0, 0, 0, 0]


def test_patch_ignores_ring_and_patch_size(tmp_path):
    """Pixels just outside the 7 x 7 patch hold a different value: they must not count."""
    make_capture(tmp_path, GRID, pixel, kind="exr", white=WHITE, ring=0.9,
                 settings={"white_albedo": ALBEDO})
    table, _ = measure(tmp_path, patch=7)
    np.testing.assert_allclose(table.values, truth(), rtol=1e-6)
    bigger, _ = measure(tmp_path, patch=9)
    assert not np.allclose(bigger.values, truth(), rtol=1e-2)


def test_dark_frame_subtracted(tmp_path):
    dark = 0.05
    rows = make_capture(tmp_path, GRID, lambda *a: pixel(*a) + dark, kind="exr", white=None)
    # the white reference also carries the dark signal
    for pl in GRID.phi_l:
        for tl in GRID.theta_l:
            f = f"w/{tl:g}_{pl:g}.exr"
            rows.append(dict(file=f, kappa="", theta_v=0, phi_v=0, theta_l=tl, phi_l=pl, kind="white"))
            write_image(tmp_path / f, np.full((15, 15, 3), WHITE * math.cos(math.radians(tl)) + dark), "exr")
    rows.append(dict(file="dark.exr", kappa="", theta_v="", phi_v="", theta_l="", phi_l="", kind="dark"))
    write_image(tmp_path / "dark.exr", np.full((15, 15, 3), dark), "exr")
    write_csv(tmp_path / "capture.csv", rows)
    table, rep = measure(tmp_path, white_albedo=ALBEDO)
    assert rep.n_dark == 1
    np.testing.assert_allclose(table.values, truth(), rtol=1e-5)


def test_brackets_and_saturation(tmp_path):
    rows = []
    # sample 0: exposure 4 saturates (0.3 * 4 > 1), exposure 1 does not -> 0.3
    # sample 1: only one exposure, saturated -> invalid, filled from sample 0
    for i, (tv, exps) in enumerate([(0.0, [4.0, 1.0]), (30.0, [4.0])]):
        for j, e in enumerate(exps):
            f = f"s{i}_{j}.png"
            rows.append(dict(file=f, kappa=0, theta_v=tv, phi_v=0, theta_l=0, phi_l=0, exposure=e))
            write_image(tmp_path / f, np.full((11, 11, 3), min(0.3 * e, 1.0)), "png16")
    write_csv(tmp_path / "capture.csv", rows)
    table, rep = measure(tmp_path, fill="kappa-fit")  # one stand: the paper's rule fills it
    assert table.values[0, 0, 0, 0, 0, 0] == pytest.approx(0.3, rel=1e-4)
    assert table.measured.tolist() == [[[[[True, False]]]]]
    assert table.fill_source[0, 0, 0, 0, 1] == 0
    assert rep.n_saturated == 1 and rep.n_filled == 1


def test_bracket_merge_both_unsaturated(tmp_path):
    g_rows = []
    for j, e in enumerate([1.0, 0.5]):
        f = f"b{j}.exr"
        g_rows.append(dict(file=f, kappa=0, theta_v=0, phi_v=0, theta_l=0, phi_l=0, exposure=e))
        write_image(tmp_path / f, np.full((9, 9, 3), 0.4 * e + (0.01 if j == 0 else 0.0)), "exr")
    write_csv(tmp_path / "capture.csv", g_rows)
    table, _ = measure(tmp_path)
    # (0.41 + 0.2) / (1 + 0.5)
    assert table.values[0, 0, 0, 0, 0, 0] == pytest.approx(0.61 / 1.5, rel=1e-6)


def test_hidden_by_stand_not_read_and_filled(tmp_path):
    stands = [{"kappa": -0.2, "face_width_mm": 6.0, "wall_height_mm": 2.0}, {"kappa": 0.0}, {"kappa": 0.2}]
    make_capture(tmp_path, GRID, pixel, kind="png16", stands=stands)
    cap = read_capture(tmp_path)
    assert cap.hidden[0].any() and not cap.hidden[1:].any()
    # hidden photographs are never read: deleting them changes nothing
    hidden_files = [r.file for i, r in enumerate(cap.rows) if r.kind == "sample" and cap.hidden[cap.sample_index[i]]]
    for f in hidden_files:
        (tmp_path / f).unlink()
    table, rep = measure(tmp_path, fill="kappa-fit")
    np.testing.assert_array_equal(table.measured, ~cap.hidden)
    assert rep.n_hidden == int(cap.hidden.sum()) == rep.n_filled
    src = table.fill_source[~table.measured]
    assert np.all(src >= 0) and table.measured.ravel()[src].all()
    # kappa-fit: from the same direction on the other stands (flat first, then convex)
    per_k = int(np.prod(GRID.shape[1:]))
    hid = np.flatnonzero(~table.measured.ravel())
    np.testing.assert_array_equal(table.fill_sources[~table.measured], np.stack([hid + per_k, hid + 2 * per_k], 1))
    # the paper's rule: from the same curvature
    table, _ = measure(tmp_path, fill="nearest")
    src = table.fill_source[~table.measured]
    assert np.all(src >= 0) and table.measured.ravel()[src].all()
    assert np.all(src // per_k == 0)


def test_hidden_column_without_stand_file(tmp_path):
    rows = make_capture(tmp_path, GRID, pixel, kind="exr")
    rows[5]["hidden"] = "view"
    write_csv(tmp_path / "capture.csv", rows)
    table, rep = measure(tmp_path, fill="kappa-fit")
    assert rep.n_hidden == 1 and (~table.measured).sum() == 1


def test_curvature_without_a_measured_sample_names_the_capture(tmp_path):
    rows = make_capture(tmp_path, SMALL, pixel, kind="exr", size=9)
    for r in rows:
        if r["kappa"] == 0.2:
            r["hidden"] = "view"
    write_csv(tmp_path / "capture.csv", rows)
    with pytest.raises(CaptureError, match=f"{tmp_path}: kappa = 0.2 1/mm: no sample was measured"):
        measure(tmp_path)
