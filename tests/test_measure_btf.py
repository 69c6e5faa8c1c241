"""From photographs to a CD-BTF: the rig lays a known CD-BTF on the stands, ``measure(..., btf=N)`` gets it back.

Ground truth: the CD-BTF the rig renders, decoded at the texel centres and
grid samples (:meth:`cdbrdf.CDBTF.decode`), compared on the samples the
measurement marks measured (not filled). The texels are independent random
multiples (0.5 to 1.5) of a glossy lobe, the hardest case for the
rectification (no two neighbours alike). The error budget (docs/capture.md,
"Measuring a CD-BTF"): photon noise (about 0.5 % per texel at 3 px per
texel) and, on a curved stand, the normal's turn over the texels' distance
from the crest (``kappa * size_u / 2`` rad without a scan).
"""

from __future__ import annotations

import json
import math
import shutil

import numpy as np
import pytest

from cdbrdf import CDBTF, Grid
from cdbrdf.btf import load as load_btf
from cdbrdf.cli import main
from cdbrdf.errors import CaptureError, OptionError
from cdbrdf.frames import direction_from_angles
from cdbrdf.measure import measure
from cdbrdf.measure.btf import BTFReport, view_geometry
from cdbrdf.measure.registration import face_hits, face_points, image_axes, parse_registration
from cdbrdf.measure.stands import Stand

from .render_helpers import require_llvm_module  # noqa: E402

require_llvm_module()

from cdbrdf.rig import RigOptions, simulate_capture  # noqa: E402

SMALL = Grid.regular(theta_step_deg=40, phi_step_deg=90, theta_max_deg=40, kappa=[0.0, 0.22])
FULL = Grid.regular(theta_step_deg=30, phi_step_deg=90, theta_max_deg=60, kappa=[-0.22, 0.0, 0.22])


def texture(grid: Grid, texels: int, repeat_mm: tuple[float, float], seed: int = 3) -> CDBTF:
    """Random texel multiples of a glossy, curvature-dependent lobe (exactly representable: max_error 1e-4)."""
    rng = np.random.default_rng(seed)
    m = grid.mesh()
    h = direction_from_angles(m["theta_l"], m["phi_l"]) + direction_from_angles(m["theta_v"], m["phi_v"])
    h /= np.linalg.norm(h, axis=-1, keepdims=True)
    base = (0.05 + 0.3 * np.clip(h[..., 2], 0, 1) ** 8 * (1 + m["kappa"]))[..., None] * [1.0, 0.7, 0.4]
    tilt = (0.05 * h[..., 0] * (1 + m["kappa"]))[..., None] * [0.2, 0.3, 0.6]
    w = rng.uniform(-1, 1, (texels, texels, 1))[..., None, None, None, None, None]
    vals = np.maximum(base[None, None] * (1 + 0.5 * w) + w * tilt, 0.0)
    return CDBTF.from_values(vals, grid, repeat_mm=repeat_mm, max_error=1e-4,
                             attrs={"material": "test-texels", "quantity": "brdf"})


def errors(truth: CDBTF, got: CDBTF, measured: np.ndarray) -> tuple[float, list[float]]:
    """Median relative error on the measured samples: all, and per curvature."""
    t = truth.decode()
    rel = np.abs(got.decode() - t) / np.maximum(np.abs(t), 1e-6)
    per = [float(np.median(rel[:, :, k][:, :, measured[k]])) for k in range(measured.shape[0])]
    return float(np.median(rel[:, :, measured])), per


@pytest.fixture(scope="module")
def small(tmp_path_factory):
    btf = texture(SMALL, 4, (0.3, 0.3))
    folder = tmp_path_factory.mktemp("btf") / "cap"
    simulate_capture(btf, folder, RigOptions(seed=1))
    return btf, folder


def test_rig_to_measure_btf_recovers_the_texels(small):
    """The fast end-to-end check: 4 x 4 texels, a flat and a convex stand, within 3 % median; the tile mean
    is the plain measurement's with a patch of one repeat (12 pixels of 0.3 / 12 mm at the normal view)."""
    btf, folder = small
    got, rep = measure(folder, btf=4)
    assert isinstance(got, CDBTF) and isinstance(rep, BTFReport)
    assert got.texels == (4, 4) and got.repeat_mm == pytest.approx((0.3, 0.3)) and got.grid == SMALL
    assert rep.px_per_texel >= 2.5 and rep.measured is not None and rep.measured.sum() == rep.n_measured >= 80
    assert got.attrs["quantity"] == "brdf" and got.attrs["provenance"]["method"] == "measured_btf"
    med, per = errors(btf, got, rep.measured)
    assert med <= 0.03 and max(per) <= 0.03, (med, per)
    # the tile mean keeps which samples were measured and how the others were filled, in the file too
    np.testing.assert_array_equal(got.mean().measured, rep.measured)
    assert np.all(got.mean().fill_source[~rep.measured] >= 0) and np.all(got.mean().fill_source[rep.measured] == -1)
    got.save(folder.parent / "m.h5")
    np.testing.assert_array_equal(load_btf(folder.parent / "m.h5").mean().measured, rep.measured)
    pixel_mm = json.loads((folder / "stands.json").read_text())["pixel_mm"]
    plain, _ = measure(folder, patch=round(0.3 / pixel_mm))
    diff = np.abs(got.mean().values - plain.values) / plain.values
    assert np.median(diff[rep.measured]) <= 0.02


