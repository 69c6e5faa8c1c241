"""Curvature maps in the viewer: the asset, the GLSL lookup against the Python rule, ``view --mesh M --normal-map N``.

Known answers: the GLSL rule at points (texel values at a UV and level, the level of a footprint, the
curvature of the mesh's shape operator plus the map's, the tilted frame) is the Python rule
(:func:`cdbrdf.mesh.curvature_map.lookup`, :func:`~cdbrdf.mesh.curvature_map.footprint_level`, the plug-in's
:func:`cdbrdf.render._maps_jit.detail` and :func:`~cdbrdf.render._maps_jit.frame`); the page of
``cdbrdf view --mesh quad.obj --normal-map wrinkles.png`` opens on the quad and shows the issue's sine
wrinkles (10 mm period, 0.4 mm amplitude: 10 stripes over the 100 mm quad, a curvature of +-0.158 / mm
at the crests and troughs) where the page without the map shows a flat quad.
"""

from __future__ import annotations

import base64
import json
import logging

import numpy as np
import pytest

from cdbrdf import materials
from cdbrdf.cli import main
from cdbrdf.mesh import SHAPE_ATTRIBUTES, CurvatureMap, Mesh, SurfaceMaps, normal_map_from_normals, prepare_mesh
from cdbrdf.mesh.curvature_map import footprint_level, lookup, neighbourhood_level, principal, pyramid
from cdbrdf.view.asset import mesh_asset
from cdbrdf.view.export import export_viewer, viewer_files
from cdbrdf.view.map_asset import map_atlas

from .maps_helpers import PEAK, quad, sine_normals, write_normal_png
from .test_viewer import needs_chromium, open_page, pixels


def random_map(seed: int = 0, shape: tuple[int, int] = (23, 37)) -> CurvatureMap:
    """Smooth random texel values on an odd-sized map (levels resampled by area), mirrored and offset."""
    rng = np.random.default_rng(seed)
    base = rng.normal(size=shape + (6,)) * np.array([0.3, 0.3, 20.0, 10.0, 10.0, 20.0])
    return CurvatureMap(pyramid(base), name="random", transform=(2.0, -1.5, 0.25, 0.1))


def map_mesh(cmap: CurvatureMap, *, uv_scale=(100.0, 60.0), neighbourhood_mm: float = 2.0) -> Mesh:
    """A prepared quad carrying ``cmap`` as :func:`cdbrdf.mesh.apply_maps` leaves it."""
    m = prepare_mesh(quad(), units="mm", neighbourhood_mm=neighbourhood_mm, maps=SurfaceMaps(uv_scale=uv_scale))
    m.metadata["curvature_map"] = cmap
    return m


