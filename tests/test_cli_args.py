"""Every option of every command is validated while parsing: one line, exit 2, nothing written."""

from __future__ import annotations

import argparse
import math

import numpy as np
import pytest

from cdbrdf.cli import main
from cdbrdf.commands import _args

from .conftest import make_table


@pytest.fixture
def files(tmp_path, small_grid):
    """A table, a mesh and a capture plan to point the commands at; the output folder."""
    make_table(small_grid, attrs={"material": "felt", "quantity": "brdf"}).save(tmp_path / "t.h5")
    (tmp_path / "m.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0.1\nf 1 2 3\nf 2 4 3\n")
    (tmp_path / "plan.csv").write_text("file,kappa,theta_v,phi_v,theta_l,phi_l\n")
    out = tmp_path / "out"
    out.mkdir()
    return tmp_path, out


def _exit_code(argv: list[str]) -> int:
    try:
        return main(argv)
    except SystemExit as e:  # argparse's errors exit, run-time errors return
        return int(e.code)


T, M = "{d}/t.h5", "{d}/m.obj"
RENDER = ["render", T, "--scene", "sine", "-o", "{o}/a.png"]
MOSAIC = ["mosaic", T, "-o", "{o}/a.png"]
PLAN = ["plan", "-o", "{o}/plan"]
SIM = ["simulate-capture", "denim", "-o", "{o}/cap"]
CURV = ["curvature", M, "-o", "{o}/c.ply"]
SYNTH = ["synth", "denim", "-o", "{o}/s.h5"]
MEASURE = ["measure", "{d}", "-o", "{o}/m.h5"]

