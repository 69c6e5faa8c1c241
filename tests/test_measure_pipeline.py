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