def block(asset, name):
    b = asset.header["blocks"][name]
    dt = np.dtype({"float32": "<f4", "float16": "<f2", "uint32": "<u4"}[b["dtype"]])
    return np.frombuffer(asset.blob, dt, b["bytes"] // dt.itemsize, b["offset"]).reshape(b["shape"])


# -- the asset ----------------------------------------------------------------------------------------
def test_map_atlas_holds_every_level_as_the_renderer_keeps_them():
    cmap = bake_wrinkles(512)
    h, atlas = map_atlas(cmap, uv_scale=100.0, neighbourhood_mm=5.0)
    # the renderer's levels: none finer than a quarter of the 5 mm neighbourhood (0.195 mm texels: 2 dropped)
    kept = cmap.coarser(int(neighbourhood_level(cmap, (100.0, 100.0), 5.0)))
    assert h["texels"] == [128, 128] and len(h["levels"]) == kept.n_levels == 8
    assert h["min_level"] == pytest.approx(neighbourhood_level(kept, (100.0, 100.0), 5.0))
    assert 0 < h["min_level"] < 1 and h["dropped_levels"] == 0 and h["note"] is None
    flat = atlas.reshape(-1, 4)
    for (w, hh, off), lv in zip(h["levels"], kept.levels, strict=True):
        assert (w, hh) == (lv.shape[1], lv.shape[0])
        i = 2 * (off + np.arange(w * hh))
        np.testing.assert_array_equal(flat[i], lv.reshape(-1, 6)[:, :4])
        np.testing.assert_array_equal(flat[i + 1, :2], lv.reshape(-1, 6)[:, 4:])
    assert atlas.shape[1] == 2048 and h["atlas"] == {"width": 2048, "height": atlas.shape[0], "format": "RGBA"}


def test_map_atlas_drops_the_finest_levels_past_the_texture_size(caplog):
    cmap = bake_wrinkles(512)
    with caplog.at_level(logging.WARNING, logger="cdbrdf.view.map_asset"):
        h, atlas = map_atlas(cmap, uv_scale=100.0, neighbourhood_mm=0.5, max_texels=2 * 64 * 64 * 4 // 3 + 200)
    assert h["texels"] == [64, 64] and h["dropped_levels"] == 3 and atlas.size <= 4 * (2 * 64 * 64 * 4 // 3 + 2048)
    assert "the viewer keeps its levels from 64 x 64 texels (1.56 mm" in h["note"]
    assert [r.getMessage() for r in caplog.records] == [h["note"]]


def bake_wrinkles(texels: int) -> CurvatureMap:
    from cdbrdf.mesh import bake_normal_map

    return bake_normal_map(normal_map_from_normals(sine_normals(texels), name="wrinkles"))


def test_mesh_asset_carries_the_shape_operator_and_the_uv_handedness():
    cmap = random_map()
    mesh = map_mesh(cmap)
    a = mesh_asset(mesh, name="quad")
    shape = block(a, "shape")
    for i, k in enumerate(SHAPE_ATTRIBUTES):
        np.testing.assert_allclose(shape[:, i], mesh.attributes[k], rtol=1e-6, atol=1e-9)
    assert (shape[:, 3] == 1).all() and a.header["map"]["name"] == "random"
    mirrored = mesh.copy()
    mirrored.uv = mesh.uv * [1.0, -1.0]  # v runs against n x dP/du
    assert (block(mesh_asset(mirrored, name="m"), "shape")[:, 3] == -1).all()
    half = mesh_asset(mesh, name="quad", precision="float16")
    assert half.header["map"]["atlas"]["type"] == "float16" and block(half, "map").dtype == np.float16
    plain = mesh_asset(prepare_mesh(quad(), units="mm"), name="plain")
    assert "map" not in plain.header and "shape" not in plain.header["blocks"]


# -- the GLSL rule against the Python one ---------------------------------------------------------------
@pytest.fixture(scope="module")
def rule_page(browser, tmp_path_factory):
    cmap = random_map()
    files = viewer_files([("shot.h5", materials.load("shot"))], meshes={"m": ("mapped quad", map_mesh(cmap))})
    page, messages = open_page(browser, export_viewer(tmp_path_factory.mktemp("rule") / "v", files).resolve().as_uri())
    page.messages = messages
    page.cmap, page.header = cmap, json.loads(files["assets/mesh-m.json"])["map"]
    yield page
    page.close()


def queries(n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    u, v = rng.uniform(-3, 3, n), rng.uniform(-3, 3, n)
    u[:20] = np.linspace(0, 1, 20, endpoint=False) / 2.0 - 0.125  # the texel centres' edges and the repeat's seam
    level = rng.uniform(0, 6, n)
    level[20:40] = np.arange(20) % 6  # whole levels, the last one
    level[40:100] = -1  # from the footprint
    fu, fv = 10 ** rng.uniform(-4, 0, n), 10 ** rng.uniform(-4, 0, n)
    shape = rng.normal(size=(n, 3)) * 0.1
    hand = np.where(rng.random(n) < 0.3, -1.0, 1.0)
    th, ph = np.radians(rng.uniform(0, 89, n)), rng.uniform(0, 2 * np.pi, n)
    wi = np.c_[np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)]
    return np.c_[u, v, level, fu, fv, shape, hand, wi]


@needs_chromium
def test_glsl_map_lookup_matches_the_python_rule(rule_page):
    """Texel values (trilinear, periodic, mirrored transform, odd sizes), the footprint's level, the curvature
    of the mesh's shape operator plus the map's, and the tilted frame: the Python rule within float32."""
    import mitsuba as mi

    import cdbrdf.render
    from cdbrdf.render import _maps_jit as mj

    h = rule_page.header
    cmap = rule_page.cmap.coarser(rule_page.cmap.n_levels - len(h["levels"]))
    q = queries(600, 1)
    got = np.array(rule_page.evaluate("(q) => cdbrdfViewer.mapEvaluate(q, {surface: 'm'})", q.tolist()))
    assert rule_page.messages == []
    lv = np.where(q[:, 2] >= 0, q[:, 2], footprint_level(cmap, q[:, 3], q[:, 4], h["min_level"]))
    np.testing.assert_allclose(got[:, 6], lv, atol=2e-5)
    assert (lv[40:100] > h["min_level"]).any() and (lv[40:100] == h["min_level"]).any()  # both sides of the clamp
    ref = lookup(cmap, q[:, 0], q[:, 1], lv)
    scale = np.abs(ref).max(axis=0)
    err = np.abs(got[:, :6] - ref) / scale  # float32 UVs: ~1e-5 of a texel's difference (measured 1.8e-5)
    assert err.max() < 1e-4, (err.max(axis=0), q[np.argmax(err.max(axis=1))])
    p, qq, kxx, kxy, kyy = mj.detail(np, list(ref.T), tuple(h["uv_scale_mm"]), q[:, 8])
    mesh = q[:, 5:8]
    kmax = principal(mesh[:, 0] + kxx, mesh[:, 1] + kxy, mesh[:, 2] + kyy)
    ks = np.abs(kmax).max()
    np.testing.assert_allclose(got[:, 7], kmax, atol=1e-4 * ks)
    np.testing.assert_allclose(got[:, 8], mesh[:, 0] + kxx, atol=1e-4 * ks)
    np.testing.assert_allclose(got[:, 15], qq, atol=1e-4 * np.abs(qq).max())  # q flips on a mirrored layout
    with cdbrdf.render.variant("scalar_rgb"):
        import drjit as dr

        frames = [mj.frame(mi, dr, float(a), float(b), mi.Vector3f(*w)) for a, b, w in zip(p, qq, q[:, 9:12],
                                                                                           strict=True)]
        n_ref = np.array([[f.n.x, f.n.y, f.n.z] for f in frames])
        s_ref = np.array([[f.s.x, f.s.y, f.s.z] for f in frames])
    np.testing.assert_allclose(got[:, 9:12], n_ref, atol=2e-5)
    np.testing.assert_allclose(got[:, 12:15], s_ref, atol=2e-5)
    # the mirror rule ran: some tilted normals face away from the viewer before it
    raw = np.c_[p, qq, np.ones_like(p)]
    assert (np.einsum("ij,ij->i", raw, q[:, 9:12]) <= 0).sum() > 5


# -- the command line and the page -------------------------------------------------------------------
@pytest.fixture(scope="module")
def quad_files(tmp_path_factory):
    """The issue's quad (two triangles, 100 mm) as an OBJ with UVs 0 to 1, and its sine-wrinkle normal map."""
    import trimesh

    d = tmp_path_factory.mktemp("quad")
    m = quad()
    trimesh.Trimesh(m.vertices, m.faces, visual=trimesh.visual.TextureVisuals(uv=m.uv), process=False).export(
        d / "quad.obj")
    write_normal_png(d / "wrinkles.png", sine_normals(512))
    return d


def test_cli_view_lays_the_map_as_render_does(quad_files, tmp_path, capsys):
    d = quad_files
    shot = str(materials.path("shot"))
    assert main(["view", shot, "--mesh", str(d / "quad.obj"), "--normal-map", str(d / "wrinkles.png"),
                 "--uv-scale", "100", "--export", str(tmp_path / "v")]) == 0
    err = capsys.readouterr().err
    assert "quad.obj: note: UV scale: 100 mm per UV unit (given)" in err
    assert ("wrinkles.png: normal map, 512 x 512 texels, one repeat per 100 x 100 mm; its curvature at the 1 mm "
            "neighbourhood: up to 0.157 1/mm") in err
    h = json.loads((tmp_path / "v" / "assets" / "mesh-user.json").read_text())
    assert h["map"]["uv_scale_mm"] == [100.0, 100.0] and h["blocks"]["shape"]["shape"] == [4, 4]
    assert '"options":{"surface":"user"}' in (tmp_path / "v" / "data.js").read_text()
    # without --uv-scale: detected and said so, as cdbrdf render does (100 mm to the UV unit: a unit, dm)
    assert main(["view", shot, "--mesh", str(d / "quad.obj"), "--normal-map", str(d / "wrinkles.png"),
                 "--export", str(tmp_path / "w")]) == 0
    assert "quad.obj: note: UV scale: 100 mm per UV unit (the UVs are lengths in dm: " in capsys.readouterr().err
    # a CD-BTF on the mesh takes the maps' one UV scale
    from .test_viewer_btf import aniso_grid, random_btf

    random_btf(aniso_grid(), rank=2).save(tmp_path / "weave.h5")
    assert main(["-q", "view", str(tmp_path / "weave.h5"), "--mesh", str(d / "quad.obj"), "--normal-map",
                 str(d / "wrinkles.png"), "--uv-scale", "80,90", "--export", str(tmp_path / "b")]) == 0
    h = json.loads((tmp_path / "b" / "assets" / "mesh-user.json").read_text())
    assert h["uv_scale_mm"] == h["map"]["uv_scale_mm"] == [80.0, 90.0]
    # the map options need a mesh: one line
    assert main(["view", shot, "--normal-map", str(d / "wrinkles.png"), "--export", str(tmp_path / "x")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("cdbrdf view: error: --normal-map: only for --mesh MESH") and err.count("\n") == 1
    assert not (tmp_path / "x").exists()


@pytest.fixture(scope="module")
def wrinkle_pages(browser, quad_files, tmp_path_factory):
    """The page of ``view --mesh quad.obj --normal-map wrinkles.png``, and of the quad without it."""
    from .test_viewer_btf import aniso_grid, random_btf

    d, out = quad_files, tmp_path_factory.mktemp("pages")
    shot = str(materials.path("shot"))
    random_btf(aniso_grid(), rank=2).save(out / "weave.h5")
    pages = {}
    for key, table, extra in (("map", shot, ["--normal-map", str(d / "wrinkles.png")]), ("plain", shot, []),
                              ("btf", str(out / "weave.h5"), ["--normal-map", str(d / "wrinkles.png")])):
        assert main(["-q", "view", table, "--mesh", str(d / "quad.obj"), "--uv-scale", "100", *extra,
                     "--export", str(out / key)]) == 0
        page, messages = open_page(browser, (out / key / "index.html").resolve().as_uri(), width=240, height=150)
        page.messages = messages
        pages[key] = page
    yield pages
    for p in pages.values():
        p.close()


def curvature(page) -> np.ndarray:
    p = page.evaluate("cdbrdfViewer.curvatureImage()")
    return np.frombuffer(base64.b64decode(p["data"]), "<f4").reshape(p["height"], p["width"], 4)[::-1]


@needs_chromium
def test_page_opens_on_the_mesh_framed(wrinkle_pages):
    page = wrinkle_pages["map"]
    st = page.evaluate("cdbrdfViewer.state()")
    assert page.messages == [] and st["surface"] == "user" and st["mapped"] == ["user"]
    assert page.locator("#surface").input_value() == "user"
    assert (st["cam"]["elevation"], st["cam"]["azimuth"]) == (20, -65)  # cdbrdf render's view of a mesh
    assert st["mapText"].startswith("wrinkles.png: normal map, one repeat per 100 x 100 mm (UV scale 100 mm per UV "
                                    "unit); looked up per pixel by its footprint on 10 levels from 512 x 512 texels")
    # framed as cdbrdf render frames it: the quad fills about 3/4 of the canvas's limiting side
    front = curvature(page)[..., 2] > 0.5
    ys, xs = np.nonzero(front)
    extent = max((xs.max() - xs.min() + 1) / 240, (ys.max() - ys.min() + 1) / 150)
    assert 0.6 < extent < 0.9, extent


@needs_chromium
def test_page_shows_the_wrinkles(wrinkle_pages):
    """Seen from above, light at 45 degrees across them: 10 stripes over the quad, crests convex at 0.158 / mm."""
    shots = {}
    for key, page in wrinkle_pages.items():
        if key == "btf":
            continue
        page.evaluate("cdbrdfViewer.setCamera(90, -90, 190)")  # the 100 mm quad from above, u to the right
        page.evaluate("cdbrdfViewer.setLight(45, 0)")
        shots[key] = pixels(page).astype(np.float64).mean(axis=-1)
        shots[key + "-k"] = curvature(page)
    page = wrinkle_pages["map"]
    page.evaluate("cdbrdfViewer.setMaps(false)")
    off = pixels(page).astype(np.float64).mean(axis=-1)
    page.evaluate("cdbrdfViewer.setMaps(true)")
    assert np.abs(off - shots["plain"]).max() <= 1  # the toggle shows the mesh without its map
    k = shots["map-k"]
    front = (k[..., 2] > 0.5) & (shots["plain-k"][..., 2] > 0.5)
    rows = np.nonzero(front.sum(axis=1) == front.sum(axis=1).max())[0]
    cols = np.nonzero(front[rows[len(rows) // 2]])[0]
    band = (slice(rows[len(rows) // 4], rows[3 * len(rows) // 4]), slice(cols[0], cols[-1] + 1))

    def spectrum(img):  # amplitude (8-bit levels) per spatial frequency across the quad (cycles over its width)
        prof = img[band].mean(axis=0)
        return np.abs(np.fft.rfft(prof - prof.mean())) * 2 / len(prof)

    with_map, plain = spectrum(shots["map"]), spectrum(shots["plain"])
    assert np.argmax(with_map) == 10 and with_map[10] > 10 and plain[10] < 0.5, (with_map[:12], plain[:12])
    diff = np.abs(shots["map"] - shots["plain"])[band]
    assert np.percentile(diff, 90) > 5  # the pixels differ along the wrinkles
    # the curvature looked up: the map's (the quad is flat), +-0.158 / mm at the crests and troughs
    kq = k[..., 1][band]
    assert np.abs(shots["plain-k"][..., 1][band]).max() < 1e-6
    assert kq.max() == pytest.approx(PEAK, rel=0.04) and kq.min() == pytest.approx(-PEAK, rel=0.04)


@needs_chromium
def test_crest_pixels_are_the_table_at_the_tilted_query(wrinkle_pages):
    """At a crest the colour is the table at the query the click reads (tilted angles, the map's kappa)."""
    from cdbrdf.colour import srgb_encode

    page = wrinkle_pages["map"]
    page.evaluate("cdbrdfViewer.setCamera(60, -90, 190)")
    page.evaluate("cdbrdfViewer.setLight(40, 20)")
    img, k = pixels(page), curvature(page)
    ys, xs = np.nonzero((k[..., 2] > 0.5) & (k[..., 1] > 0.9 * PEAK) & (k[..., 3] > 0.3))
    assert len(ys) > 20
    table = materials.load("shot")
    ev = page.evaluate("cdbrdfViewer.state()")["exposure"]
    for i in (len(ys) // 3, 2 * len(ys) // 3):
        y, x = int(ys[i]), int(xs[i])
        q = page.evaluate(f"cdbrdfViewer.pick({x}, {y})")
        assert q["kappa"] == pytest.approx(k[y, x, 0], abs=1e-6) and q["kappa"] > 0.9 * PEAK
        f = table.evaluate(q["theta_v"], q["phi_v"], q["theta_l"], q["phi_l"], q["kappa"])
        expect = 255 * srgb_encode(np.clip(f * k[y, x, 3] * np.pi * 2**ev, 0, 1))
        np.testing.assert_allclose(img[y, x], expect, atol=1.5)
    # the plain BRDF keeps the wrinkles' shading (the tilted normal) and reads kappa 0
    page.evaluate("cdbrdfViewer.setMode('brdf')")
    kb, brdf = curvature(page), pixels(page)
    page.evaluate("cdbrdfViewer.setMode('cdbrdf')")
    assert (kb[..., 0][kb[..., 2] > 0.5] == 0).all()
    plain = wrinkle_pages["plain"]
    plain.evaluate("cdbrdfViewer.setCamera(60, -90, 190)")
    plain.evaluate("cdbrdfViewer.setLight(40, 20)")
    plain.evaluate("cdbrdfViewer.setMode('brdf')")
    flat = pixels(plain)
    plain.evaluate("cdbrdfViewer.setMode('cdbrdf')")
    front = kb[..., 2] > 0.5
    assert np.abs(brdf - flat).max(axis=-1)[front].mean() > 3


@needs_chromium
def test_a_cd_btf_takes_the_map_too(wrinkle_pages):
    """A CD-BTF on the mapped mesh: the weave and the wrinkles in one program (no console message)."""
    page = wrinkle_pages["btf"]
    page.evaluate("cdbrdfViewer.setCamera(90, -90, 60)")
    page.evaluate("cdbrdfViewer.setLight(45, 0)")
    on = pixels(page)
    page.evaluate("cdbrdfViewer.setMaps(false)")
    off = pixels(page)
    page.evaluate("cdbrdfViewer.setMaps(true)")
    st = page.evaluate("cdbrdfViewer.state()")
    assert page.messages == [] and st["surface"] == "user" and st["btf"][0] is not None
    assert np.abs(on - off).max(axis=-1).mean() > 3 and off.std() > 3
