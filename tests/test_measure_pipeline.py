"""The measurement pipeline (cdbrdf.measure.pipeline): schedulers, the command line, options, on hand-made folders."""

from __future__ import annotations

import numpy as np
import pytest

import cdbrdf
from cdbrdf.cli import main
from cdbrdf.measure import measure

from .measure_helpers import (
    ALBEDO,
    GRID,
    SMALL,
    WHITE,
    make_capture,
    pixel,
    same_tables,
    truth,
    write_csv,
    write_image,
)


def test_local_cluster_same_table(tmp_path):
    import distributed
    make_capture(tmp_path, GRID, pixel, kind="png16", white=WHITE)
    ref, _ = measure(tmp_path)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster:
        table, _ = measure(tmp_path, scheduler=cluster.scheduler_address)
        with distributed.Client(cluster) as client:
            table2, _ = measure(tmp_path, scheduler=client)
    same_tables(table, ref)
    same_tables(table2, ref)


def test_local_schedulers_same_table(tmp_path):
    make_capture(tmp_path, GRID, pixel, kind="png16")
    ref, _ = measure(tmp_path, scheduler="synchronous")
    t, _ = measure(tmp_path, scheduler="threads", num_workers=2)
    same_tables(t, ref)
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
    from cdbrdf.images import write_png

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


def test_cli_force_replaces_an_earlier_output(tmp_path, capsys):
    make_capture(tmp_path / "cap", SMALL, pixel, kind="exr", size=9)
    out = tmp_path / "m.h5"
    out.write_bytes(b"old")
    assert main(["-q", "measure", str(tmp_path / "cap"), "-o", str(out)]) == 2
    assert "already exists" in capsys.readouterr().err and out.read_bytes() == b"old"
    assert main(["-q", "measure", str(tmp_path / "cap"), "-o", str(out), "--force"]) == 0
    assert cdbrdf.load(out).measured.all()


# --------------------------------------------------------------------------- refused before any work
def _no_work(tmp_path, cap, call):
    """``call(progress)`` must fail before any photograph is read and leave nothing beside the capture."""
    seen = []
    before = sorted(p.name for p in tmp_path.iterdir())
    call(lambda done, total: seen.append(done))
    assert seen == [] and sorted(p.name for p in tmp_path.iterdir()) == before


@pytest.mark.parametrize("name", ["sub", "", ".", "sub/"])
def test_output_that_is_a_folder_is_refused_before_any_work(tmp_path, monkeypatch, capsys, name):
    make_capture(tmp_path / "cap", SMALL, pixel, kind="exr", size=9)
    (tmp_path / "sub").mkdir()
    monkeypatch.chdir(tmp_path)

    def call(progress):
        with pytest.raises(IsADirectoryError):
            measure("cap", name, progress=progress)
        assert main(["-q", "measure", "cap", "-o", name, "--force"]) == 2

    _no_work(tmp_path, "cap", call)
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "give a file name" in err
    assert list((tmp_path / "sub").iterdir()) == []  # no sub/..ckpt, no sub.ckpt


def test_output_that_is_a_device_or_fifo_is_never_replaced(tmp_path, capsys):
    import os
    import stat

    make_capture(tmp_path / "cap", SMALL, pixel, kind="exr", size=9)
    fifo, dev = tmp_path / "fifo", tmp_path / "null"
    os.mkfifo(fifo)
    dev.symlink_to(os.devnull)
    for p in (fifo, dev):
        def call(progress, p=p):
            with pytest.raises(FileExistsError, match="not a regular file"):
                measure(tmp_path / "cap", p, progress=progress)
            assert main(["-q", "measure", str(tmp_path / "cap"), "-o", str(p), "--force"]) == 2

        _no_work(tmp_path, "cap", call)
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and "is not a regular file" in err
    assert stat.S_ISFIFO(fifo.lstat().st_mode) and dev.is_symlink() and stat.S_ISCHR(os.stat(os.devnull).st_mode)


BAD_OPTIONS = [
    ({"scheduler": "bogus"}, "scheduler: 'bogus' is neither"),
    ({"scheduler": 3}, "scheduler: 3 is neither"),
    ({"scheduler": ""}, "scheduler"),
    ({"patch": 0}, "patch: expected a positive whole number"),
    ({"patch": "a"}, "patch"),
    ({"patch": 7.5}, "patch"),
    ({"patch": True}, "patch"),
    ({"batch_size": 0}, "batch_size"),
    ({"num_workers": 0}, "num_workers"),
    ({"num_workers": "2"}, "num_workers"),
    ({"white_albedo": -1}, r"white_albedo: expected a number in \(0, 1.5\]"),
    ({"white_albedo": float("nan")}, "white_albedo"),
    ({"white_albedo": "0.5"}, "white_albedo"),
    ({"material": ""}, "material"),
    ({"material": 5}, "material"),
    ({"progress": 5}, "progress"),
]


@pytest.mark.parametrize("kw, match", BAD_OPTIONS, ids=[str(k) for k, _ in BAD_OPTIONS])
def test_bad_option_is_an_option_error_before_anything_is_created(tmp_path, kw, match):
    from cdbrdf.errors import OptionError

    make_capture(tmp_path / "cap", SMALL, pixel, kind="exr", size=9)
    before = sorted(p.name for p in tmp_path.iterdir())
    with pytest.raises(OptionError, match=match):
        measure(tmp_path / "cap", tmp_path / "m.h5", **kw)
    assert sorted(p.name for p in tmp_path.iterdir()) == before


def test_cli_bad_scheduler_leaves_no_checkpoint(tmp_path, capsys):
    make_capture(tmp_path / "cap", SMALL, pixel, kind="exr", size=9)
    assert main(["-q", "measure", str(tmp_path / "cap"), "-o", str(tmp_path / "m.h5"), "--scheduler", "bogus"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "scheduler: 'bogus'" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cap"]


def test_unreachable_scheduler_fails_before_the_checkpoint_is_created(tmp_path, monkeypatch):
    distributed = pytest.importorskip("distributed")
    make_capture(tmp_path / "cap", SMALL, pixel, kind="exr", size=9)

    def unreachable(address, **kw):
        assert not (tmp_path / "m.h5.ckpt").exists()  # not created before the connection
        raise OSError(f"Timed out trying to connect to {address} after 10 s")

    monkeypatch.setattr(distributed, "Client", unreachable)
    with pytest.raises(OSError, match=r"scheduler tcp://127.0.0.1:9: cannot connect \(Timed out"):
        measure(tmp_path / "cap", tmp_path / "m.h5", scheduler="tcp://127.0.0.1:9")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cap"]


def test_failure_before_the_first_batch_removes_the_new_checkpoint(tmp_path, monkeypatch):
    """A checkpoint this run created and saved nothing in is removed again; one with batches is kept."""
    from cdbrdf.measure import pipeline

    make_capture(tmp_path / "cap", GRID, pixel, kind="png16", white=WHITE)

    def broken(*a, **k):
        raise RuntimeError("worker lost")

    monkeypatch.setattr(pipeline, "_compute", broken)
    with pytest.raises(RuntimeError, match="worker lost"):
        measure(tmp_path / "cap", tmp_path / "m.h5")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cap"]
    monkeypatch.undo()
    with pytest.raises(pipeline.MeasurementInterrupted):
        measure(tmp_path / "cap", tmp_path / "m.h5", batch_size=8, _interrupt_after=8)
    assert (tmp_path / "m.h5.ckpt").is_dir()
