"""The HTML report and the output folder swap."""

from __future__ import annotations

import pytest

from cdbrdf.report import Report, output_folder


def _png(path):
    import matplotlib.figure

    fig = matplotlib.figure.Figure(figsize=(1, 1))
    fig.add_subplot().plot([0, 1])
    fig.savefig(path)


def test_report_links_figures_relatively(tmp_path):
    r = Report("Title <x>", lead="lead text")
    s = r.section("Mosaics", "some text")
    s.figure("a.png", "Figure A", "what to look at")
    s.table("numbers", ["stand", "measured"], [["-0.22", 5], ["0", 1.23456789]])
    s.detail("provenance", {"k": 1})
    _png(tmp_path / "a.png")
    page = r.write(tmp_path).read_text()
    assert '<img src="a.png"' in page
    assert "Title &lt;x&gt;" in page
    assert "<td>1.235</td>" in page
    assert "http" not in page  # no network reference


def test_report_refuses_missing_figures(tmp_path):
    r = Report("t")
    r.section("s").figure("missing.png", "m", "c")
    with pytest.raises(FileNotFoundError, match="missing.png"):
        r.write(tmp_path)


def test_output_folder_replaces_whole_previous_output(tmp_path):
    dest = tmp_path / "out"
    with output_folder(dest) as d:
        (d / "old.txt").write_text("1")
    assert (dest / "old.txt").exists()
    with output_folder(dest) as d:
        (d / "new.txt").write_text("2")
    assert (dest / "new.txt").exists() and not (dest / "old.txt").exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


def test_output_folder_keeps_old_results_on_failure(tmp_path):
    dest = tmp_path / "out"
    with output_folder(dest) as d:
        (d / "old.txt").write_text("1")
    with pytest.raises(RuntimeError):
        with output_folder(dest) as d:
            (d / "new.txt").write_text("2")
            raise RuntimeError("boom")
    assert (dest / "old.txt").exists() and not (dest / "new.txt").exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


def test_output_folder_refuses_foreign_folder(tmp_path):
    dest = tmp_path / "mine"
    dest.mkdir()
    (dest / "thesis.tex").write_text("precious")
    with pytest.raises(FileExistsError, match="was not written by cdbrdf"):
        with output_folder(dest):
            pass
    assert (dest / "thesis.tex").read_text() == "precious"


def test_output_folder_sweeps_a_killed_runs_partial_folder(tmp_path):
    """A partial folder (with the demo's work folder inside) of a dead process is removed by the next run."""
    import os
    import subprocess
    import sys

    from cdbrdf.fsutil import mark_owned, temp_sibling

    out = tmp_path / "out"
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                          capture_output=True, text=True, check=True)
    pid = int(dead.stdout)
    stale = temp_sibling(out, "partial")
    stale = stale.with_name(stale.name.replace(f".{os.getpid()}.", f".{pid}.", 1))
    (stale / ".work" / "capture-denim").mkdir(parents=True)
    mark_owned(stale, "output")
    (stale / ".work" / "capture-denim" / "photo.png").write_bytes(b"x")
    mine = temp_sibling(out, "partial")  # a live run's (this process's) partial is left alone
    mine.mkdir()
    mark_owned(mine, "output")
    with output_folder(out) as tmp:
        (tmp / "a.txt").write_text("new\n")
    assert not stale.exists() and mine.exists()
    assert (out / "a.txt").read_text() == "new\n"


def test_output_folder_interrupt_leaves_nothing(tmp_path):
    out = tmp_path / "out"
    with pytest.raises(KeyboardInterrupt):
        with output_folder(out) as tmp:
            (tmp / "a.txt").write_text("half\n")
            raise KeyboardInterrupt
    assert list(tmp_path.iterdir()) == []


def test_check_output_folder_refuses_up_front(tmp_path, monkeypatch):
    from cdbrdf.report import check_output_folder

    (tmp_path / "f.txt").write_text("x")
    with pytest.raises(FileExistsError, match="not a folder"):
        check_output_folder(tmp_path / "f.txt")
    with output_folder(tmp_path / "o"):
        pass
    monkeypatch.chdir(tmp_path / "o")
    with pytest.raises(FileExistsError, match="current folder"):
        check_output_folder(".")
    assert check_output_folder(tmp_path / "new") == tmp_path / "new"
