"""Tests of cdbrdf.mesh: accuracy on irregular meshes, units, noise, repairs, frames, the directional mode.

Known answers: a cylinder of radius r has principal curvatures 1/r (across
its axis) and 0; a sphere of radius R has 1/R everywhere; the sine sheet's
curvature is analytic. Signs: > 0 where the surface bends away from its
normal (convex).
"""

from __future__ import annotations

import numpy as np
import pytest

from cdbrdf.errors import MeshError
from cdbrdf.mesh import (
    CURVATURE_MODES,
    DEFAULT_NEIGHBOURHOOD_MM,
    SineSheet,
    Skirt,
    check_kappa_range,
    max_curvature,
    neighbourhood_from_table,
    parse_units,
    principal_curvatures,
    repair,
    sine_sheet_curvature,
    sine_sheet_height,
    sine_sheet_mesh,
    skirt_mesh,
    surface_curvature,
)

from .mesh_helpers import R_CYL, cylinder_patch, jittered_uv, shared_mesh, sphere_mesh

R_SPHERE = 10.0  # mm


def rel_err(k, truth):
    return np.abs(k - truth) / abs(truth)


# -- accuracy on irregular meshes --------------------------------------------------
@pytest.mark.parametrize("convex", [True, False])
def test_cylinder_curvature_accuracy_and_sign(convex):
    v, f, uv, interior = cylinder_patch(R_CYL, convex=convex)
    assert 15000 <= v.shape[0] <= 30000
    k = max_curvature(v, f)
    truth = 0.22 if convex else -0.22
    assert np.median(rel_err(k[interior], truth)) <= 0.01
    assert np.mean(np.sign(k[interior]) == np.sign(truth)) > 0.999


def test_cylinder_principal_directions():
    v, f, uv, interior = cylinder_patch(R_CYL, convex=True)
    pc = principal_curvatures(v, f)
    d = pc.kappa_direction[interior]
    assert np.median(np.abs(d[:, 1])) < 0.05  # across the axis (y)
    assert np.median(np.abs(pc.k2[interior])) < 0.02 * 0.22
    assert np.allclose(np.linalg.norm(pc.d1[interior], axis=1), 1.0, atol=1e-6)
    assert np.all(pc.k1 >= pc.k2)


@pytest.mark.parametrize("outward", [True, False])
def test_sphere_curvature_accuracy_and_sign(outward):
    v, f = sphere_mesh(R_SPHERE)
    if not outward:
        f = f[:, ::-1]
    s = surface_curvature(v, f, frame=None)
    # a closed surface faces outward whatever its winding: convex, 0.1 everywhere
    assert np.median(rel_err(s.kappa, 0.1)) <= 0.01
    assert np.all(s.kappa > 0)
    assert any("re-oriented" in r for r in s.repairs) == (not outward)


def test_normals_set_the_front_side():
    v, f, uv, interior = cylinder_patch(R_CYL, convex=True, n=60)
    outward = v * np.array([1.0, 0.0, 1.0])
    outward /= np.linalg.norm(outward, axis=1, keepdims=True)
    k_out = max_curvature(v, f, normals=outward)
    k_in = max_curvature(v, f, normals=-outward)
    assert np.allclose(k_out, -k_in)
    assert np.median(k_out[interior]) > 0


def test_sine_sheet_analytic_matches_estimate():
    sheet = SineSheet(amplitude_mm=2.0, wavelength_mm=20.0, width_mm=40.0, depth_mm=20.0, vertices_per_wavelength=96)
    m = sine_sheet_mesh(sheet)
    k = max_curvature(m.vertices, m.faces, neighbourhood_mm=2.0)
    interior = (np.abs(m.vertices[:, 0]) < 17) & (np.abs(m.vertices[:, 1]) < 8)
    err = np.abs(k - m.attributes["curvature"])[interior]
    assert np.median(err) < 0.01 * sheet.crest_curvature_mm
    x = m.vertices[:, 0]
    crest = interior & (np.abs(x - 5.0) < 0.3)
    trough = interior & (np.abs(x + 5.0) < 0.3)
    assert np.all(k[crest] > 0.9 * sheet.crest_curvature_mm)
    assert np.all(k[trough] < -0.9 * sheet.crest_curvature_mm)