#: (base command, bad option and value, text the message must contain)
BAD: list[tuple[list[str], list[str], str]] = [
    (MEASURE, ["--patch", "0"], "--patch"),
    (MEASURE, ["--patch", "nan"], "--patch"),
    (MEASURE, ["--white-albedo", "5"], "--white-albedo"),
    (MEASURE, ["--white-albedo", "nan"], "--white-albedo"),
    (MEASURE, ["--workers", "0"], "--workers"),
    (RENDER, ["--exposure", "nan"], "--exposure"),
    (RENDER, ["--exposure", "1e6"], "--exposure"),
    (RENDER, ["--view", "nan,0"], "--view"),
    (RENDER, ["--view", "40"], "--view"),
    (RENDER, ["--light", "inf,0"], "--light"),
    (RENDER, ["--light", "45,x"], "--light"),
    (RENDER, ["--max-depth", "0"], "--max-depth"),
    (RENDER, ["--seed", "-1"], "--seed"),
    (RENDER, ["--seed", str(2**70)], "--seed"),
    (RENDER, ["--seed", "1.5"], "--seed"),
    (RENDER, ["--spp", "0"], "--spp"),
    (RENDER, ["--spp", "1e9"], "--spp"),
    (RENDER, ["--envmap", "/nonexistent.exr"], "--envmap"),
    (RENDER, ["--envmap", "{d}/t.h5"], "--envmap"),
    (RENDER, ["--size", "40000x40000"], "CDBRDF_MAX_RENDER_PIXELS"),
    (RENDER, ["--size", "0x10"], "--size"),
    (RENDER, ["--size", "10"], "--size"),
    (RENDER, ["--wavelength", "1e-9"], "--wavelength"),
    (RENDER, ["--wavelength", "0.01"], "CDBRDF_MAX_MESH_FACES"),
    (RENDER, ["--amplitude", "-1"], "--amplitude"),
    (RENDER, ["--sheet-size", "60xnan"], "--sheet-size"),
    (RENDER, ["--irradiance", "0"], "--irradiance"),
    (RENDER, ["--irradiance", "inf"], "--irradiance"),
    (RENDER, ["--units", "furlong"], "--units"),
    (RENDER, ["--variant", "cuda"], "--variant"),
    (RENDER, ["--zoom", "0"], "--zoom"),
    (RENDER, ["--zoom", "nan"], "--zoom"),
    (RENDER, ["--zoom", "1e4"], "--zoom"),
    (RENDER, ["--fov", "0"], "--fov"),
    (RENDER, ["--fov", "175"], "--fov"),
    (RENDER, ["--zoom", "0.1", "--fov", "150"], "--zoom: 0.1 with a field of view of 150 degrees widens the lens"),
    (RENDER, ["--look-at", "nowhere"], "one of centre, fold, crest, valley"),
    (RENDER, ["--look-at", "1,2"], "--look-at"),
    (RENDER, ["--look-at", "1,2,nan"], "--look-at"),
    (RENDER, ["--view", "100,0"], "--view: elevation 100 degrees is not in [-90, 90]"),
    (["render", T, "--scene", "plane", "-o", "{o}/a.png"], [], "invalid choice: 'plane' (choose from 'sine', 'swatch')"),
    (RENDER, ["--delta-e", "ab"], "--delta-e: only with --compare"),
    (RENDER, ["--compare", "--delta-e", "cmc"], "--delta-e"),
    (RENDER, ["--fold-radii", "20,10"], "--fold-radii: only for --scene swatch"),
    (["render", T, "--scene", "swatch", "-o", "{o}/a.png"], ["--fold-radii", "20,0.1"],
     "--fold-radii: 0.1 mm is not a radius between 0.5 and 1000 mm"),
    (["render", T, "--scene", "swatch", "-o", "{o}/a.png"], ["--amplitude", "2"], "--amplitude: only for --scene sine"),
    (["render", T, "--mesh", M, "-o", "{o}/a.png"], ["--wavelength", "10"], "--wavelength: only for --scene sine"),
    (["render", T, "--mesh", "{d}/missing.obj", "-o", "{o}/a.png"], [], "--mesh"),
    (["render", T, "--scene", "sine", "-o", "{o}/nowhere/a.png"], [], "--output"),
    (MOSAIC, ["--channel", "-1"], "--channel"),
    (MOSAIC, ["--channel", "1;rm"], "--channel"),
    (MOSAIC, ["--dpi", "0"], "--dpi"),
    (MOSAIC, ["--dpi", "1e9"], "--dpi"),
    (MOSAIC, ["--exposure", "nan"], "--exposure"),
    (MOSAIC, ["--kappa", "nan"], "--kappa"),
    (PLAN, ["--patch", "0"], "--patch"),
    (PLAN, ["--theta-step", "0"], "--theta-step"),
    (PLAN, ["--theta-step", "0.01"], "CDBRDF_MAX_"),
    (PLAN, ["--theta-max", "90"], "--theta-max"),
    (PLAN, ["--phi-step", "-30"], "--phi-step"),
    (PLAN, ["--kappa", "0,nan"], "--kappa"),
    (PLAN, ["--kappa", "0,0"], "--kappa"),
    (PLAN, ["--face-width", "0"], "--face-width"),
    (PLAN, ["--wall-height", "-1"], "--wall-height"),
    (PLAN, ["--pixel-mm", "-1"], "--pixel-mm"),
    (PLAN, ["--format", "gif"], "--format"),
    (SIM, ["--white-albedo", "5"], "--white-albedo"),
    (SIM, ["--white-albedo", "0"], "--white-albedo"),
    (SIM, ["--exposures", "0"], "--exposures"),
    (SIM, ["--exposures", "1,,2"], "--exposures"),
    (SIM, ["--seed", "-1"], "--seed"),
    (SIM, ["--seed", str(2**32)], "--seed"),
    (SIM, ["--size", "4"], "--size"),
    (SIM, ["--size", "100000"], "--size"),
    (SIM, ["--field", "0"], "--field"),
    (SIM, ["--spp", "0"], "--spp"),
    (SIM, ["--gain", "nan"], "--gain"),
    (SIM, ["--noise", "nan"], "--noise"),
    (SIM, ["--noise", "-5,3"], "--noise"),
    (SIM, ["--image", "jpg"], "--image"),
    (SIM, ["--plan", "{d}/missing.csv"], "--plan"),
    (["simulate-capture", "felt", "-o", "{o}/cap"], [], "felt"),
    (CURV, ["--neighbourhood", "1e5"], "--neighbourhood"),
    (CURV, ["--neighbourhood", "0"], "--neighbourhood"),
    (CURV, ["--units", "furlong"], "--units"),
    (["curvature", "{d}/missing.ply", "-o", "{o}/c.ply"], [], "missing.ply"),
    (SYNTH, ["--grid", "regular:0,30"], "--grid"),
    (SYNTH, ["--grid", "regular:nan,30"], "--grid"),
    (SYNTH, ["--grid", "hexagonal"], "--grid"),
    (SYNTH, ["--grid", "regular:0.01,0.01"], "CDBRDF_MAX_TABLE_SAMPLES"),
    (SYNTH, ["--kappa", "inf"], "--kappa"),
    (SYNTH, ["--set", "thickness_mm=nan"], "thickness_mm"),
    (["demo", "-o", "{o}/demo", "--fabrics", "velvet,felt"], [], "--fabrics: 'felt' unknown"),
    (["demo", "-o", "{o}/demo", "--fabrics", "velvet,velvet"], [], "--fabrics: a fabric named twice"),
    (["demo", "-o", "{o}/demo", "--fabrics", "denim,"], [], "--fabrics"),
    (["demo", "-o", "{o}/demo"], ["--wall-height", "-1"], "--wall-height"),
    (["demo", "-o", "{o}/demo"], ["--face-width", "100"], "must stay below 180"),
]


