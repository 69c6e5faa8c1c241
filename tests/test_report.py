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
