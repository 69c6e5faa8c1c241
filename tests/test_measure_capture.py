"""The capture folder's format (cdbrdf.measure.capture): rows, grid, stands.json settings, plans, brackets."""

from __future__ import annotations

import csv

import pytest

from cdbrdf import Grid
from cdbrdf.cli import main
from cdbrdf.measure import CaptureError, measure
from cdbrdf.measure.capture import PLAN_COLUMNS, read_capture, read_rows, row_kind
from cdbrdf.measure.plan import bracket_rows, plan_rows, write_plan
from cdbrdf.measure.stands import Stand, hidden_mask, read_stands

from .measure_helpers import (
    SMALL,
    make_capture,
    pixel,
    write_csv,
)


@pytest.mark.parametrize("edit,msg", [
    (lambda r: r.pop("theta_v"), "missing column"),
    (lambda r: r.update(kind="flat"), "kind 'flat' is not one of sample, white, dark"),
    (lambda r: r.update(theta_l="abc"), "line 2: column 'theta_l': 'abc' is not a number"),
    (lambda r: r.update(theta_v=95), "outside"),
    (lambda r: r.update(file="x.jpg"), "unsupported extension"),
    (lambda r: r.update(exposure=-1), "exposure must be positive"),
    (lambda r: r.update(exposure=1e-320), r"exposure 9.99989e-321 is outside \[1e-9, 1e9\]"),
])
def test_capture_table_errors(tmp_path, edit, msg):
    r = dict(file="a.png", kappa=0, theta_v=0, phi_v=0, theta_l=0, phi_l=0)
    edit(r)
    write_csv(tmp_path / "capture.csv", [r])
    with pytest.raises(CaptureError, match=msg):
        measure(tmp_path)


def test_uneven_azimuths_are_refused(tmp_path):
    rows = [dict(file=f"{p}.png", kappa=0, theta_v=30, phi_v=p, theta_l=0, phi_l=0) for p in (0, 90, 200)]
    write_csv(tmp_path / "capture.csv", rows)
    with pytest.raises(CaptureError, match="do not form a table grid"):
        read_capture(tmp_path)


# --------------------------------------------------------------------------- capture table hardening
def _stray(rows, **edit):
    r = dict(rows[0], file="s/stray.exr", **edit)
    rows.insert(5, r)
    return rows


@pytest.mark.parametrize("edit,axis", [
    (dict(theta_v=31), "theta_v = 31"),
    (dict(kappa=0.25), "kappa = 0.25"),
    (dict(theta_l=41), "theta_l = 41"),
    (dict(phi_v=45), "phi_v = 45"),  # would also make the azimuths uneven
])
def test_stray_row_that_grows_the_grid_is_refused(tmp_path, edit, axis):
    rows = make_capture(tmp_path, SMALL, pixel, kind="exr", size=9)
    write_csv(tmp_path / "capture.csv", _stray(rows, **edit))
    with pytest.raises(CaptureError, match=rf"capture.csv: line 7: {axis} is used by 1 sample condition"):
        read_capture(tmp_path)


def test_explicit_grid_in_stand_file(tmp_path):
    rows = make_capture(tmp_path, SMALL, pixel, kind="exr", size=9)
    write_csv(tmp_path / "capture.csv", _stray(rows, theta_v=31))
    axes = {n: list(getattr(SMALL, n)) for n in ("kappa", "theta_l", "phi_l", "theta_v", "phi_v")}
    axes["theta_v"] = [0, 30, 31, 60]
    (tmp_path / "stands.json").write_text(__import__("json").dumps({"grid": axes}))
    cap = read_capture(tmp_path)  # listed: accepted
    assert list(cap.grid.theta_v) == [0, 30, 31, 60]
    axes["theta_v"] = [0, 30, 60, 75]  # 31 not listed; 75 listed but not photographed
    (tmp_path / "stands.json").write_text(__import__("json").dumps({"grid": axes}))
    with pytest.raises(CaptureError, match="line 7: theta_v = 31 is not on the grid of stands.json"):
        read_capture(tmp_path)
    write_csv(tmp_path / "capture.csv", rows[:5] + rows[6:])
    table, rep = measure(tmp_path)
    assert list(table.grid.theta_v) == [0, 30, 60, 75] and rep.n_not_photographed == table.measured.size // 4
    (tmp_path / "stands.json").write_text('{"grid": {"kappa": [0]}}')
    with pytest.raises(CaptureError, match="grid: expected an object with the lists"):
        read_capture(tmp_path)


