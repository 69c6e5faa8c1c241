"""One owner per range and per parameter: the records' ranges, the command line that reads them, the plug-in's table."""

from __future__ import annotations

import argparse
import re
from pathlib import Path

import pytest

from cdbrdf.errors import OptionError
from cdbrdf.ranges import Range

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.parametrize("rng, inside, outside, expect", [
    (Range(1, 64, integer=True), [1, 64, 7], [0, 65, 1.5, True, "3", float("nan")], "an integer in [1, 64]"),
    (Range(0.0, 1.5, lo_open=True), [1e-9, 1.5, 1], [0, 1.6, float("inf"), None], "a number in (0, 1.5]"),
    (Range(0.0, 90.0, hi_open=True, unit="degrees"), [0.0, 89.9], [90.0, -1e-9], "a number in [0, 90) degrees"),
    (Range(0.0, lo_open=True), [1e300], [0.0, -1.0], "a positive number"),
])
def test_a_range_accepts_exactly_its_numbers(rng, inside, outside, expect):
    assert rng.expect() == expect
    for x in inside:
        assert x in rng and rng.check("x", x) == x
    for x in outside:
        assert x not in rng
        with pytest.raises(OptionError, match=f"^x: expected {re.escape(expect)}, got"):
            rng.check("x", x)


def _ranges():
    """Every range a record owns and the option of the command line that parses it."""
    from cdbrdf.measure.capture import WHITE_ALBEDO_RANGE
    from cdbrdf.measure.options import PATCH_RANGE_PX
    from cdbrdf.mesh import maps
    from cdbrdf.render import lighting, spec
    from cdbrdf.rig import options as rig

    return [
        ("render", "--height-scale", maps.HEIGHT_SCALE_RANGE_MM),
        ("render", "--spp", spec.SPP_RANGE), ("render", "--max-depth", spec.MAX_DEPTH_RANGE),
        ("render", "--irradiance", lighting.IRRADIANCE_RANGE), ("render", "--seed", spec.SEED_RANGE),
        ("simulate-capture", "--spp", rig.SPP_RANGE), ("simulate-capture", "--gain", rig.GAIN_RANGE),
        ("simulate-capture", "--field", rig.FIELD_RANGE_MM), ("simulate-capture", "--shifts", rig.SHIFTS_RANGE),
        ("simulate-capture", "--px-per-texel", rig.PX_PER_TEXEL_RANGE),
        ("simulate-capture", "--white-albedo", WHITE_ALBEDO_RANGE), ("simulate-capture", "--seed", rig.SEED_RANGE),
        ("measure", "--patch", PATCH_RANGE_PX), ("measure", "--white-albedo", WHITE_ALBEDO_RANGE),
    ]


def test_the_measurement_options_are_checked_once_for_both_paths():
    """measure() and measure_btf() share one record: the same ranges, the same one-line refusals."""
    from cdbrdf.measure import MeasureOptions

    assert MeasureOptions(patch=999, white_albedo=1.5).patch == 999
    for bad, match in (({"patch": 1000}, r"^patch: expected an integer in \[1, 999\], got 1000$"),
                       ({"patch": 0}, "^patch: expected a positive whole number"),
                       ({"white_albedo": 1.6}, r"^white_albedo: expected a number in \(0, 1.5\], got 1.6$"),
                       ({"material": ""}, "^material: expected a printable name"),
                       ({"batch_size": True}, "^batch_size: expected a positive whole number")):
        with pytest.raises(OptionError, match=match):
            MeasureOptions(**bad)


def _option_type(command, option):
    from cdbrdf.cli import build_parser

    sub = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    return next(a for a in sub.choices[command]._actions if option in a.option_strings).type


