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
from cdbrdf.measure.capture import read_capture
from cdbrdf.measure.checkpoint import checkpoint_path
from cdbrdf.measure.preflight import UnusablePhotographs

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
    with pytest.raises(UnusablePhotographs, match=rows[7]["file"].replace("/", ".") + r".*missing"):
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
    (lambda r: r.update(exposure=1e-320), r"exposure 9.99989e-321 is outside \[1e-9, 1e9\]"),
])
def test_capture_table_errors(tmp_path, edit, msg):
    r = dict(file="a.png", kappa=0, theta_v=0, phi_v=0, theta_l=0, phi_l=0)
    edit(r)
    write_csv(tmp_path / "capture.csv", [r])
    with pytest.raises(CaptureError, match=msg):
        measure(tmp_path)


def test_curvature_without_a_measured_sample_names_the_capture(tmp_path):
    rows = make_capture(tmp_path, SMALL, pixel, kind="exr", size=9)
    for r in rows:
        if r["kappa"] == 0.2:
            r["hidden"] = "view"
    write_csv(tmp_path / "capture.csv", rows)
    with pytest.raises(CaptureError, match=f"{tmp_path}: kappa = 0.2 1/mm: no sample was measured"):
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


# --------------------------------------------------------------------------- capture table hardening
SMALL = Grid(kappa=[0.0, 0.2], theta_l=[0.0, 40.0], phi_l=[0.0, 180.0],
             theta_v=[0.0, 30.0, 60.0], phi_v=[0.0, 90.0, 180.0, 270.0])


def _stray(rows, **edit):
    r = dict(rows[0], **edit)
    rows.insert(5, r)
    return rows


@pytest.mark.parametrize("edit,axis", [
    (dict(theta_v=31), "theta_v = 31"),
    (dict(kappa=0.25), "kappa = 0.25"),
    (dict(theta_l=41), "theta_l = 41"),
    (dict(phi_v=45), "phi_v = 45"),  # would also make the azimuths uneven
])
def test_stray_row_that_grows_the_grid_is_refused(tmp_path, edit, axis):
    rows = make_capture(tmp_path, SMALL, pixel, kind="exr", size=9)
    write_csv(tmp_path / "capture.csv", _stray(rows, **edit))
    with pytest.raises(CaptureError, match=rf"capture.csv: line 7: {axis} is used by 1 sample condition"):
        read_capture(tmp_path)


def test_explicit_grid_in_stand_file(tmp_path):
    rows = make_capture(tmp_path, SMALL, pixel, kind="exr", size=9)
    write_csv(tmp_path / "capture.csv", _stray(rows, theta_v=31))
    axes = {n: list(getattr(SMALL, n)) for n in ("kappa", "theta_l", "phi_l", "theta_v", "phi_v")}
    axes["theta_v"] = [0, 30, 31, 60]
    (tmp_path / "stands.json").write_text(__import__("json").dumps({"grid": axes}))
    cap = read_capture(tmp_path)  # listed: accepted
    assert list(cap.grid.theta_v) == [0, 30, 31, 60]
    axes["theta_v"] = [0, 30, 60, 75]  # 31 not listed; 75 listed but not photographed
    (tmp_path / "stands.json").write_text(__import__("json").dumps({"grid": axes}))
    with pytest.raises(CaptureError, match="line 7: theta_v = 31 is not on the grid of stands.json"):
        read_capture(tmp_path)
    write_csv(tmp_path / "capture.csv", rows[:5] + rows[6:])
    table, rep = measure(tmp_path)
    assert list(table.grid.theta_v) == [0, 30, 60, 75] and rep.n_not_photographed == table.measured.size // 4
    (tmp_path / "stands.json").write_text('{"grid": {"kappa": [0]}}')
    with pytest.raises(CaptureError, match="grid: expected an object with the lists"):
        read_capture(tmp_path)