@pytest.mark.parametrize("doc,msg", [
    ({"stands": [{"kappa": 0.0}, {"kappa": 0.2}], "pixel_mm": 1e308}, r"pixel_mm: expected a number in \[0, 10\]"),
    ({"stands": [{"kappa": 0.0}, {"kappa": 0.2}], "pixel_mm": -0.01}, "pixel_mm"),
    ({"stands": [{"kappa": 0.0}, {"kappa": 0.2}], "pixel_mm": True}, "pixel_mm"),
    ({"stands": [{"kappa": 0.0}, {"kappa": 0.2, "face_width_mm": 0}]}, "stand 1: .*must be positive"),
    ({"stands": [{"kappa": 0.0}, {"kappa": -0.2}]}, "no stand for kappa 0.2"),
    ({"white_albedo": 0}, r"white_albedo: expected a number in \(0, 1.5\]"),
    ({"white_albedo": "high"}, "white_albedo"),
    ({"encoding": "gamma"}, "encoding: 'gamma' is not one of"),
    ({"material": {"a": 1}}, "material: expected a printable name"),
])
def test_stand_file_values_are_checked(tmp_path, doc, msg):
    make_capture(tmp_path, SMALL, pixel, kind="exr", size=9)
    (tmp_path / "stands.json").write_text(__import__("json").dumps(doc))
    with pytest.raises(CaptureError, match=msg) as exc:
        measure(tmp_path)
    assert "stands.json" in str(exc.value) and "\n" not in str(exc.value)


def test_stand_file_deeply_nested_or_huge(tmp_path, monkeypatch):
    from cdbrdf.errors import LimitError

    make_capture(tmp_path, SMALL, pixel, kind="exr", size=9)
    (tmp_path / "stands.json").write_text('{"stands": ' + "[" * 100_000 + "]" * 100_000 + "}")
    with pytest.raises(CaptureError, match="stands.json: not valid JSON .nested too deeply."):
        read_capture(tmp_path)
    monkeypatch.setenv("CDBRDF_MAX_JSON_BYTES", "1000")
    with pytest.raises(LimitError, match="stands.json.*CDBRDF_MAX_JSON_BYTES"):
        read_capture(tmp_path)


def test_capture_rows_limit(tmp_path, monkeypatch):
    from cdbrdf.errors import LimitError

    make_capture(tmp_path, SMALL, pixel, kind="exr", size=9)
    read_capture(tmp_path)
    monkeypatch.setenv("CDBRDF_MAX_CAPTURE_ROWS", "50")
    with pytest.raises(LimitError, match=r"capture.csv: a table of: 96 rows exceed the limit of 50"):
        read_capture(tmp_path)


@pytest.mark.parametrize("mangle,msg", [
    (lambda b: b.replace(b"s/0_0_0_0_1", b"s/0_0\x00_0_0_1"), "line 3: NUL byte"),
    (lambda b: b.replace(b"s/0_0_0_0_2", b"s/\xe90_0_0_0_2"), r"line 4: not UTF-8 text \(byte 0xe9\)"),
    (lambda b: b.decode().encode("utf-16"), "UTF-16 text"),
    (lambda b: b.replace(b"s/0_0_0_0_1.exr", b'"s/0_0_0_0_1.exr' + b"x" * 200_000), "line 3: not valid CSV"),
    (lambda b: b.replace(b"s/0_0_0_0_1.exr", b"s/0_0_0_0_1\x07.exr"), "line 3: file .* contains control"),
    (lambda b: b.replace(b"s/0_0_0_0_1.exr,0.0,", b"s/0_0_0_0_1.exr,1e400,"), "line 3: column 'kappa'.* not finite"),
    (lambda b: b.replace(b"s/0_0_0_0_1.exr,0.0,", b"s/0_0_0_0_1.exr,0.0,,,"), "line 3: more fields"),
])
def test_capture_table_bytes(tmp_path, mangle, msg):
    make_capture(tmp_path, SMALL, pixel, kind="exr", size=9)
    p = tmp_path / "capture.csv"
    p.write_bytes(mangle(p.read_bytes()))
    with pytest.raises(CaptureError, match=msg) as exc:
        read_capture(tmp_path)
    assert str(p) in str(exc.value) and "\n" not in str(exc.value)


