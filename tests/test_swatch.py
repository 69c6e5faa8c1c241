"""The swatch (cdbrdf.mesh.Swatch): folds of known radii, analytic curvature, its scene.

Its profile is circular arcs and straight pieces joined without a kink, so
the curvature is known exactly: +-1/R on the arcs, 0 elsewhere. It is
checked three ways: the geometry (arc vertices lie on circles of radius R,
the tangent turns continuously), the curvature fitted from the mesh alone
(:func:`cdbrdf.mesh.max_curvature`) against the analytic one inside every
arc, and the curvature Mitsuba's own intersections see in a tiny render.
"""

from __future__ import annotations

import numpy as np
import pytest

import cdbrdf
from cdbrdf.mesh import SurfaceMaps, Swatch, max_curvature, swatch_curvature, swatch_mesh

from .render_helpers import needs_llvm


def _profile(sw, m):
    """The vertices of the first row (y = -depth / 2): x, z, normal, curvature."""
    ny = sw.grid_shape[1]
    first = np.arange(0, m.n_vertices, ny)
    return m.vertices[first, 0], m.vertices[first, 2], m.normals[first], m.attributes["curvature"][first]


def test_swatch_geometry_is_arcs_of_the_given_radii():
    sw = Swatch(radii_mm=(20.0, -10.0, 5.0, 3.0), depth_mm=4.0)
    m = swatch_mesh(sw)
    x, z, n, k = _profile(sw, m)
    assert m.faces.shape[0] == sw.face_count and (len(x), sw.grid_shape[1]) == sw.grid_shape
    assert x.min() == pytest.approx(-sw.width_mm / 2) and x.max() == pytest.approx(sw.width_mm / 2)
    assert np.all(np.diff(x) > 0)  # a height field across the folds: every slope below 90 degrees
    # the flat cloth at both ends lies at z = 0 and is flat
    assert z[0] == 0.0 and z[-1] == pytest.approx(0.0, abs=1e-9) and k[0] == 0.0 and k[-1] == 0.0
    # slopes: the steepest is the swatch's slope_deg; normals are unit and up
    slope = np.degrees(np.arctan(np.abs(n[:, 0] / n[:, 2])))
    assert slope.max() == pytest.approx(sw.slope_deg, abs=1e-9)
    np.testing.assert_allclose(np.linalg.norm(n, axis=1), 1.0)
    assert np.all(n[:, 2] > 0)
    # each fold's crest (|kappa| = 1/R, sign of R) lies on a circle of radius |R|: fit it
    for r in sw.radii_mm:
        on = np.flatnonzero(np.isclose(k, 1.0 / r, rtol=1e-12))
        # the crest of a ridge (r > 0) is its longest arc; a groove's bottom likewise
        runs = np.split(on, np.flatnonzero(np.diff(on) > 1) + 1)
        arc = max(runs, key=len)
        px, pz = x[arc], z[arc]
        a = np.c_[2 * px, 2 * pz, np.ones(len(px))]
        cx, cz, c = np.linalg.lstsq(a, px**2 + pz**2, rcond=None)[0]
        radius = np.sqrt(c + cx**2 + cz**2)
        assert radius == pytest.approx(abs(r), rel=1e-9)
        assert (cz < pz.mean()) == (r > 0)  # a ridge's centre lies below its crest: convex, kappa > 0
    # the normal turns continuously: no kink where the pieces meet
    turn = np.degrees(np.arccos(np.clip(np.sum(n[1:] * n[:-1], axis=1), -1, 1)))
    assert turn.max() < 360 * sw.step_mm / (2 * np.pi * min(abs(r) for r in sw.radii_mm)) + 1e-6


def test_swatch_curvature_function_and_mesh_agree():
    sw = Swatch()
    m = swatch_mesh(sw)
    x, _, _, k = _profile(sw, m)
    np.testing.assert_array_equal(swatch_curvature(x, sw), k)
    assert sorted(set(np.round(k[k > 0], 12))) == pytest.approx(
        sorted({1 / r for r in sw.radii_mm} | {0.5 / r for r in sw.radii_mm}))  # arcs; joins of an arc and a line
    assert swatch_curvature([-1e3, 1e3], sw).tolist() == [0.0, 0.0]
    np.testing.assert_array_equal(m.attributes["curvature_dir"], m.attributes["curvature"])
    assert m.metadata["units"] == "mm" and m.metadata["up"] == "z" and m.metadata["frame"] == "uv"
    # u runs along the cloth across the folds (its arc length), v along them
    u = m.uv.reshape(len(x), -1, 2)
    assert u[0, 0, 0] == 0.0 and u[-1, 0, 0] == pytest.approx(1.0) and np.all(np.diff(u[:, 0, 0]) > 0)
    assert sw.length_mm > sw.width_mm  # the cloth is longer than the ground it covers


