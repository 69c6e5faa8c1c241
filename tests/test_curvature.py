"""Tests of cdbrdf.curvature (mesh curvature) and the mesh reader/writer.

Meshes are irregular (jittered points, Delaunay / convex hull), since regular
grids flatter curvature estimators.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import ConvexHull, Delaunay

from cdbrdf.curvature import (
    MeshError,
    max_curvature,
    principal_curvatures,
    sine_sheet_curvature,
    sine_sheet_height,
    weld,
)
from cdbrdf.render.meshio import Mesh, read_mesh, read_obj, read_ply, write_ply
from cdbrdf.render.scenes import SineSheet, sine_sheet_mesh

R_CYL = 1.0 / 0.22  # mm, the paper's largest curvature
R_SPHERE = 10.0  # mm


def jittered_uv(nu: int, nv: int, seed: int, jitter: float = 0.4) -> np.ndarray:
    rng = np.random.default_rng(seed)
    u, v = np.meshgrid(np.arange(nu, dtype=float), np.arange(nv, dtype=float), indexing="ij")
    u += rng.uniform(-jitter, jitter, u.shape)
    v += rng.uniform(-jitter, jitter, v.shape)
    u[0], u[-1], v[:, 0], v[:, -1] = 0, nu - 1, 0, nv - 1
    return np.c_[u.ravel() / (nu - 1), v.ravel() / (nv - 1)]


def cylinder_patch(radius: float, *, convex: bool, n: int = 140, seed: int = 0):
    """Half a cylinder (axis y, apex on +z) from jittered Delaunay points.

    Faces wind counter-clockwise seen from outside (convex) or from the axis
    (concave). Returns vertices, faces, uv, interior mask.
    """
    uv = jittered_uv(n, n, seed)
    f = Delaunay(uv).simplices.astype(np.int64)
    a = (uv[:, 0] - 0.5) * np.pi
    v = np.c_[radius * np.sin(a), (uv[:, 1] - 0.5) * np.pi * radius, radius * np.cos(a)]
    # Delaunay faces are CCW in (u, v); u runs along +x at the apex and v along +y,
    # so the winding normal points +z (outward) there.
    e = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    radial = v[f].mean(1) * np.array([1.0, 0.0, 1.0])
    wrong = np.einsum("ij,ij->i", e, radial) < 0 if convex else np.einsum("ij,ij->i", e, radial) > 0
    f[wrong] = f[wrong][:, ::-1]
    interior = np.all((uv > 0.1) & (uv < 0.9), axis=1)
    return v, f, uv, interior


def sphere_mesh(radius: float, n: int = 20000, seed: int = 1):
    """Jittered Fibonacci sphere, convex hull, faces wound outward."""
    rng = np.random.default_rng(seed)
    i = np.arange(n) + 0.5
    polar = np.arccos(1 - 2 * i / n)
    azim = np.pi * (1 + 5**0.5) * i
    p = np.c_[np.cos(azim) * np.sin(polar), np.sin(azim) * np.sin(polar), np.cos(polar)]
    p += rng.normal(scale=0.3 * np.sqrt(4 * np.pi / n), size=p.shape)
    p /= np.linalg.norm(p, axis=1, keepdims=True)
    f = ConvexHull(p).simplices.astype(np.int64)
    e = np.cross(p[f[:, 1]] - p[f[:, 0]], p[f[:, 2]] - p[f[:, 0]])
    wrong = np.einsum("ij,ij->i", e, p[f].mean(1)) < 0
    f[wrong] = f[wrong][:, ::-1]
    return p * radius, f


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
    # Sign right at (nearly) every interior vertex.
    assert np.mean(np.sign(k[interior]) == np.sign(truth)) > 0.999


def test_cylinder_principal_directions():
    v, f, uv, interior = cylinder_patch(R_CYL, convex=True)
    pc = principal_curvatures(v, f)
    # kappa direction is across the axis (y): |d . y| small; the other curvature ~ 0.
    d = pc.kappa_direction[interior]
    assert np.median(np.abs(d[:, 1])) < 0.05
    assert np.median(np.abs(pc.k2[interior])) < 0.01 * 0.22
    assert np.allclose(np.linalg.norm(pc.d1[interior], axis=1), 1.0, atol=1e-6)
    assert np.all(pc.k1 >= pc.k2)


@pytest.mark.parametrize("outward", [True, False])
def test_sphere_curvature_accuracy_and_sign(outward):
    v, f = sphere_mesh(R_SPHERE)
    if not outward:
        f = f[:, ::-1]
    k = max_curvature(v, f)
    truth = 0.1 if outward else -0.1
    assert np.median(rel_err(k, truth)) <= 0.01
    assert np.all(np.sign(k) == np.sign(truth))


def test_normals_argument_sets_sign():
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
    k = max_curvature(m.vertices, m.faces)
    interior = (np.abs(m.vertices[:, 0]) < 17) & (np.abs(m.vertices[:, 1]) < 8)
    err = np.abs(k - m.attributes["curvature"])[interior]
    assert np.median(err) < 0.01 * sheet.crest_curvature_mm
    # crests (sin = 1 at x = L/4) are convex, troughs concave
    x = m.vertices[:, 0]
    crest = interior & (np.abs(x - 5.0) < 0.3)
    trough = interior & (np.abs(x + 5.0) < 0.3)
    assert np.all(k[crest] > 0.9 * sheet.crest_curvature_mm)
    assert np.all(k[trough] < -0.9 * sheet.crest_curvature_mm)


def test_sine_sheet_irregular_mesh():
    uv = jittered_uv(200, 60, seed=3)
    f = Delaunay(uv).simplices.astype(np.int64)
    x = (uv[:, 0] - 0.5) * 40.0
    y = (uv[:, 1] - 0.5) * 12.0
    v = np.c_[x, y, sine_sheet_height(x, amplitude_mm=2.0, wavelength_mm=20.0)]
    e = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    f[e[:, 2] < 0] = f[e[:, 2] < 0][:, ::-1]
    k = max_curvature(v, f)
    truth = sine_sheet_curvature(x, amplitude_mm=2.0, wavelength_mm=20.0)
    interior = (np.abs(x) < 17) & (np.abs(y) < 4.5)
    assert np.median(np.abs(k - truth)[interior]) < 0.01 * 2.0 * (2 * np.pi / 20) ** 2


def test_sine_sheet_curvature_formula():
    # At a crest the curvature is A k^2; at an inflection it is 0.
    A, L = 1.5, 12.0
    kk = 2 * np.pi / L
    assert sine_sheet_curvature(L / 4, amplitude_mm=A, wavelength_mm=L) == pytest.approx(A * kk**2)
    assert sine_sheet_curvature(-L / 4, amplitude_mm=A, wavelength_mm=L) == pytest.approx(-A * kk**2)
    assert sine_sheet_curvature(0.0, amplitude_mm=A, wavelength_mm=L) == pytest.approx(0.0, abs=1e-12)


# -- welding, orientation and degenerate input ----------------------------------------
def test_duplicated_vertices_are_welded():
    v, f, uv, interior = cylinder_patch(R_CYL, convex=True, n=60)
    k_ref = max_curvature(v, f)
    # Split: every face gets its own three vertices (worst-case seams).
    v_split = v[f.reshape(-1)]
    f_split = np.arange(v_split.shape[0]).reshape(-1, 3)
    k_split = max_curvature(v_split, f_split)
    assert np.allclose(k_split, k_ref[f.reshape(-1)], rtol=1e-9, atol=1e-12)
    vw, fw, index = weld(v_split, f_split)
    assert vw.shape[0] == v.shape[0]
    assert np.allclose(vw[index], v_split)


def test_inconsistent_orientation_is_refused():
    v, f, uv, interior = cylinder_patch(R_CYL, convex=True, n=30)
    f = f.copy()
    f[::7] = f[::7][:, ::-1]
    with pytest.raises(MeshError, match="consistently oriented"):
        max_curvature(v, f)


def test_degenerate_inputs_are_refused():
    v = np.array([[0.0, 0, 0], [1, 0, 0], [2, 0, 0], [3, 0, 0]])
    with pytest.raises(MeshError, match="degenerate"):
        max_curvature(v, np.array([[0, 1, 2], [1, 2, 3]]))
    with pytest.raises(MeshError, match="no faces"):
        max_curvature(v, np.zeros((0, 3), dtype=int))
    with pytest.raises(MeshError, match="vertex indices"):
        max_curvature(v, np.array([[0, 1, 9]]))
    with pytest.raises(MeshError, match="shape"):
        max_curvature(np.zeros((5, 2)), np.array([[0, 1, 2]]))
    with pytest.raises(MeshError, match="NaN"):
        max_curvature(np.full((4, 3), np.nan), np.array([[0, 1, 2]]))
    with pytest.raises(MeshError, match="at least 3"):
        max_curvature(np.zeros((2, 3)), np.array([[0, 1, 1]]))


def test_unreferenced_vertex_gets_zero():
    v, f, uv, interior = cylinder_patch(R_CYL, convex=True, n=30)
    v2 = np.vstack([v, [[100.0, 100.0, 100.0]]])
    k = max_curvature(v2, f)
    assert k[-1] == 0.0
    assert np.allclose(k[:-1], max_curvature(v, f))


# -- mesh files -------------------------------------------------------------------------
def test_ply_round_trip(tmp_path):
    m = sine_sheet_mesh(SineSheet(width_mm=20, depth_mm=10, vertices_per_wavelength=16))
    path = tmp_path / "s.ply"
    write_ply(path, m)
    r = read_ply(path)
    assert np.allclose(r.vertices, m.vertices, atol=1e-5)
    assert np.array_equal(r.faces, m.faces)
    assert np.allclose(r.uv, m.uv, atol=1e-6)
    assert np.allclose(r.normals, m.normals, atol=1e-6)
    assert np.allclose(r.attributes["curvature"], m.attributes["curvature"], atol=1e-6)
    header = path.read_bytes().split(b"end_header")[0]
    assert b"property float curvature_x" in header


def test_ascii_ply_with_quads(tmp_path):
    text = """ply