def test_registration_is_written_and_the_photographs_resolve_the_texels(small):
    btf, folder = small
    doc = json.loads((folder / "stands.json").read_text())
    reg = parse_registration(doc["registration"], "stands.json")
    assert reg.camera == "orthographic" and reg.repeat_mm == pytest.approx(btf.repeat_mm)
    assert sorted(reg.origins) == [0.0, 0.22]
    assert all(0 <= u < 0.3 and 0 <= v < 0.3 for u, v in reg.origins.values())
    assert doc["pixel_mm"] <= 0.3 / 4 / 3 + 1e-12  # 3 px per texel by default


@pytest.mark.parametrize("kappa", [0.22, 0.0, -0.22])
def test_the_camera_model_maps_the_face_to_pixels_and_back(kappa):
    """face_points -> image coordinates -> face_hits gives the arc length and height back."""
    st = Stand(kappa)
    v = direction_from_angles(35.0, 120.0)
    s, y = np.linspace(-0.8, 0.8, 9), np.linspace(-0.5, 0.5, 9)
    p, n = face_points(st, s, y)
    assert np.allclose(np.linalg.norm(n, axis=-1), 1.0)
    right, down = image_axes(v)
    assert abs(right @ v) < 1e-12 and abs(down @ v) < 1e-12 and abs(right @ down) < 1e-12
    o = (p @ right)[:, None] * right + (p @ down)[:, None] * down  # the ray through each point's pixel
    q, n2, _t, s2 = face_hits(st, o, v)
    np.testing.assert_allclose(q, p, atol=1e-9)
    np.testing.assert_allclose(s2, s, atol=1e-9)
    np.testing.assert_allclose(n2, n, atol=1e-9)


