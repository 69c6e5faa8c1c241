"""The measurement pipeline on hand-made capture folders with known answers."""

from __future__ import annotations

import math

import numpy as np
import pytest

import cdbrdf
from cdbrdf import Grid
from cdbrdf.cli import main
from cdbrdf.measure import CaptureError, MeasurementInterrupted, measure
from cdbrdf.measure.images import ImageError
from cdbrdf.measure.pipeline import checkpoint_path, read_capture

from .measure_helpers import make_capture, write_csv, write_image

GRID = Grid(kappa=[-0.2, 0.0, 0.2], theta_l=[0.0, 40.0], phi_l=[0.0, 180.0],
            theta_v=[0.0, 30.0, 60.0], phi_v=[0.0, 90.0, 180.0, 270.0])
ALBEDO = 0.9
SCALE = 2.0


def brdf(k, tv, pv, tl, pl):
    """A smooth known BRDF (sr^-1), RGB."""
    return np.array([0.08, 0.12, 0.2]) * (1 + k) * (1 + 0.5 * np.cos(np.radians(tv)))


def pixel(k, tv, pv, tl, pl):
    return brdf(k, tv, pv, tl, pl) * np.cos(np.radians(tl)) * SCALE


WHITE = ALBEDO / math.pi * SCALE


def truth(grid=GRID):
    m = grid.mesh()
    return brdf(m["kappa"][..., None], m["theta_v"][..., None], 0, 0, 0)


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
    g = Grid(kappa=[0.0], theta_l=[0.0], phi_l=[0.0], theta_v=[0.0, 30.0], phi_v=[0.0])
    rows = []
    # sample 0: exposure 4 saturates (0.3 * 4 > 1), exposure 1 does not -> 0.3
    # sample 1: only one exposure, saturated -> invalid, filled from sample 0
    for i, (tv, exps) in enumerate([(0.0, [4.0, 1.0]), (30.0, [4.0])]):
        for j, e in enumerate(exps):
            f = f"s{i}_{j}.png"
            rows.append(dict(file=f, kappa=0, theta_v=tv, phi_v=0, theta_l=0, phi_l=0, exposure=e))
            write_image(tmp_path / f, np.full((11, 11, 3), min(0.3 * e, 1.0)), "png16")
    write_csv(tmp_path / "capture.csv", rows)
    table, rep = measure(tmp_path)
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
    table, rep = measure(tmp_path)
    np.testing.assert_array_equal(table.measured, ~cap.hidden)
    assert rep.n_hidden == int(cap.hidden.sum()) == rep.n_filled
    src = table.fill_source[~table.measured]
    assert np.all(src >= 0) and table.measured.ravel()[src].all()
    # filled from the same curvature
    per_k = int(np.prod(GRID.shape[1:]))
    assert np.all(src // per_k == 0)


def test_hidden_column_without_stand_file(tmp_path):
    rows = make_capture(tmp_path, GRID, pixel, kind="exr")
    rows[5]["hidden"] = "view"
    write_csv(tmp_path / "capture.csv", rows)
    table, rep = measure(tmp_path)
    assert rep.n_hidden == 1 and (~table.measured).sum() == 1


def test_missing_photograph_stops_without_output(tmp_path):
    rows = make_capture(tmp_path / "cap", GRID, pixel, kind="png16")
    (tmp_path / "cap" / rows[7]["file"]).unlink()
    out = tmp_path / "out.h5"
    with pytest.raises(FileNotFoundError, match=rows[7]["file"].replace("/", ".")):
        measure(tmp_path / "cap", out)
    assert not out.exists()
    table, rep = measure(tmp_path / "cap", out, skip_bad=True)
    assert out.exists() and rep.n_skipped_samples == 1 and rep.skipped_files[0][0] == rows[7]["file"]
    assert (~table.measured).sum() == 1


def test_corrupt_photograph_stops_without_output(tmp_path):
    rows = make_capture(tmp_path / "cap", GRID, pixel, kind="png16")
    bad = tmp_path / "cap" / rows[11]["file"]
    bad.write_bytes(bad.read_bytes()[:60])
    out = tmp_path / "out.h5"
    with pytest.raises(ImageError, match=rows[11]["file"].replace("/", ".")):
        measure(tmp_path / "cap", out)
    assert not out.exists()
    table, rep = measure(tmp_path / "cap", out, skip_bad=True)
    assert [f for f, _ in rep.skipped_files] == [rows[11]["file"]]
    assert not table.measured.ravel()[11]


def _same_tables(a, b):
    assert a == b  # values, mask, fill source, std, attrs: exactly equal
    np.testing.assert_array_equal(a.values, b.values)


def test_interrupt_and_resume_is_bit_identical(tmp_path):
    make_capture(tmp_path / "cap", GRID, pixel, kind="png16", white=WHITE)
    ref, _ = measure(tmp_path / "cap", tmp_path / "ref.h5")
    out = tmp_path / "out.h5"
    with pytest.raises(MeasurementInterrupted):
        measure(tmp_path / "cap", out, batch_size=8, _interrupt_after=20)
    assert not out.exists() and checkpoint_path(out).is_dir()
    table, rep = measure(tmp_path / "cap", out, batch_size=8)
    assert rep.n_images_resumed == 24
    assert out.exists() and not checkpoint_path(out).exists()
    _same_tables(table, ref)
    _same_tables(cdbrdf.load(out), cdbrdf.load(tmp_path / "ref.h5"))


def test_checkpoint_of_other_options_is_discarded(tmp_path):
    make_capture(tmp_path / "cap", GRID, pixel, kind="png16")
    out = tmp_path / "out.h5"
    with pytest.raises(MeasurementInterrupted):
        measure(tmp_path / "cap", out, batch_size=8, _interrupt_after=8)
    table, rep = measure(tmp_path / "cap", out, patch=5)
    assert rep.n_images_resumed == 0


def test_changed_image_is_read_again(tmp_path):
    rows = make_capture(tmp_path / "cap", GRID, pixel, kind="exr")
    out = tmp_path / "out.h5"
    with pytest.raises(MeasurementInterrupted):
        measure(tmp_path / "cap", out, batch_size=8, _interrupt_after=8)
    write_image(tmp_path / "cap" / rows[0]["file"], np.full((15, 15, 3), 0.01), "exr")
    table, rep = measure(tmp_path / "cap", out)
    assert rep.n_images_resumed == 7
    assert table.values[0, 0, 0, 0, 0, 0] == pytest.approx(0.01, rel=1e-6)


def test_local_cluster_same_table(tmp_path):
    distributed = pytest.importorskip("distributed")
    make_capture(tmp_path, GRID, pixel, kind="png16", white=WHITE)
    ref, _ = measure(tmp_path)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster:
        table, _ = measure(tmp_path, scheduler=cluster.scheduler_address)
        with distributed.Client(cluster) as client:
            table2, _ = measure(tmp_path, scheduler=client)
    _same_tables(table, ref)
    _same_tables(table2, ref)


def test_local_schedulers_same_table(tmp_path):
    make_capture(tmp_path, GRID, pixel, kind="png16")
    ref, _ = measure(tmp_path, scheduler="synchronous")
    t, _ = measure(tmp_path, scheduler="threads", num_workers=2)
    _same_tables(t, ref)
    with pytest.raises(ValueError, match="neither a scheduler address"):
        measure(tmp_path, scheduler="bogus")


def test_centre_columns(tmp_path):
    rows = []
    img = np.full((20, 30, 3), 0.8)
    img[2:5, 3:6] = 0.25
    write_image(tmp_path / "a.exr", img, "exr")
    rows.append(dict(file="a.exr", kappa=0, theta_v=0, phi_v=0, theta_l=0, phi_l=0, cx=4, cy=3))
    write_csv(tmp_path / "capture.csv", rows)
    table, _ = measure(tmp_path, patch=3)
    assert table.values.ravel()[0] == pytest.approx(0.25)


def test_grey_images_one_channel(tmp_path):
    from cdbrdf.measure.images import write_png

    write_png(tmp_path / "g.png", np.full((9, 9), 40000, np.uint16))
    write_csv(tmp_path / "capture.csv", [dict(file="g.png", kappa=0, theta_v=0, phi_v=0, theta_l=0, phi_l=0)])
    table, _ = measure(tmp_path, linear=True)
    assert table.shape[-1] == 1 and table.values.ravel()[0] == pytest.approx(40000 / 65535)


def test_extra_columns_kept_as_provenance(tmp_path):
    rows = make_capture(tmp_path, GRID, pixel, kind="exr")
    for r in rows:
        r["operator"] = "ak"
    write_csv(tmp_path / "capture.csv", rows)
    table, _ = measure(tmp_path)
    prov = table.attrs["provenance"]
    assert prov["extra_columns"] == {"operator": ["ak"]} and prov["method"] == "measured"


@pytest.mark.parametrize("edit,msg", [
    (lambda r: r.pop("theta_v"), "missing column"),
    (lambda r: r.update(kind="flat"), "kind 'flat' is not one of sample, white, dark"),
    (lambda r: r.update(theta_l="abc"), "line 2: column 'theta_l': 'abc' is not a number"),
    (lambda r: r.update(theta_v=95), "outside"),
    (lambda r: r.update(file="x.jpg"), "unsupported extension"),
    (lambda r: r.update(exposure=-1), "exposure must be positive"),
])
def test_capture_table_errors(tmp_path, edit, msg):
    r = dict(file="a.png", kappa=0, theta_v=0, phi_v=0, theta_l=0, phi_l=0)
    edit(r)
    write_csv(tmp_path / "capture.csv", [r])
    with pytest.raises(CaptureError, match=msg):
        measure(tmp_path)


def test_uneven_azimuths_are_refused(tmp_path):
    rows = [dict(file=f"{p}.png", kappa=0, theta_v=30, phi_v=p, theta_l=0, phi_l=0) for p in (0, 90, 200)]
    write_csv(tmp_path / "capture.csv", rows)
    with pytest.raises(CaptureError, match="do not form a table grid"):
        read_capture(tmp_path)


def test_cli_measure(tmp_path, capsys):
    rows = make_capture(tmp_path / "cap", GRID, pixel, kind="png16", white=WHITE,
                        settings={"white_albedo": ALBEDO})
    out = tmp_path / "m.h5"
    assert main(["measure", str(tmp_path / "cap"), "-o", str(out)]) == 0
    text = capsys.readouterr().out
    assert "measured" in text and "filled" in text
    t = cdbrdf.load(out)
    np.testing.assert_allclose(t.values, truth(), rtol=3e-4)
    assert main(["measure", str(tmp_path / "cap"), "-o", str(out)]) == 2
    assert "already exists" in capsys.readouterr().err
    (tmp_path / "cap" / rows[3]["file"]).unlink()
    out2 = tmp_path / "m2.h5"
    assert main(["-q", "measure", str(tmp_path / "cap"), "-o", str(out2)]) == 2
    err = capsys.readouterr().err
    assert rows[3]["file"] in err and not out2.exists()
    assert main(["-q", "measure", str(tmp_path / "cap"), "-o", str(out2), "--skip-bad"]) == 0
    assert cdbrdf.load(out2).measured.sum() == t.measured.size - 1


def test_killed_process_resumes(tmp_path):
    """SIGKILL a measuring process after its first checkpointed batch; the rerun resumes."""
    import os
    import signal
    import subprocess
    import sys
    import time

    make_capture(tmp_path / "cap", GRID, pixel, kind="png16", white=WHITE)
    ref, _ = measure(tmp_path / "cap")
    out = tmp_path / "out.h5"
    script = (
        "import sys, time\n"
        "from cdbrdf.measure import measure\n"
        "measure(sys.argv[1], sys.argv[2], batch_size=6, num_workers=1,\n"
        "        progress=lambda d, t: time.sleep(0.3))\n"
    )
    env = dict(os.environ)
    src = str(__import__("pathlib").Path(cdbrdf.__file__).parents[1])
    env["PYTHONPATH"] = src + os.pathsep + env.get("PYTHONPATH", "")
    proc = subprocess.Popen([sys.executable, "-c", script, str(tmp_path / "cap"), str(out)], env=env)
    ck = checkpoint_path(out)
    deadline = time.monotonic() + 60
    while not list(ck.glob("batch-*.npz")) and time.monotonic() < deadline and proc.poll() is None:
        time.sleep(0.02)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    assert not out.exists()
    done = len(list(ck.glob("batch-*.npz")))
    assert done >= 1
    table, rep = measure(tmp_path / "cap", out)
    assert rep.n_images_resumed >= 6
    _same_tables(table, ref)
