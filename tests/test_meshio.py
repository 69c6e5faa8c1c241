"""Mesh files: PLY (every layout), OBJ, glTF/GLB, STL, OFF in; PLY out; corrupt and hostile files refused.

Known answers: files written here from known arrays; trimesh's own readers
and writers as the reference for the formats cdbrdf reads through it.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from cdbrdf.errors import CDBRDFError, LimitError, MeshError
from cdbrdf.mesh import Mesh, SineSheet, prepare_mesh, read_mesh, read_obj, read_ply, sine_sheet_mesh, write_ply

from .mesh_helpers import R_CYL, cylinder_patch, shared_mesh, write_ascii_ply, write_obj


def binary_ply(path, v, lists, *, endian="<", count_type="u1", index_type="i4", element="face",
               extra_vertex=(), comments=()):
    """A binary PLY written by hand: x y z [extra] float32, one list element."""
    bo = {"<": "binary_little_endian", ">": "binary_big_endian"}[endian]
    names = {"u1": "uchar", "i4": "int", "u4": "uint", "i2": "short", "i1": "char"}
    head = ["ply", f"format {bo} 1.0", *[f"comment {c}" for c in comments], f"element vertex {len(v)}",
            "property float x", "property float y", "property float z"]
    head += [f"property float {n}" for n, _ in extra_vertex]
    head += [f"element {element} {len(lists)}",
             f"property list {names[count_type]} {names[index_type]} vertex_indices", "end_header"]
    cols = [np.asarray(v, dtype=endian + "f4")] + [np.asarray(a, dtype=endian + "f4")[:, None] for _, a in extra_vertex]
    body = np.hstack(cols).astype(endian + "f4").tobytes()
    for lst in lists:
        body += np.array([len(lst)], dtype=endian + count_type).tobytes()
        body += np.asarray(lst, dtype=endian + index_type).tobytes()
    path.write_bytes(("\n".join(head) + "\n").encode() + body)
    return path


def quad_grid(n=4):
    x, y = np.meshgrid(np.arange(n, dtype=float), np.arange(n, dtype=float), indexing="ij")
    v = np.c_[x.ravel(), y.ravel(), np.zeros(n * n)]
    quads = [[i * n + j, (i + 1) * n + j, (i + 1) * n + j + 1, i * n + j + 1]
             for i in range(n - 1) for j in range(n - 1)]
    return v, quads


# -- PLY -------------------------------------------------------------------------------------
def test_ply_round_trip_keeps_everything_and_records_the_metadata(tmp_path):
    m = sine_sheet_mesh(SineSheet(width_mm=20, depth_mm=10, vertices_per_wavelength=16))
    m.tangents = np.tile([1.0, 0.0, 0.0], (m.n_vertices, 1))
    m.metadata.update({"units": "in", "neighbourhood_mm": 2.5})
    path = tmp_path / "s.ply"
    write_ply(path, m)
    r = read_ply(path)
    assert np.allclose(r.vertices, m.vertices, atol=1e-5)
    assert np.array_equal(r.faces, m.faces)
    assert np.allclose(r.uv, m.uv, atol=1e-6)
    assert np.allclose(r.normals, m.normals, atol=1e-6)
    assert np.allclose(r.tangents, m.tangents)
    for name in ("curvature", "curvature_dir"):
        assert np.allclose(r.attributes[name], m.attributes[name], atol=1e-6)
    assert r.metadata["units"] == "in" and r.metadata["up"] == "z" and r.metadata["curvature_units"] == "1/mm"
    assert float(r.metadata["neighbourhood_mm"]) == 2.5
    header = path.read_bytes().split(b"end_header")[0]
    assert b"property float curvature_x" in header and b"property float curvature_dir_x" in header
    # the same as trimesh reads
    import trimesh

    t = trimesh.load(path, process=False)
    assert np.allclose(t.vertices, r.vertices) and np.array_equal(t.faces, r.faces)


def test_ascii_ply_with_quads_and_polygons(tmp_path):
    v, quads = quad_grid()
    polys = quads[:-1] + [[0, 1, 5, 6, 2]]  # a pentagon
    m = read_mesh(write_ascii_ply(tmp_path / "q.ply", v, polys, uv=v[:, :2] / 3))
    assert m.faces.shape == (2 * 8 + 3, 3)
    assert m.faces[:2].tolist() == [[0, 4, 5], [0, 5, 1]]  # a quad as a fan
    assert np.allclose(m.uv[5], v[5, :2] / 3)


@pytest.mark.parametrize("endian", ["<", ">"])
def test_binary_ply_with_mixed_triangles_and_quads(tmp_path, endian):
    v, quads = quad_grid()
    lists = [q[:3] if k % 2 else q for k, q in enumerate(quads)]
    m = read_mesh(binary_ply(tmp_path / "m.ply", v, lists, endian=endian))
    n_tri = sum(len(lst) - 2 for lst in lists)
    assert m.faces.shape == (n_tri, 3)
    assert m.faces[0].tolist() == [0, 4, 5] and m.faces[1].tolist() == [0, 5, 1]
    assert np.allclose(m.vertices, v)


def test_ply_triangle_strips(tmp_path):
    v, _ = quad_grid(3)
    # one strip over the 2x2 cells of the first row, a restart, then one triangle
    strips = [[0, 3, 1, 4, 2, 5, -1, 3, 6, 4]]
    m = read_mesh(binary_ply(tmp_path / "t.ply", v, strips, element="tristrips"))
    assert m.faces.tolist() == [[0, 3, 1], [1, 3, 4], [1, 4, 2], [2, 4, 5], [3, 6, 4]]  # odd ones (n+1, n, n+2)
    # every triangle faces the same way (strips alternate their order)
    n = np.cross(m.vertices[m.faces[:, 1]] - m.vertices[m.faces[:, 0]],
                 m.vertices[m.faces[:, 2]] - m.vertices[m.faces[:, 0]])
    assert np.all(np.sign(n[:, 2]) == np.sign(n[0, 2]))


def test_ply_per_corner_texcoords_split_the_vertices(tmp_path):
    text = "\n".join([
        "ply", "format ascii 1.0", "element vertex 4", "property float x", "property float y", "property float z",
        "element face 2", "property list uchar int vertex_indices", "property list uchar float texcoord",
        "end_header", "0 0 0", "1 0 0", "1 1 0", "0 1 0",
        "3 0 1 2 6 0 0 1 0 1 1", "3 0 2 3 6 0.5 0.5 1 1 0 1", ""])
    (tmp_path / "w.ply").write_text(text)
    m = read_mesh(tmp_path / "w.ply")
    assert m.n_vertices == 5  # vertex 0 has two UVs
    assert m.uv is not None and np.allclose(m.uv[m.faces[1, 0]], [0.5, 0.5])
    assert np.allclose(m.vertices[m.faces[1, 0]], [0, 0, 0])


def test_ply_foreign_properties_and_unit_comments(tmp_path):
    v, quads = quad_grid()
    p = binary_ply(tmp_path / "f.ply", v, quads,
                   extra_vertex=[("quality", np.ones(16)), ("thickness_x", np.arange(16))],
                   comments=["made by a scanner", "cdbrdf units cm", "cdbrdf up y"])
    m = read_mesh(p)
    assert "thickness" in m.attributes and "quality" not in m.attributes
    assert m.metadata["units"] == "cm" and m.metadata["up"] == "y" and m.metadata["source"] == str(p)


# -- OBJ, glTF, STL, OFF through trimesh -------------------------------------------------------
def test_obj_with_separate_indices_groups_quads_and_objects(tmp_path):
    text = """# quads, groups, objects, separate vt/vn indices, negative indices