def test_the_camera_model_is_the_rigs_sensor():
    """A pixel's ray in the rig's Mitsuba camera passes where the registration's camera model puts it."""
    import cdbrdf.render as cr
    from cdbrdf.rig.camera import _ray_map

    size, field = 40, 2.0
    views = [direction_from_angles(t, p) for t, p in ((0.0, 0.0), (50.0, 30.0), (70.0, 250.0))]
    with cr.variant():
        import mitsuba as mi

        origin, d_u, d_v, _d = _ray_map(mi, views, size, field)
    px = field / size
    for k, v in enumerate(views):
        right, down = image_axes(v)
        for col, row in ((3, 5), (20, 20), (31, 9)):
            o = origin[k] + (col + 0.5) / size * d_u[k] + (row + 0.5) / size * d_v[k]
            o -= (o @ v) * v  # onto the plane through the stand's centre
            want = (col - size // 2) * px * right + (row - size // 2) * px * down
            np.testing.assert_allclose(o, want, atol=1e-4)


def test_too_coarse_a_camera_is_one_line():
    with pytest.raises(CaptureError, match="theta_v = 0 degrees .* do not resolve 16 x 16 texels") as e:
        view_geometry(Stand(0.0), (0.0, 0.0), np.array([0.0, 0.0, 1.0]), width=64, height=64, cx=None, cy=None,
                      pixel_mm=0.05, texels=(16, 16), repeat_mm=(0.4, 0.4))
    assert "\n" not in str(e.value)


def test_capture_without_registration_is_refused_in_one_line(small, tmp_path, capsys):
    shutil.copytree(small[1], tmp_path / "cap")
    doc = json.loads((tmp_path / "cap" / "stands.json").read_text())
    del doc["registration"]
    (tmp_path / "cap" / "stands.json").write_text(json.dumps(doc))
    with pytest.raises(CaptureError, match="no registration"):
        measure(tmp_path / "cap", btf=2)
    assert main(["-q", "measure", str(tmp_path / "cap"), "--btf", "2", "-o", str(tmp_path / "b.h5")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "no registration" in err and not (tmp_path / "b.h5").exists()


@pytest.mark.parametrize("texels, match", [(0, "btf: expected"), (257, "btf: expected"), ((2, 3, 4), "btf: expected"),
                                           (True, "btf: expected")])
def test_bad_texels_are_an_option_error(tmp_path, texels, match):
    with pytest.raises(OptionError, match=match):
        measure(tmp_path, btf=texels)


def test_cli_texels_out_of_range_is_one_line(tmp_path, capsys):
    with pytest.raises(SystemExit):
        main(["measure", str(tmp_path), "--btf", "0", "-o", str(tmp_path / "b.h5")])
    assert "--btf" in capsys.readouterr().err


def test_registration_errors_are_one_line():
    for doc, match in (([], "expected an object"), ({"version": 2}, "newer"), ({"camera": "pinhole"}, "camera"),
                       ({"stands": [{"kappa": 0.0}]}, "stand 0"), ({"repeat_mm": [1.0, -1.0]}, "positive"),
                       ({"foo": 1}, "unknown keys"), ({"repeat_mm": [10**400, 1.0]}, "out of range"),
                       ({"repeat_mm": [1e300, 1.0]}, "at most")):
        with pytest.raises(CaptureError, match=match) as e:
            parse_registration(doc, "stands.json")
        assert "\n" not in str(e.value)


@pytest.mark.slow
def test_cli_simulate_and_measure_a_btf_file(tmp_path, capsys):
    """``cdbrdf simulate-capture B.h5`` then ``cdbrdf measure --btf``: a CD-BTF file back, within 3 %."""
    from cdbrdf.btf import load

    btf = texture(SMALL, 4, (0.4, 0.3), seed=5)
    btf.save(tmp_path / "truth.h5")
    assert main(["-q", "simulate-capture", str(tmp_path / "truth.h5"), "-o", str(tmp_path / "cap"),
                 "--px-per-texel", "3"]) == 0
    assert main(["measure", str(tmp_path / "cap"), "--btf", "4", "-o", str(tmp_path / "m.h5")]) == 0
    out = capsys.readouterr().out
    assert "CD-BTF: 4 x 4 texels" in out
    got = load(tmp_path / "m.h5")
    assert got.attrs["provenance"]["n_measured"] >= 80
    _, rep = measure(tmp_path / "cap", btf=4)  # the file keeps no per-sample mask: the report's
    med, per = errors(btf, got, rep.measured)
    assert med <= 0.03 and max(per) <= 0.03, (med, per)


@pytest.mark.slow
@pytest.mark.parametrize("shifts", [1, 4])
def test_denim_sized_repeat_on_the_paper_stands(tmp_path, shifts):
    """8 x 8 texels of a 1.6 x 1.2 mm repeat on kappa -0.22, 0, 0.22. Without a scan the normal turns by up
    to kappa * 0.8 mm = 10 degrees at the repeat's edge on the curved stands (about 6 to 8 % median there);
    with four positions of the fabric each texel is taken within 0.2 mm of the crest: within 3 % on every
    stand. The tile mean agrees with the model's tile mean, and (four positions, so the plain patches
    sample four places of the repeat) with the plain measurement of the same photographs."""
    btf = texture(FULL, 8, (1.6, 1.2))
    simulate_capture(btf, tmp_path / "cap", RigOptions(seed=1, shifts=shifts))
    got, rep = measure(tmp_path / "cap", btf=8)
    med, per = errors(btf, got, rep.measured)
    assert med <= 0.03 and per[1] <= 0.01, (med, per)
    if shifts == 1:
        assert min(per[0], per[2]) > 0.03  # the turn of the normal: what the scan removes
        return
    assert max(per) <= 0.03, per
    m = rep.measured
    tile = np.abs(got.mean().values - btf.mean().values) / btf.mean().values
    assert np.median(tile[m]) <= 0.02
    plain, _ = measure(tmp_path / "cap")
    diff = np.abs(got.mean().values - plain.values) / plain.values
    assert np.median(diff[m]) <= 0.05 and math.isfinite(float(diff.max()))


def test_a_scan_interpolates_each_texel_to_the_crest():
    """Texels linear in their arc length from the crest come back exactly at s = 0; one-sided: the nearest."""
    from cdbrdf.measure.btf import _at_the_crest

    s = np.array([[0.1, -0.2, 0.3], [-0.3, 0.2, 0.5]])  # two positions, three texels (the last: one side only)
    truth = np.array([[1.0, 2.0], [3.0, 4.0], [5.0, 6.0]])  # (texels, channels) at s = 0
    slope = np.array([0.5, -1.0])
    found = [(truth + s[p][:, None] * slope, s[p]) for p in range(2)]
    got = _at_the_crest(found)
    np.testing.assert_allclose(got[:2], truth[:2], rtol=1e-12)
    np.testing.assert_allclose(got[2], truth[2] + 0.3 * slope, rtol=1e-12)


def test_unusable_photographs_are_listed_then_the_list_goes_with_a_good_run(small, tmp_path):
    """As the CDBRDF path: a damaged photograph stops the run with FILE.bad.txt; once repaired, the
    successful run removes the stale list; the list beside an input is refused before anything is read."""
    from cdbrdf.measure.preflight import UnusablePhotographs

    cap = tmp_path / "cap"
    shutil.copytree(small[1], cap)
    victims = [p for p in sorted((cap / "k0").rglob("*")) if p.suffix in (".png", ".tif", ".tiff", ".exr")][:2]
    good = [v.read_bytes() for v in victims]
    for v in victims:
        v.write_bytes(b"not an image")
    out = tmp_path / "b.h5"
    with pytest.raises(UnusablePhotographs, match="2 photographs cannot be used .*b.h5.bad.txt"):
        measure(cap, out, btf=4)
    listing = tmp_path / "b.h5.bad.txt"
    assert all(v.name in listing.read_text() for v in victims) and not out.exists()
    for v, data in zip(victims, good):
        v.write_bytes(data)
    measure(cap, out, btf=4)
    assert out.exists() and not listing.exists()
