"""The browser renderer of a glTF export (cdbrdf view x.glb) in headless Chromium (software WebGL2):
the page against Mitsuba on the CAD shirt, the plain three.js GLTFLoader page with the fallback, the command.

The renderer's GLSL lookup is also checked by the lookup conformance suite (``glsl_gltf`` in
tests/lookup_cases.py).
"""

from __future__ import annotations

import base64
import json
import os

import numpy as np
import pytest

from cdbrdf import materials
from cdbrdf.cli import main
from cdbrdf.export.gltf import build_gltf, export_mesh
from cdbrdf.mesh import MeshSurface, garment_mesh
from cdbrdf.view.export import write_viewer
from cdbrdf.view.gltf_page import bundle_missing, gltf_viewer_files, view_options
from cdbrdf.view.server import ViewerServer

from .test_export import FIXED_FALLBACK
from .test_viewer import needs_chromium

needs_renderer = pytest.mark.skipif(bool(bundle_missing()) and not os.environ.get("CI"),
                                    reason="the glTF renderer is not built (scripts/setup.sh builds it with npm)")

#: The comparison's picture: small, so that Mitsuba and software WebGL take about a second each.
SIZE = (160, 120)
#: The light: direction towards it in the z-up world (theta, phi, degrees) and its irradiance.
LIGHT = (40.0, -100.0, float(np.pi))


@pytest.fixture(scope="module")
def shirt():
    """The CAD shirt (mm, Z-up, sewn panels) with denim, its fallback fitted: the GLB and its parts."""
    denim = materials.load("denim")
    mesh = export_mesh(garment_mesh(), table=denim)
    asset = build_gltf(denim, mesh)
    return denim, mesh, asset, asset.glb()


def open_page(browser, url):
    page = browser.new_page(viewport={"width": 1300, "height": 800})
    page.set_default_timeout(120_000)
    messages: list[str] = []
    page.on("console", lambda m: messages.append(f"{m.type}: {m.text}"))
    page.on("pageerror", lambda e: messages.append(f"pageerror: {e}"))
    page.on("requestfailed", lambda r: messages.append(f"requestfailed: {r.url}"))
    page.goto(url, wait_until="load")
    return page, messages


def pixels(page, api="cdbrdfGltf"):
    p = page.evaluate(f"{api}.pixels()")
    return np.frombuffer(base64.b64decode(p["data"]), np.uint8).reshape(p["height"], p["width"], 4)[::-1, :, :3]


def mitsuba_view(denim, width, height, mesh=None, view=(15.0, -70.0)):
    """Mitsuba's render of a mesh (default: the CAD shirt, prepared; cdbrdf's plug-in, one directional light,
    direct light only) and its camera in glTF's frame (metres, +Y up), read from the scene's sensor."""
    import mitsuba as mi

    from cdbrdf.mesh import prepare_mesh
    from cdbrdf.render import Light, RenderSpec
    from cdbrdf.render.camera import Camera
    from cdbrdf.render.picture import render_scene
    from cdbrdf.render.plugin import variant
    from cdbrdf.render.scenes import mesh_scene

    from .lookup_cases import need_mitsuba

    need_mitsuba()
    prepared = prepare_mesh(garment_mesh(), table=denim) if mesh is None else mesh
    with variant("llvm_ad_rgb"):
        spec = RenderSpec(surface=MeshSurface(prepared, up="auto" if mesh is None else "z"),
                          light=Light(lighting="paper", direction=LIGHT[:2], irradiance=LIGHT[2]),
                          size=(width, height), spp=32, max_depth=2, camera=Camera(view=view))
        scene = mesh_scene(denim, spec)
        sensor = scene.sensors()[0]
        m = np.array(sensor.world_transform().matrix, dtype=np.float64).reshape(4, 4)
        x_fov = float(np.ravel(mi.traverse(sensor)["x_fov"])[0])
        image = render_scene(scene, spp=32, alpha=True)
    unit = 1e-3  # the shirt is in mm, glTF in metres

    def gl(v, s=1.0):
        return [float(v[0]) * s, float(v[2]) * s, -float(v[1]) * s]

    fov = np.degrees(2 * np.arctan(np.tan(np.radians(x_fov) / 2) * min(width, height) / width))
    camera = {"position": gl(m[:3, 3], unit), "target": gl(m[:3, 3] + 100.0 * m[:3, 2], unit), "up": gl(m[:3, 1]),
              "fov_deg": float(fov)}
    return image, camera


