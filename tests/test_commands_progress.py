"""The command line's one progress adapter (cdbrdf.commands._progress)."""

from __future__ import annotations

from cdbrdf.commands._progress import ProgressBars


def test_bars_follow_the_callbacks_one_bar_per_stage(capsys):
    with ProgressBars(unit="img", leave=True, mininterval=0.0) as bars:
        cb = bars.callback("measure")
        cb(0, 4)
        cb(4, 4)
        bars.update("render", 1, 2)  # a new stage closes the first bar
        bars.update("render", 2, 2)
    err = capsys.readouterr().err
    assert "measure" in err and "4/4" in err
    assert "render" in err and "2/2" in err


def test_total_can_grow_while_running(capsys):
    with ProgressBars(mininterval=0.0, leave=True) as bars:
        bars.update("x", 1, 0)  # the library may not know the total at first
        bars.update("x", 3, 5)
    assert "3/5" in capsys.readouterr().err


def test_quiet_draws_nothing(capsys):
    with ProgressBars(quiet=True) as bars:
        bars.callback("measure")(1, 2)
        bars.update("other", 2, 2)
    assert capsys.readouterr().err == ""