def test_sine_sheet_irregular_mesh():
    from scipy.spatial import Delaunay

    uv = jittered_uv(200, 60, seed=3)
    f = Delaunay(uv).simplices.astype(np.int64)
    x = (uv[:, 0] - 0.5) * 40.0
    y = (uv[:, 1] - 0.5) * 12.0
    v = np.c_[x, y, sine_sheet_height(x, amplitude_mm=2.0, wavelength_mm=20.0)]
    e = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    f[e[:, 2] < 0] = f[e[:, 2] < 0][:, ::-1]
    k = max_curvature(v, f, neighbourhood_mm=2.0)
    truth = sine_sheet_curvature(x, amplitude_mm=2.0, wavelength_mm=20.0)
    interior = (np.abs(x) < 17) & (np.abs(y) < 4.5)
    assert np.median(np.abs(k - truth)[interior]) < 0.01 * 2.0 * (2 * np.pi / 20) ** 2


def test_sine_sheet_curvature_formula():
    A, L = 1.5, 12.0
    kk = 2 * np.pi / L
    assert sine_sheet_curvature(L / 4, amplitude_mm=A, wavelength_mm=L) == pytest.approx(A * kk**2)
    assert sine_sheet_curvature(-L / 4, amplitude_mm=A, wavelength_mm=L) == pytest.approx(-A * kk**2)
    assert sine_sheet_curvature(0.0, amplitude_mm=A, wavelength_mm=L) == pytest.approx(0.0, abs=1e-12)


# -- units and scale -------------------------------------------------------------------
@pytest.mark.parametrize("unit, mm", [("m", 1000.0), ("cm", 10.0), ("in", 25.4), ("0.37", 0.37), (2.5, 2.5)])
def test_same_cylinder_in_any_unit_gives_the_same_curvature(unit, mm):
    v, f, uv, interior = cylinder_patch(R_CYL, n=90)
    k_mm = max_curvature(v, f)
    k_u = max_curvature(v / mm, f, units=unit)
    assert np.median(rel_err(k_u[interior], 0.22)) <= 0.01
    # the same in mm^-1 to 0.1 % at every interior vertex
    assert np.max(np.abs(k_u[interior] - k_mm[interior]) / np.abs(k_mm[interior])) <= 1e-3


def test_units_registry():
    assert parse_units("in").mm_per_unit == 25.4
    assert parse_units("2.5").mm_per_unit == 2.5 and str(parse_units("2.5")) == "2.5 mm per unit"
    assert parse_units(1000.0).name == "m"
    for bad in ("furlong", "-1", "0", "nan", "1e12"):
        with pytest.raises(MeshError, match="units"):
            parse_units(bad)


def test_a_wrong_unit_is_found_and_the_likely_one_named():
    sk = skirt_mesh(Skirt(around=61, down=41, sash=False))
    v_m = sk.vertices / 1000.0  # the garment in metres, read as if in millimetres
    s = surface_curvature(v_m, sk.faces, uv=sk.uv, units="mm")
    chk = check_kappa_range(s.kappa, s.areas, (-0.22, 0.22), units=s.units, size_units=1.0)
    assert chk.outside_share > 0.9
    assert chk.likely_units is not None and chk.likely_units[0] == "m"
    assert "probably wrong" in chk.message and "--units m" in chk.message
    assert any("is the unit right" in n for n in s.notes)
    right = surface_curvature(v_m, sk.faces, uv=sk.uv, units="m")
    ok = check_kappa_range(right.kappa, right.areas, (-0.22, 0.22), units=right.units)
    assert ok.outside_share < 0.01 and ok.message is None and ok.likely_units is None
    # a plain BRDF (one curvature, e.g. an imported file) does not depend on kappa: no warning
    plain = check_kappa_range(s.kappa, s.areas, (0.0, 0.0), units=s.units, size_units=1.0)
    assert plain.outside_share > 0.9 and plain.message is None and plain.likely_units is None