@pytest.mark.parametrize("base, bad, expect", BAD, ids=[" ".join(b[:1] + o) for b, o, _ in BAD])
def test_bad_value_is_one_line_exit_2_nothing_written(files, capsys, base, bad, expect):
    d, o = files
    argv = ["-q"] + [a.format(d=d, o=o) for a in base + bad]
    before = sorted(p.name for p in d.iterdir())
    assert _exit_code(argv) == 2
    err = capsys.readouterr().err
    command = base[0]
    assert err.startswith(f"cdbrdf {command}: error: ")
    assert err.count("\n") == 1 and err.endswith("\n"), err
    assert expect in err and "Traceback" not in err
    assert list(o.iterdir()) == []
    assert sorted(p.name for p in d.iterdir()) == before


def test_every_option_has_a_validating_type():
    """No option of any command takes a bare float/int or an unchecked text."""
    from cdbrdf.cli import build_parser

    free_text = {"--title", "--scheduler", "--material", "-o", "--set"}  # free by nature / checked in run
    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    for name, p in sub.choices.items():
        for a in p._actions:
            if a.nargs == 0 or isinstance(a, argparse._HelpAction) or not a.option_strings:
                continue
            if a.choices is not None or set(a.option_strings) & free_text:
                continue
            assert a.type not in (None, int, float), f"{name} {a.option_strings}: not validated"


def test_arguments_that_were_valid_still_are(files):
    from cdbrdf.cli import build_parser

    d, o = files
    p = build_parser()
    a = p.parse_args(["render", str(d / "t.h5"), "--scene", "sine", "-o", str(o / "a.png"),
                      "--view=-10,-90", "--light", "45,0", "--size", "24x16", "--seed", "7"])
    assert a.size == (24, 16) and a.view == [-10.0, -90.0] and a.seed == 7
    assert a.zoom is None and a.fov is None and a.look_at is None and a.delta_e is None  # the camera's defaults
    a = p.parse_args(["render", str(d / "t.h5"), "--scene", "swatch", "-o", str(o / "a.png"), "--zoom", "4",
                      "--fov", "20", "--look-at=-5,0,2.5", "--fold-radii", "20,-5", "--compare", "--delta-e", "ab"])
    assert (a.zoom, a.fov, a.look_at, a.fold_radii, a.delta_e) == (4.0, 20.0, [-5.0, 0.0, 2.5], [20.0, -5.0], "ab")
    assert p.parse_args(["render", str(d / "t.h5"), "--mesh", str(d / "m.obj"), "-o", str(o / "a.png"), "--look-at",
                         "fold"]).look_at == "fold"
    assert a.sheet_size is None  # not given: the sine sheet's own size (cdbrdf.mesh.SineSheet) applies
    assert p.parse_args(["render", str(d / "t.h5"), "--scene", "sine", "-o", str(o / "a.png"), "--sheet-size",
                         "30x40"]).sheet_size == [30, 40]
    a = p.parse_args(["plan", "-o", str(o), "--kappa=-0.22,0.22", "--theta-step", "60"])
    assert a.kappa == [-0.22, 0.22] and a.theta_step == 60.0
    a = p.parse_args(["simulate-capture", "denim", "-o", str(o), "--exposures", "1,0.25", "--noise", "none"])
    assert a.exposures == [1.0, 0.25] and not a.noise.enabled
    a = p.parse_args(["mosaic", "f.h5", "-o", "x.png", "--channel", "G", "--exposure", "white"])
    assert a.channel == "G" and a.exposure == "white"
    assert p.parse_args(["mosaic", "f.h5", "-o", "x.png", "--channel", "1"]).channel == 1