@needs_chromium
@needs_renderer
def test_page_and_mitsuba_agree_on_the_cad_shirt(browser, shirt, tmp_path):
    """The same mesh, camera and light: the page's pixels and Mitsuba's agree within median Delta E*ab 2."""
    from cdbrdf.colour import card_exposure_ev, delta_e, srgb_to_lab
    from cdbrdf.render.lighting import card_irradiance

    denim, _, _, glb = shirt
    w, h = SIZE
    image, camera = mitsuba_view(denim, w, h)
    ev = card_exposure_ev(card_irradiance(LIGHT, None))
    ours, flat, theirs, seen = _compare(browser, glb, image, camera, ev, tmp_path)
    de = delta_e(srgb_to_lab(ours), srgb_to_lab(theirs), metric="ab")[seen]
    assert np.median(de) <= 2.0, np.percentile(de, [50, 90, 99])
    assert np.percentile(de, 90) <= 5.0, np.percentile(de, [50, 90, 99])


def _compare(browser, glb, image, camera, ev, tmp_path):
    """The page's CDBRDF and plain BRDF pictures, Mitsuba's as shown, and the pixels inside the silhouette."""
    from scipy.ndimage import binary_erosion

    from cdbrdf.colour import srgb_encode

    h, w = image.shape[:2]
    opts = {"camera": camera, "light": list(LIGHT), "exposure_ev": ev, "width": w, "height": h, "environment": False}
    index = write_viewer(tmp_path / "v", gltf_viewer_files(glb, name="shirt.glb", options=opts))
    page, messages = open_page(browser, index.resolve().as_uri())
    page.evaluate("cdbrdfGltf.ready")
    ours = pixels(page)
    page.evaluate("cdbrdfGltf.setMode('brdf')")
    flat = pixels(page)
    page.close()
    assert messages == []
    theirs = np.round(255 * srgb_encode(np.clip(image[..., :3] * 2.0**ev, 0, 1))).astype(np.uint8)
    seen = binary_erosion(image[..., 3] > 0.999, iterations=1)  # inside the silhouette (no edge antialiasing)
    assert seen.sum() > 0.1 * w * h
    return ours, flat, theirs, seen


@needs_chromium
@needs_renderer
def test_page_and_mitsuba_agree_on_the_swatch_where_curvature_matters(browser, tmp_path):
    """Shot fabric on folds of radius 20, 10, 5 and 3 mm: where the curvature changes the colour, the page's
    CDBRDF follows Mitsuba's."""
    from cdbrdf.colour import card_exposure_ev, delta_e, srgb_to_lab
    from cdbrdf.mesh import swatch_mesh
    from cdbrdf.render.lighting import card_irradiance

    shot = materials.load("shot")
    glb = build_gltf(shot, export_mesh("swatch"), fallback=FIXED_FALLBACK).glb()
    image, camera = mitsuba_view(shot, *SIZE, mesh=swatch_mesh(), view=(45.0, -75.0))
    ev = card_exposure_ev(card_irradiance(LIGHT, None))
    ours, flat, theirs, seen = _compare(browser, glb, image, camera, ev, tmp_path)
    de = delta_e(srgb_to_lab(ours), srgb_to_lab(theirs), metric="ab")[seen]
    de_flat = delta_e(srgb_to_lab(flat), srgb_to_lab(theirs), metric="ab")[seen]
    assert np.median(de) <= 2.0, np.percentile(de, [50, 90, 99])
    bent = de_flat > 3.0  # where the plain BRDF misses Mitsuba's CDBRDF by more than 3
    assert bent.sum() > 200, bent.sum()
    assert np.median(de[bent]) <= 2.0, (np.percentile(de[bent], [50, 90]), np.percentile(de_flat[bent], [50, 90]))


