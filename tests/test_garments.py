"""Garments as their makers export them: the up axis from the geometry, units, the cloth's curvature.

The meshes are made by :mod:`cdbrdf.mesh.garments` and written to OBJ / PLY
files, so that the real readers run: a CAD garment (Z-up OBJ in mm, 9-14 mm
edges, panels sewn along seams with coincident, unwelded vertices), the same
garment as Blender exports it (Y-up OBJ in metres), and a scan-like Y-up bust
(PLY, closed with a flat base, or open at the base).
"""

from __future__ import annotations

import logging

import numpy as np
import pytest

from cdbrdf.mesh import detect_up, read_mesh, z_up_mesh
from cdbrdf.mesh.garments import Garment, bust_mesh, garment_mesh

from .mesh_helpers import write_ascii_ply, write_obj


def cad_garment(tmp_path, garment: Garment | None = None):
    m = garment_mesh(garment or Garment())
    return write_obj(tmp_path / "cad-top.obj", m.vertices, m.faces, m.uv)


def blender_garment(tmp_path):
    """The CAD garment as Blender's OBJ exporter writes it: Y-up (forward -z), metres."""
    m = garment_mesh()
    v = np.c_[m.vertices[:, 0], m.vertices[:, 2], -m.vertices[:, 1]] * 1e-3
    return write_obj(tmp_path / "blender-top.obj", v, m.faces, m.uv)


def scan_bust(tmp_path, base="closed"):
    m = bust_mesh(base=base)
    return write_ascii_ply(tmp_path / f"bust-{base}.ply", m.vertices, m.faces.tolist())


def test_garment_is_made_of_sewn_panels():
    m = garment_mesh()
    e = np.linalg.norm(m.vertices[m.faces[:, [1, 2, 0]]] - m.vertices[m.faces], axis=2)
    assert 9.0 <= np.median(e) <= 14.0
    assert set(np.unique(m.metadata["panels"])) == {0, 1, 2, 3}
    # the seams: vertices of different panels at the same place, not shared
    _, inv, count = np.unique(m.vertices.round(6), axis=0, return_inverse=True, return_counts=True)
    assert (count > 1).sum() > 100
    assert all((np.bincount(m.faces[m.metadata["panels"] == p].ravel(), minlength=m.n_vertices) > 0).any()
               for p in range(4))


@pytest.mark.parametrize(("make", "axis", "reason"), [
    (cad_garment, "z", "openings"),
    (blender_garment, "y", "openings"),
    (lambda p: scan_bust(p, "closed"), "y", "flat base"),
    (lambda p: scan_bust(p, "open"), "y", "1 opening"),
])
def test_up_axis_comes_from_the_geometry(tmp_path, caplog, make, axis, reason):
    mesh = read_mesh(make(tmp_path))
    with caplog.at_level(logging.WARNING, logger="cdbrdf.mesh.prepare"):
        up, why = detect_up(mesh)
    assert up == axis and reason in why
    convention = "y" if mesh.metadata["format"] == "obj" else "z"
    warned = any("the geometry says the up axis is" in r.getMessage() for r in caplog.records)
    assert warned == (axis != convention)
    world, was, _ = z_up_mesh(mesh)
    assert was == axis
    # upright: the world's z is the garment's height (the neck above the hem) or the bust's
    ext = world.vertices.max(0) - world.vertices.min(0)
    assert ext[2] > 1.5 * ext[1]


def test_up_axis_given_overrides_the_geometry(tmp_path):
    mesh = read_mesh(cad_garment(tmp_path))
    assert z_up_mesh(mesh, "y")[1:] == ("y", "given")


def test_convention_decides_when_the_geometry_does_not(tmp_path):
    # a closed, round object: no openings, no base, no tall axis
    from .mesh_helpers import sphere_mesh

    v, f = sphere_mesh(10.0, n=400)
    mesh = read_mesh(write_obj(tmp_path / "ball.obj", v, f))
    assert detect_up(mesh) == ("y", "OBJ's usual convention (the geometry does not tell)")


