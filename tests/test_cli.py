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


def test_version_imports_no_command_and_no_heavy_library():
    code = ("import sys; from cdbrdf.cli import main\n"
            "try:\n    main(['--version'])\nexcept SystemExit as e:\n    assert e.code == 0\n"
            "heavy = ('numba', 'mitsuba', 'drjit', 'h5py', 'matplotlib', 'dask', 'scipy', 'xarray')\n"
            "print(sorted(m for m in sys.modules if m.startswith('cdbrdf.commands.') or m.split('.')[0] in heavy))")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    first, imported = r.stdout.splitlines()
    assert first == f"cdbrdf {cdbrdf.__version__}"
    assert imported == "[]"


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


def test_memory_hints_name_limits_that_exist():
    """The command line names the limits limits.py owns (their names, not copies of their variables)."""
    from cdbrdf.cli import _MEMORY_HINTS, _memory_hint
    from cdbrdf.limits import LIMITS

    assert all(name in LIMITS for names in _MEMORY_HINTS.values() for name in names)
    assert _memory_hint("render") == "CDBRDF_MAX_RENDER_PIXELS, CDBRDF_MAX_MESH_FACES"
    assert _memory_hint("info") == ""


def test_keyboard_interrupt_exits_130(monkeypatch, capsys):
    import cdbrdf.commands.info as info

    def interrupted(args):
        raise KeyboardInterrupt

    monkeypatch.setattr(info, "run", interrupted)
    assert main(["info", "x.h5"]) == 130
    assert capsys.readouterr().err == "cdbrdf: interrupted\n"


# -- hostile input, second round ------------------------------------------------------------------------
def _run(argv):
    """``main(argv)``'s exit status, whether it returns or exits while parsing."""
    try:
        return main(argv)
    except SystemExit as e:
        return e.code


def _aliased_cases(tmp_path, table_file):
    """For every command that reads and writes files: its argv with an output that is (or holds) an input."""
    from cdbrdf.outputs import output_folder

    p, t = table_file
    one = tmp_path / "flat.h5"
    t.brdf(0.0).save(one)
    (tmp_path / "k13.h5").write_bytes(one.read_bytes())
    (tmp_path / "scan.ply").write_text("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                                       "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
                                       "end_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n")
    (tmp_path / "env.exr").write_bytes(b"an environment map")
    (tmp_path / "t.png").write_bytes(p.read_bytes())  # a table whose name says png
    with output_folder(tmp_path / "sim") as d:  # an earlier simulated capture, its plan the input now
        (d / "capture.csv").write_text("file,kappa,theta_l,phi_l,theta_v,phi_v,exposure,kind,encoding\n")
    with output_folder(tmp_path / "demo", maker="demo", signature=("report.html",)) as d:
        (d / "report.html").write_text("r")
        (d / "denim.h5").write_bytes(p.read_bytes())
    obj = tmp_path / "shirt"  # an OBJ whose MTL names a normal map; a glTF whose image is a PNG
    obj.mkdir()
    (obj / "shirt.obj").write_text("mtllib shirt.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\n"
                                   "usemtl cloth\nf 1/1 2/2 3/3\n")
    (obj / "shirt.mtl").write_text("newmtl cloth\nKd 0.5 0.5 0.5\nmap_Kd -s 1 1 1 diffuse.png\nnorm -bm 1 normal.png\n")
    (obj / "normal.png").write_bytes(b"the shirt's normal map")
    (obj / "diffuse.png").write_bytes(b"the shirt's colour")
    (obj / "tri.gltf").write_text(json.dumps({
        "asset": {"version": "2.0"}, "buffers": [{"uri": "tri%20data.ply", "byteLength": 36}],
        "images": [{"uri": "wrinkles.png"}]}))
    (obj / "tri data.ply").write_bytes(bytes(36))  # a buffer (whatever its name)
    (obj / "wrinkles.png").write_bytes(b"the glTF's normal map")
    s = str
    return {
        "render-mtl-norm": ["render", s(p), "--mesh", s(obj / "shirt.obj"), "-o", s(obj / "normal.png")],
        "render-mtl-map": ["render", s(p), "--mesh", s(obj / "shirt.obj"), "-o", s(obj / "diffuse.png")],
        "render-mtl": ["render", s(p), "--mesh", s(obj / "shirt.obj"), "--compare", "-o", s(obj / "shirt.mtl")],
        "render-gltf-image": ["render", s(p), "--mesh", s(obj / "tri.gltf"), "-o", s(obj / "wrinkles.png")],
        "curvature-gltf-buffer": ["curvature", s(obj / "tri.gltf"), "-o", s(obj / "tri data.ply")],
        "curvature": ["curvature", s(tmp_path / "scan.ply"), "-o", s(tmp_path / "scan.ply")],
        "import": ["import", s(one), "-o", s(one), "--grid", "regular:45,120"],
        "stack": ["stack", "--kappa", "0", s(one), "--kappa", "0.13", s(tmp_path / "k13.h5"), "-o",
                  s(tmp_path / "k13.h5")],
        "render": ["render", s(p), "--mesh", s(tmp_path / "scan.ply"), "--envmap", s(tmp_path / "env.exr"), "-o",
                   s(tmp_path / "env.exr")],
        "render-table": ["render", s(p), "--scene", "sine", "-o", s(p)],
        "mosaic": ["mosaic", s(tmp_path / "t.png"), "-o", s(tmp_path / "t.png")],
        "view": ["view", s(tmp_path / "demo" / "denim.h5"), "--export", s(tmp_path / "demo")],
        "simulate-capture": ["simulate-capture", s(p), "--plan", s(tmp_path / "sim" / "capture.csv"), "-o",
                             s(tmp_path / "sim")],
    }


