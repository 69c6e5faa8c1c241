"""The glTF export (cdbrdf export, cdbrdf.export): the asset's mesh and table, reading it back, the fallback
material's fit, MikkTSpace tangents against the reference implementation, the Khronos validator, MaterialX.

The browser renderer of the assets is tested in tests/test_gltf_renderer.py.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

import cdbrdf
from cdbrdf import materials
from cdbrdf.cli import main
from cdbrdf.errors import FormatError
from cdbrdf.export.fallback import FallbackFit, fit_fallback, gltf_brdf
from cdbrdf.export.gltf import build_gltf, export_mesh, write_gltf
from cdbrdf.gltf_table import EXTENSION, decode_table, encode_table
from cdbrdf.mesh import MeshSurface, garment_mesh, prepare_mesh

from .conftest import make_table
from .gltf_helpers import accessor, errors, mikktspace, needs_node, read_glb, validate
from .shared_data import shared_file

SCHEMA = Path(__file__).resolve().parents[1] / "docs" / "schema" / "material.CDBRDF_materials_curvature_brdf.schema.json"

#: A fallback for the tests that are not about it (the fit takes seconds).
FIXED_FALLBACK = FallbackFit((0.05, 0.06, 0.09), 0.9, (0.1, 0.1, 0.3), 0.4, 0.0, 0.0, 0.3, 0.2, 0)


@pytest.fixture(scope="module")
def denim():
    return materials.load("denim")


@pytest.fixture(scope="module")
def shirt(denim, tmp_path_factory):
    """The CAD shirt (mm, Z-up, sewn panels) with denim, as a GLB, and the prepared mesh the renderer uses."""
    path = tmp_path_factory.mktemp("shirt") / "shirt.glb"
    mesh = export_mesh(garment_mesh(), table=denim)
    asset = build_gltf(denim, mesh, fallback=FIXED_FALLBACK)
    write_gltf(asset, path)
    return path, mesh, asset


# -- the table in the asset --------------------------------------------------------------------------
def test_lookup_texture_round_trip_within_half_a_step(denim):
    lut = encode_table(denim)
    parts = decode_table(lut.spec, lut.png, lut.measured_png)
    v = denim.values.astype(np.float64)
    scale = np.array(lut.spec["lookup"]["encoding"]["scale"])
    g = denim.grid
    off_pole = (g.mesh()["theta_l"] > 0) & (g.mesh()["theta_v"] > 0)
    d = np.abs(parts.values.astype(np.float64) - v)
    # every sample off the pole: within half a 16-bit step of its channel's range (plus float32 rounding)
    assert np.all(d[off_pole] <= scale / 131070 * (1 + 1e-6) + 1e-7 * np.abs(v[off_pole]))
    # the pole rings hold their mean: the lookup of the read table is the source's everywhere
    back = cdbrdf.CDBRDF(parts.values, **parts.axes, attrs=parts.attrs)
    rng = np.random.default_rng(0)
    q = (rng.uniform(0, 90, 500), rng.uniform(-360, 720, 500), rng.uniform(0, 90, 500), rng.uniform(0, 360, 500),
         rng.uniform(-0.3, 0.3, 500))
    np.testing.assert_allclose(back.evaluate(*q), denim.evaluate(*q), rtol=0, atol=float(scale.max()) / 65535)
    assert lut.spec["lookup"]["encoding"]["error"]["maxAbsoluteOverRange"] <= 0.5 / 65535 * (1 + 1e-9)
    np.testing.assert_array_equal(parts.measured, denim.measured)


def test_isotropic_grey_table_with_virtual_pole_and_filled_samples():
    g = cdbrdf.Grid(kappa=[-0.2, 0.0, 0.25], theta_l=[10.0, 35.0, 60.0], phi_l=[0.0], theta_v=[10.0, 40.0, 70.0],
                    phi_v=np.arange(0.0, 360.0, 45.0), symmetry="isotropic")
    t0 = make_table(g, channels=1, seed=4)
    measured = np.ones(g.shape, bool)
    measured[0, 0, 2, :, 2] = False
    t = cdbrdf.CDBRDF(t0.values, **g.axes(), measured=measured, symmetry="isotropic", attrs={"material": "iso"})
    lut = encode_table(t)
    assert lut.spec["lookup"]["theta_l"][0] == 0.0 and lut.spec["lookup"]["shape"] == [3, 1, 4, 8, 4]
    parts = decode_table(lut.spec, lut.png, lut.measured_png)
    back = cdbrdf.CDBRDF(parts.values, **parts.axes, measured=parts.measured, fill_source=parts.fill_source,
                         attrs=parts.attrs)
    assert back.isotropic and back.n_channels == 1
    np.testing.assert_allclose(back.values, t.values, rtol=0, atol=1.2 / 65535)  # no pole stored: every sample
    np.testing.assert_array_equal(back.measured, measured)
    assert (back.fill_source[~measured] == -2).all()


def test_a_table_the_texture_cannot_hold_is_refused():
    g = cdbrdf.Grid(kappa=[0.0], theta_l=[0.0, 45.0], phi_l=[0.0], theta_v=[0.0, 45.0], phi_v=[0.0, 180.0])
    with pytest.raises(FormatError, match="glTF export takes RGB or grey tables; this one has 2 channels"):
        encode_table(make_table(g, channels=2))


# -- the asset ---------------------------------------------------------------------------------------
def test_cad_shirt_asset(shirt, denim):
    """The CAD shirt (mm, Z-up) with denim: at most 16 MB, one curvature per vertex, metres and +Y up, the table back."""
    path, mesh, _ = shirt
    assert path.stat().st_size <= 16 * 1024**2
    doc, blob = read_glb(path)
    prim = doc["meshes"][0]["primitives"][0]
    pos = accessor(doc, blob, prim["attributes"]["POSITION"])
    kappa = accessor(doc, blob, prim["attributes"]["_CURVATURE"])
    assert kappa.shape == (pos.shape[0], 1)  # one value per vertex
    np.testing.assert_allclose(kappa[:, 0], mesh.attributes["curvature"], rtol=1e-6, atol=1e-7)
    # in metres, +Y up: the 620 mm tall shirt stands along y; the panels are sewn, not stacked
    ext = pos.max(0) - pos.min(0)
    assert ext[1] == pytest.approx(0.62, rel=0.02) and ext[0] < 1.0
    np.testing.assert_allclose(doc["accessors"][prim["attributes"]["POSITION"]]["min"], pos.min(0), rtol=1e-6)
    n = accessor(doc, blob, prim["attributes"]["NORMAL"])
    t = accessor(doc, blob, prim["attributes"]["TANGENT"])
    np.testing.assert_allclose(np.linalg.norm(n, axis=1), 1, atol=1e-5)
    np.testing.assert_allclose(np.linalg.norm(t[:, :3], axis=1), 1, atol=1e-5)
    assert np.abs(np.einsum("ij,ij->i", t[:, :3], n)).max() < 1e-4 and set(np.unique(t[:, 3])) <= {-1.0, 1.0}
    uv = accessor(doc, blob, prim["attributes"]["TEXCOORD_0"])
    np.testing.assert_allclose(uv[:, 1], 1 - mesh.uv[:, 1], atol=1e-6)  # glTF's v runs down
    idx = accessor(doc, blob, prim["indices"]).reshape(-1, 3)
    assert idx.max() < pos.shape[0] and idx.shape[0] == mesh.faces.shape[0]
    mat = doc["materials"][prim["material"]]
    assert EXTENSION in doc["extensionsUsed"] and "KHR_materials_sheen" in mat["extensions"]
    assert "extensionsRequired" not in doc  # the fallback works everywhere
    ext_json = mat["extensions"][EXTENSION]
    assert ext_json["curvature"] == {"attribute": "_CURVATURE", "mode": "max", "units": "1/mm",
                                     "neighbourhoodMm": pytest.approx(mesh.info["neighbourhood_mm"])}
    back = cdbrdf.load(path)
    rel = np.abs(back.values - denim.values) / np.abs(denim.values)
    assert np.median(rel) <= 0.01 and np.median(rel) < 1e-4  # the 1 %, and what 16 bits give
    assert back.attrs["material"] == "denim" and back.attrs["gltf_export"]["extension"] == EXTENSION


def test_directional_curvature_and_its_direction(denim, tmp_path):
    mesh = export_mesh(garment_mesh(), table=denim)
    asset = build_gltf(denim, mesh, curvature_mode="directional", fallback=FIXED_FALLBACK)
    write_gltf(asset, tmp_path / "d.glb")
    doc, blob = read_glb(tmp_path / "d.glb")
    prim = doc["meshes"][0]["primitives"][0]
    k = accessor(doc, blob, prim["attributes"]["_CURVATURE"])[:, 0]
    d = accessor(doc, blob, prim["attributes"]["_CURVATURE_DIRECTION"])
    n = accessor(doc, blob, prim["attributes"]["NORMAL"])
    np.testing.assert_allclose(k, mesh.attributes["curvature_dir"], rtol=1e-6, atol=1e-7)
    np.testing.assert_allclose(np.linalg.norm(d, axis=1), 1, atol=1e-5)
    assert np.abs(np.einsum("ij,ij->i", d, n)).max() < 1e-3  # in the tangent plane
    e = doc["materials"][0]["extensions"][EXTENSION]["curvature"]
    assert e["mode"] == "directional" and e["directionAttribute"] == "_CURVATURE_DIRECTION"


def test_mesh_without_uvs_is_welded_again(denim, tmp_path):
    """prepare_mesh gives a mesh without UVs one vertex per corner (its frame's UVs): the asset welds them."""
    from cdbrdf.mesh import Mesh

    from .mesh_helpers import sphere_mesh

    v, f = sphere_mesh(20.0, n=600)
    prepared = prepare_mesh(Mesh(v, f), units="mm")
    assert prepared.n_vertices == 3 * f.shape[0]  # one per corner: the principal frame's per-face UVs
    mesh = export_mesh(MeshSurface(Mesh(v, f), units="mm"))
    assert mesh.n_vertices == v.shape[0] and mesh.uv is None and mesh.faces.shape == f.shape
    np.testing.assert_allclose(np.einsum("ij,ij->i", mesh.tangents[:, :3], mesh.normals), 0, atol=1e-9)
    # a sphere of radius 20 mm: convex everywhere, 1/20 per mm
    np.testing.assert_allclose(mesh.attributes["curvature"], 0.05, rtol=0.05)
    write_gltf(build_gltf(denim, mesh, fallback=FIXED_FALLBACK), tmp_path / "s.glb")
    doc, _ = read_glb(tmp_path / "s.glb")
    assert "TEXCOORD_0" not in doc["meshes"][0]["primitives"][0]["attributes"]


def test_the_asset_and_its_extension_follow_the_schema(shirt):
    import jsonschema

    schema = json.loads(SCHEMA.read_text())
    doc, _ = read_glb(shirt[0])
    ext = doc["materials"][0]["extensions"][EXTENSION]
    jsonschema.validate(ext, schema)
    from cdbrdf.mesh import SurfaceMaps, normal_map_from_normals

    from .maps_helpers import quad, sine_normals

    maps = SurfaceMaps(normal_map=normal_map_from_normals(sine_normals(32)))
    wrinkled = build_gltf(materials.load("denim"), export_mesh(MeshSurface(quad(), units="mm"), maps=maps),
                          fallback=FIXED_FALLBACK).document
    jsonschema.validate(wrinkled["materials"][0]["extensions"][EXTENSION], schema)  # with its curvature map
    broken = {k: v for k, v in ext.items() if k != "lookup"}
    with pytest.raises(jsonschema.ValidationError, match="'lookup' is a required property"):
        jsonschema.validate(broken, schema)


def test_read_back_refusals(shirt, tmp_path, capsys):
    path = shirt[0]
    data = path.read_bytes()
    cut = tmp_path / "cut.glb"
    cut.write_bytes(data[: len(data) // 2])
    with pytest.raises(FormatError, match="cut.glb: not a readable glTF file"):
        cdbrdf.load(cut)
    doc, blob = read_glb(path)
    newer = json.loads(json.dumps(doc))
    newer["materials"][0]["extensions"][EXTENSION]["version"] = "2.0"
    plain = json.loads(json.dumps(doc))
    del plain["materials"][0]["extensions"][EXTENSION]
    import base64

    for name, d in (("newer", newer), ("plain", plain)):
        d["buffers"][0]["uri"] = "data:application/octet-stream;base64," + base64.b64encode(blob).decode()
        (tmp_path / f"{name}.gltf").write_text(json.dumps(d))
    with pytest.raises(FormatError, match="version 2.0 is newer than this cdbrdf reads"):
        cdbrdf.load(tmp_path / "newer.gltf")
    with pytest.raises(FormatError, match="no material with the CDBRDF_materials_curvature_brdf extension"):
        cdbrdf.load(tmp_path / "plain.gltf")
    assert main(["info", str(tmp_path / "plain.gltf")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "plain.gltf" in err and "Traceback" not in err


# -- the fallback material -------------------------------------------------------------------------
def test_gltf_brdf_at_normal_incidence_is_the_specifications():
    """l = v = n: D = 1 / (pi alpha^2), V = 1/4, F = 0.04: f = 0.96 base / pi + 0.04 / (4 pi alpha^2)."""
    z = np.array([[0.0, 0.0, 1.0]])
    p = {"base_color": [0.5, 0.2, 0.1], "roughness": 0.5, "sheen_color": [0.0, 0.0, 0.0], "sheen_roughness": 0.5}
    a = 0.25
    want = 0.96 * np.array(p["base_color"]) / math.pi + 0.04 / (4 * math.pi * a * a)
    np.testing.assert_allclose(gltf_brdf(p, z, z)[0], want, rtol=1e-12)
    # anisotropy 0 at any rotation, and a rotation by pi (an axis, not a direction) changes nothing
    q = dict(p, anisotropy_strength=0.7, anisotropy_rotation=0.3)
    rng = np.random.default_rng(1)
    dl, dv = (rng.normal(size=(50, 3)) for _ in range(2))
    dl[:, 2], dv[:, 2] = np.abs(dl[:, 2]) + 0.2, np.abs(dv[:, 2]) + 0.2
    dl /= np.linalg.norm(dl, axis=1, keepdims=True)
    dv /= np.linalg.norm(dv, axis=1, keepdims=True)
    np.testing.assert_allclose(gltf_brdf(q, dl, dv), gltf_brdf(dict(q, anisotropy_rotation=0.3 + math.pi), dl, dv),
                               rtol=1e-10)
    # reciprocity
    np.testing.assert_allclose(gltf_brdf(q, dl, dv), gltf_brdf(q, dv, dl), rtol=1e-10)


def test_fallback_fit_recovers_a_gltf_material():
    """A table made of glTF's own BRDF (sheen and anisotropy) is fitted back: its parameters, error about 0."""
    from cdbrdf.frames import direction_from_angles

    g = cdbrdf.Grid.paper(kappa=[0.0])
    m = g.mesh()
    truth = {"base_color": [0.30, 0.12, 0.05], "roughness": 0.45, "sheen_color": [0.25, 0.3, 0.5],
             "sheen_roughness": 0.35, "anisotropy_strength": 0.6, "anisotropy_rotation": 0.0}
    dl = direction_from_angles(m["theta_l"].ravel(), m["phi_l"].ravel())
    dv = direction_from_angles(m["theta_v"].ravel(), m["phi_v"].ravel())
    f = gltf_brdf(truth, dl, dv).reshape(*g.shape, 3)
    fit = fit_fallback(cdbrdf.CDBRDF(f, g, attrs={"quantity": "brdf"}))
    assert fit.relative_rms_error < 0.02, fit
    np.testing.assert_allclose(fit.base_color, truth["base_color"], atol=0.02)
    np.testing.assert_allclose(fit.sheen_color, truth["sheen_color"], atol=0.05)
    assert fit.roughness == pytest.approx(0.45, abs=0.05) and fit.sheen_roughness == pytest.approx(0.35, abs=0.05)
    assert fit.anisotropy_strength == pytest.approx(0.6, abs=0.1)
    assert min(abs(fit.anisotropy_rotation), abs(abs(fit.anisotropy_rotation) - math.pi)) < 0.1


# -- MikkTSpace ------------------------------------------------------------------------------------
@needs_node
def test_tangents_are_mikktspace_s(shirt):
    """Per corner, the asset's TANGENT equals the reference implementation's (WebAssembly, npm mikktspace)."""
    doc, blob = read_glb(shirt[0])
    a = doc["meshes"][0]["primitives"][0]["attributes"]
    idx = accessor(doc, blob, doc["meshes"][0]["primitives"][0]["indices"])[:, 0].astype(np.int64)
    pos, nrm, uv, tan = (accessor(doc, blob, a[k]).astype(np.float64)
                         for k in ("POSITION", "NORMAL", "TEXCOORD_0", "TANGENT"))
    ref = mikktspace(pos[idx], nrm[idx], uv[idx])
    ours = tan[idx]
    cos = np.einsum("ij,ij->i", ours[:, :3], ref[:, :3])
    assert np.mean(cos > 0.9999) > 0.99 and np.percentile(cos, 0.1) > 0.99, np.percentile(cos, [0.1, 1, 50])
    # glTF's v runs down: the reference run on glTF's UVs gives the opposite handedness
    assert np.mean(ours[:, 3] == -ref[:, 3]) > 0.999


# -- the Khronos validator -------------------------------------------------------------------------
@needs_node
def test_every_asset_passes_the_khronos_validator(shirt, denim, tmp_path):
    sine = tmp_path / "sine.gltf"
    write_gltf(build_gltf(denim, export_mesh("sine"), fallback=FIXED_FALLBACK), sine)
    swatch = tmp_path / "swatch.glb"
    write_gltf(build_gltf(denim, export_mesh("swatch"), curvature_mode="directional",
                          fallback=FixedAnisotropic), swatch)
    tee = tmp_path / "tee.glb"
    write_gltf(build_gltf(denim, export_mesh(shared_file("garments/pattern_generator_tee_sim/tee_sim.obj"),
                                             table=denim), fallback=FIXED_FALLBACK), tee)
    from cdbrdf.mesh import SurfaceMaps, normal_map_from_normals

    from .maps_helpers import quad, sine_normals

    wrinkled = tmp_path / "quad.glb"  # a normal map baked per texel: the curvature map's textures
    maps = SurfaceMaps(normal_map=normal_map_from_normals(sine_normals(64)))
    write_gltf(build_gltf(denim, export_mesh(MeshSurface(quad(), units="mm"), table=denim, maps=maps),
                          fallback=FIXED_FALLBACK),
               wrinkled)
    reports = validate(shirt[0], sine, swatch, tee, wrinkled)
    for r in reports:
        assert r["issues"]["numErrors"] == 0, errors(r)
    info = reports[2]["info"]
    assert "KHR_materials_anisotropy" in info["extensionsUsed"] and EXTENSION in info["extensionsUsed"]


FixedAnisotropic = FallbackFit((0.05, 0.06, 0.09), 0.9, (0.1, 0.1, 0.3), 0.4, 0.5, 0.3, 0.3, 0.2, 0)


# -- MaterialX -------------------------------------------------------------------------------------
def test_materialx_document_validates_and_says_what_it_cannot_hold(tmp_path):
    import MaterialX as mx

    from cdbrdf.export.materialx import CURVATURE_NOTE, materialx_document, write_materialx

    out = write_materialx(FixedAnisotropic, tmp_path / "denim.mtlx", material="denim", source="denim.h5")
    doc = mx.createDocument()
    mx.readFromXmlFile(doc, str(out))
    lib = mx.createDocument()
    mx.loadLibraries(mx.getDefaultDataLibraryFolders(), mx.getDefaultDataSearchPath(), lib)
    doc.importLibrary(lib)
    ok, message = doc.validate()
    assert ok, message
    shader = doc.getNode("denim_fallback")
    assert shader.getCategory() == "standard_surface"
    assert shader.getInputValue("sheen_roughness") == pytest.approx(0.4)
    assert list(shader.getInputValue("base_color").asTuple()) == pytest.approx([0.05, 0.06, 0.09])
    assert shader.getInputValue("specular_rotation") == pytest.approx(0.3 / (2 * math.pi))
    assert CURVATURE_NOTE in out.read_text() and "not expressible in MaterialX" in CURVATURE_NOTE
    assert materialx_document(FIXED_FALLBACK).getNode("fabric").getType() == "material"


# -- the command -----------------------------------------------------------------------------------
def test_cli_export_and_info(tmp_path, capsys):
    d = materials.path("denim")
    out = tmp_path / "sine.gltf"
    assert main(["export", str(d), "--scene", "sine", "-o", str(out), "--materialx", str(tmp_path / "d.mtlx")]) == 0
    err = capsys.readouterr().err
    assert "largest error 7.6e-06 of each channel's range" in err and "relative RMS error" in err
    assert (tmp_path / "d.mtlx").is_file()
    assert main(["info", str(out)]) == 0
    text = capsys.readouterr().out
    assert "material      denim" in text and "glTF export" in text
    for args, msg in ((["--scene", "swatch", "--units", "cm"], "--units: only with --mesh"),
                      ([], "give --scene sine, --scene swatch or --mesh MESH")):
        assert main(["export", str(d), *args, "-o", str(tmp_path / "x.glb")]) == 2
        err = capsys.readouterr().err
        assert msg in err and err.count("\n") == 1
    with pytest.raises(SystemExit) as e:
        main(["export", str(d), "--scene", "sine", "-o", str(tmp_path / "x.obj")])
    assert e.value.code == 2 and "use .glb, .gltf" in capsys.readouterr().err
    assert not (tmp_path / "x.glb").exists()
