"""End to end: the simulated rig photographs a known material, the pipeline measures it back.

Tolerance (stated in docs/capture.md). A pixel of linear value x holds
x * FW photo-electrons (FW = full well) plus read noise r, so its relative
noise is sqrt(x FW + r^2) / (x FW); the N x N patch mean divides it by N.
A sample's value is the ratio of its patch (x_s = gain f cos(theta_l)) to the
white reference's (x_w = gain albedo / pi cos(theta_l)), so its relative
standard error is sigma = sqrt(s(x_s)^2 + s(x_w)^2).

- Against the ideal measurement of the same photograph
  (:func:`cdbrdf.rig.expected_patch_value`: the table integrated over
  the local directions the patch sees on the curved face): within
  5 sigma + 0.2 % (noise-free, the rig and the pipeline agree to 0.07 %).
- Against the table's value at the grid node: within 5 sigma + 1 %, the 1 %
  covering the patch's extent over a curved face for this smooth material.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import cdbrdf
from cdbrdf import CDBRDF, Grid, render
from cdbrdf.cli import main
from cdbrdf.measure import Stand, hidden_mask, measure

from .render_helpers import require_llvm_module  # noqa: E402

require_llvm_module()

from cdbrdf.rig import (  # noqa: E402
    NoiseModel,
    RigOptions,
    expected_patch_value,
    simulate_capture,
    stand_meshes,
)

CAPTURE_GRID = Grid.regular(theta_step_deg=30, phi_step_deg=90, theta_max_deg=60,
                            kappa=[-0.22, 0.0, 0.22])
NOISE = NoiseModel(full_well=20000.0, read_e=3.0)
GAIN = 2.0
ALBEDO = 0.99
N = 7


def material() -> CDBRDF:
    """A cloth-like table: colour shifts with curvature, a broad anisotropic lobe."""
    g = Grid.paper()
    m = g.mesh()
    tv, pv, tl, pl = (np.radians(m[n]) for n in ("theta_v", "phi_v", "theta_l", "phi_l"))
    k = m["kappa"][..., None]
    base = np.array([0.06, 0.09, 0.20]) + k * np.array([0.25, 0.22, 0.05])  # lighter when convex
    lobe = (np.cos(tv) * np.cos(tl) * (1 + 0.4 * np.cos(pv - pl) * np.cos(pl) ** 2))[..., None]
    return CDBRDF(base * (0.5 + 0.5 * lobe), g, attrs={"material": "test-cloth", "quantity": "brdf"})


@pytest.fixture(scope="module")
def captured(tmp_path_factory):
    folder = tmp_path_factory.mktemp("rig") / "cap"
    mat = material()
    rep = simulate_capture(mat, folder, RigOptions(size=32, field_mm=2.0, noise=NOISE, gain=GAIN,
                                                   white_albedo=ALBEDO, seed=7), grid=CAPTURE_GRID)
    return mat, folder, rep


def _truth(mat, grid):
    m = grid.mesh()
    return mat.evaluate(m["theta_v"], m["phi_v"], m["theta_l"], m["phi_l"], m["kappa"])


def _expected(mat, grid, **kw):
    m = grid.mesh()
    out = np.zeros(grid.shape + (mat.n_channels,))
    for idx in np.ndindex(grid.shape):
        out[idx] = expected_patch_value(mat, Stand(m["kappa"][idx]), m["theta_v"][idx], m["phi_v"][idx],
                                        m["theta_l"][idx], m["phi_l"][idx], **kw)
    return out


def _sigma_rel(x):
    e = x * NOISE.full_well
    return np.sqrt(e + NOISE.read_e ** 2) / e / N


def test_measured_agrees_within_noise(captured):
    mat, folder, rep = captured
    assert rep.n_images == CAPTURE_GRID.kappa.size * 144 + 12 and rep.n_saturated_pixels == 0
    table, mrep = measure(folder, fill="kappa-fit")  # the rig is tested here; docs/capture.md compares the fills
    assert table.quantity == "brdf"
    truth = _truth(mat, CAPTURE_GRID)
    cos_l = np.cos(np.radians(CAPTURE_GRID.mesh()["theta_l"]))[..., None]
    sigma = np.hypot(_sigma_rel(GAIN * truth * cos_l), _sigma_rel(GAIN * ALBEDO / math.pi * cos_l))
    meas = table.measured
    ideal = _expected(mat, CAPTURE_GRID, size=32, field_mm=2.0)
    rel_ideal = table.values / ideal - 1
    assert np.all(np.abs(rel_ideal[meas]) <= (5 * sigma + 0.002)[meas]), np.abs(rel_ideal[meas]).max()
    rel = table.values / truth - 1
    assert np.all(np.abs(rel[meas]) <= (5 * sigma + 0.01)[meas]), np.abs(rel[meas]).max()
    # the noise is really there (not a noise-free pass): the spread matches the prediction
    z = rel[meas] / sigma[meas]
    assert 0.5 < np.std(z) < 3.0


def test_hidden_marked_and_filled(captured):
    mat, folder, _ = captured
    table, rep = measure(folder, fill="kappa-fit")
    hid = hidden_mask(CAPTURE_GRID, [Stand(k) for k in CAPTURE_GRID.kappa], pixel_mm=2.0 / 32) > 0
    assert hid[0].any() and not hid[1:].any()
    np.testing.assert_array_equal(table.measured, ~hid)
    assert rep.n_hidden == hid.sum() == rep.n_filled
    # kappa-fit: from the same direction on the other stands
    per_k = int(np.prod(CAPTURE_GRID.shape[1:]))
    src = table.fill_sources[hid]
    assert (src[src >= 0] // per_k != 0).all() and (src[:, 0] % per_k == np.flatnonzero(hid.ravel()) % per_k).all()
    # the paper's rule: every filled sample copies a measured one of its own curvature
    table, rep = measure(folder, fill="nearest")
    src = table.fill_source[hid]
    assert np.all(src // per_k == 0)
    flat = table.values.reshape(-1, table.n_channels)
    np.testing.assert_array_equal(table.values[hid], flat[src])
    # no wall artefact: filled values lie within the measured range of that curvature
    meas0 = table.values[0][table.measured[0]]
    assert np.all(table.values[0][~table.measured[0]] <= meas0.max(axis=0))


def test_artefact_appears_without_stand_geometry(captured, tmp_path):
    """Measuring the hidden photographs anyway gives the wall's colour or a shadow."""
    mat, folder, _ = captured
    import shutil

    raw = tmp_path / "raw"
    shutil.copytree(folder, raw)
    (raw / "stands.json").write_text('{"white_albedo": 0.99}')
    import csv

    with open(raw / "capture.csv") as fh:
        rows = list(csv.DictReader(fh))
    for r in rows:
        r["hidden"] = ""  # forget the plan's marks too
    with open(raw / "capture.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    table, rep = measure(raw)
    assert rep.n_hidden == 0
    truth = _truth(mat, CAPTURE_GRID)
    hid = hidden_mask(CAPTURE_GRID, [Stand(k) for k in CAPTURE_GRID.kappa], pixel_mm=2.0 / 32) > 0
    rel = np.abs(table.values / truth - 1)
    assert np.median(rel[hid]) > 0.1  # far outside the noise
    assert np.median(rel[~hid]) < 0.01


def test_stand_meshes_match_geometry():
    st = Stand(-0.22, face_width_mm=6.0, wall_height_mm=1.0)
    parts = stand_meshes(st)
    fab = parts["fabric"]
    r = st.radius_mm
    # the fabric lies on the trough's circle, normals point to its axis
    p = fab["positions"]
    row = p[p[:, 1] == p[0, 1]]  # one cross-section
    np.testing.assert_allclose(np.hypot(p[:, 0], p[:, 2] - r), r, rtol=1e-12)
    np.testing.assert_allclose(fab["normals"], -np.stack([p[:, 0], 0 * p[:, 1], p[:, 2] - r], -1) / r, atol=1e-12)
    # u increases along +x (the bending direction)
    sel = p[:, 1] == p[0, 1]
    assert np.all(np.diff(fab["uv"][sel, 0]) > 0) and np.all(np.diff(row[:, 0]) > 0)
    # no sliver triangles: every edge is at most 0.5 mm long
    tri = p[fab["faces"]]
    edges = np.linalg.norm(tri - np.roll(tri, 1, axis=1), axis=-1)
    assert edges.max() < 0.51
    top = max(parts["wallR"]["positions"][:, 2])
    assert top == pytest.approx(st.edge_mm[1] + 1.0)


def test_cli_plan_simulate_measure(tmp_path, capsys):
    mat = material()
    mat.save(tmp_path / "mat.h5")
    plan = tmp_path / "plan"
    assert main(["-q", "plan", "-o", str(plan), "--kappa=-0.22,0.22", "--theta-step", "60",
                 "--theta-max", "60", "--phi-step", "180", "--no-picture"]) == 0
    cap = tmp_path / "cap"
    assert main(["-q", "simulate-capture", str(tmp_path / "mat.h5"), "-o", str(cap), "--plan",
                 str(plan / "capture.csv"), "--size", "16", "--field", "1", "--noise", "none"]) == 0
    out = tmp_path / "m.h5"
    assert main(["-q", "measure", str(cap), "-o", str(out)]) == 0
    t = cdbrdf.load(out)
    g = t.grid
    ideal = _expected(mat, g, size=16, field_mm=1.0)
    rel = np.abs(t.values / ideal - 1)[t.measured]
    assert rel.max() < 0.002
    assert (~t.measured).sum() > 0  # theta 60 along x on the concave stand


def test_brackets_rescue_saturation(tmp_path):
    """At gain 8 the long exposure saturates; the short one of each bracket is used."""
    mat = material()
    g = Grid(kappa=[0.0, 0.22], theta_l=[0.0, 45.0], phi_l=[0.0, 180.0], theta_v=[0.0, 45.0],
             phi_v=[0.0, 180.0])
    rep = simulate_capture(mat, tmp_path / "cap", RigOptions(size=16, field_mm=1.0, gain=8.0, exposures=(1.0, 0.1),
                                                             noise=NOISE, image_kind="png16"), grid=g)
    assert rep.n_saturated_pixels > 0
    table, mrep = measure(tmp_path / "cap")
    assert mrep.n_saturated == 0 and table.measured.all()
    truth = _truth(mat, g)
    ideal = _expected(mat, g, size=16, field_mm=1.0)
    cos_l = np.cos(np.radians(g.mesh()["theta_l"]))[..., None]
    sigma = np.hypot(_sigma_rel(0.8 * truth * cos_l), _sigma_rel(0.8 * ALBEDO / math.pi * cos_l))
    assert np.all(np.abs(table.values / ideal - 1) <= 5 * sigma + 0.002)


@pytest.mark.parametrize("kind", ["png8", "tif16", "exr"])
def test_other_image_kinds(tmp_path, kind):
    mat = material()
    g = Grid(kappa=[0.0], theta_l=[0.0, 45.0], phi_l=[0.0], theta_v=[0.0, 45.0], phi_v=[0.0, 180.0])
    simulate_capture(mat, tmp_path / "cap", RigOptions(size=16, field_mm=1.0, noise=NoiseModel(0, 0),
                                                       image_kind=kind), grid=g)
    table, _ = measure(tmp_path / "cap")
    tol = 0.02 if kind == "png8" else 1e-3
    np.testing.assert_allclose(table.values, _expected(mat, g, size=16, field_mm=1.0), rtol=tol)


def test_capture_lists_its_folder_a_bounded_number_of_times(tmp_path, monkeypatch):
    """The photographs go into the folder output_folder made (and swept): none sweeps it again.

    Sweeping per photograph listed the folder once per file, quadratic in the
    capture's size (the paper's 26,000 photographs took three times as long).
    """
    from cdbrdf import fsutil

    calls = []
    real = fsutil.sweep_stale
    monkeypatch.setattr(fsutil, "sweep_stale", lambda dest: calls.append(dest) or real(dest))
    mat = material()
    g = Grid(kappa=[0.0, 0.22], theta_l=[0.0, 30.0, 60.0], phi_l=[0.0, 180.0], theta_v=[0.0, 30.0, 60.0],
             phi_v=[0.0, 90.0, 180.0, 270.0])
    simulate_capture(mat, tmp_path / "cap", RigOptions(size=8, field_mm=1.0, noise=NoiseModel(0, 0)), grid=g)
    n_photos = sum(1 for p in (tmp_path / "cap").rglob("*.png"))
    assert n_photos >= 2 * 6 * 12
    assert len(calls) <= 10, f"{len(calls)} sweeps for {n_photos} photographs"


def test_plan_png_names_rendered_as_tiff_get_tif_names(tmp_path):
    """A plan's .png names rendered as TIFF/EXR: files and capture.csv carry the format's extension."""
    import csv

    from cdbrdf.images import read_image

    mat = material()
    g = Grid(kappa=[0.0], theta_l=[0.0], phi_l=[0.0], theta_v=[0.0, 45.0], phi_v=[0.0, 180.0])
    simulate_capture(mat, tmp_path / "plan", RigOptions(size=16, field_mm=1.0, noise=NoiseModel(0, 0)), grid=g)
    for kind, ext in (("tif16", ".tif"), ("exr", ".exr")):
        cap = tmp_path / kind
        simulate_capture(mat, cap, RigOptions(size=16, field_mm=1.0, noise=NoiseModel(0, 0), image_kind=kind),
                         plan=tmp_path / "plan" / "capture.csv")
        with open(cap / "capture.csv", newline="") as fh:
            names = [r["file"] for r in csv.DictReader(fh)]
        assert names and all(n.endswith(ext) for n in names)
        assert not list(cap.rglob("*.png"))
        for n in names:
            read_image(cap / n)
        table, _ = measure(cap)
        assert table.measured.all()


def test_noise_model_parse():
    assert NoiseModel.parse("none").enabled is False
    assert NoiseModel.parse("1000,2") == NoiseModel(1000.0, 2.0)
    with pytest.raises(ValueError, match="FULL_WELL"):
        NoiseModel.parse("lots")


@pytest.mark.parametrize("electrons", [40.0, 400.0, 4000.0, 20000.0])
def test_noise_has_the_photon_and_read_statistics(electrons):
    """Mean e and variance e + r^2 (in electrons), in both the Poisson and the normal regime.

    400,000 draws: the sample mean's standard error is sqrt(var / n), the sample
    variance's about var * sqrt(2 / n) (normal) plus the fourth moment of a
    Poisson (1 / e); 5 of those are allowed.
    """
    from cdbrdf.rig.sensor import POISSON_NORMAL_ELECTRONS

    n = 400_000
    x = np.full((n // 4, 2, 2), electrons / NOISE.full_well)
    got = NOISE.apply(x, np.random.default_rng(3)) * NOISE.full_well
    var = electrons + NOISE.read_e ** 2
    assert abs(got.mean() - electrons) < 5 * math.sqrt(var / n)
    assert abs(got.var() / var - 1) < 5 * math.sqrt(2 / n + 1 / (electrons * n))
    if electrons < POISSON_NORMAL_ELECTRONS:  # Poisson below: skewed like it (third moment e)
        skew = ((got - got.mean()) ** 3).mean() / electrons
        assert abs(skew - 1) < 0.3
    assert NoiseModel(0, 0).apply(x, np.random.default_rng(0)) is x


def test_camera_row_gives_each_pixel_the_ray_of_its_orthographic_camera():
    """The row's camera i is Mitsuba's orthographic sensor at sensor_to_world(view i), ray for ray."""
    import mitsuba as mi

    from cdbrdf.frames import direction_from_angles
    from cdbrdf.rig.camera import FAR_CLIP_MM, NEAR_CLIP_MM, camera_row, sensor_to_world

    render.set_variant()
    views = [direction_from_angles(tv, pv) for tv, pv in ((0, 0), (40, 30), (75, 250))]
    size, field = 16, 1.0
    row = camera_row(mi, views, size=size, field_mm=field, spp=1)
    assert tuple(row.film().size()) == (size * len(views), size)
    rng = np.random.default_rng(0)
    u, v = rng.random(50), rng.random(50)
    for i, view in enumerate(views):
        own = mi.load_dict({"type": "orthographic", "to_world": sensor_to_world(mi, view, size, field),
                            "near_clip": NEAR_CLIP_MM, "far_clip": FAR_CLIP_MM,
                            "film": {"type": "hdrfilm", "width": size, "height": size}})
        want, _ = own.sample_ray(0.0, 0.0, mi.Point2f(u, v), mi.Point2f(0.5, 0.5))
        got, w = row.sample_ray(0.0, 0.0, mi.Point2f((i + u) / len(views), v), mi.Point2f(0.5, 0.5))
        def xyz(p):
            return np.stack([np.broadcast_to(np.asarray(c), u.shape) for c in (p.x, p.y, p.z)])

        for a, b in ((got.o, want.o), (got.d, want.d)):
            np.testing.assert_allclose(xyz(a), xyz(b), atol=2e-5)  # mm: float32 rounding of 60 mm
        np.testing.assert_allclose(np.asarray(got.maxt), np.asarray(want.maxt), rtol=1e-6)
        np.testing.assert_allclose(np.asarray(w), 1.0)


def test_preset_denim_end_to_end(tmp_path):
    """The issue's 'done when' on a reduced grid: the denim preset, simulated and measured back."""
    from cdbrdf import materials
    mat = materials.load("denim")
    simulate_capture(mat, tmp_path / "cap", RigOptions(size=32, field_mm=2.0, noise=NOISE, gain=GAIN,
                                                       white_albedo=ALBEDO), grid=CAPTURE_GRID)
    table, rep = measure(tmp_path / "cap", fill="kappa-fit")
    assert rep.n_saturated == 0
    truth = _truth(mat, CAPTURE_GRID)
    cos_l = np.cos(np.radians(CAPTURE_GRID.mesh()["theta_l"]))[..., None]
    sigma = np.hypot(_sigma_rel(GAIN * truth * cos_l), _sigma_rel(GAIN * ALBEDO / math.pi * cos_l))
    ideal = _expected(mat, CAPTURE_GRID, size=32, field_mm=2.0)
    rel = table.values / ideal - 1
    meas = table.measured
    assert np.all(np.abs(rel[meas]) <= (5 * sigma + 0.002)[meas]), np.abs(rel[meas]).max()
    hid = hidden_mask(CAPTURE_GRID, [Stand(k) for k in CAPTURE_GRID.kappa], pixel_mm=2.0 / 32) > 0
    np.testing.assert_array_equal(table.measured, ~hid)


def test_expected_patch_value_limits():
    """A tiny field gives the table's node value; a flat stand gives it at any field."""
    mat = material()
    for k in (-0.22, 0.0, 0.22):
        node = mat.evaluate(60.0, 90.0, 30.0, 180.0, k)
        tiny = expected_patch_value(mat, Stand(k), 60.0, 90.0, 30.0, 180.0, size=64, field_mm=1e-4)
        np.testing.assert_allclose(tiny, node, rtol=1e-6)
    flat = expected_patch_value(mat, Stand(0.0), 45.0, 30.0, 30.0, 200.0, size=16, field_mm=5.0)
    np.testing.assert_allclose(flat, mat.evaluate(45.0, 30.0, 30.0, 200.0, 0.0), rtol=1e-12)


TINY_GRID = Grid(kappa=[0.0], theta_l=[0.0], phi_l=[0.0], theta_v=[0.0, 30.0], phi_v=[0.0])


def _tiny(folder, *, plan=None, progress=None, **options):
    opts = RigOptions(**{"size": 8, "spp": 1, "field_mm": 1.0, "noise": NoiseModel(0, 0), **options})
    return simulate_capture(material(), folder, opts, grid=TINY_GRID, plan=plan, progress=progress)


def test_simulate_capture_refuses_a_foreign_folder(tmp_path):
    cap = tmp_path / "cap"
    cap.mkdir()
    (cap / "mine.txt").write_text("user data\n")
    with pytest.raises(FileExistsError, match="not written by cdbrdf"):
        _tiny(cap)
    assert sorted(p.name for p in cap.iterdir()) == ["mine.txt"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cap"]


def test_simulate_capture_cli_refuses_a_foreign_folder_at_once(tmp_path, capsys):
    cap = tmp_path / "cap"
    cap.mkdir()
    (cap / "photo.png").write_bytes(b"x")
    assert main(["-q", "simulate-capture", "denim", "-o", str(cap)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "not written by cdbrdf" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cap"]


def test_simulate_capture_replaces_an_earlier_capture_whole(tmp_path):
    cap = tmp_path / "cap"
    rep = _tiny(cap)
    assert rep.folder == cap and (cap / "capture.csv").is_file()
    first = {str(p.relative_to(cap)) for p in cap.rglob("*.png")}
    _tiny(cap, exposures=(1.0, 0.5))
    names = {str(p.relative_to(cap)) for p in cap.rglob("*.png")}
    assert not names & first and any("_e1." in n for n in names)  # nothing of the first run mixed in
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cap"]  # no partial folder left


def test_resimulating_refuses_a_capture_holding_files_the_rig_did_not_write(tmp_path, capsys):
    """A table measured into a simulated capture, or the user's notes, were deleted without a word."""
    cap = tmp_path / "cap"
    _tiny(cap)
    measure(cap, cap / "result.h5")
    (cap / "notes.txt").write_text("my notes")
    before = sorted(str(p.relative_to(cap)) for p in cap.rglob("*"))
    with pytest.raises(FileExistsError, match=r"cap: holds 2 files that cdbrdf did not write there "
                                              r"\(notes.txt, result.h5\)"):
        _tiny(cap, seed=1)
    assert main(["-q", "simulate-capture", "denim", "-o", str(cap), "--size", "8", "--spp", "1"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "notes.txt, result.h5" in err and "move them away" in err
    assert sorted(str(p.relative_to(cap)) for p in cap.rglob("*")) == before
    assert (cap / "notes.txt").read_text() == "my notes" and cdbrdf.load(cap / "result.h5").measured.any()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cap"]


@pytest.mark.parametrize("exc", [RuntimeError("boom"), KeyboardInterrupt()])
def test_simulate_capture_failure_leaves_the_old_folder(tmp_path, exc):
    cap = tmp_path / "cap"
    _tiny(cap)
    before = sorted(str(p.relative_to(cap)) for p in cap.rglob("*"))

    def progress(done, total):
        if done >= 1:  # after the first rendering's photographs
            raise exc

    with pytest.raises(type(exc)):
        _tiny(cap, exposures=(1.0, 0.5), progress=progress)
    assert sorted(str(p.relative_to(cap)) for p in cap.rglob("*")) == before  # no "_e0" photograph mixed in
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cap"]


def test_simulate_capture_cli_interrupt_leaves_nothing(tmp_path, monkeypatch, capsys):
    import cdbrdf.rig.simulate as simulate

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(simulate, "write_photograph", interrupted)
    mat = tmp_path / "mat.h5"
    material().save(mat)
    assert main(["-q", "simulate-capture", str(mat), "-o", str(tmp_path / "cap"), "--size", "8"]) == 130
    assert sorted(p.name for p in tmp_path.iterdir()) == ["mat.h5"]


def test_simulate_capture_large_seed(tmp_path):
    """Seeds up to 2**32 - 1 are accepted (Mitsuba's seed is derived modulo 2**32)."""
    _tiny(tmp_path / "cap", seed=2**32 - 1)
    assert (tmp_path / "cap" / "capture.csv").is_file()


# --------------------------------------------------------------------------- plans checked before rendering
def _plan_with(tmp_path, edits):
    """A plan of 36 photographs + 6 white references; ``edits``: {line number: new line}."""
    from cdbrdf.measure.plan import write_plan

    write_plan(tmp_path / "plan", Grid(kappa=[0.0], theta_l=[0.0, 40.0], phi_l=[0.0, 120.0, 240.0],
                                       theta_v=[0.0, 40.0], phi_v=[0.0, 120.0, 240.0]), [Stand(0.0)])
    p = tmp_path / "plan" / "capture.csv"
    lines = p.read_text().splitlines()
    for n, text in edits.items():
        lines[n - 1] = text
    p.write_text("\n".join(lines) + "\n")
    return p


BAD_PLANS = [
    ({3: "../victim.png,0,40,0,0,0,1,sample,"}, "line 3: file '../victim.png' has a '..' component"),
    ({4: "{victim2},0,0,120,0,0,1,sample,"}, "line 4: file '.*victim2.png' is an absolute path"),
    ({3: "k0/l0_0_v0_0.png,0,40,0,0,0,1,sample,"}, "line 3: file 'k0/l0_0_v0_0.png' is also the file of line 2"),
    ({3: "k0/a.png,0,95,0,0,0,1,sample,"}, r"line 3: theta_v = 95 is outside \[0, 90\)"),
    ({3: "k0/a.png,0,nan,0,0,0,1,sample,"}, "line 3: column 'theta_v': 'nan' is not finite"),
    ({3: "k0/a.png,0,40,0,-5,0,1,sample,"}, "line 3: theta_l = -5 is outside"),
    ({3: "k0/a.png,0,40,0,0,0,0,sample,"}, "line 3: exposure must be positive"),
    ({3: "k0/a.png,0,40,0,0,0,1e308,sample,"}, "line 3: exposure 1e.308 is outside"),
    ({3: "k0/a.png,0,40,0,0,0,1,bogus,"}, "line 3: kind 'bogus' is not one of"),
    ({3: "k0/a.png,0,41,0,0,0,1,sample,"}, "line 3: theta_v = 41 is used by 1 sample condition"),
]


@pytest.mark.parametrize("edits, msg", BAD_PLANS, ids=[m.split(": ", 1)[1][:30] for _, m in BAD_PLANS])
def test_bad_plan_is_refused_before_anything_is_rendered(tmp_path, monkeypatch, capsys, edits, msg):
    import cdbrdf.rig.simulate as simulate

    victim, victim2 = tmp_path / "victim.png", tmp_path / "victim2.png"
    victim.write_text("precious user data")
    victim2.write_text("precious")
    plan = _plan_with(tmp_path, {n: t.format(victim2=victim2) for n, t in edits.items()})
    rendered = []
    monkeypatch.setattr(simulate, "write_photograph", lambda path, *a: rendered.append(path))
    with pytest.raises(cdbrdf.errors.CaptureError, match=rf"plan/capture.csv: {msg}"):
        _tiny(tmp_path / "out", plan=plan)
    os_cwd = tmp_path / "run"
    os_cwd.mkdir()
    monkeypatch.chdir(os_cwd)
    assert main(["-q", "simulate-capture", "denim", "-o", "out", "--plan", str(plan), "--size", "8",
                 "--spp", "1"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "plan/capture.csv: line" in err
    assert rendered == [] and not (tmp_path / "out").exists() and list(os_cwd.iterdir()) == []
    assert victim.read_text() == "precious user data" and victim2.read_text() == "precious"


def test_plan_grid_of_stands_json_is_kept_for_the_measurement(tmp_path):
    """A plan whose stands.json lists the grid: the capture keeps it, so measure builds that grid."""
    import json

    plan = _plan_with(tmp_path, {})
    doc = json.loads((plan.parent / "stands.json").read_text())
    doc["grid"] = {"kappa": [0], "theta_l": [0, 40], "phi_l": [0, 120, 240], "theta_v": [0, 40, 60],
                   "phi_v": [0, 120, 240]}
    (plan.parent / "stands.json").write_text(json.dumps(doc))
    _tiny(tmp_path / "cap", plan=plan)
    assert json.loads((tmp_path / "cap" / "stands.json").read_text())["grid"] == doc["grid"]
    table, _ = measure(tmp_path / "cap")
    assert list(table.theta_v) == [0, 40, 60] and not table.measured[..., 2].any()


@pytest.mark.parametrize("kw, match", [
    ({"image_kind": "jpeg"}, "image_kind: 'jpeg' is not one of png16"),
    ({"size": 4}, r"size: expected an integer in \[8, 8192\], got 4"),
    ({"size": 16.0}, "size: expected an integer"),
    ({"spp": 0}, r"spp: expected an integer in \[1, 65536\], got 0"),
    ({"field_mm": float("nan")}, r"field_mm: expected a number in \(0, 10000\] mm, got nan"),
    ({"gain": -1}, r"gain: expected a number in \(0, 1e\+12\]"),
    ({"white_albedo": 0}, r"white_albedo: expected a number in \(0, 1.5\], got 0"),
    ({"white_albedo": 1.6}, r"white_albedo: expected a number in \(0, 1.5\]"),
    ({"exposures": ()}, "exposures: expected 1 to 16 numbers, got 0"),
    ({"exposures": (1.0, -1.0)}, "exposures: expected a number in"),
    ({"px_per_texel": 100}, r"px_per_texel: expected a number in \[0.5, 64\]"),
    ({"seed": 2**32}, "seed: expected an integer in"),
    ({"noise": "20000,3"}, "noise: expected a cdbrdf.rig.NoiseModel"),
])
def test_rig_options_refuse_a_bad_option_when_made(tmp_path, kw, match):
    """Checked once, when the record is made: before a folder is touched."""
    with pytest.raises(cdbrdf.errors.OptionError, match=match):
        simulate_capture(material(), tmp_path / "cap", RigOptions(**kw))
    assert list(tmp_path.iterdir()) == []


def test_simulate_capture_takes_its_former_keywords_with_a_warning(tmp_path):
    """The migration path: the options as keywords still work, with a DeprecationWarning."""
    with pytest.warns(DeprecationWarning, match="pass a cdbrdf.rig.RigOptions"):
        rep = simulate_capture(material(), tmp_path / "cap", grid=TINY_GRID, size=8, spp=1, field_mm=1.0,
                               noise=NoiseModel(0, 0))
    assert rep.n_images > 0
    with pytest.warns(DeprecationWarning), pytest.raises(cdbrdf.errors.OptionError, match="unknown option 'colour'"):
        simulate_capture(material(), tmp_path / "cap2", colour="red")


def test_simulate_capture_command_takes_the_records_ranges(tmp_path, capsys):
    """The command line and the library accept the same white reference (the capture format's range)."""
    mat = tmp_path / "mat.h5"
    material().save(mat)
    with pytest.raises(SystemExit):
        main(["-q", "simulate-capture", str(mat), "-o", str(tmp_path / "c1"), "--white-albedo", "1.6"])
    assert "(0, 1.5]" in capsys.readouterr().err
    assert RigOptions(white_albedo=1.2).white_albedo == 1.2  # what stands.json accepts, the library takes