format ascii 1.0
element vertex 4
property float x
property float y
property float z
property float u
property float v
element face 1
property list uchar int vertex_indices
end_header
0 0 0 0 0
1 0 0 1 0
1 1 0 1 1
0 1 0 0 1
4 0 1 2 3
"""
    p = tmp_path / "q.ply"
    p.write_text(text)
    m = read_mesh(p)
    assert m.faces.tolist() == [[0, 1, 2], [0, 2, 3]]
    assert np.allclose(m.uv[2], [1, 1])


def test_obj_reader_splits_corners(tmp_path):
    text = """# two triangles sharing an edge, with a UV seam
v 0 0 0
v 1 0 0
v 1 1 0
v 0 1 0
vt 0 0
vt 1 0
vt 1 1
vt 0 1
vt 0.5 0.5
vn 0 0 1
f 1/1/1 2/2/1 3/3/1
f 1/5/1 3/3/1 4/4/1
"""
    p = tmp_path / "m.obj"
    p.write_text(text)
    m = read_obj(p)
    assert m.vertices.shape[0] == 5  # vertex 1 appears with two UVs
    assert m.uv is not None and m.normals is not None
    assert np.allclose(m.vertices[m.faces[1, 0]], [0, 0, 0])
    assert np.allclose(m.uv[m.faces[1, 0]], [0.5, 0.5])


def test_unknown_mesh_format(tmp_path):
    p = tmp_path / "m.stl"
    p.write_text("solid")
    with pytest.raises(ValueError, match="unknown mesh format"):
        read_mesh(p)


def test_curvature_command(tmp_path):
    from cdbrdf.cli import main

    v, f, uv, interior = cylinder_patch(R_CYL / 10.0, convex=True, n=60)  # in cm
    src = tmp_path / "cyl.ply"
    write_ply(src, Mesh(v, f, None, uv, {}))
    out = tmp_path / "out.ply"
    assert main(["-q", "curvature", str(src), "-o", str(out), "--units", "cm"]) == 0
    r = read_ply(out)
    assert r.uv is not None
    inner = np.all((r.uv > 0.15) & (r.uv < 0.85), axis=1)
    assert np.median(r.attributes["curvature"][inner]) == pytest.approx(0.22, rel=0.01)
    assert main(["-q", "curvature", str(src), "-o", str(tmp_path / "x.obj")]) == 2


def test_sign_guard_against_a_flipped_library_convention(monkeypatch):
    """If libigl reported curvatures with the opposite sign, the umbrella check restores ours."""
    import igl

    v, f, uv, interior = cylinder_patch(R_CYL, convex=True, n=60)
    k_ref = max_curvature(v, f)
    real = igl.principal_curvature

    def flipped(*args, **kw):
        pd1, pd2, pv1, pv2, bad = real(*args, **kw)
        return pd2, pd1, -pv2, -pv1, bad

    monkeypatch.setattr(igl, "principal_curvature", flipped)
    assert np.allclose(max_curvature(v, f), k_ref)
