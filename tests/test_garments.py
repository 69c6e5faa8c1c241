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


def test_a_seam_left_a_hair_apart_with_its_panels_wound_apart_is_one_surface():
    """The sewn cylinder with the second panel's seam vertices 2 % of an edge off the first's (as a simulation
    leaves a seam) and its faces wound the other way: the seam is welded for the fit (its vertices stay in the
    output) and its curvature is 1/R, as inside the panels; not a boundary fitted one-sided, not a spike."""
    from cdbrdf.mesh import surface_curvature, weld_seams
    from cdbrdf.mesh.curvature import LOCATIONS

    v, f = sewn_cylinder(panels=2)
    n_half = v.shape[0] // 2
    rng = np.random.default_rng(3)
    v[n_half:] += rng.normal(0.0, 1.0, (n_half, 3)) * 0.02 * 12.0 / np.sqrt(3.0)  # 2 % of the 12 mm edge
    f[f.max(axis=1) >= n_half] = f[f.max(axis=1) >= n_half][:, ::-1]
    n_welded = int(weld_seams(v, f).max()) + 1
    n_rows = round(200.0 / 12.0) + 1
    assert n_welded == v.shape[0] - 2 * n_rows  # both seams' vertices, one by one, and nothing else
    s = surface_curvature(v, f, units="mm", frame=None)
    assert s.source.size == v.shape[0]  # the output keeps both panels' vertices
    err = np.abs(np.abs(s.kappa) * 40.0 - 1.0)
    seam, inner = s.location == LOCATIONS.index("seam"), s.location == LOCATIONS.index("interior")
    assert seam.sum() == 4 * (n_rows - 2)  # both panels' vertices on the two seams, between the open ends
    assert np.median(err[seam]) < 0.03 and err[seam].max() < 0.06
    assert abs(np.median(err[seam]) - np.median(err[inner])) < 0.02
    assert np.all(np.sign(s.kappa) == np.sign(s.kappa[0]))  # one orientation across the seam


def test_layers_a_cloths_thickness_apart_and_short_edges_are_not_welded():
    """Two boundary vertices 10 % of an edge apart (a pleat's or a collar's layers) stay apart, and a
    panel's own short edge (2 % of the median) is not collapsed."""
    from cdbrdf.mesh import weld_seams

    g = np.stack(np.meshgrid(np.arange(6.0), np.arange(6.0), indexing="ij"), -1).reshape(-1, 2) * 10.0
    i, j = np.meshgrid(np.arange(5), np.arange(5), indexing="ij")
    q = (i * 6 + j).ravel()
    quad = np.concatenate([np.c_[q, q + 6, q + 7], np.c_[q, q + 7, q + 1]])
    lower = np.c_[g, np.zeros(36)]
    upper = np.c_[g, np.full(36, 1.0)]  # 1 mm above: 10 % of the 10 mm edge
    v = np.concatenate([lower, upper])
    f = np.concatenate([quad, quad + 36])
    assert int(weld_seams(v, f).max()) + 1 == 72
    v2 = lower.copy()
    v2[1, 1] = 0.2  # the first boundary edge is 0.2 mm long: 2 % of the median
    w = weld_seams(v2, quad)
    assert np.all((w[quad][:, 0] != w[quad][:, 1]) & (w[quad][:, 1] != w[quad][:, 2]) & (w[quad][:, 0] != w[quad][:, 2]))


def folded_strip(r: float = 2.0, flat: float = 100.0, width: float = 200.0, edge: float = 10.0, n_fold: int = 6):
    """A strip folded back on itself over a radius ``r`` (a collar's or a turned-up cuff's fold), coarse
    (``edge`` mm) away from the fold, with ``n_fold`` segments around it."""
    y1 = np.linspace(-flat, 0.0, int(flat / edge) + 1)
    a = np.linspace(-np.pi / 2, np.pi / 2, n_fold + 1)[1:-1]
    prof = np.r_[np.c_[y1, 0 * y1], np.c_[r * np.cos(a), r + r * np.sin(a)], np.c_[y1[::-1], 2 * r + 0 * y1]]
    xs = np.linspace(0.0, width, int(width / edge) + 1)
    v = np.c_[np.repeat(xs, len(prof)), np.tile(prof, (len(xs), 1))]
    n = len(prof)
    i, j = np.meshgrid(np.arange(len(xs) - 1), np.arange(n - 1), indexing="ij")
    q = (i * n + j).ravel()
    return v, np.concatenate([np.c_[q, q + n, q + n + 1], np.c_[q, q + n + 1, q + 1]])