def test_capture_table_utf8_bom_and_blank_lines(tmp_path):
    make_capture(tmp_path, SMALL, pixel, kind="exr", size=9)
    p = tmp_path / "capture.csv"
    ref = read_capture(tmp_path)
    lines = p.read_bytes().split(b"\n")
    p.write_bytes(b"\xef\xbb\xbf" + b"\n".join(lines[:3] + [b""] + lines[3:]))
    cap = read_capture(tmp_path)
    assert cap.grid == ref.grid and [r.file for r in cap.rows] == [r.file for r in ref.rows]
    assert cap.rows[2].line == ref.rows[2].line + 1  # the physical line, blank line counted


# --------------------------------------------------------------------------- plans
def test_write_plan_and_read_stands(tmp_path):
    g = Grid.regular(theta_step_deg=30, phi_step_deg=90, theta_max_deg=60, kappa=[-0.22, 0.22])
    rows = write_plan(tmp_path, g, [Stand(-0.22), Stand(0.22)])
    with open(tmp_path / "capture.csv") as fh:
        got = list(csv.DictReader(fh))
    assert len(got) == len(rows) == 2 * 12 * 12 + 12
    assert {r["kind"] for r in got} == {"sample", "white"}
    assert len({r["file"] for r in got}) == len(got)
    hidden = [r for r in got if r["hidden"]]
    assert hidden and all(float(r["kappa"]) == -0.22 for r in hidden)
    stands = read_stands(tmp_path / "stands.json")
    assert set(stands) == {-0.22, 0.22}


def test_plan_rows_extension():
    g = Grid.regular(theta_step_deg=30, phi_step_deg=180, theta_max_deg=30, kappa=[0.0])
    assert plan_rows(g, [Stand(0.0)], extension="exr")[0]["file"].endswith(".exr")
    with pytest.raises(ValueError, match="not one of"):
        plan_rows(g, [Stand(0.0)], extension="jpg")


def test_cli_plan(tmp_path, capsys):
    out = tmp_path / "p"
    assert main(["plan", "-o", str(out), "--theta-step", "30", "--phi-step", "90"]) == 0
    text = capsys.readouterr().out
    assert "kappa -0.22 1/mm" in text and (out / "plan.png").stat().st_size > 0
    assert main(["plan", "-o", str(out)]) == 2  # exists
    assert "already exists" in capsys.readouterr().err


def test_cli_plan_says_what_stands_without_walls_would_hide(tmp_path, capsys):
    grid = Grid.paper()
    bare = hidden_mask(grid, [Stand(float(k), wall_height_mm=0.0) for k in grid.kappa])
    assert main(["plan", "-o", str(tmp_path / "a"), "--no-picture"]) == 0
    line = capsys.readouterr().out.splitlines()[-1]
    assert line == (f"  without walls (--wall-height 0) the concave stands would hide {int((bare[0] > 0).sum())} "
                    f"at -0.22, {int((bare[1] > 0).sum())} at -0.13")
    assert main(["plan", "-o", str(tmp_path / "b"), "--no-picture", "--wall-height", "0"]) == 0
    assert "without walls" not in capsys.readouterr().out


# --------------------------------------------------------------------------- brackets and re-written plans
def test_bracket_rows():
    rows = [dict(file="k0/a.png", kind="sample", exposure="1"), dict(file="white/w.tif", kind="white", exposure="1"),
            dict(file="d.exr", kind="dark", exposure="2")]
    got = bracket_rows(rows, [1.0, 0.25])
    assert [(r["file"], r["exposure"]) for r in got] == [
        ("k0/a_e0.png", "1"), ("k0/a_e1.png", "0.25"), ("white/w_e0.tif", "1"), ("white/w_e1.tif", "0.25"),
        ("d.exr", "2")]
    assert rows[0]["file"] == "k0/a.png"  # the input is not changed