def _snapshot(folder):
    return {q: q.read_bytes() for q in sorted(folder.rglob("*")) if q.is_file() and not q.is_symlink()}


@pytest.mark.parametrize("command", ["curvature", "import", "stack", "render", "render-table", "mosaic", "view",
                                     "simulate-capture", "render-mtl-norm", "render-mtl-map", "render-mtl",
                                     "render-gltf-image", "curvature-gltf-buffer"])
def test_an_output_that_is_or_holds_an_input_is_refused_by_every_command(tmp_path, table_file, capsys, command):
    """The one output rule: scan.ply -o scan.ply, import flat.h5 -o flat.h5, --export over the inputs' folder..."""
    argv = _aliased_cases(tmp_path, table_file)[command]
    before = _snapshot(tmp_path)
    assert _run(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err, err
    assert ("is the input" in err or "holds the input" in err or "an output folder of `cdbrdf demo`" in err), err
    assert _snapshot(tmp_path) == before  # every file untouched, byte for byte


def _holder(path):
    code = ("import sys, time\nfrom cdbrdf.outputs import output_lock\n"
            "with output_lock(sys.argv[1]):\n    print('held', flush=True)\n    time.sleep(60)\n")
    p = subprocess.Popen([sys.executable, "-c", code, str(path)], stdout=subprocess.PIPE, text=True)
    assert p.stdout.readline().strip() == "held"
    return p


def test_a_second_run_on_the_same_output_is_refused_at_once(tmp_path, table_file, capsys):
    p, t = table_file
    out = tmp_path / "o.h5"
    out.write_bytes(b"the first run's result")
    holder = _holder(out)
    try:
        for argv in (["synth", "denim", "-o", str(out)], ["import", str(p), "-o", str(out)],
                     ["measure", str(tmp_path), "-o", str(out), "--force"]):
            assert _run(argv) == 2
            err = capsys.readouterr().err
            assert f"o.h5: another cdbrdf run (process {holder.pid}) is writing it" in err and err.count("\n") == 1
        assert out.read_bytes() == b"the first run's result"
        assert not (tmp_path / "o.h5.ckpt").exists()
    finally:
        holder.kill()
        holder.wait()
        holder.stdout.close()


def test_broken_pipe_on_stdout_ends_quietly(tmp_path, small_grid):
    p = tmp_path / "big.h5"
    make_table(small_grid, attrs={"provenance": {"notes": "x" * 200_000}}).save(p)  # more than a pipe holds
    proc = subprocess.Popen([sys.executable, "-m", "cdbrdf.cli", "info", str(p)], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE)
    proc.stdout.close()  # the reader goes away at once (`cdbrdf info big.h5 | head -0`)
    err = proc.stderr.read()
    proc.stderr.close()
    assert proc.wait() in (0, 141) and err == b""


def test_control_characters_of_a_file_are_escaped_when_printed(tmp_path, small_grid, capsys):
    evil = "\x1b[31mred\x1b]0;owned\x07\u202e"
    p = tmp_path / "t.h5"
    make_table(small_grid, attrs={"material": evil, "colour_space": evil, "provenance": evil}).save(p)
    assert main(["info", str(p)]) == 0
    out = capsys.readouterr().out
    assert "\x1b" not in out and "\x07" not in out and "\u202e" not in out
    assert "\\x1b[31mred" in out and "\\u202e" in out
    bad = tmp_path / "b\x1b[2J.h5"
    bad.write_bytes(b"not a table")
    assert main(["info", str(bad)]) == 2
    err = capsys.readouterr().err
    assert "\x1b" not in err and "b\\x1b[2J.h5" in err and err.count("\n") == 1


def test_a_full_disk_is_one_line_and_keeps_the_old_file(tmp_path):
    import resource

    out = tmp_path / "Z.h5"
    out.write_bytes(b"old" * 1000)

    def small_files():
        resource.setrlimit(resource.RLIMIT_FSIZE, (16_384, 16_384))

    r = subprocess.run([sys.executable, "-m", "cdbrdf.cli", "-q", "synth", "denim", "--kappa", "0", "--grid",
                        "regular:30,60", "-o", str(out)], capture_output=True, text=True, preexec_fn=small_files,
                       timeout=300)
    assert r.returncode == 2, r  # not a segfault in HDF5's close
    assert r.stderr.count("\n") == 1 and "Z.h5: cannot be written: no space left" in r.stderr
    assert out.read_bytes() == b"old" * 1000 and sorted(q.name for q in tmp_path.iterdir()) == ["Z.h5"]