@needs_chromium
@needs_renderer
def test_plain_gltfloader_page_shows_the_fallback(browser, shirt, tmp_path):
    """three.js's GLTFLoader without the plugin: the fitted standard material (sheen), drawn, near the CDBRDF."""
    from cdbrdf.colour import delta_e, srgb_to_lab

    _, _, asset, glb = shirt
    opts = view_options(glb, size=(200, 150))
    index = write_viewer(tmp_path / "v", gltf_viewer_files(glb, name="shirt.glb", options=opts))
    page, messages = open_page(browser, (index.parent / "plain.html").resolve().as_uri())
    got = page.evaluate("plainGltf.ready")
    plain = pixels(page, "plainGltf")
    page.close()
    assert messages == []
    fit = asset.fallback
    assert got["materials"] == ["MeshPhysicalMaterial"] and got["metalness"] == 0
    np.testing.assert_allclose(got["color"], fit.base_color, rtol=1e-6)
    np.testing.assert_allclose(got["sheenColor"], fit.sheen_color, rtol=1e-6, atol=1e-7)
    assert got["sheen"] == 1 and got["roughness"] == pytest.approx(fit.roughness, rel=1e-6)
    assert got["sheenRoughness"] == pytest.approx(fit.sheen_roughness, rel=1e-6)
    shirt_px = np.any(np.abs(plain.astype(int) - plain[0, 0].astype(int)) > 2, axis=-1)  # not the background
    assert 0.05 < shirt_px.mean() < 0.9 and plain[shirt_px].std() > 2
    # the renderer's fallback mode is the same three.js material and lights: the same picture
    page, messages = open_page(browser, index.resolve().as_uri())
    page.evaluate("cdbrdfGltf.ready")
    page.evaluate("cdbrdfGltf.setMode('fallback')")
    fallback = pixels(page)
    page.evaluate("cdbrdfGltf.setEnvironment(true)")
    page.evaluate("cdbrdfGltf.setMode('cdbrdf')")
    cd = pixels(page)
    page.close()
    assert messages == []
    both = shirt_px & np.any(np.abs(fallback.astype(int) - fallback[0, 0].astype(int)) > 2, axis=-1)
    de = delta_e(srgb_to_lab(plain), srgb_to_lab(fallback), metric="ab")[both]
    assert np.median(de) < 1.0, np.percentile(de, [50, 90])
    # and the fallback looks like the fabric: the median Delta E*ab to the CDBRDF picture (measured: about 3)
    de_cd = delta_e(srgb_to_lab(plain), srgb_to_lab(cd), metric="ab")[both]
    assert np.median(de_cd) < 8.0, np.percentile(de_cd, [50, 90])


@needs_chromium
@needs_renderer
def test_served_page_modes_and_frame_time(browser, shirt):
    _, _, _, glb = shirt
    files = gltf_viewer_files(glb, name="shirt.glb", options=view_options(glb, size=(160, 120)))
    with ViewerServer(files).start() as srv:
        page, messages = open_page(browser, srv.url)
        st = page.evaluate("cdbrdfGltf.ready")
        assert st["mode"] == "cdbrdf" and st["software"] and st["env"]
        page.evaluate("cdbrdfGltf.setEnvironment(false)")  # one light: a frame in a fraction of a second
        shown = {m: pixels(page) for m in ("cdbrdf", "brdf", "curvature", "fallback")
                 if page.evaluate(f"cdbrdfGltf.setMode('{m}')")}
        info = page.evaluate("cdbrdfGltf.info()")
        ms = page.evaluate("cdbrdfGltf.frameTime(2)")
        err = page.evaluate("cdbrdfGltf.setMode('mosaic').then(() => 'ok', (e) => e.message)")
        page.close()
    assert messages == []
    assert err == "mode: mosaic is not one of cdbrdf, brdf, fallback, curvature"
    assert info["fallback"] == "MeshPhysicalMaterial" and info["extension"]["curvature"]["attribute"] == "_CURVATURE"
    assert ms > 0
    for a in ("brdf", "curvature", "fallback"):
        assert np.any(shown[a] != shown["cdbrdf"]), a
    red = shown["curvature"][..., 0].astype(int) - shown["curvature"][..., 2]
    assert (red > 25).sum() > 20 and (red < -25).sum() > 20  # convex and concave folds of the shirt (about 0.03 / mm)