def test_a_tight_fold_keeps_its_curvature_and_nothing_spikes():
    """A 2 mm fold on a 10 mm mesh: the fold's vertices bend at about 1/r (the cloth bends tighter than a
    table's stands: reported, true), nothing exceeds it, and the tessellation's own bend agrees."""
    from cdbrdf.mesh import surface_curvature
    from cdbrdf.mesh.curvature import dihedral_curvature

    v, f = folded_strip()
    s = surface_curvature(v, f, units="mm", frame=None)
    k = np.abs(s.kappa)
    on_fold = (v[s.source, 1] > 0.5) & (s.location == 0)
    assert 0.4 < np.median(k[on_fold]) < 0.6  # 1/r = 0.5
    assert k.max() < 0.75
    bend = dihedral_curvature(v, f)
    out = k > 0.22
    assert out.any() and np.all(bend[s.source[out]] >= 0.5 * k[out])


def test_the_tessellations_own_bend_of_a_cylinder_is_one_over_its_radius():
    from cdbrdf.mesh.curvature import dihedral_curvature

    a, z = np.meshgrid(np.linspace(0, np.pi, 61), np.linspace(0, 50, 21), indexing="ij")
    v = np.stack([25.0 * np.cos(a), 25.0 * np.sin(a), z], -1).reshape(-1, 3) / 1000.0  # in metres
    i, j = np.meshgrid(np.arange(60), np.arange(20), indexing="ij")
    q = (i * 21 + j).ravel()
    f = np.concatenate([np.c_[q, q + 21, q + 22], np.c_[q, q + 22, q + 1]])
    bend = dihedral_curvature(v, f, units="m")
    inner = (np.abs(v[:, 2] - 0.025) < 0.02) & (a.ravel() > 0.1) & (a.ravel() < np.pi - 0.1)
    assert np.allclose(bend[inner], 1 / 25.0, rtol=0.01)


# -- a scanned head ---------------------------------------------------------------------------
@pytest.mark.parametrize("base", ["open", "closed"])
@pytest.mark.parametrize("tilt", [0.0, 25.0, 40.0])
def test_a_scanned_head_is_upright_whichever_way_its_file_is(tmp_path, base, tilt):
    """A head and neck scanned Y-up (PLY, whose usual convention is Z), its neck cut at a slant and left open or
    capped: y is up; the same head in a Z-up file: z."""
    from cdbrdf.mesh.garments import head_mesh

    m = head_mesh(base=base, tilt_deg=tilt)
    up, why = detect_up(read_mesh(write_ascii_ply(tmp_path / "head.ply", m.vertices, m.faces.tolist())))
    assert up == "y" and ("opening" in why if base == "open" else "flat base" in why), why
    v = np.c_[m.vertices[:, 0], -m.vertices[:, 2], m.vertices[:, 1]]
    up, _ = detect_up(read_mesh(write_ascii_ply(tmp_path / "head-z.ply", v, m.faces.tolist())))
    assert up == "z"


# -- what a file says -------------------------------------------------------------------------
@pytest.mark.parametrize(("header", "units", "up"), [
    ("Units: metres, Y-up (the simulation's frame).", "m", "y"),
    ("This file uses centimeters as units for non-parametric coordinates.", "cm", None),
    ("exported with up axis: Z\nunit = mm", "mm", "z"),
    ("Blender v2.90.0 OBJ File: ''", None, None),
    ("a file with nothing to say", None, None),
])
def test_the_files_own_statements_are_read_with_their_source(tmp_path, header, units, up):
    m = garment_mesh()
    mesh = read_mesh(write_obj(tmp_path / "top.obj", m.vertices, m.faces, m.uv, header=header))
    assert mesh.metadata.get("units") == units and mesh.metadata.get("up") == up
    if units:
        assert mesh.metadata["units_source"].startswith("the file's header")
    if up:
        assert detect_up(mesh) == (up, mesh.metadata["up_source"])
    blender_or_maya = "Blender" in header or "centimeters" in header
    assert (mesh.metadata.get("up_default", (None,))[0] == "y") == blender_or_maya


def test_a_makehuman_asset_is_in_decimetres_y_up(tmp_path):
    from cdbrdf.mesh import prepare_mesh

    m = garment_mesh()
    v = np.c_[m.vertices[:, 0], m.vertices[:, 2], -m.vertices[:, 1]] / 100.0  # MakeHuman: dm, Y-up
    path = write_obj(tmp_path / "top.obj", v, m.faces, m.uv)
    (tmp_path / "top.mhmat").write_text("name top\n")
    mesh = read_mesh(path)
    assert (mesh.metadata["units"], mesh.metadata["up"]) == ("dm", "y")
    assert detect_up(mesh)[1] == "MakeHuman's frame, +Y up (top.mhmat beside it)"
    assert prepare_mesh(mesh).metadata["units_note"] == "units: dm (MakeHuman's unit (top.mhmat beside it))"