def test_write_plan_with_exposures_writes_brackets(tmp_path):
    g = Grid.regular(theta_step_deg=30, phi_step_deg=180, theta_max_deg=30, kappa=[0.0])
    rows = write_plan(tmp_path, g, [Stand(0.0)], exposures=(1.0, 0.25))
    assert rows == bracket_rows(plan_rows(g, [Stand(0.0)]), [1.0, 0.25])
    with open(tmp_path / "capture.csv", newline="") as fh:
        assert next(csv.reader(fh)) == list(PLAN_COLUMNS)
    cap = read_capture(tmp_path)
    groups = cap.brackets("sample")
    assert len(groups) == g.theta_l.size * g.phi_l.size * g.theta_v.size * g.phi_v.size
    assert all([cap.rows[i].exposure for i in idx] == [1.0, 0.25] for idx in groups.values())
    assert len(cap.brackets("white")) == g.theta_l.size * g.phi_l.size
    assert write_plan(tmp_path, g, [Stand(0.0)], exposures=(1.0,)) == plan_rows(g, [Stand(0.0)])


def test_read_rows_keeps_the_text(tmp_path):
    g = Grid.regular(theta_step_deg=30, phi_step_deg=180, theta_max_deg=30, kappa=[0.0])
    rows = write_plan(tmp_path, g, [Stand(0.0)])
    columns, got = read_rows(tmp_path / "capture.csv")
    assert columns == list(PLAN_COLUMNS) and got == rows
    p = tmp_path / "capture.csv"
    p.write_text("file,kappa,theta_v,phi_v,theta_l\na.png,0,0,0,0\n")
    with pytest.raises(CaptureError, match="missing column.* phi_l"):
        read_rows(p)
    p.write_text("file,kappa,theta_v,phi_v,theta_l,phi_l\na.png,0,0,0,0,0,9\n")
    with pytest.raises(CaptureError, match="line 2: more fields than columns"):
        read_rows(p)
    p.write_bytes(b"file,kappa,theta_v,phi_v,theta_l,phi_l\na.png,0,0\x00,0,0,0\n")
    with pytest.raises(CaptureError, match="line 2: NUL byte"):
        read_rows(p)


def test_row_kind():
    assert row_kind({}) == row_kind({"kind": ""}) == row_kind({"kind": " "}) == "sample"
    assert row_kind({"kind": " White "}) == "white" and row_kind({"kind": None}) == "sample"


# --------------------------------------------------------------------------- file names, duplicates, plans
@pytest.mark.parametrize("name, why", [
    ("../victim.png", "has a '..' component"),
    ("k0/../../victim.png", "has a '..' component"),
    ("..\\victim.png", "has a '..' component"),
    ("/tmp/victim.png", "is an absolute path"),
    ("C:\\photos\\a.png", "is an absolute path"),
    ("C:a.png", "is an absolute path"),
    ("\\\\server\\share\\a.png", "is an absolute path"),
    ("k0/a.png/", "names a folder, not a file"),
    ("k0/.", "names a folder, not a file"),
])
def test_file_outside_the_capture_folder_is_refused(tmp_path, name, why):
    rows = make_capture(tmp_path, SMALL, pixel, kind="exr", size=9)
    rows[3]["file"] = name
    write_csv(tmp_path / "capture.csv", rows)
    with pytest.raises(CaptureError, match=rf"capture.csv: line 5: .*{why}"):
        read_capture(tmp_path)


def test_relative_names_inside_the_folder_are_kept(tmp_path):
    rows = make_capture(tmp_path, SMALL, pixel, kind="exr", size=9)
    (tmp_path / "s" / "0_0_0_0_1.exr").rename(tmp_path / "s" / "a b..exr")
    rows[1]["file"] = "./s/a b..exr"  # '.' components and dots inside a name are fine
    write_csv(tmp_path / "capture.csv", rows)
    cap = read_capture(tmp_path)
    assert cap.rows[1].file == "./s/a b..exr"
    table, _ = measure(tmp_path)
    assert table.measured.all()


@pytest.mark.parametrize("second", ["s/0_0_0_0_0.exr", "s/./0_0_0_0_0.exr", "s//0_0_0_0_0.exr",
                                    " s/0_0_0_0_0.exr"])
def test_two_rows_naming_one_photograph_are_refused(tmp_path, second):
    """Two conditions photographed by one file would silently get the same value."""
    rows = make_capture(tmp_path, SMALL, pixel, kind="exr", size=9)
    assert rows[0]["file"] == "s/0_0_0_0_0.exr"
    rows[2]["file"] = second
    write_csv(tmp_path / "capture.csv", rows)
    with pytest.raises(CaptureError, match=r"capture.csv: line 4: file '.*0_0_0_0_0.exr' is also the file of line 2"):
        read_capture(tmp_path)
    with pytest.raises(CaptureError, match="is also the file of line 2"):
        measure(tmp_path)