@pytest.mark.parametrize("command, option, rng", _ranges(), ids=lambda x: x if isinstance(x, str) else "")
def test_the_command_line_accepts_what_the_record_accepts(command, option, rng):
    """At and just beyond each bound: the option parses exactly the values the record's range holds."""
    parse = _option_type(command, option)
    step = 1 if rng.integer else 1e-6 * max(1.0, abs(rng.hi or 1.0))
    for bound in (rng.lo, rng.hi):
        for x in (bound - step, bound, bound + step):
            text = str(int(x)) if rng.integer else repr(float(x))
            value = int(x) if rng.integer else float(x)
            if value in rng:
                assert parse(text) == value
            else:
                with pytest.raises(argparse.ArgumentTypeError):
                    parse(text)


def test_the_plugin_table_is_made_from_its_registry():
    """The docstring of cdbrdf.render.plugin and docs/rendering.md hold the registry's table, every row."""
    import cdbrdf.render.plugin as plugin
    from cdbrdf.render._params import PARAMETERS, parameter_table

    assert parameter_table("rst") in plugin.__doc__
    assert parameter_table("markdown") in (ROOT / "docs" / "rendering.md").read_text(encoding="utf-8")
    for name in ("curvature", "curvature_mode", "curvature_scale", "unit", "scene_scale_applied", "uv_scale",
                 "texel_filter", "normal_map", "normal_map_convention", "height_map", "height_scale", "map_size",
                 "curvature_map", "neighbourhood", "pixel_angle", "map_filter", "shading_normals", "mode",
                 "sampling", "storage", "scale", "cosine_weight", "filename", "table"):
        assert name in PARAMETERS, name


def test_the_registry_is_what_the_plugin_reads():
    """Every name the plug-in's code reads is in the registry, and every registered one is read (the source's
    ``get("NAME")`` and ``props["NAME"]``, the dict entry's keys)."""
    from cdbrdf.render._params import PARAMETERS
    from cdbrdf.render.plugin import _DICT_KEYS

    src = ROOT / "src" / "cdbrdf" / "render"
    code = "".join((src / f).read_text(encoding="utf-8") for f in ("_bsdf_core.py", "_bsdf.py", "_maps_jit.py"))
    read = set(re.findall(r'\bget\("(\w+)"', code)) | set(re.findall(r'props\["(\w+)"\]', code))
    read |= set(re.findall(r'"(\w+)" (?:not )?in props', code)) | set(re.findall(r'extras\.get\("(\w+)"\)', code))
    assert read == set(PARAMETERS) - {"table"}
    assert _DICT_KEYS == {"type", "id", *PARAMETERS} - {"filename"}


def test_the_plugin_refuses_a_name_outside_its_registry():
    from cdbrdf.render._bsdf_core import _getter

    get = _getter({}, {"uv_scale": 2.0})
    assert get("uv_scale") == 2.0 and get("mode", "cdbrdf") == "cdbrdf"
    with pytest.raises(KeyError, match="not a parameter"):
        get("uv_scael")


def test_render_help_says_percent_once(capsys):
    """argparse formats help, not descriptions: the description's 18 % grey card is written with one %."""
    from cdbrdf.cli import main

    with pytest.raises(SystemExit):
        main(["render", "--help"])
    out = " ".join(capsys.readouterr().out.split())  # as wrapped to the terminal's width
    assert "an 18 % grey card" in out and "%%" not in out


def test_curvature_command_records_the_up_axis_it_is_given(tmp_path, capsys):
    """cdbrdf curvature --up y writes it into the PLY, and the mesh read back says so (render and view use it)."""
    from cdbrdf.cli import main
    from cdbrdf.mesh import Mesh, detect_up, read_ply, write_ply

    from .mesh_helpers import cylinder_patch

    v, f, uv, _ = cylinder_patch(10.0, n=12)
    src = tmp_path / "patch.ply"
    write_ply(src, Mesh(v, f, uv=uv))
    assert main(["-q", "curvature", str(src), "-o", str(tmp_path / "y.ply"), "--up", "y"]) == 0
    assert main(["-q", "curvature", str(src), "-o", str(tmp_path / "auto.ply")]) == 0
    assert read_ply(tmp_path / "y.ply").metadata["up"] == "y"
    assert detect_up(read_ply(tmp_path / "y.ply")) == ("y", "recorded in the file")
    assert "up" not in read_ply(tmp_path / "auto.ply").metadata
