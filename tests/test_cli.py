"""The command line: info, version, help, user errors."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

import cdbrdf
from cdbrdf.cli import main

from .conftest import make_table


@pytest.fixture
def table_file(tmp_path, small_grid):
    measured = np.ones(small_grid.shape, bool)
    measured[0, 0, 2] = False
    t = make_table(small_grid, measured=measured, attrs={"material": "felt", "quantity": "brdf",
                                                         "provenance": {"by": "test"}})
    p = tmp_path / "t.h5"
    t.save(p)
    return p, t


def test_version(capsys):
    with pytest.raises(SystemExit) as e:
        main(["--version"])
    assert e.value.code == 0
    assert capsys.readouterr().out.strip() == f"cdbrdf {cdbrdf.__version__}"


def test_help_lists_commands(capsys):
    with pytest.raises(SystemExit):
        main(["--help"])
    out = capsys.readouterr().out
    assert "info" in out and "mosaic" in out


def test_no_command_is_an_error(capsys):
    assert main([]) == 2


def test_info(table_file, capsys):
    p, t = table_file
    assert main(["info", str(p)]) == 0
    out = capsys.readouterr().out
    assert "felt" in out and "brdf" in out
    assert "kappa" in out and "-0.2, 0, 0.05, 0.3" in out
    frac = 100 * t.measured.mean()
    assert f"{frac:.1f}% of samples" in out
    assert '"by": "test"' in out


def test_info_json(table_file, capsys):
    p, t = table_file
    assert main(["info", "--json", str(p)]) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["material"] == "felt"
    assert info["shape"] == list(t.shape)
    assert info["channels"]["G"]["max"] == pytest.approx(float(t.values[..., 1].max()))
    assert info["measured_fraction"] == pytest.approx(t.measured.mean())


def test_info_missing_file(tmp_path, capsys):
    assert main(["info", str(tmp_path / "nope.h5")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "nope.h5" in err and "no such file" in err
    assert "Traceback" not in err


def test_info_bad_file(tmp_path, capsys):
    p = tmp_path / "bad.h5"
    p.write_text("not a table")
    assert main(["info", str(p)]) == 2
    err = capsys.readouterr().err
    assert "bad.h5: not an HDF5 file" in err and err.startswith("cdbrdf info: error:")


def test_debug_shows_traceback(tmp_path):
    p = tmp_path / "bad.h5"
    p.write_text("x")
    r = subprocess.run([sys.executable, "-m", "cdbrdf.cli", "--debug", "info", str(p)],
                       capture_output=True, text=True)
    assert r.returncode != 0 and "Traceback" in r.stderr and "FormatError" in r.stderr


def test_console_script_exit_code(tmp_path):
    r = subprocess.run([sys.executable, "-m", "cdbrdf.cli", "info", str(tmp_path / "x.h5")],
                       capture_output=True, text=True)
    assert r.returncode == 2 and r.stderr.startswith("cdbrdf info: error:")


def test_negative_comma_lists_are_values():
    from cdbrdf.cli import _join_negative_lists

    assert _join_negative_lists(["plan", "--kappa", "-0.22,-0.13,0", "-o", "x"]) == [
        "plan", "--kappa=-0.22,-0.13,0", "-o", "x"]
    # space-separated lists (nargs="+") and plain negative numbers are left alone
    assert _join_negative_lists(["mosaic", "f", "--kappa", "-0.13", "0"]) == ["mosaic", "f", "--kappa", "-0.13", "0"]
    assert _join_negative_lists(["x", "-q", "-0.1,2"]) == ["x", "-q", "-0.1,2"]


def test_version_is_fast_and_imports_no_command():
    code = ("import sys, time; t = time.perf_counter(); from cdbrdf.cli import main\n"
            "try:\n    main(['--version'])\nexcept SystemExit as e:\n    assert e.code == 0\n"
            "print(time.perf_counter() - t, any(m.startswith('cdbrdf.commands.') for m in sys.modules))")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    first, seconds, imported = r.stdout.splitlines()[0], *r.stdout.split()[-2:]
    assert first == f"cdbrdf {cdbrdf.__version__}"
    assert imported == "False" and float(seconds) < 2.0


def test_no_command_prints_help(capsys):
    assert main([]) == 2
    assert "COMMAND" in capsys.readouterr().err


@pytest.mark.parametrize("argv", [["nope"], ["info"], ["info", "x.h5", "--frobnicate"], ["--bogus"]])
def test_usage_errors_are_one_line(argv, capsys):
    with pytest.raises(SystemExit) as e:
        main(argv)
    assert e.value.code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and ": error: " in err and "usage:" not in err


@pytest.mark.parametrize("exc, words", [(MemoryError(), "out of memory while running info"),
                                        (RecursionError("maximum recursion depth"), "nested too deeply")])
def test_memory_and_recursion_errors_are_one_line(monkeypatch, capsys, exc, words):
    import cdbrdf.commands.info as info

    def boom(args):
        raise exc

    monkeypatch.setattr(info, "run", boom)
    assert main(["info", "x.h5"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("cdbrdf info: error: ") and words in err
    assert err.count("\n") == 1 and "Traceback" not in err


def test_memory_error_names_the_limit(monkeypatch, capsys):
    import cdbrdf.commands.plan as plan

    def boom(args):
        raise MemoryError

    monkeypatch.setattr(plan, "run", boom)
    assert main(["plan", "-o", "x"]) == 2
    assert "CDBRDF_MAX_CAPTURE_ROWS" in capsys.readouterr().err


def test_keyboard_interrupt_exits_130(monkeypatch, capsys):
    import cdbrdf.commands.info as info

    def interrupted(args):
        raise KeyboardInterrupt

    monkeypatch.setattr(info, "run", interrupted)
    assert main(["info", "x.h5"]) == 130
    assert capsys.readouterr().err == "cdbrdf: interrupted\n"