def _plan(tmp_path, edit=None):
    """A small plan written by write_plan, its third line replaced by ``edit``."""
    write_plan(tmp_path / "plan", Grid(kappa=[0.0], theta_l=[0.0, 40.0], phi_l=[0.0, 120.0, 240.0],
                                       theta_v=[0.0, 40.0], phi_v=[0.0, 120.0, 240.0]), [Stand(0.0)])
    p = tmp_path / "plan" / "capture.csv"
    if edit is not None:
        lines = p.read_text().splitlines()
        lines[2] = edit
        p.write_text("\n".join(lines) + "\n")
    return p


PLAN_ROWS = [
    ("k0/a.png,0,95,0,0,0,1,sample,", r"theta_v = 95 is outside \[0, 90\)"),
    ("k0/a.png,0,nan,0,0,0,1,sample,", "column 'theta_v': 'nan' is not finite"),
    ("k0/a.png,0,40,0,-5,0,1,sample,", r"theta_l = -5 is outside \[0, 90\)"),
    ("k0/a.png,0,40,0,0,0,0,sample,", "exposure must be positive"),
    ("k0/a.png,0,40,0,0,0,-1,sample,", "exposure must be positive"),
    ("k0/a.png,0,40,0,0,0,1e308,sample,", r"exposure 1e\+308 is outside"),
    ("k0/a.png,0,40,0,0,0,1,bogus,", "kind 'bogus' is not one of"),
    ("k0/a.png,0,41,0,0,0,1,sample,", "theta_v = 41 is used by 1 sample condition"),
    ("../victim.png,0,40,0,0,0,1,sample,", "has a '..' component"),
    ("/tmp/victim.png,0,40,0,0,0,1,sample,", "is an absolute path"),
    ("k0/l0_0_v0_0.png,0,40,0,0,0,1,sample,", "is also the file of line 2"),
    ("k0/a.png,0,40,0,0,0,1,sample,,extra", "more fields than columns"),
]


@pytest.mark.parametrize("row, msg", PLAN_ROWS, ids=[r for r, _ in PLAN_ROWS])
def test_read_plan_applies_the_capture_rules(tmp_path, row, msg):
    from cdbrdf.measure.capture import read_plan

    p = _plan(tmp_path, row)
    with pytest.raises(CaptureError, match=rf"plan/capture.csv: line 3: .*{msg}"):
        read_plan(p)


def test_read_plan_of_a_good_plan(tmp_path):
    from cdbrdf.measure.capture import read_plan

    plan = read_plan(_plan(tmp_path))
    assert plan.columns == list(PLAN_COLUMNS) and len(plan.rows) == len(plan.records) == 36 + 6
    assert plan.grid.shape == (1, 3, 2, 3, 2) and list(plan.stands) == [0.0]
    assert plan.records[0]["file"] == plan.rows[0].file == "k0/l0_0_v0_0.png"
    assert [r.kind for r in plan.rows].count("white") == 6


def test_write_rows_refuses_names_a_capture_cannot_have(tmp_path):
    from cdbrdf.measure.plan import write_rows

    good = dict(file="k0/a.png", kappa="0", theta_v="0", phi_v="0", theta_l="0", phi_l="0")
    for bad, msg in ((dict(good, file="../a.png"), "line 3: .*'..' component"),
                     (dict(good), "line 3: file 'k0/a.png' is also the file of line 2"),
                     (dict(good, file=""), "line 3: column 'file' is empty")):
        with pytest.raises(CaptureError, match=msg):
            write_rows(tmp_path / "capture.csv", [good, bad])
        assert not (tmp_path / "capture.csv").exists()