def test_factories_directly():
    f = _args.finite_float(0, 1, lo_open=True)
    assert f("0.5") == 0.5
    for bad in ("0", "nan", "inf", "-inf", "1.0001", "x", ""):
        with pytest.raises(argparse.ArgumentTypeError):
            f(bad)
    assert _args.int_range(1, 3)("3") == 3
    for bad in ("0", "4", "1.0", "1e2", "0x1", " "):
        with pytest.raises(argparse.ArgumentTypeError):
            _args.int_range(1, 3)(bad)
    assert _args.seed()(str(2**32 - 1)) == 2**32 - 1
    assert _args.float_list(min_len=2, max_len=2)("1,2") == [1.0, 2.0]
    with pytest.raises(argparse.ArgumentTypeError, match="3 numbers"):
        _args.float_list(min_len=3, max_len=3)("1,2")
    assert math.isclose(_args.finite_float()("1e300"), 1e300)


def test_size_limit_follows_the_environment(monkeypatch):
    monkeypatch.setenv("CDBRDF_MAX_RENDER_PIXELS", "100")
    assert _args.size_wxh()("10x10") == (10, 10)
    with pytest.raises(argparse.ArgumentTypeError, match="CDBRDF_MAX_RENDER_PIXELS"):
        _args.size_wxh()("11x10")


def test_curvature_cost_is_bounded_at_any_neighbourhood(tmp_path, monkeypatch):
    """The fit thins a fine mesh to the neighbourhood: a huge neighbourhood costs no more fitting than a tiny one.

    The work counted is what the kernels do: (vertices fitted or transferred) x (neighbours each looks at).
    """
    from cdbrdf.mesh import _kernels

    n = 30
    x, y = np.meshgrid(np.linspace(0, 1, n), np.linspace(0, 1, n), indexing="ij")
    lines = [f"v {a:g} {b:g} {0.1 * np.sin(3 * a):g}" for a, b in zip(x.ravel(), y.ravel(), strict=True)]
    for i in range(n - 1):
        for j in range(n - 1):
            a = i * n + j + 1
            lines += [f"f {a} {a + n} {a + n + 1}", f"f {a} {a + n + 1} {a + 1}"]
    (tmp_path / "g.obj").write_text("\n".join(lines) + "\n")
    work = {}

    def counting(kernel, nbr_at):
        def run(*args):
            start, stop = args[-2:]
            work[nb] += (stop - start) * args[nbr_at].shape[1]
            return kernel(*args)
        return run

    monkeypatch.setattr(_kernels, "fit_vertices", counting(_kernels.fit_vertices, 7))
    monkeypatch.setattr(_kernels, "transfer_tensors", counting(_kernels.transfer_tensors, 10))
    for nb in ("5", "0.001", "1e4"):
        work[nb] = 0
        assert main(["-q", "curvature", str(tmp_path / "g.obj"), "-o", str(tmp_path / f"c{nb}.ply"),
                     "--neighbourhood", nb]) == 0
    assert 0 < work["1e4"] <= min(work["0.001"], work["5"]), work


WRITERS = {"render": RENDER, "mosaic": MOSAIC, "curvature": CURV, "synth": SYNTH, "measure": MEASURE}


@pytest.mark.parametrize("special", ["fifo", "devnull"])
@pytest.mark.parametrize("command", sorted(WRITERS))
def test_output_that_is_not_a_regular_file_is_refused(files, capsys, command, special):
    """-o naming a FIFO or a device (/dev/null) is refused before any work, never replaced by a file."""
    import os
    import stat

    d, o = files
    argv = ["-q"] + [a.format(d=d, o=o) for a in WRITERS[command]]
    i = argv.index("-o") + 1
    target = o / (special + os.path.splitext(argv[i])[1])  # the suffix the command writes
    argv[i] = str(target)
    if special == "fifo":
        os.mkfifo(target)
    else:
        target.symlink_to(os.devnull)
    if command == "measure":
        argv.append("--force")
    assert _exit_code(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"cdbrdf {command}: error: ") and err.count("\n") == 1, err
    assert "is not a regular file" in err
    assert sorted(p.name for p in o.iterdir()) == [target.name]
    if special == "fifo":
        assert stat.S_ISFIFO(target.lstat().st_mode)
    else:
        assert target.is_symlink() and stat.S_ISCHR(os.stat(os.devnull).st_mode)