@pytest.mark.parametrize("doc,msg", [
    ({"stands": [{"kappa": 0.0}, {"kappa": 0.2}], "pixel_mm": 1e308}, r"pixel_mm: expected a number in \[0, 10\]"),
    ({"stands": [{"kappa": 0.0}, {"kappa": 0.2}], "pixel_mm": -0.01}, "pixel_mm"),
    ({"stands": [{"kappa": 0.0}, {"kappa": 0.2}], "pixel_mm": True}, "pixel_mm"),
    ({"stands": [{"kappa": 0.0}, {"kappa": 0.2, "face_width_mm": 0}]}, "stand 1: .*must be positive"),
    ({"stands": [{"kappa": 0.0}, {"kappa": -0.2}]}, "no stand for kappa 0.2"),
    ({"white_albedo": 0}, r"white_albedo: expected a number in \(0, 1.5\]"),
    ({"white_albedo": "high"}, "white_albedo"),
    ({"encoding": "gamma"}, "encoding: 'gamma' is not one of"),
    ({"material": {"a": 1}}, "material: expected a printable name"),
])
def test_stand_file_values_are_checked(tmp_path, doc, msg):
    make_capture(tmp_path, SMALL, pixel, kind="exr", size=9)
    (tmp_path / "stands.json").write_text(__import__("json").dumps(doc))
    with pytest.raises(CaptureError, match=msg) as exc:
        measure(tmp_path)
    assert "stands.json" in str(exc.value) and "\n" not in str(exc.value)


def test_stand_file_deeply_nested_or_huge(tmp_path, monkeypatch):
    from cdbrdf.errors import LimitError

    make_capture(tmp_path, SMALL, pixel, kind="exr", size=9)
    (tmp_path / "stands.json").write_text('{"stands": ' + "[" * 100_000 + "]" * 100_000 + "}")
    with pytest.raises(CaptureError, match="stands.json: not valid JSON .nested too deeply."):
        read_capture(tmp_path)
    monkeypatch.setenv("CDBRDF_MAX_JSON_BYTES", "1000")
    with pytest.raises(LimitError, match="stands.json.*CDBRDF_MAX_JSON_BYTES"):
        read_capture(tmp_path)


def test_capture_rows_limit(tmp_path, monkeypatch):
    from cdbrdf.errors import LimitError

    make_capture(tmp_path, SMALL, pixel, kind="exr", size=9)
    read_capture(tmp_path)
    monkeypatch.setenv("CDBRDF_MAX_CAPTURE_ROWS", "50")
    with pytest.raises(LimitError, match=r"capture.csv: a table of: 96 rows exceed the limit of 50"):
        read_capture(tmp_path)


@pytest.mark.parametrize("mangle,msg", [
    (lambda b: b.replace(b"s/0_0_0_0_1", b"s/0_0\x00_0_0_1"), "line 3: NUL byte"),
    (lambda b: b.replace(b"s/0_0_0_0_2", b"s/\xe90_0_0_0_2"), r"line 4: not UTF-8 text \(byte 0xe9\)"),
    (lambda b: b.decode().encode("utf-16"), "UTF-16 text"),
    (lambda b: b.replace(b"s/0_0_0_0_1.exr", b'"s/0_0_0_0_1.exr' + b"x" * 200_000), "line 3: not valid CSV"),
    (lambda b: b.replace(b"s/0_0_0_0_1.exr", b"s/0_0_0_0_1\x07.exr"), "line 3: file .* contains control"),
    (lambda b: b.replace(b"s/0_0_0_0_1.exr,0.0,", b"s/0_0_0_0_1.exr,1e400,"), "line 3: column 'kappa'.* not finite"),
    (lambda b: b.replace(b"s/0_0_0_0_1.exr,0.0,", b"s/0_0_0_0_1.exr,0.0,,,"), "line 3: more fields"),
])
def test_capture_table_bytes(tmp_path, mangle, msg):
    make_capture(tmp_path, SMALL, pixel, kind="exr", size=9)
    p = tmp_path / "capture.csv"
    p.write_bytes(mangle(p.read_bytes()))
    with pytest.raises(CaptureError, match=msg) as exc:
        read_capture(tmp_path)
    assert str(p) in str(exc.value) and "\n" not in str(exc.value)


def test_capture_table_utf8_bom_and_blank_lines(tmp_path):
    make_capture(tmp_path, SMALL, pixel, kind="exr", size=9)
    p = tmp_path / "capture.csv"
    ref = read_capture(tmp_path)
    lines = p.read_bytes().split(b"\n")
    p.write_bytes(b"\xef\xbb\xbf" + b"\n".join(lines[:3] + [b""] + lines[3:]))
    cap = read_capture(tmp_path)
    assert cap.grid == ref.grid and [r.file for r in cap.rows] == [r.file for r in ref.rows]
    assert cap.rows[2].line == ref.rows[2].line + 1  # the physical line, blank line counted