# --------------------------------------------------------------------------- inputs that are not regular files; keys
@pytest.mark.parametrize("name", ["capture.csv", "stands.json"])
@pytest.mark.parametrize("kind", ["fifo", "/dev/zero"])
def test_capture_inputs_that_are_not_regular_files_are_refused(tmp_path, capsys, name, kind):
    import os

    from .test_measure_stands import unblocking

    make_capture(tmp_path / "cap", SMALL, pixel, kind="exr", size=9, settings={"white_albedo": 0.9})
    p = tmp_path / "cap" / name
    p.unlink()
    if kind == "fifo":
        os.mkfifo(p)
    else:
        p.symlink_to(kind)
    what = "FIFO" if kind == "fifo" else "character device"
    with unblocking(p):
        with pytest.raises(CaptureError, match=rf"{name}: not a regular file \(a {what}\)"):
            read_capture(tmp_path / "cap")
        assert main(["-q", "measure", str(tmp_path / "cap"), "-o", str(tmp_path / "m.h5")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"{name}: not a regular file" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cap"]


def test_capture_csv_size_limit(tmp_path, monkeypatch):
    from cdbrdf.errors import LimitError

    make_capture(tmp_path, SMALL, pixel, kind="exr", size=9)
    size = (tmp_path / "capture.csv").stat().st_size
    monkeypatch.setenv("CDBRDF_MAX_CSV_BYTES", str(size - 1))
    with pytest.raises(LimitError, match=rf"capture.csv: CSV file: {size:,} bytes exceed the limit .*MAX_CSV_BYTES"):
        read_capture(tmp_path)
    monkeypatch.setenv("CDBRDF_MAX_CSV_BYTES", str(size))
    read_capture(tmp_path)


def test_unknown_stands_json_key_is_refused(tmp_path, capsys):
    """A typo (white_albdeo) was ignored, giving values 1/albedo off with exit status 0."""
    from cdbrdf.measure.capture import STAND_FILE_KEYS

    make_capture(tmp_path / "cap", SMALL, pixel, kind="exr", size=9, settings={"white_albdeo": 0.5})
    with pytest.raises(CaptureError, match=r"stands.json: unknown key 'white_albdeo'; valid keys are stands, grid, "
                                           r"white_albedo, pixel_mm, encoding, material, simulated, registration"):
        read_capture(tmp_path / "cap")
    assert main(["-q", "measure", str(tmp_path / "cap"), "-o", str(tmp_path / "m.h5")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "white_albdeo" in err
    assert not (tmp_path / "m.h5").exists()
    # every documented key is accepted
    doc = {"grid": None, "white_albedo": 0.5, "pixel_mm": 0.0, "encoding": "linear", "material": "felt",
           "simulated": True, "registration": {"version": 1, "camera": "orthographic", "repeat_mm": [1.0, 2.0],
                                               "stands": [{"kappa": 0.0, "u_mm": 0.5, "v_mm": 0.25}]}}
    assert set(doc) | {"stands"} == set(STAND_FILE_KEYS)
    doc.pop("grid")
    make_capture(tmp_path / "ok", SMALL, pixel, kind="exr", size=9, settings=doc,
                 stands=[{"kappa": 0.0}, {"kappa": 0.2}])
    assert read_capture(tmp_path / "ok").settings["white_albedo"] == 0.5


def test_simulated_setting_must_be_a_boolean(tmp_path):
    make_capture(tmp_path, SMALL, pixel, kind="exr", size=9, settings={"simulated": "yes"})
    with pytest.raises(CaptureError, match="simulated: expected true or false"):
        read_capture(tmp_path)


@pytest.mark.parametrize("name", ["capture.csv", "stands.json"])
def test_plan_never_writes_into_a_fifo(tmp_path, capsys, name):
    """The plan's files are written atomically: a FIFO in their place is refused (writing it blocked)."""
    import os
    import stat
    import threading

    out = tmp_path / "plan"
    out.mkdir()
    fifo = out / name
    os.mkfifo(fifo)
    stop = threading.Event()

    def drain():  # feeds a writer that blocked on the FIFO (the old behaviour), so the test fails, never hangs
        if stop.wait(5):
            return
        fd = os.open(fifo, os.O_RDONLY | os.O_NONBLOCK)
        while not stop.wait(0.1):
            try:
                os.read(fd, 1 << 16)
            except BlockingIOError:
                pass
        os.close(fd)

    t = threading.Thread(target=drain, daemon=True)
    t.start()
    try:
        rc = main(["-q", "plan", "-o", str(out), "--kappa", "0", "--theta-step", "40", "--theta-max", "40",
                   "--phi-step", "120", "--force"])
    finally:
        stop.set()
        t.join()
    assert rc == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"{name}: exists and is not a regular file (a FIFO)" in err
    assert stat.S_ISFIFO(fifo.lstat().st_mode) and sorted(p.name for p in out.iterdir()) == [name]
