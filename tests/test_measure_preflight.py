"""Checks before any work (cdbrdf.measure.preflight): unusable photographs, outputs that would replace inputs."""

from __future__ import annotations

import numpy as np
import pytest

from cdbrdf.cli import main
from cdbrdf.images import ImageError
from cdbrdf.measure import CaptureError, measure
from cdbrdf.measure.checkpoint import checkpoint_path
from cdbrdf.measure.preflight import UnusablePhotographs

from .measure_helpers import (
    ALBEDO,
    GRID,
    SMALL,
    WHITE,
    make_capture,
    pixel,
    same_tables,
    write_image,
)


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


# --------------------------------------------------------------------------- photographs that cannot be used
def _spoil(folder, rows):
    """Seven kinds of unusable photographs; returns {file: expected problem}."""
    import os

    from cdbrdf.images import write_png

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
    monkeypatch.setattr(pipeline, "read_patch_status", lambda *a: reads.append(a))
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
    from cdbrdf.measure import preflight as pipeline  # read_patch_status reads the patch (one owner)

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
    same_tables(table, ref)