o first
v 0 0 0
v 1 0 0
v 1 1 0
v 0 1 0
v 2 0 0
v 2 1 0
vt 0 0
vt 1 0
vt 1 1
vt 0 1
vt 0.5 0.5
vn 0 0 1
g panelA
f 1/1/1 2/2/1 3/3/1 4/4/1
g panelB
usemtl blue
f 2/5/1 5/2/1 6/3/1 3/4/1
o second
v 0 0 1
v 1 0 1
v 1 1 1
f -3/1/1 -2/2/1 -1/3/1
"""
    (tmp_path / "m.obj").write_text(text)
    m = read_obj(tmp_path / "m.obj")
    assert m.faces.shape == (5, 3) and m.uv is not None and m.normals is not None
    # vertex 2 (1, 0, 0) appears with two UVs: (1, 0) in panel A and (0.5, 0.5) in panel B
    at = np.flatnonzero(np.all(m.vertices == [1, 0, 0], axis=1))
    assert sorted(map(tuple, m.uv[at].tolist())) == [(0.5, 0.5), (1.0, 0.0)]
    assert m.metadata["format"] == "obj"
    s = prepare_mesh(m)
    assert s.faces.shape[0] == 5 and "curvature" in s.attributes


def test_gltf_and_glb_with_uvs_normals_and_node_transforms(tmp_path):
    import trimesh

    v, f, uv, _ = cylinder_patch(R_CYL / 1000.0, n=12)  # in metres
    n = v * np.array([1.0, 0.0, 1.0])
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    mesh = trimesh.Trimesh(v, f, vertex_normals=n, process=False,
                           visual=trimesh.visual.TextureVisuals(uv=uv, material=trimesh.visual.material.PBRMaterial()))
    scene = trimesh.Scene()
    scene.add_geometry(mesh, node_name="a", geom_name="a")
    scene.add_geometry(mesh, node_name="b", geom_name="b",
                       transform=trimesh.transformations.translation_matrix([0.0, 0.0, 0.02]))
    for ext in ("glb", "gltf"):
        path = tmp_path / f"c.{ext}"
        scene.export(path)
        m = read_mesh(path)
        assert m.faces.shape == (2 * len(f), 3) and m.uv is not None and m.normals is not None
        assert m.metadata["units"] == "m" and m.metadata["up"] == "y"
        assert np.isclose(m.vertices[:, 2].max(), v[:, 2].max() + 0.02, atol=1e-6)  # the transform applied
        assert np.allclose(np.linalg.norm(m.normals, axis=1), 1.0, atol=1e-5)
        s = prepare_mesh(m)  # metres, from the file: kappa 0.22 / mm on both parts
        assert s.metadata["units"] == "m"
        assert np.median(s.attributes["curvature"]) == pytest.approx(0.22, rel=0.05)


def test_stl_triangle_soup_and_off(tmp_path):
    import trimesh

    v, f, uv, _ = cylinder_patch(R_CYL, n=12)
    t = trimesh.Trimesh(v, f, process=False)
    for ext in ("stl", "off"):
        t.export(tmp_path / f"c.{ext}")
        m = read_mesh(tmp_path / f"c.{ext}")
        assert m.faces.shape == f.shape and m.uv is None
        s = prepare_mesh(m)
        if ext == "stl":
            assert any(r.startswith("welded") for r in s.metadata["repairs"])
        assert s.metadata["frame"] == "principal" and s.uv is not None


def test_unknown_format_and_missing_file(tmp_path):
    with pytest.raises(MeshError, match="unknown mesh format"):
        read_mesh(tmp_path / "m.fbx")
    with pytest.raises(MeshError, match="cannot be read"):
        read_mesh(tmp_path / "missing.ply")


# -- corrupt and hostile files -----------------------------------------------------------------
def ply_text(vertex_count=3, face_count=1, body="0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n", fmt="ascii"):
    return (f"ply\nformat {fmt} 1.0\nelement vertex {vertex_count}\nproperty float x\nproperty float y\n"
            f"property float z\nelement face {face_count}\nproperty list uchar int vertex_indices\nend_header\n"
            + body)


HOSTILE = {
    "1e12 faces (ascii)": ply_text(face_count=10**12),
    "1e12 faces (binary)": ply_text(face_count=10**12, fmt="binary_little_endian", body="\x00" * 64),
    "1e12 vertices": ply_text(vertex_count=10**12, fmt="binary_little_endian", body="\x00" * 64),
    "nan coordinates": ply_text(body="nan 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"),
    "1e308 coordinates": ply_text(body="1e308 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"),
    "inf coordinates": ply_text(body="inf 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"),
    "index out of range": ply_text(body="0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n"),
    "negative index": ply_text(body="0 0 0\n1 0 0\n0 1 0\n3 0 -1 2\n"),
    "list runs past the end": ply_text(body="0 0 0\n1 0 0\n0 1 0\n200 0 1 2\n"),
    "truncated": ply_text()[:-12],
    "words in the data": ply_text(body="0 0 0\n1 zero 0\n0 1 0\n3 0 1 2\n"),
    "no end_header": "ply\nformat ascii 1.0\nelement vertex 3\n",
    "not ply": "solid nothing\n",
    "bad format": ply_text(fmt="binary_middle_endian"),
    "point cloud": "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\n"
                   "end_header\n0 0 0\n",
    "all degenerate": ply_text(body="0 0 0\n1 0 0\n2 0 0\n3 0 1 2\n"),
    "fractional index": ply_text(body="0 0 0\n1 0 0\n0 1 0\n3 0 1.5 2\n"),
}


@pytest.mark.parametrize("name", sorted(HOSTILE))
def test_corrupt_ply_is_one_mesh_error_naming_the_file(tmp_path, name):
    p = tmp_path / "bad.ply"
    p.write_bytes(HOSTILE[name].encode("latin-1"))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(CDBRDFError) as info:
            prepare_mesh(p)
    assert isinstance(info.value, MeshError | LimitError)
    msg = str(info.value)
    assert "\n" not in msg and (str(p) in msg or "mesh" in msg)


@pytest.mark.parametrize("ext, data", [
    ("obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 99\n"),
    ("obj", "v nan 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"),
    ("obj", "v 1e308 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"),
    ("obj", "this is not an obj\n"),
    ("obj", ""),
    ("stl", "\x00" * 80 + "\xff\xff\xff\x7f" + "\x00" * 50),
    ("glb", "glTF\x02\x00\x00\x00" + "\xff" * 40),
    ("gltf", '{"asset": {"version": "2.0"}, "meshes": [{"primitives": [{"attributes": {"POSITION": 7}}]}]}'),
    ("off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 5\n"),
])
def test_corrupt_files_of_other_formats_are_one_mesh_error(tmp_path, ext, data):
    p = tmp_path / f"bad.{ext}"
    p.write_bytes(data.encode("latin-1"))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(CDBRDFError) as info:
            prepare_mesh(p)
    assert "\n" not in str(info.value) and str(p) in str(info.value)


def test_faces_beyond_the_limit_are_refused_before_reading(tmp_path, monkeypatch):
    v, f, uv, _ = cylinder_patch(R_CYL, n=10)
    p = tmp_path / "c.ply"
    write_ply(p, Mesh(v, f))
    monkeypatch.setenv("CDBRDF_MAX_MESH_FACES", "10")
    with pytest.raises(LimitError, match="CDBRDF_MAX_MESH_FACES"):
        read_mesh(p)
    write_obj(tmp_path / "c.obj", v, f)
    with pytest.raises(LimitError, match="CDBRDF_MAX_MESH_FACES"):
        read_mesh(tmp_path / "c.obj")


def test_write_refuses_bad_meshes_and_writes_nothing(tmp_path):
    v, f, uv, _ = cylinder_patch(R_CYL, n=10)
    with pytest.raises(MeshError, match="faces"):
        write_ply(tmp_path / "x.ply", Mesh(v, f + 1000))
    with pytest.raises(MeshError, match="attribute"):
        write_ply(tmp_path / "x.ply", Mesh(v, f, attributes={"curvature": np.zeros(3)}))
    assert not list(tmp_path.iterdir())


# -- the real meshes ---------------------------------------------------------------------------
def test_real_meshes_read():
    spot = read_mesh(shared_mesh("spot.obj"))
    assert spot.n_vertices == 3225 and spot.faces.shape == (5856, 3) and spot.uv is not None
    fan = read_mesh(shared_mesh("fandisk.obj"))
    assert fan.uv is None and fan.faces.shape == (12946, 3)


# -- ASCII PLY: one record a line --------------------------------------------------------------
def _ascii_header(n_vertex, n_face, *, texcoord=False):
    head = ["ply", "format ascii 1.0", "comment cdbrdf units mm", f"element vertex {n_vertex}",
            "property float x", "property float y", "property float z", "property float curvature_x",
            f"element face {n_face}", "property list uchar int vertex_indices"]
    if texcoord:
        head.append("property list uchar float texcoord")
    return head + ["end_header"]


#: A square of 4 vertices (x y z curvature_x) and 2 triangles: header lines 1-11, vertices 12-15, faces 16-17.
SQUARE_LINES = _ascii_header(4, 2) + ["0 0 0 0.5", "1 0 0 0.25", "1 1 0 0.125", "0 1 0 1",
                                      "3 0 1 2", "3 0 2 3"]


def _square(lines, *, end="\n"):
    return end.join(lines) + end


def _expect_line_error(tmp_path, text, match):
    p = tmp_path / "bad.ply"
    p.write_bytes(text.encode("ascii"))
    with pytest.raises(MeshError) as info:
        read_ply(p)
    msg = str(info.value)
    assert "\n" not in msg and msg.startswith(f"{p}: ")
    assert msg == f"{p}: {match}"


@pytest.mark.parametrize("case, lines, message", [
    ("merged vertex lines", SQUARE_LINES[:11] + ["0 0 0 0.5 1 0 0 0.25", "1 1 0 0.125", "0 1 0 1",
                                                   "3 0 1 2", "3 0 2 3", "3 0 1 2"],
     "line 12: element 'vertex' record 0: expected 4 values, found 8"),
    ("a vertex split over two lines", SQUARE_LINES[:12] + ["1 0", "0 0.25"] + SQUARE_LINES[14:],
     "line 13: element 'vertex' record 1: expected 4 values, found 2"),
    ("a missing vertex value", SQUARE_LINES[:13] + ["1 1 0"] + SQUARE_LINES[14:],
     "line 14: element 'vertex' record 2: expected 4 values, found 3"),
    ("an extra vertex value", SQUARE_LINES[:14] + ["0 1 0 1 7"] + SQUARE_LINES[15:],
     "line 15: element 'vertex' record 3: expected 4 values, found 5"),
    # token by token, "3 0 1" would take the next line's "3" as its third index
    ("a face missing a value", SQUARE_LINES[:15] + ["3 0 1", "3 0 2 3"],
     "line 16: element 'face' record 0: expected 4 values (vertex_indices: 3 items), found 3"),
    ("a face with an extra value", SQUARE_LINES[:16] + ["3 0 2 3 1"],
     "line 17: element 'face' record 1: expected 4 values (vertex_indices: 3 items), found 5"),
    ("merged face lines", SQUARE_LINES[:15] + ["3 0 1 2 3 0 2 3"],
     "line 16: element 'face' record 0: expected 4 values (vertex_indices: 3 items), found 8"),
    ("a list count above its items", SQUARE_LINES[:15] + ["4 0 1 2", "3 0 2 3"],
     "line 16: element 'face' record 0: expected 5 values (vertex_indices: 4 items), found 4"),
    ("a list count below its items", SQUARE_LINES[:16] + ["2 0 2 3"],
     "line 17: element 'face' record 1: expected 3 values (vertex_indices: 2 items), found 4"),
    ("a fractional list count", SQUARE_LINES[:16] + ["2.5 0 2 3"],
     "line 17: element 'face' record 1: the count of list 'vertex_indices' is 2.5, not a whole number >= 0"),
    ("a record too few", SQUARE_LINES[:-1],
     "element 'face' declares 2 records, the data ends after 1 of them (line 16)"),
    ("a record too many", SQUARE_LINES + ["3 1 2 3"],
     "line 18: data after the last record the header declares (4 'vertex', 2 'face')"),
    ("a comment in the data", SQUARE_LINES[:13] + ["comment not here"] + SQUARE_LINES[13:],
     "line 14: a comment in the data (PLY comments belong in the header)"),
    ("a malformed number", SQUARE_LINES[:13] + ["1 1-0 0 0.125"] + SQUARE_LINES[14:],
     "line 14: '1-0' is not a number"),
])
def test_ascii_ply_record_not_one_line_is_an_error_naming_the_line(tmp_path, case, lines, message):
    _expect_line_error(tmp_path, _square(lines), message)


def test_ascii_ply_line_numbers_count_crlf_headers_and_blank_lines(tmp_path):
    lines = SQUARE_LINES[:11] + ["", "0 0 0 0.5", "   ", "1 0 0 0.25", "1 1 0 0.125", "0 1 0", "3 0 1 2", "3 0 2 3"]
    _expect_line_error(tmp_path, _square(lines, end="\r\n"),
                       "line 17: element 'vertex' record 3: expected 4 values, found 3")


def test_ascii_ply_list_counts_of_two_lists_are_checked(tmp_path):
    # header lines 1-12, vertices 13-15, the face 16
    head = _ascii_header(3, 1, texcoord=True)
    good = head + ["0 0 0 1", "1 0 0 1", "0 1 0 1", "3 0 1 2 6 0 0 1 0 0 1"]
    (tmp_path / "ok.ply").write_text(_square(good))
    m = read_ply(tmp_path / "ok.ply")
    assert m.uv is not None and np.allclose(m.uv[m.faces[0]], [[0, 0], [1, 0], [0, 1]])
    _expect_line_error(tmp_path, _square(head + good[len(head):-1] + ["3 0 1 2 6 0 0 1 0 0"]),
                       "line 16: element 'face' record 0: expected 11 values (vertex_indices: 3 items, "
                       "texcoord: 6 items), found 10")
    _expect_line_error(tmp_path, _square(head + good[len(head):-1] + ["3 0 1 2"]),
                       "line 16: element 'face' record 0: expected at least 5 values, found 4")


def _twin_files(tmp_path):
    """The same irregular mesh as binary PLY (cdbrdf's writer) and as ASCII (float32 values in full), and quads."""
    v, f, uv, _ = cylinder_patch(R_CYL, n=9, seed=5)
    k = np.linspace(-0.3, 0.2, len(v))
    mesh = Mesh(v, f, None, uv, {"curvature": k}, metadata={"units": "cm"})
    write_ply(tmp_path / "b.ply", mesh)
    cols = [np.asarray(a, dtype=np.float32).astype(np.float64) for a in (*v.T, *uv.T, k)]
    head = ["ply", "format ascii 1.0", "comment cdbrdf units cm", f"element vertex {len(v)}",
            *[f"property float {c}" for c in ("x", "y", "z", "u", "v", "curvature_x")],
            f"element face {len(f)}", "property list uchar int vertex_indices", "end_header"]
    rows = [" ".join(repr(float(c[i])) for c in cols) for i in range(len(v))]
    rows += [" ".join(map(str, [3, *t])) for t in f]
    return tmp_path / "b.ply", head, rows


@pytest.mark.parametrize("layout", ["plain", "crlf", "blank lines", "trailing whitespace", "no final newline",
                                    "tabs"])
def test_valid_ascii_ply_reads_equal_to_the_binary_path(tmp_path, layout):
    bin_path, head, rows = _twin_files(tmp_path)
    if layout == "plain":
        text = "\n".join(head + rows) + "\n"
    elif layout == "crlf":
        text = "\r\n".join(head + rows) + "\r\n"
    elif layout == "blank lines":
        text = "\n".join(head + ["", *[r + ("\n\n \t\n" if i % 7 == 0 else "") for i, r in enumerate(rows)], ""])
    elif layout == "trailing whitespace":
        text = "\n".join(head + [" " + r + " \t " for r in rows]) + "\n"
    elif layout == "no final newline":
        text = "\n".join(head + rows)
    else:
        text = "\n".join(head + [r.replace(" ", "\t") for r in rows]) + "\n"
    (tmp_path / "a.ply").write_bytes(text.encode("ascii"))
    a, b = read_ply(tmp_path / "a.ply"), read_ply(bin_path)
    assert np.array_equal(a.vertices, b.vertices) and np.array_equal(a.faces, b.faces)
    assert np.array_equal(a.uv, b.uv) and np.array_equal(a.attributes["curvature"], b.attributes["curvature"])
    assert a.metadata["units"] == b.metadata["units"] == "cm"


def test_ascii_ply_values_are_the_correctly_rounded_doubles(tmp_path):
    """Every token reads bit for bit as Python's ``float`` reads it (the numba fast path and its fallback)."""
    from cdbrdf.mesh._ply import parse_ply

    rng = np.random.default_rng(7)
    x = rng.normal(size=4000) * 10.0 ** rng.integers(-30, 30, 4000)
    tokens = [f"{v:.9g}" for v in x.astype(np.float32)] + [repr(float(v)) for v in x]
    tokens += [f"{v:.17g}" for v in x[:500]] + [f"{v:.{int(d)}e}" for v, d in zip(x, rng.integers(0, 16, 4000))]
    tokens += [str(i) for i in rng.integers(-10**12, 10**12, 500)]
    tokens += ["-0", "+0.0", "007.50", ".5", "5.", "1E+05", "-1e-22", "1e22", "1e23", "9007199254740993",
               "123456789012345678901234567890", "0.30000000000000004", "1e-400", "1e400", "nan", "-inf",
               "Infinity", "4.9406564584124654e-324", "2.2250738585072014e-308", "1.7976931348623157e308"]
    tokens += [""] * (-len(tokens) % 3)
    tokens = [t or "1" for t in tokens]
    rows = [" ".join(tokens[i:i + 3]) for i in range(0, len(tokens), 3)]
    text = "\n".join(ply_text(vertex_count=len(rows), body="").splitlines() + rows + ["3 0 1 2"]) + "\n"
    d = parse_ply(text.encode("ascii"), "t.ply")
    got = np.stack([d.vertex[k] for k in "xyz"], axis=1).reshape(-1)
    want = np.array([float(t) for t in tokens])
    assert np.array_equal(got.view(np.int64), want.view(np.int64))


# -- hostile input, second round ------------------------------------------------------------------------
@pytest.mark.parametrize("face", ["f 0 1 2", "f 1/1 2/2 0/3", "f 1/0 2/2 3/3", "f -0 1 2", "  f\t1 0 2"])
def test_obj_index_0_names_no_vertex_and_is_refused(tmp_path, face):
    """OBJ indices count from 1: `f 0 1 2` was accepted (read as the last vertex)."""
    p = tmp_path / "zero.obj"
    p.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\n" + face + "\n")
    with pytest.raises(MeshError, match=r"zero\.obj: line 7: a face refers to index 0"):
        read_mesh(p)
    p.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3\nf 2 -1 3\n")
    assert read_mesh(p).faces.shape == (2, 3)  # 1 and -1 (the last vertex) are valid indices


@pytest.mark.parametrize("kind", ["fifo", "/dev/zero"])
@pytest.mark.parametrize("ext", ["ply", "obj", "stl"])
def test_special_files_are_refused_before_they_are_read(tmp_path, kind, ext):
    import os

    p = tmp_path / f"m.{ext}"
    if kind == "fifo":
        os.mkfifo(p)
    else:
        p.symlink_to(kind)
    with pytest.raises(MeshError, match=rf"m\.{ext}: cannot be read \(not a regular file"):
        read_mesh(p)


@pytest.mark.parametrize("far", [1e10, 1e14])
def test_a_mesh_with_a_vertex_kilometres_away_is_refused(far):
    """One triangle 1e10-1e14 mm long rendered an all-black image with exit 0 (the object shrank below a pixel)."""
    v, f, uv, _ = cylinder_patch(R_CYL, n=12)
    n = len(v)
    v = np.r_[v, [[far, 0, 0], [far, 1, 0], [far, 0, 1]]]
    f = np.r_[f, [[n, n + 1, n + 2]]]
    uv = np.r_[uv, np.zeros((3, 2))]
    with pytest.raises(MeshError, match=r"mm across \(unit mm\), beyond 1e\+06 mm"):
        prepare_mesh(Mesh(v, f, None, uv, {}, None, {}))
    with pytest.raises(MeshError, match=r"unit m\), beyond 1e\+06 mm"):  # a wrong unit: 1 km in metres is 1e6 mm
        prepare_mesh(Mesh(v[:n] * 1e4, f[:-1], None, uv[:n], {}, None, {}), units="m")


# -- the files a mesh pulls in --------------------------------------------------------------------------
_TRI_OBJ = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nusemtl cloth\nf 1/1 2/2 3/3\n"


def test_referenced_files_of_obj_mtl_and_gltf(tmp_path):
    import json

    from cdbrdf.mesh import referenced_files

    (tmp_path / "a.obj").write_text("mtllib a.mtl\n" + _TRI_OBJ)
    (tmp_path / "a.mtl").write_text("newmtl cloth\nmap_Kd -o 0.5 0.5 -clamp on tex/diffuse map.png\n"
                                    "map_Bump -bm 0.3 bump.png\nnorm normal.png\ndisp -mm 0 1 height.exr\n")
    refs = referenced_files(tmp_path / "a.obj")
    assert [(r.role, r.path.relative_to(tmp_path).as_posix()) for r in refs] == [
        ("mtllib", "a.mtl"), ("map_Kd", "tex/diffuse map.png"), ("map_Bump", "bump.png"), ("norm", "normal.png"),
        ("disp", "height.exr")]
    (tmp_path / "b.gltf").write_text(json.dumps({"asset": {"version": "2.0"},
                                                 "buffers": [{"uri": "b%20c.bin"}, {"uri": "data:,abc"}],
                                                 "images": [{"uri": "img/n.png"}, {"bufferView": 0}]}))
    assert [(r.role, r.path.relative_to(tmp_path).as_posix()) for r in referenced_files(tmp_path / "b.gltf")] == [
        ("buffer", "b c.bin"), ("image", "img/n.png")]
    assert referenced_files(tmp_path / "x.ply") == []


@pytest.mark.parametrize("where", ["mtllib", "map", "gltf-image", "gltf-buffer"])
def test_a_fifo_named_by_a_mesh_is_refused_before_anything_opens_it(tmp_path, where):
    """trimesh opened an OBJ's mtllib, an MTL's map and a glTF's uri itself: a FIFO there hung the run."""
    import json
    import os

    if where in ("mtllib", "map"):
        (tmp_path / "a.obj").write_text("mtllib a.mtl\n" + _TRI_OBJ)
        if where == "mtllib":
            os.mkfifo(tmp_path / "a.mtl")
        else:
            (tmp_path / "a.mtl").write_text("newmtl cloth\nmap_Kd pipe.png\n")
            os.mkfifo(tmp_path / "pipe.png")
        mesh = tmp_path / "a.obj"
    else:
        doc = {"asset": {"version": "2.0"}, "buffers": [{"uri": "pipe.bin" if where == "gltf-buffer" else "b.bin",
                                                          "byteLength": 4}],
               "images": [{"uri": "pipe.png" if where == "gltf-image" else "ok.png"}]}
        (tmp_path / "a.gltf").write_text(json.dumps(doc))
        os.mkfifo(tmp_path / ("pipe.bin" if where == "gltf-buffer" else "pipe.png"))
        mesh = tmp_path / "a.gltf"
    with pytest.raises(MeshError, match=r"its (mtllib|map_Kd|buffer|image) .*pipe|its mtllib .*a\.mtl.*FIFO"):
        read_mesh(mesh)


@pytest.mark.parametrize("uri", ["file:///etc/passwd", "http://example.com/n.png", "/etc/passwd"])
def test_a_gltf_uri_that_is_no_relative_file_is_refused(tmp_path, uri):
    import json

    (tmp_path / "a.gltf").write_text(json.dumps({"asset": {"version": "2.0"}, "images": [{"uri": uri}]}))
    with pytest.raises(MeshError, match=r"a\.gltf: glTF images\[0\]\.uri .* is not a relative file name"):
        read_mesh(tmp_path / "a.gltf")


def test_a_missing_normal_map_named_by_the_mtl_is_said(tmp_path):
    (tmp_path / "a.obj").write_text("mtllib a.mtl\n" + _TRI_OBJ)
    (tmp_path / "a.mtl").write_text("newmtl cloth\nnorm wrinkles.png\n")
    mesh = read_mesh(tmp_path / "a.obj")
    assert "normal_map" not in mesh.metadata
    assert any("names the normal map" in n and "wrinkles.png" in n and "does not exist" in n
               for n in mesh.metadata["notes"])