# -- units ------------------------------------------------------------------------------------
@pytest.mark.parametrize(("mm_per_unit", "size_units", "likely"), [
    (1.0, 8.0, None),  # an 8 mm teapot in mm: small, but its bends are cloth's; no other unit
    (1.0, 0.008, "m"),  # an 8 mm teapot in metres read as mm: bends a thousand times tighter than a yarn
    (1000.0, 0.008, None),  # the same with its unit
])
def test_the_unit_is_suggested_only_when_the_surface_bends_tighter_than_a_yarn(mm_per_unit, size_units, likely):
    from cdbrdf.mesh import Units, check_kappa_range
    from cdbrdf.mesh.units import UNITS_MM

    from .mesh_helpers import sphere_mesh

    v, f = sphere_mesh(0.5 * size_units, n=400)
    name = next(k for k, x in UNITS_MM.items() if x == mm_per_unit)
    kappa_mm = np.full(len(v), 2.0 / (size_units * mm_per_unit))  # a sphere: 1 / its radius, mm^-1
    chk = check_kappa_range(kappa_mm, np.ones(len(v)), (-0.22, 0.22), units=Units(mm_per_unit, name),
                            size_units=size_units)
    assert chk.outside_share == 1.0
    assert (chk.likely_units[0] if chk.likely_units else None) == likely
    assert ("--units m" in chk.message) == (likely == "m")
    if likely is None:
        assert "the unit is not the cause" in chk.message


# -- the cloth's curvature --------------------------------------------------------------------
def sewn_cylinder(radius=40.0, height=200.0, edge=12.0, panels=2, seed=0):
    """A cylinder of ``panels`` panels sewn along vertical seams (coincident, unwelded vertices), jittered."""
    rng = np.random.default_rng(seed)
    na, nz = round(2 * np.pi * radius / edge / panels), round(height / edge)
    vs, fs, off = [], [], 0
    for p in range(panels):
        a = np.linspace(0, 2 * np.pi / panels, na + 1) + p * 2 * np.pi / panels
        z = np.linspace(0, height, nz + 1)
        A, Z = np.meshgrid(a, z, indexing="ij")
        inner = (np.arange(na + 1) % na != 0)[:, None]  # the seams' columns stay where the other panel's are
        A = A + inner * rng.uniform(-0.2, 0.2, A.shape) * (2 * np.pi / panels / na)
        vs.append(np.stack([radius * np.cos(A), radius * np.sin(A), Z], -1).reshape(-1, 3))
        i, j = np.meshgrid(np.arange(na), np.arange(nz), indexing="ij")
        q = (i * (nz + 1) + j).ravel()
        fs.append(np.concatenate([np.c_[q, q + nz + 1, q + nz + 2], np.c_[q, q + nz + 2, q + 1]]) + off)
        off += vs[-1].shape[0]
    return np.concatenate(vs), np.concatenate(fs)


def test_seams_are_one_surface_and_boundaries_are_fitted_one_sided():
    """A coarse (12 mm edges) cylinder of radius 40 mm in two sewn panels, open at both ends: 1/40 everywhere."""
    from cdbrdf.mesh import surface_curvature
    from cdbrdf.mesh.curvature import LOCATIONS

    v, f = sewn_cylinder()
    s = surface_curvature(v, f, units="mm", neighbourhood_mm=5.0, frame=None)
    err = np.abs(s.kappa * 40.0 - 1.0)
    where = {name: s.location == i for i, name in enumerate(LOCATIONS)}
    assert where["seam"].sum() > 20 and where["boundary"].sum() > 20
    assert np.median(err[where["seam"]]) < 0.02 and err[where["seam"]].max() < 0.05
    assert np.median(err[where["boundary"]]) < 0.03 and err[where["boundary"]].max() < 0.05
    assert any("coarser than the neighbourhood" in n for n in s.notes)


def test_cad_garment_curvature_is_the_cloths(tmp_path):
    """The CAD garment with default options: <= 1 % of the vertices outside the table's range, none at a
    seam or an opening (the report by location)."""
    from cdbrdf.mesh import prepare_mesh

    mesh = prepare_mesh(cad_garment(tmp_path), kappa_range=(-0.22, 0.22))
    by = mesh.metadata["outside_by_location"]
    assert by["seam"][0] == 0 and by["boundary"][0] == 0
    assert by["seam"][1] > 100 and by["boundary"][1] > 100
    assert sum(o for o, _ in by.values()) <= 0.01 * mesh.n_vertices
    assert any(n.startswith("curvature outside the table's range") for n in mesh.metadata["notes"])