# -- scan noise, outliers -------------------------------------------------------------
def noisy_cylinder(sigma=0.05, seed=4):
    # edges of about 0.3 mm, a scanner's resolution
    v, f, uv, interior = cylinder_patch(R_CYL, n=48, angle=np.pi, length=30.0, n_along=100)
    rng = np.random.default_rng(seed)
    return v + rng.normal(scale=sigma, size=v.shape), f, uv, interior


def test_noisy_cylinder_gives_its_true_curvature():
    v, f, uv, interior = noisy_cylinder()
    edge = np.median(np.linalg.norm(v[f[:, 0]] - v[f[:, 1]], axis=1))
    assert 0.2 < edge < 0.4
    k = max_curvature(v, f)  # the default neighbourhood
    assert np.median(rel_err(k[interior], 0.22)) <= 0.05
    assert abs(np.median(k[interior]) / 0.22 - 1) <= 0.03
    assert np.percentile(np.abs(k), 99.9) < 0.5  # no noise-sized curvatures
    # at the scale of the triangles the noise is the curvature
    k_fine = max_curvature(v, f, neighbourhood_mm=0.4)
    assert np.percentile(np.abs(k_fine), 95) > 1.0


def test_outliers_do_not_spread():
    v, f, uv, interior = cylinder_patch(R_CYL, n=80)
    rng = np.random.default_rng(5)
    spikes = rng.choice(np.flatnonzero(interior), size=v.shape[0] // 100, replace=False)
    radial = v * np.array([1.0, 0.0, 1.0])
    radial /= np.linalg.norm(radial, axis=1, keepdims=True)
    v2 = v.copy()
    v2[spikes] += 1.0 * radial[spikes]  # 1 mm spikes on 1 % of the vertices
    k = max_curvature(v2, f)
    clean = interior.copy()
    clean[spikes] = False
    assert np.median(rel_err(k[clean], 0.22)) <= 0.03
    assert np.percentile(rel_err(k[clean], 0.22), 90) <= 0.15


# -- repairs -------------------------------------------------------------------------------
def test_duplicated_vertices_are_welded():
    v, f, uv, interior = cylinder_patch(R_CYL, convex=True, n=60)
    k_ref = max_curvature(v, f)
    v_split = v[f.reshape(-1)]  # a triangle soup (STL)
    f_split = np.arange(v_split.shape[0]).reshape(-1, 3)
    s = surface_curvature(v_split, f_split, frame=None)
    assert s.repairs[0] == f"welded {v_split.shape[0] - v.shape[0]} duplicate vertices"
    assert s.source.size == v.shape[0]  # merged in the output too
    k_split = max_curvature(v_split, f_split)
    assert np.allclose(k_split, k_ref[f.reshape(-1)], rtol=1e-9, atol=1e-12)


def test_uv_seams_are_kept_and_not_reported():
    v, f, uv, interior = cylinder_patch(R_CYL, n=40)
    # cut the UV map along x = 0: the right half's vertices get their own copies with other UVs
    right = v[:, 0] > 0
    copy = np.flatnonzero(right)
    v2 = np.vstack([v, v[copy]])
    uv2 = np.vstack([uv, uv[copy] + [0.0, 0.5]])
    remap = np.arange(v.shape[0])
    remap[copy] = v.shape[0] + np.arange(copy.size)
    f2 = f.copy()
    rf = right[f].all(axis=1)
    f2[rf] = remap[f[rf]]
    s = surface_curvature(v2, f2, uv=uv2)
    assert s.repairs == ()
    assert np.median(rel_err(s.kappa, 0.22)) <= 0.02  # one surface for the curvature across the seam
    assert s.source.size > v.shape[0]  # the seam's vertices stay split in the output


def test_mixed_winding_is_reoriented_not_refused():
    v, f, uv, interior = cylinder_patch(R_CYL, convex=True, n=40)
    f = f.copy()
    f[::7] = f[::7][:, ::-1]
    s = surface_curvature(v, f, frame=None)
    assert s.repairs == ("re-oriented 1 of 1 component",)
    # the majority of the area wound outward decides: convex
    assert np.median(rel_err(s.kappa, 0.22)) <= 0.02


def test_duplicate_and_degenerate_faces_are_dropped():
    v, f, uv, interior = cylinder_patch(R_CYL, n=30)
    v2 = np.vstack([v, v[:1]])
    f2 = np.vstack([f, f[:2], f[5:6, [1, 2, 0]], [[0, 0, 1]], [[0, 1, v.shape[0]]]])
    s = surface_curvature(v2, f2, frame=None)
    assert "dropped 2 degenerate faces" in s.repairs  # a repeated vertex, and one repeated by welding
    assert "dropped 3 duplicate faces" in s.repairs
    assert s.faces.shape[0] == f.shape[0]


def test_double_sided_panel_has_each_sides_sign():
    v, f, uv, interior = cylinder_patch(R_CYL, n=40)
    both = np.vstack([f, f[:, ::-1]])  # the same triangles, once with each winding
    s = surface_curvature(v, both, uv=uv)
    assert any("double-sided" in r for r in s.repairs)
    assert s.faces.shape[0] == 2 * f.shape[0]
    # seen from its own front, each layer: the outer one convex, the inner one concave
    radial = v[s.source] * np.array([1.0, 0.0, 1.0])
    outer = np.einsum("ij,ij->i", s.normals, radial) > 0
    assert outer.sum() == (~outer).sum()
    inner_ok = interior[s.source]
    assert np.median(s.kappa[outer & inner_ok]) == pytest.approx(0.22, rel=0.02)
    assert np.median(s.kappa[~outer & inner_ok]) == pytest.approx(-0.22, rel=0.02)
    a = np.full(v.shape[0], np.nan)
    b = np.full(v.shape[0], np.nan)
    a[s.source[outer]] = s.directional[outer]
    b[s.source[~outer]] = s.directional[~outer]
    assert np.allclose(a, -b, equal_nan=True)


def test_non_manifold_edge_is_cut_and_each_sheet_gets_its_curvature():
    # three half-cylinders sharing one straight edge (x = R, z = 0): three faces on each of its edges
    v, f, uv, interior = cylinder_patch(R_CYL, n=30)
    rot = []
    for ang in (0.0, 2.0 * np.pi / 3.0, 4.0 * np.pi / 3.0):
        c, s_ = np.cos(ang), np.sin(ang)
        rot.append((v - [R_CYL, 0, 0]) @ np.array([[c, 0, s_], [0, 1, 0], [-s_, 0, c]]).T + [R_CYL, 0, 0])
    vv = np.vstack(rot)
    ff = np.vstack([f + i * v.shape[0] for i in range(3)])
    s = surface_curvature(vv, ff, frame=None)
    assert any("welded" in r for r in s.repairs) and any("split" in r and "non-manifold" in r for r in s.repairs)
    inner = np.tile(interior, 3)[s.source]
    assert np.median(np.abs(s.kappa[inner])) == pytest.approx(0.22, rel=0.03)


def test_moebius_strip_is_accepted():
    t = np.linspace(0, 2 * np.pi, 121)[:-1]
    w = np.linspace(-3, 3, 9)
    T, W = np.meshgrid(t, w, indexing="ij")
    R = 20.0
    x = (R + W * np.cos(T / 2)) * np.cos(T)
    y = (R + W * np.cos(T / 2)) * np.sin(T)
    z = W * np.sin(T / 2)
    v = np.c_[x.ravel(), y.ravel(), z.ravel()]
    n_t, n_w = T.shape
    faces = []
    for i in range(n_t):
        for j in range(n_w - 1):
            i2 = (i + 1) % n_t
            j_a, j_b = (j, j + 1) if i2 else (n_w - 1 - j, n_w - 2 - j)  # the half twist
            a, b = i * n_w + j, i * n_w + j + 1
            c, d = i2 * n_w + j_b, i2 * n_w + j_a
            faces += [[a, d, c], [a, c, b]]
    s = surface_curvature(v, np.array(faces), frame=None)
    assert any("non-orientable" in r for r in s.repairs)
    assert np.isfinite(s.kappa).all() and np.abs(s.kappa).max() < 1.0


def test_skirt_is_accepted_with_the_right_sign_on_each_visible_side():
    """Two panels sewn with opposite winding, plus a double-sided sash: convex from outside everywhere."""
    m = skirt_mesh(Skirt(fold_amplitude_mm=0.0, around=61, down=41))
    s = surface_curvature(m.vertices, m.faces, uv=m.uv)
    assert "re-oriented 1 of 2 components" in s.repairs
    assert any("double-sided" in r for r in s.repairs)
    p = m.vertices[s.source]
    outward = p * np.array([1.0, 0.0, 1.0])
    # the sign each vertex shows on the side facing outwards (a viewer outside the skirt)
    facing_out = np.sign(np.einsum("ij,ij->i", s.normals, outward))
    seen_from_outside = s.kappa * facing_out
    away_from_hems = (p[:, 1] > 40) & (p[:, 1] < 520)
    assert np.all(seen_from_outside[away_from_hems] > 0)
    r = np.hypot(p[:, 0], p[:, 2])
    # a cone: the curvature across it is cos(half-angle) / r
    half = np.arctan((300.0 - 130.0) / 560.0)
    assert np.median(np.abs(seen_from_outside[away_from_hems] * r[away_from_hems]) / np.cos(half)) == \
        pytest.approx(1.0, rel=0.03)
    sash = s.source >= 2 * 61 * 41
    assert sash.any() and np.all(seen_from_outside[sash & away_from_hems] > 0)
    # both sides of the sash are there, with opposite normals
    assert (facing_out[sash] > 0).sum() == (facing_out[sash] < 0).sum()


def test_unrenderable_meshes_are_refused_with_a_reason():
    v = np.array([[0.0, 0, 0], [1, 0, 0], [2, 0, 0], [3, 0, 0]])
    with pytest.raises(MeshError, match="degenerate"):
        max_curvature(v, np.array([[0, 1, 2], [1, 2, 3]]))
    with pytest.raises(MeshError, match="no faces"):
        max_curvature(v, np.zeros((0, 3), dtype=int))
    with pytest.raises(MeshError, match="refer to vertices"):
        max_curvature(v, np.array([[0, 1, 9]]))
    with pytest.raises(MeshError, match="shape"):
        max_curvature(np.zeros((5, 2)), np.array([[0, 1, 2]]))
    with pytest.raises(MeshError, match="NaN"):
        max_curvature(np.full((4, 3), np.nan), np.array([[0, 1, 2]]))
    with pytest.raises(MeshError, match="not lengths"):
        max_curvature(np.full((4, 3), 1e308), np.array([[0, 1, 2]]))
    with pytest.raises(MeshError, match="integer"):
        max_curvature(v, np.array([[0.0, 1.0, 2.0]]))
    with pytest.raises(MeshError, match="neighbourhood"):
        max_curvature(v, np.array([[0, 1, 3]]), neighbourhood_mm=0.0)


def test_unreferenced_vertex_gets_zero():
    v, f, uv, interior = cylinder_patch(R_CYL, convex=True, n=30)
    v2 = np.vstack([v, [[100.0, 100.0, 100.0]]])
    k = max_curvature(v2, f)
    assert k[-1] == 0.0
    assert np.allclose(k[:-1], max_curvature(v, f))


def test_repair_keeps_the_files_normals_and_flips_the_wrong_ones():
    v, f, uv, interior = cylinder_patch(R_CYL, n=30)
    n = v * np.array([1.0, 0.0, 1.0])
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    n[::10] *= -1.0
    r = repair(v, f, normals=n)
    assert any(x.startswith("flipped ") and x.endswith("vertex normals to match the faces") for x in r.repairs)
    assert np.all(np.einsum("ij,ij->i", r.out_normals, n[r.out_source] * np.where(
        np.arange(len(v))[r.out_source] % 10 == 0, -1, 1)[:, None]) > 0.99)


# -- frames and the directional mode ------------------------------------------------------
def test_directional_curvature_follows_the_uv_frame():
    v, f, uv, interior = cylinder_patch(R_CYL, n=60)
    across = surface_curvature(v, f, uv=uv)  # u runs around the cylinder: x is the bending direction
    along = surface_curvature(v, f, uv=uv[:, ::-1].copy())  # u along the axis
    inner = interior[across.source]
    assert across.frame == "uv"
    assert np.median(across.directional[inner]) == pytest.approx(0.22, rel=0.02)
    assert np.median(np.abs(along.directional[interior[along.source]])) < 0.01 * 0.22
    # at 45 degrees the normal curvature is half (Euler: k1 cos^2 + k2 sin^2)
    diag = np.c_[uv[:, 0] + uv[:, 1], uv[:, 1] - uv[:, 0]]
    d45 = surface_curvature(v, f, uv=diag)
    assert np.median(d45.directional[interior[d45.source]]) == pytest.approx(0.11, rel=0.05)
    # the maximum curvature does not depend on the frame
    assert np.allclose(np.sort(across.kappa), np.sort(along.kappa))


def test_mesh_without_uvs_takes_the_principal_frame():
    v, f, uv, interior = cylinder_patch(R_CYL, n=40)
    s = surface_curvature(v, f)
    assert s.frame == "principal" and any("no UV coordinates" in n for n in s.notes)
    assert s.uv is not None and s.source.size == 3 * s.faces.shape[0]  # per-face UVs, one vertex per corner
    # dP/du of each generated face is its bending direction: across the axis
    from cdbrdf.mesh.frames import face_uv_tangents

    ft, ok = face_uv_tangents(v[s.source], s.faces, s.uv)
    assert ok.all() and np.median(np.abs(ft[:, 1])) < 0.05
    assert np.allclose(s.directional, s.kappa)
    with pytest.raises(MeshError, match="no UV coordinates"):
        surface_curvature(v, f, frame="uv")


def test_tangent_attribute_frame():
    v, f, uv, interior = cylinder_patch(R_CYL, n=40)
    t = np.tile([0.0, 1.0, 0.0], (v.shape[0], 1))  # along the axis
    s = surface_curvature(v, f, uv=uv, tangents=t, frame="tangent")
    assert s.frame == "tangent"
    assert np.median(np.abs(s.directional[interior[s.source]])) < 0.01 * 0.22
    with pytest.raises(MeshError, match="tangent"):
        surface_curvature(v, f, frame="tangent")
    with pytest.raises(MeshError, match="frame"):
        surface_curvature(v, f, frame="bogus")


def test_attribute_names_for_the_plugin():
    """One name map: a mode's array in a Mesh, its PLY property (Mitsuba keeps ``_x`` ones) and Mitsuba's name."""
    from cdbrdf.errors import OptionError
    from cdbrdf.mesh import attribute_of_ply, curvature_mode, mitsuba_attribute, ply_property
    from cdbrdf.mesh.attributes import SHAPE_ATTRIBUTES, SHAPE_MESH_ATTRIBUTE, SHAPE_PLY_PROPERTIES

    names = {m: (r.attribute, r.ply_property, r.mitsuba_attribute) for m, r in CURVATURE_MODES.items()}
    assert names == {"max": ("curvature", "curvature_x", "vertex_curvature"),
                     "directional": ("curvature_dir", "curvature_dir_x", "vertex_curvature_dir")}
    for a in ("curvature", "curvature_dir", "seam", *SHAPE_ATTRIBUTES):  # the PLY name reads back as the array's
        assert attribute_of_ply(ply_property(a)) == a
    assert [ply_property(a) for a in SHAPE_ATTRIBUTES] == list(SHAPE_PLY_PROPERTIES)
    assert {mitsuba_attribute(a) for a in SHAPE_ATTRIBUTES} == {SHAPE_MESH_ATTRIBUTE}  # one three-channel one
    assert ply_property("shape_xx", shape=False) == "shape_xx_x" and attribute_of_ply("shape_x", shape=False) == "shape"
    assert attribute_of_ply("nx") is None and curvature_mode("max") is CURVATURE_MODES["max"]
    with pytest.raises(OptionError, match="curvature mode: 'min' is not one of max, directional"):
        curvature_mode("min")


def test_neighbourhood_from_the_tables_provenance():
    assert neighbourhood_from_table({"provenance": {"parameters": {"footprint_mm": 1.5}}})[0] == 1.5
    assert neighbourhood_from_table({"provenance": {"patch_mm": 3.0, "patch_px": 7}})[0] == 3.0
    assert neighbourhood_from_table({"provenance": {"patch_px": 7, "pixel_mm": 0.5}})[0] == 3.5
    for attrs in (None, {}, {"provenance": "model"}, {"provenance": {"patch_px": 7}},
                  {"provenance": {"patch_mm": "x"}}, {"provenance": {"patch_mm": -1}}):
        assert neighbourhood_from_table(attrs)[0] == DEFAULT_NEIGHBOURHOOD_MM
    from cdbrdf import materials

    assert neighbourhood_from_table(materials.load("denim").attrs)[0] == 1.0


# -- the real meshes ------------------------------------------------------------------------
def test_spot_uv_charts_are_reported_and_the_principal_frame_avoids_them():
    from cdbrdf.mesh import read_mesh

    m = read_mesh(shared_mesh("spot.obj"))
    assert m.uv is not None
    s = surface_curvature(m.vertices, m.faces, uv=m.uv, units=1000.0)  # a cow about 1.7 m long
    assert s.repairs == ()
    assert any("seam edges" in n for n in s.notes)
    assert np.isfinite(s.kappa).all() and np.percentile(np.abs(s.kappa), 99) < 0.1
    p = surface_curvature(m.vertices, m.faces, uv=m.uv, units=1000.0, frame="principal")
    assert not any("seam edges" in n for n in p.notes)
    # the same surface, the same curvature at every vertex whatever the frame
    by_source = np.full(m.n_vertices, np.nan)
    by_source[s.source] = s.kappa
    assert np.allclose(p.kappa, by_source[p.source])


def test_fandisk_cad_part_without_uvs():
    from cdbrdf.mesh import read_mesh

    m = read_mesh(shared_mesh("fandisk.obj"))
    assert m.uv is None
    s = surface_curvature(m.vertices, m.faces, units=20.0)  # about 10 cm across
    assert s.frame == "principal"
    assert s.repairs == ()  # a clean closed part
    # closed and oriented outward: the outward normals point away from the centre on average
    p = m.vertices[s.source]
    assert np.mean(np.einsum("ij,ij->i", s.normals, p - p.mean(0)) > 0) > 0.7
    # its flat faces have no curvature, its rounded ones some, its sharp edges get their own normals
    assert np.percentile(np.abs(s.kappa), 25) < 1e-6 and np.percentile(np.abs(s.kappa), 95) > 0.01
    corners_per_vertex = np.bincount(s.source) if s.source.size else np.zeros(0)
    assert corners_per_vertex.max() > 1


def test_a_measured_table_records_its_patch_for_the_neighbourhood(tmp_path):
    from cdbrdf.images import write_png
    from cdbrdf.measure import measure

    from .measure_helpers import write_csv

    write_png(tmp_path / "g.png", np.full((15, 15), 40000, np.uint16))
    write_csv(tmp_path / "capture.csv", [dict(file="g.png", kappa=0, theta_v=0, phi_v=0, theta_l=0, phi_l=0)])
    (tmp_path / "stands.json").write_text('{"pixel_mm": 0.4}')
    table, _ = measure(tmp_path, linear=True)
    assert table.attrs["provenance"]["patch_mm"] == pytest.approx(7 * 0.4)
    nb, why = neighbourhood_from_table(table.attrs)
    assert nb == pytest.approx(2.8) and "measured patch" in why