# --------------------------------------------------------------------------- outputs that are inputs
def _files(folder):
    return {p: p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


@pytest.mark.parametrize("target", ["capture.csv", "stands.json", "PHOTO", "WHITE", "DARK"])
def test_output_that_is_an_input_is_refused(tmp_path, target):
    rows = make_capture(tmp_path / "cap", SMALL, pixel, kind="exr", size=9, white=WHITE,
                        settings={"white_albedo": ALBEDO},
                        extra_rows=[dict(file="d.exr", kappa="", theta_v="", phi_v="", theta_l="",
                                         phi_l="", kind="dark")])
    write_image(tmp_path / "cap" / "d.exr", np.zeros((9, 9, 3)), "exr")
    name = {"PHOTO": rows[3]["file"], "WHITE": rows[-2]["file"], "DARK": "d.exr"}.get(target, target)
    before = _files(tmp_path / "cap")
    out = tmp_path / "cap" / name
    with pytest.raises(CaptureError, match="must not replace an input"):
        measure(tmp_path / "cap", out, overwrite=True)
    (tmp_path / "link.h5").symlink_to(out)
    with pytest.raises(CaptureError, match="must not replace an input"):
        measure(tmp_path / "cap", tmp_path / "link.h5", overwrite=True)
    (tmp_path / "hard.h5").hardlink_to(out)
    with pytest.raises(CaptureError, match="must not replace an input"):
        measure(tmp_path / "cap", tmp_path / "hard.h5", overwrite=True)
    assert _files(tmp_path / "cap") == before
    assert main(["-q", "measure", str(tmp_path / "cap"), "-o", str(out), "--force"]) == 2
    assert _files(tmp_path / "cap") == before


def test_checkpoint_folder_holding_the_capture_is_refused(tmp_path, capsys):
    make_capture(tmp_path / "x.ckpt", SMALL, pixel, kind="exr", size=9)
    with pytest.raises(CaptureError, match="x.ckpt: holds .*capture.csv"):
        measure(tmp_path / "x.ckpt", tmp_path / "x")
    assert (tmp_path / "x.ckpt" / "capture.csv").is_file()


def test_cli_force_replaces_an_earlier_output(tmp_path, capsys):
    make_capture(tmp_path / "cap", SMALL, pixel, kind="exr", size=9)
    out = tmp_path / "m.h5"
    out.write_bytes(b"old")
    assert main(["-q", "measure", str(tmp_path / "cap"), "-o", str(out)]) == 2
    assert "already exists" in capsys.readouterr().err and out.read_bytes() == b"old"
    assert main(["-q", "measure", str(tmp_path / "cap"), "-o", str(out), "--force"]) == 0
    assert cdbrdf.load(out).measured.all()


# --------------------------------------------------------------------------- checkpoint folders
def _interrupted(tmp_path, after=8):
    make_capture(tmp_path / "cap", GRID, pixel, kind="png16", white=WHITE)
    out = tmp_path / "out.h5"
    with pytest.raises(MeasurementInterrupted):
        measure(tmp_path / "cap", out, batch_size=8, _interrupt_after=after)
    return out, checkpoint_path(out)


def test_foreign_checkpoint_folder_is_never_deleted(tmp_path, capsys):
    make_capture(tmp_path / "cap", SMALL, pixel, kind="exr", size=9)
    out = tmp_path / "out.h5"
    ck = checkpoint_path(out)
    ck.mkdir()
    (ck / "thesis.tex").write_text("years of work")
    with pytest.raises(FileExistsError, match=r"out.h5.ckpt: exists and is not a checkpoint made by cdbrdf"):
        measure(tmp_path / "cap", out)
    assert (ck / "thesis.tex").read_text() == "years of work" and not out.exists()
    assert main(["-q", "measure", str(tmp_path / "cap"), "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "out.h5.ckpt" in err
    assert (ck / "thesis.tex").read_text() == "years of work"
    # a file of that name is not touched either
    (ck / "thesis.tex").unlink()
    ck.rmdir()
    ck.write_text("notes")
    with pytest.raises(FileExistsError, match="not a checkpoint"):
        measure(tmp_path / "cap", out)
    assert ck.read_text() == "notes"


def test_checkpoint_is_marked_and_removed(tmp_path):
    from cdbrdf.fsutil import is_owned

    out, ck = _interrupted(tmp_path)
    assert is_owned(ck, "checkpoint")
    measure(tmp_path / "cap", out)
    assert not ck.exists() and not [p for p in tmp_path.iterdir() if p.name.startswith(".")]


def test_checkpoint_of_the_previous_version_is_adopted(tmp_path):
    """Checkpoints written before folders carried the owner mark: key.json + batch-*.npz."""
    import json

    from cdbrdf.fsutil import OWNER_MARK

    out, ck = _interrupted(tmp_path, after=16)
    ref, _ = measure(tmp_path / "cap")
    cap = read_capture(tmp_path / "cap")
    (ck / OWNER_MARK).unlink()
    # the previous version's key also hashed skip_bad
    doc = {"capture": cap.digest, "patch": 7, "linear": False, "skip_bad": False, "needed": len(cap.rows)}
    key = __import__("hashlib").sha256(json.dumps(doc, sort_keys=True).encode()).hexdigest()
    (ck / "key.json").write_text(json.dumps({"key": key, "version": 1}))
    (ck / ".batch-abc123.npz").write_bytes(b"half")  # a temporary of the previous version
    table, rep = measure(tmp_path / "cap", out)
    assert rep.n_images_resumed == 16 and not ck.exists()
    _same_tables(table, ref)


# --------------------------------------------------------------------------- damaged batches
def _truncate(f):
    f.write_bytes(f.read_bytes()[:100])


def _garbage(f):
    f.write_bytes(b"\x00" * 500)


def _empty(f):
    f.write_bytes(b"")


def _missing_key(f):
    with np.load(f) as z:
        d = dict(z)
    d.pop("status")
    np.savez(f, **d)


def _wrong_shape(f):
    with np.load(f) as z:
        d = dict(z)
    k = next(k for k in d if k.startswith("v"))
    d[k] = d[k][:2]
    np.savez(f, **d)


def _bad_status(f):
    with np.load(f) as z:
        d = dict(z)
    d["status"] = d["status"][:-1]
    np.savez(f, **d)


def _object_array(f):
    with np.load(f) as z:
        d = dict(z)
    d["rows"] = np.array([object()] * len(d["rows"]), dtype=object)
    np.savez(f, **d)


@pytest.mark.parametrize("damage", [_truncate, _garbage, _empty, _missing_key, _wrong_shape, _bad_status,
                                    _object_array])
def test_damaged_checkpoint_batch_is_read_again(tmp_path, caplog, damage):
    out, ck = _interrupted(tmp_path, after=16)
    ref, _ = measure(tmp_path / "cap")
    batches = sorted(ck.glob("batch-*.npz"))
    assert len(batches) == 2
    damage(batches[1])
    with caplog.at_level("WARNING"):
        table, rep = measure(tmp_path / "cap", out, batch_size=8)
    assert rep.n_images_resumed == 8
    assert any("unreadable checkpoint batch ignored" in r.getMessage() and batches[1].name in r.getMessage()
               for r in caplog.records)
    _same_tables(table, ref)


# --------------------------------------------------------------------------- SIGKILL leftovers
def _run_killed(tmp_path, sabotage, out, batch_size=8):
    """Run measure in a child process that SIGKILLs itself where ``sabotage`` says; returns its status."""
    import os
    import subprocess
    import sys

    script = (
        "import os, signal, sys, shutil\n"
        "import numpy as np\n"
        "from cdbrdf.measure import measure\n"
        "def die():\n"
        "    os.kill(os.getpid(), signal.SIGKILL)\n"
        + sabotage +
        f"measure(sys.argv[1], sys.argv[2], batch_size={batch_size}, num_workers=1, scheduler='synchronous')\n"
    )
    env = dict(os.environ)
    src = str(__import__("pathlib").Path(cdbrdf.__file__).parents[1])
    env["PYTHONPATH"] = src + os.pathsep + env.get("PYTHONPATH", "")
    return subprocess.run([sys.executable, "-c", script, str(tmp_path / "cap"), str(out)], env=env,
                          timeout=120).returncode


def _dotfiles(folder):
    return sorted(p.name for p in folder.iterdir() if p.name.startswith("."))


def test_killed_while_saving_a_batch_leaves_nothing_behind(tmp_path):
    import signal

    make_capture(tmp_path / "cap", GRID, pixel, kind="png16", white=WHITE)
    ref, _ = measure(tmp_path / "cap")
    out = tmp_path / "out.h5"
    ck = checkpoint_path(out)
    sabotage = (
        "real = np.savez\n"
        "calls = []\n"
        "def savez(fh, **kw):\n"
        "    calls.append(1)\n"
        "    if len(calls) == 2:\n"
        "        fh.write(b'PK half a batch'); fh.flush(); die()\n"
        "    real(fh, **kw)\n"
        "np.savez = savez\n"
    )
    assert _run_killed(tmp_path, sabotage, out) == -signal.SIGKILL
    temps = [n for n in _dotfiles(ck) if n.endswith(".tmp")]
    assert len(temps) == 1 and temps[0].startswith(".batch-00000008.npz.")
    with pytest.raises(MeasurementInterrupted):
        measure(tmp_path / "cap", out, batch_size=8, _interrupt_after=8)
    assert _dotfiles(ck) == [".cdbrdf-owned"]  # the dead run's temporary is swept
    table, rep = measure(tmp_path / "cap", out, batch_size=8)
    assert rep.n_images_resumed == 16
    _same_tables(table, ref)
    assert _dotfiles(tmp_path) == []


def test_killed_while_writing_the_output_leaves_nothing_behind(tmp_path):
    import signal

    make_capture(tmp_path / "cap", GRID, pixel, kind="png16", white=WHITE)
    out = tmp_path / "out.h5"
    sabotage = (
        "real = os.fsync\n"
        "def fsync(fd):\n"
        "    if os.readlink(f'/proc/self/fd/{fd}').endswith('.tmp') and '.out.h5.' in os.readlink(f'/proc/self/fd/{fd}'):\n"
        "        die()\n"
        "    real(fd)\n"
        "os.fsync = fsync\n"
    )
    if not __import__("os").path.exists("/proc/self/fd"):
        pytest.skip("needs /proc")
    assert _run_killed(tmp_path, sabotage, out) == -signal.SIGKILL
    assert not out.exists() and any(n.startswith(".out.h5.") for n in _dotfiles(tmp_path))
    table, rep = measure(tmp_path / "cap", out)
    assert rep.n_images_resumed == 148 and out.exists()
    assert _dotfiles(tmp_path) == []


def test_killed_while_removing_the_checkpoint(tmp_path):
    """remove_owned renames first: the rerun is not blocked and the half-removed folder is swept."""
    import signal

    from cdbrdf.fsutil import OWNER_MARK

    make_capture(tmp_path / "cap", GRID, pixel, kind="png16", white=WHITE)
    out = tmp_path / "out.h5"
    sabotage = (
        "def rmtree(p, *a, **k):\n"
        f"    os.unlink(os.path.join(p, {OWNER_MARK!r}))\n"
        "    os.unlink(os.path.join(p, 'key.json'))\n"
        "    die()\n"
        "shutil.rmtree = rmtree\n"
    )
    assert _run_killed(tmp_path, sabotage, out) == -signal.SIGKILL
    left = [n for n in _dotfiles(tmp_path) if n.endswith(".old")]
    assert out.exists() and len(left) == 1 and not (tmp_path / left[0] / OWNER_MARK).exists()
    out.unlink()
    table, rep = measure(tmp_path / "cap", out)
    assert out.exists() and _dotfiles(tmp_path) == []


def test_killed_while_removing_a_checkpoint_of_the_previous_version(tmp_path):
    """The previous version deleted the folder in place: a half-deleted one is recognised and replaced."""
    out, ck = _interrupted(tmp_path, after=16)
    from cdbrdf.fsutil import OWNER_MARK

    (ck / OWNER_MARK).unlink()
    (ck / "key.json").unlink()
    table, rep = measure(tmp_path / "cap", out)
    assert rep.n_images_resumed == 0 and out.exists() and not ck.exists()


# --------------------------------------------------------------------------- photographs that cannot be used
def _spoil(folder, rows):
    """Seven kinds of unusable photographs; returns {file: expected problem}."""
    import os

    from cdbrdf.measure.images import write_png

    f = lambda i: folder / rows[i]["file"]  # noqa: E731
    f(1).unlink()
    f(2).unlink()
    f(2).mkdir()
    f(3).unlink()
    f(3).symlink_to(f(3).name)  # a link to itself: a loop
    head = bytearray(f(4).read_bytes())
    head[20] ^= 0xFF  # the height in IHDR: CRC mismatch
    f(4).write_bytes(bytes(head))
    write_png(f(5), np.zeros((40, 40, 3), np.uint16))  # another size
    f(6).unlink()
    os.mkfifo(f(6))
    write_png(f(7), np.zeros((3, 3, 3), np.uint16))  # too small for the patch (and another size)
    return {rows[1]["file"]: "missing", rows[2]["file"]: "not a regular file .a folder.",
            rows[3]["file"]: "cannot be opened .Too many levels of symbolic links.",
            rows[4]["file"]: "corrupt PNG header .CRC mismatch", rows[5]["file"]: "40 x 40 pixels where",
            rows[6]["file"]: "not a regular file .a FIFO.", rows[7]["file"]: "the 7 x 7 patch does not fit"}


def test_preflight_lists_every_unusable_photograph_before_any_work(tmp_path, capsys, monkeypatch):
    import re

    from cdbrdf.measure import pipeline

    rows = make_capture(tmp_path / "cap", GRID, pixel, kind="png16", white=WHITE)
    bad = _spoil(tmp_path / "cap", rows)
    out = tmp_path / "out.h5"
    reads = []
    monkeypatch.setattr(pipeline, "_read_task", lambda *a: reads.append(a))
    with pytest.raises(UnusablePhotographs) as exc:
        measure(tmp_path / "cap", out)
    msg = str(exc.value)
    assert "\n" not in msg and msg.startswith("7 photographs cannot be used (first: ")
    assert rows[1]["file"] in msg and "all are listed in " + str(out) + ".bad.txt" in msg
    assert reads == [] and not checkpoint_path(out).exists() and not out.exists()
    listing = (tmp_path / "out.h5.bad.txt").read_text().splitlines()
    assert len(listing) == 8 and listing[0].startswith("#")
    assert [(p, line) for p, line, _ in exc.value.problems] == [
        (str((tmp_path / "cap").resolve() / rows[i]["file"]), i + 2) for i in range(1, 8)]
    for (_p, _line, why), (name, want) in zip(exc.value.problems, bad.items()):
        assert re.search(want, why), (name, why)
    for line, name in zip(listing[1:], bad):
        assert name in line
    monkeypatch.undo()
    # the command line: one line, the list in the file
    assert main(["-q", "measure", str(tmp_path / "cap"), "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "7 photographs cannot be used" in err and "out.h5.bad.txt" in err
    # --skip-bad: all seven filled and reported; the stale list is removed
    table, rep = measure(tmp_path / "cap", out, skip_bad=True)
    assert sorted(f for f, _ in rep.skipped_files) == sorted(bad)
    assert rep.n_skipped_samples == 7 and (~table.measured).sum() == 7
    assert not (tmp_path / "out.h5.bad.txt").exists()
    assert "7 file(s) skipped" in rep.summary()


def test_unreadable_photographs_found_while_decoding(tmp_path, monkeypatch):
    """Failures of the full decode (any exception type) are handled like the pre-flight's."""
    from cdbrdf.measure import pipeline

    rows = make_capture(tmp_path / "cap", GRID, pixel, kind="png16", white=WHITE)
    ref, _ = measure(tmp_path / "cap")
    victims = {rows[10]["file"]: PermissionError(13, "Permission denied"),
               rows[20]["file"]: ImageError("corrupt PNG data (invalid distance)"),
               rows[30]["file"]: RuntimeError("decoder bug"),
               rows[40]["file"]: MemoryError()}
    real = pipeline.read_patch

    def flaky(path, **kw):
        for name, exc in victims.items():
            if str(path).endswith(name):
                raise exc
        return real(path, **kw)

    monkeypatch.setattr(pipeline, "read_patch", flaky)
    out = tmp_path / "out.h5"
    with pytest.raises(UnusablePhotographs, match=r"^4 photographs cannot be used .*checkpoint") as exc:
        measure(tmp_path / "cap", out, batch_size=16, scheduler="synchronous")
    whys = [w for _, _, w in exc.value.problems]
    assert whys == ["cannot be read (Permission denied)", "corrupt PNG data (invalid distance)",
                    "cannot be decoded (RuntimeError: decoder bug)", "cannot be decoded (MemoryError)"]
    assert not out.exists() and checkpoint_path(out).is_dir()
    table, rep = measure(tmp_path / "cap", out, skip_bad=True, scheduler="synchronous")
    assert rep.n_images_resumed == 148 - 4 and sorted(f for f, _ in rep.skipped_files) == sorted(victims)
    assert (~table.measured).sum() == 4
    monkeypatch.setattr(pipeline, "read_patch", real)
    table, rep = measure(tmp_path / "cap")
    _same_tables(table, ref)
