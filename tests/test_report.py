"""The HTML report and the output folder swap."""

from __future__ import annotations

import pytest

from cdbrdf.report import Report


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