def test_fitted_curvature_matches_the_analytic_inside_every_arc():
    """:func:`max_curvature` from the mesh alone, against the analytic curvature, 0.5 mm neighbourhood."""
    sw = Swatch(radii_mm=(20.0, -10.0, 5.0, 3.0), depth_mm=6.0, step_mm=0.1, row_mm=0.25)
    m = swatch_mesh(sw)
    nb = 0.5
    k = max_curvature(m.vertices, m.faces, neighbourhood_mm=nb)
    truth = m.attributes["curvature"]
    x, y = m.vertices[:, 0], m.vertices[:, 1]
    px, _, _, pk = _profile(sw, m)
    joins = px[1:][np.diff(pk) != 0]
    clear = (np.abs(y) < sw.depth_mm / 2 - 2 * nb) & (np.min(np.abs(x[:, None] - joins[None, :]), axis=1) > nb + 0.05)
    for r in sw.radii_mm:
        for sign in (1.0, -1.0):  # each fold has arcs of both signs (a ridge's crest and its feet)
            sel = clear & np.isclose(truth, sign / r)
            assert sel.sum() >= 10, (r, sign)
            np.testing.assert_allclose(k[sel], sign / r, rtol=1e-3)
    flat = clear & (truth == 0)
    assert flat.sum() > 100 and np.abs(k[flat]).max() < 1e-6


@pytest.mark.parametrize("kwargs, message", [
    ({"radii_mm": ()}, "radii_mm: give 1 to 32 folds, got 0"),
    ({"radii_mm": (20.0, 0.0)}, "radii_mm: 0 mm is not a radius between 0.5 and 1000 mm"),
    ({"radii_mm": (20.0, float("nan"))}, "radii_mm: nan mm is not a radius"),
    ({"radii_mm": "20"}, "radii_mm: expected signed radii in mm, got '20'"),
    ({"radii_mm": 20.0}, "radii_mm: expected signed radii in mm"),
    ({"slope_deg": 85.0}, "slope_deg: expected (0, 80] degrees"),
    ({"gap_mm": -1.0}, "gap_mm: must be a non-negative length in mm"),
    ({"depth_mm": 0.0}, "depth_mm: must be a positive length in mm"),
    ({"step_mm": float("inf")}, "step_mm: must be a positive length in mm"),
])
def test_swatch_refuses_bad_geometry(kwargs, message):
    with pytest.raises(ValueError) as info:
        Swatch(**kwargs)
    assert str(info.value).startswith(message)


def test_scene_registry():
    from cdbrdf.render.spec import SCENES, check_scene_name

    assert list(SCENES) == ["sine", "swatch"]
    assert check_scene_name("swatch") == "swatch"
    with pytest.raises(ValueError, match="scene: 'plane' is not one of sine, swatch"):
        check_scene_name("plane")


@needs_llvm
def test_swatch_renders_with_the_curvature_of_its_folds():
    """What Mitsuba's intersections see on the swatch: the folds' +-1/R, and a studio picture."""
    from cdbrdf.render import RenderSpec, render_table

    g = cdbrdf.Grid(kappa=[-0.3, 0.0, 0.3], theta_l=[0, 45, 75], phi_l=[0, 180], theta_v=[0, 45, 75],
                    phi_v=[0, 180])
    table = cdbrdf.CDBRDF(np.full(g.shape + (3,), 0.5 / np.pi), g, attrs={"quantity": "brdf"})
    sw = Swatch(radii_mm=(20.0, 5.0))
    pic = render_table(table, RenderSpec(surface=sw, size=(64, 40), spp=1, curvature_image=True,
                                         modes=("brdf", "cdbrdf")))
    assert pic.surface == "swatch" and pic.lighting == "studio" and pic.backdrop and pic.mesh is None
    seen = pic.curvature[np.isfinite(pic.curvature)]
    assert seen.size > 0.3 * pic.curvature.size  # the swatch fills the picture
    for r in sw.radii_mm:  # every fold's crest and feet are seen (pixels within 2 % of +-1/R)
        for sign in (1.0, -1.0):
            assert np.sum(np.isclose(seen, sign / r, rtol=0.02)) >= 3, (r, sign)
    assert np.all(np.abs(seen) <= 1 / 5.0 + 1e-3)
    assert np.mean(seen == 0.0) > 0.2  # the flat cloth between the folds
    with pytest.raises(ValueError, match="maps: only for meshes"):
        RenderSpec(surface="swatch", size=(8, 8), spp=1, maps=SurfaceMaps(normal_map="x.png"))


@needs_llvm
def test_render_command_swatch_close_up_and_compare(tmp_path, capsys):
    from cdbrdf.cli import main

    g = cdbrdf.Grid(kappa=[-0.2, 0.0, 0.2], theta_l=[0, 45, 75], phi_l=[0, 180], theta_v=[0, 45, 75],
                    phi_v=[0, 180])
    k = np.asarray(g.kappa)[:, None, None, None, None, None]
    cdbrdf.CDBRDF(np.broadcast_to(0.2 + k, g.shape + (3,)).copy(), g,
                  attrs={"quantity": "brdf", "material": "ramp"}).save(tmp_path / "t.h5")
    common = ["render", str(tmp_path / "t.h5"), "--scene", "swatch", "--size", "32x24", "--spp", "1"]
    assert main([*common, "--fold-radii", "10,-4", "--look-at", "crest", "--zoom", "3", "--fov", "30",
                 "-o", str(tmp_path / "a.png")]) == 0
    err = capsys.readouterr().err
    assert "swatch: ridge 10 mm (kappa +-0.1 / mm), groove 4 mm (kappa +-0.25 / mm); lighting: studio" in err
    import matplotlib.image as mpimg

    assert mpimg.imread(tmp_path / "a.png").shape[:2] == (24, 32)
    assert main(["-q", *common, "--compare", "--delta-e", "ab", "-o", str(tmp_path / "c.png")]) == 0
    assert (tmp_path / "c.png").stat().st_size > 1000