def test_an_axis_cdbrdf_cannot_turn_up_is_noted_and_the_geometry_decides(tmp_path):
    m = garment_mesh()
    mesh = read_mesh(write_obj(tmp_path / "top.obj", m.vertices, m.faces, m.uv, header="X-up"))
    assert "up" not in mesh.metadata and "cdbrdf turns y or z up only" in mesh.metadata["notes"][0]
    assert detect_up(mesh)[0] == "z"


def test_a_ply_comment_states_its_up_axis_but_cdbrdfs_record_comes_first(tmp_path):
    b = bust_mesh()
    stated = read_mesh(write_ascii_ply(tmp_path / "a.ply", b.vertices, b.faces.tolist(),
                                       extra_header="comment scanner frame: Y up"))
    assert detect_up(stated) == ("y", "the file's header: 'Y up'")
    both = read_mesh(write_ascii_ply(tmp_path / "b.ply", b.vertices, b.faces.tolist(),
                                     extra_header="comment cdbrdf up z\ncomment Y up"))
    assert detect_up(both) == ("z", "recorded in the file")


# -- units from the size ----------------------------------------------------------------------
@pytest.mark.parametrize(("scale", "unit"), [(1.0, "mm"), (0.1, "cm"), (0.01, "dm"), (0.001, "m")])
def test_a_garments_unit_is_inferred_from_its_size_and_said(tmp_path, scale, unit):
    """The CAD top (0.62 m tall) written in each unit without a word about it: the unit that makes it a
    garment's size, and the note says so; its curvature is then the cloth's."""
    from cdbrdf.mesh import prepare_mesh

    m = garment_mesh()
    mesh = prepare_mesh(write_obj(tmp_path / "top.obj", m.vertices * scale, m.faces, m.uv), kappa_range=(-0.22, 0.22))
    assert mesh.metadata["units"] == unit
    assert mesh.metadata["units_note"].startswith(f"units: inferred {unit} from the size: 0.62 m tall")
    assert "as a garment" in mesh.metadata["units_note"]
    assert mesh.metadata["outside_share"] < 0.01


def test_no_unit_is_inferred_for_an_object_of_no_known_kind(tmp_path):
    from cdbrdf.mesh import prepare_mesh

    from .mesh_helpers import sphere_mesh

    v, f = sphere_mesh(10.0, n=400)
    note = prepare_mesh(write_obj(tmp_path / "ball.obj", v, f)).metadata["units_note"]
    assert note.startswith("units: mm (none given or recorded, and the geometry is no garment or sheet")


@pytest.mark.parametrize(("scale", "header", "warned"), [
    (10.0, "units: mm", "6.2 m tall"),  # ten times too large overall
    (3.0, "units: mm", "implausibly large"),  # 1.9 m tall (a gown could be) but its cuffs 1 m around
    (1.0, "units: mm", None),
])
def test_a_stated_unit_is_followed_and_an_implausible_garment_warned_of(tmp_path, caplog, scale, header, warned):
    from cdbrdf.mesh import prepare_mesh

    m = garment_mesh()
    path = write_obj(tmp_path / "top.obj", m.vertices * scale, m.faces, m.uv, header=header)
    with caplog.at_level(logging.WARNING, logger="cdbrdf.mesh.prepare"):
        mesh = prepare_mesh(path)
    assert mesh.metadata["units"] == "mm"
    msgs = [r.getMessage() for r in caplog.records if "garment" in r.getMessage()]
    if warned is None:
        assert not msgs
    else:
        assert len(msgs) == 1 and warned in msgs[0] and "implausible for a garment" in mesh.metadata["units_note"]


def test_a_uv_map_cut_at_every_edge_follows_no_fabric_but_a_small_whole_chart_does():
    """A sheet whose UVs are cut at every face (each face its own corners, as some remeshers leave them) takes
    the material's x axis from the bending, and says so; the same sheet with whole UVs, and a quad of two
    faces, keep their UV frame."""
    from cdbrdf.mesh import surface_curvature

    v, f = folded_strip(r=20.0, n_fold=20)
    uv = v[:, :2] / 100.0
    whole = surface_curvature(v, f, uv=uv, units="mm")
    assert whole.frame == "uv"
    cut_v, cut_uv = v[f.reshape(-1)], uv[f.reshape(-1)] + np.repeat(np.arange(f.shape[0]), 3)[:, None] * 0.01
    cut = surface_curvature(cut_v, np.arange(3 * f.shape[0]).reshape(-1, 3), uv=cut_uv, units="mm")
    assert cut.frame == "principal"
    assert any("the UV map is cut at nearly every edge" in n for n in cut.notes)
    quad = surface_curvature(np.array([[0.0, 0, 0], [100, 0, 0], [100, 100, 0], [0, 100, 0]]),
                             np.array([[0, 1, 2], [0, 2, 3]]), uv=np.array([[0.0, 0], [1, 0], [1, 1], [0, 1]]))
    assert quad.frame == "uv"