def test_cli_view_of_an_asset(shirt, tmp_path, capsys):
    _, _, _, glb = shirt
    (tmp_path / "shirt.glb").write_bytes(glb)
    if bundle_missing():
        assert main(["view", str(tmp_path / "shirt.glb"), "--export", str(tmp_path / "site")]) == 2
        assert "the glTF renderer is not built" in capsys.readouterr().err
        return
    assert main(["view", str(tmp_path / "shirt.glb"), "--export", str(tmp_path / "site")]) == 0
    names = sorted(p.name for p in (tmp_path / "site").iterdir())
    assert {"index.html", "data.js", "lookup.js", "renderer.js", "plain.html", "three-plain.js"} <= set(names)
    text = (tmp_path / "site" / "data.js").read_text()
    data = json.loads(text[text.index("{"):text.rindex("}") + 1])
    assert base64.b64decode(data["glb"]) == glb and data["options"]["camera"]["fov_deg"] == 30.0
    for extra, msg in ((["--grid", "15,30"], "--grid: not for a glTF asset"),
                       (["--mesh", str(tmp_path / "shirt.glb")], "--mesh: not for a glTF asset")):
        assert main(["view", str(tmp_path / "shirt.glb"), *extra, "--export", str(tmp_path / "o")]) == 2
        err = capsys.readouterr().err
        assert msg in err and err.count("\n") == 1
    plain = tmp_path / "plain.glb"
    import trimesh

    trimesh.creation.box().export(plain)
    assert main(["view", str(plain), "--export", str(tmp_path / "o")]) == 2
    assert "no material with the CDBRDF_materials_curvature_brdf extension" in capsys.readouterr().err
    assert not (tmp_path / "o").exists()


@needs_chromium
@needs_renderer
def test_curvature_map_in_the_asset_and_the_page(browser, tmp_path):
    """A normal map's wrinkles (10 mm period, +-0.158 / mm) on a flat quad, baked per texel as the renderer bakes
    them: carried as the asset's curvature map, they tilt the normals and bend the lookup as in Mitsuba."""
    from cdbrdf.colour import card_exposure_ev, delta_e, srgb_to_lab
    from cdbrdf.mesh import SurfaceMaps, normal_map_from_normals, prepare_mesh
    from cdbrdf.render.lighting import card_irradiance

    from .gltf_helpers import accessor, read_glb
    from .maps_helpers import PEAK, quad, sine_normals

    shot = materials.load("shot")
    maps = SurfaceMaps(normal_map=normal_map_from_normals(sine_normals(256)))
    mesh = export_mesh(MeshSurface(quad(), units="mm"), table=shot, maps=maps)
    assert mesh.curvature_map is not None and mesh.uv_scale == (100.0, 100.0)
    asset = build_gltf(shot, mesh, fallback=FIXED_FALLBACK)
    (tmp_path / "q.glb").write_bytes(asset.glb())
    doc, blob = read_glb(tmp_path / "q.glb")
    curv = doc["materials"][0]["extensions"]["CDBRDF_materials_curvature_brdf"]["curvature"]
    m = curv["map"]
    assert curv["shapeAttribute"] == "_CURVATURE_SHAPE" and m["uvScale"] == [100.0, 100.0]
    assert m["levels"][0] == [0, 256, 256] and m["levels"][-1][1:] == [1, 1]
    assert m["encoding"]["error"]["maxAbsoluteOverRange"] <= 0.5 / 65535 * (1 + 1e-9)
    # dp/du per UV unit at 100 mm per UV unit: the wrinkles' curvature A k^2 at the crests
    assert m["encoding"]["offset"][2] / 100.0 == pytest.approx(-PEAK, rel=0.02)
    shape = accessor(doc, blob, doc["meshes"][0]["primitives"][0]["attributes"]["_CURVATURE_SHAPE"])
    np.testing.assert_allclose(shape, 0.0, atol=1e-6)  # the quad itself is flat
    prepared = prepare_mesh(quad(), table=shot, units="mm", maps=maps)
    image, camera = mitsuba_view(shot, *SIZE, mesh=prepared, view=(50.0, -80.0))
    ev = card_exposure_ev(card_irradiance(LIGHT, None))
    ours, _, theirs, seen = _compare(browser, asset.glb(), image, camera, ev, tmp_path / "a")
    flat = build_gltf(shot, export_mesh(MeshSurface(quad(), units="mm"), table=shot), fallback=FIXED_FALLBACK).glb()
    nomap, _, _, _ = _compare(browser, flat, image, camera, ev, tmp_path / "b")
    de = delta_e(srgb_to_lab(ours), srgb_to_lab(theirs), metric="ab")[seen]
    de_nomap = delta_e(srgb_to_lab(nomap), srgb_to_lab(theirs), metric="ab")[seen]
    assert np.median(de) <= 1.0 and np.percentile(de, 90) <= 2.0, np.percentile(de, [50, 90])
    assert np.median(de_nomap) > 2.0, np.percentile(de_nomap, [50, 90])  # the map matters
