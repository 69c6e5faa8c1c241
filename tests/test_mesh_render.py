"""Meshes through Mitsuba: the attributes the plug-in reads, both curvature modes, the sign each side
shows, the up axis, the framing, the studio lighting, the exposure, and the commands.

Small renders (few samples, small images). Known answers: tables whose value
is a known function of kappa (the image shows the curvature looked up), a
white Lambertian table (the image is the irradiance), silhouettes measured
from the film's alpha channel.
"""

from __future__ import annotations

import logging

import numpy as np
import pytest

import cdbrdf
from cdbrdf.mesh import MeshSurface
from cdbrdf.render import Camera, Light, RenderSpec, _llvm
from cdbrdf.render._llvm import find_llvm

from .mesh_helpers import R_CYL, cylinder_patch, shared_mesh, write_obj

mi = pytest.importorskip("mitsuba")

_INFO = find_llvm()
pytestmark = pytest.mark.skipif(not _INFO.ok, reason=_llvm.llvm_message(_INFO))


@pytest.fixture
def variant():
    import cdbrdf.render as cr

    cr.set_variant("llvm_ad_rgb")
    return cr


def kappa_table(gain=1.0, kappa=(-0.22, 0.0, 0.22)):
    """Value = 0.5 + gain * kappa in every direction and channel."""
    g = cdbrdf.Grid(kappa=list(kappa), theta_l=[0, 45, 75], phi_l=[0, 120, 240], theta_v=[0, 45, 75],
                    phi_v=[0, 120, 240])
    k = np.asarray(kappa, dtype=np.float64)
    v = 0.5 + gain * np.broadcast_to(k[:, None, None, None, None, None], g.shape + (3,))
    return cdbrdf.CDBRDF(np.ascontiguousarray(v), g)


def white_table():
    g = cdbrdf.Grid(kappa=[0.0], theta_l=[0, 45, 75], phi_l=[0, 180], theta_v=[0, 45, 75], phi_v=[0, 180])
    return cdbrdf.CDBRDF(np.full(g.shape + (3,), 1.0 / np.pi), g, attrs={"quantity": "brdf"})


def silhouette(img):
    """Share of the frame's width and height the object (alpha >= 0.5) spans."""
    a = img[..., 3] >= 0.5
    rows, cols = np.flatnonzero(a.any(axis=1)), np.flatnonzero(a.any(axis=0))
    return (cols[-1] - cols[0] + 1) / a.shape[1], (rows[-1] - rows[0] + 1) / a.shape[0]


# -- the attributes of the plug-in --------------------------------------------------------------
def test_written_properties_load_as_the_plugins_attributes(variant, tmp_path):
    from cdbrdf.mesh import CURVATURE_MODES, Mesh, prepare_mesh, write_ply

    v, f, uv, _ = cylinder_patch(R_CYL, n=12)
    m = prepare_mesh(Mesh(v, f, None, uv))
    path = tmp_path / "c.ply"
    write_ply(path, m)
    shape = mi.load_dict({"type": "ply", "filename": str(path)})
    for mode in CURVATURE_MODES.values():  # the one name map: a mesh's attribute, its PLY property, Mitsuba's
        attr = mode.mitsuba_attribute
        assert shape.has_attribute(attr), attr
        assert np.allclose(np.array(shape.attribute_buffer(attr)), m.attributes[mode.attribute], atol=1e-6)
    from cdbrdf.mesh._ply_format import ply_header

    vertex = next(e for e in ply_header(path.read_bytes(), str(path))[1] if e.name == "vertex")
    assert {m.ply_property for m in CURVATURE_MODES.values()} <= {p.name for p in vertex.props}
    assert [m.ply_property for m in CURVATURE_MODES.values()] == ["curvature_x", "curvature_dir_x"]


def test_directional_mode_reads_the_curvature_along_x(variant):
    """A cylinder whose u runs along its axis: the maximum curvature is 1/r, the directional one 0."""
    from cdbrdf.mesh import Mesh, prepare_mesh
    from cdbrdf.render.picture import render_scene
    from cdbrdf.render.scenes import mesh_scene

    radius = 1 / 0.13
    v, f, uv, _ = cylinder_patch(radius, n=30)
    mesh = prepare_mesh(Mesh(v, f, None, uv[:, ::-1].copy(), metadata={"up": "z"}))
    table = kappa_table()
    got = {}
    for mode in ("max", "directional"):
        scene = mesh_scene(table, RenderSpec(surface=mesh, curvature_mode=mode,
                                             light=Light(lighting="paper", direction=(0.0, 0.0)), size=(33, 33),
                                             spp=4, max_depth=2, camera=Camera(view=(89.0, -90.0), fov_deg=10.0)))
        got[mode] = render_scene(scene)[14:19, 14:19].mean()
    assert got["max"] == pytest.approx(np.pi * (0.5 + 0.13), rel=0.03)
    assert got["directional"] == pytest.approx(np.pi * 0.5, rel=0.03)


def test_each_visible_side_of_the_garment_shows_its_sign(variant):
    """The skirt without folds is convex seen from outside, on both panels and both sides of the sash."""
    from cdbrdf.mesh import Skirt, prepare_mesh, skirt_mesh
    from cdbrdf.render.picture import render_scene
    from cdbrdf.render.scenes import mesh_scene

    mesh = prepare_mesh(skirt_mesh(Skirt(fold_amplitude_mm=0.0, around=41, down=25)))
    curved = kappa_table(gain=30.0, kappa=(-0.01, 0.0, 0.01))  # 0.5 + 30 kappa: 0.7 at kappa = 1/150 mm
    flat = kappa_table(gain=0.0, kappa=(-0.01, 0.0, 0.01))
    for azimuth in (-90.0, 90.0):  # the front panel (and the sash), then the back panel
        spec = RenderSpec(surface=mesh, light=Light(lighting="paper", direction=(30.0, azimuth)), size=(40, 40),
                          spp=2, max_depth=2, camera=Camera(view=(10.0, azimuth)))
        imgs = [render_scene(mesh_scene(t, spec), alpha=True) for t in (curved, flat)]
        cover = (imgs[0][..., 3] > 0.99) & (imgs[1][..., 0] > 0.05)
        ratio = imgs[0][..., 0][cover] / imgs[1][..., 0][cover]
        assert np.median(ratio) > 1.2, azimuth  # convex: more than the flat table everywhere seen
        assert np.mean(ratio > 1.0) > 0.98, azimuth


# -- the picture: up axis, framing, lighting, exposure -----------------------------------------
def test_up_axis_is_detected_and_can_be_given(variant, tmp_path):
    """A tall post along y in an OBJ (Y-up by convention) stands up; told it is Z-up, it lies down."""
    from cdbrdf.mesh import detect_up, prepare_mesh
    from cdbrdf.render.picture import render_scene
    from cdbrdf.render.scenes import mesh_scene

    v, f, uv, _ = cylinder_patch(10.0, n=12, angle=2 * np.pi * 0.999, length=120.0)
    path = write_obj(tmp_path / "post.obj", v, f, uv)
    mesh = prepare_mesh(path)
    up, why = detect_up(mesh)
    assert up == "y" and "convention" not in why  # from its geometry
    w_h = {}
    for up in ("auto", "z"):
        img = render_scene(mesh_scene(white_table(), RenderSpec(surface=MeshSurface(mesh, up=up), size=(40, 40),
                                                                spp=1, max_depth=2, camera=Camera(view=(10.0, 0.0)))),
                           alpha=True)
        w_h[up] = silhouette(img)
    assert w_h["auto"][1] > 3 * w_h["auto"][0]  # standing
    assert w_h["z"][0] > 3 * w_h["z"][1]  # lying along the view's horizontal


@pytest.mark.parametrize("which", ["spot", "skirt"])
def test_the_object_fills_three_quarters_of_the_frame(variant, which):
    from cdbrdf.mesh import Skirt, prepare_mesh, skirt_mesh
    from cdbrdf.render.camera import DEFAULT_MESH_VIEW, FRAME_FILL
    from cdbrdf.render.picture import render_scene
    from cdbrdf.render.scenes import mesh_scene

    if which == "spot":
        mesh = prepare_mesh(shared_mesh("spot.obj"), units="m")
    else:
        mesh = prepare_mesh(skirt_mesh(Skirt(around=41, down=25)))
    for size in ((96, 72), (60, 90)):
        img = render_scene(mesh_scene(white_table(), RenderSpec(surface=mesh, size=size, spp=1, max_depth=2)),
                           alpha=True)
        fill = max(silhouette(img))
        assert 0.70 <= fill <= 0.80, (which, size, fill)
    assert DEFAULT_MESH_VIEW == (20.0, -65.0) and FRAME_FILL == 0.75


def test_studio_lighting_fills_the_shadows(variant):
    from cdbrdf.mesh import Skirt, prepare_mesh, skirt_mesh
    from cdbrdf.render.picture import render_scene
    from cdbrdf.render.scenes import mesh_scene

    mesh = prepare_mesh(skirt_mesh(Skirt(around=41, down=25)))
    spread = {}
    for lighting in ("paper", "studio"):
        spec = RenderSpec(surface=mesh, light=Light(lighting=lighting), size=(48, 48), spp=8, max_depth=2)
        img = render_scene(mesh_scene(white_table(), spec), alpha=True)
        y = img[..., :3].mean(axis=-1)[img[..., 3] > 0.99]
        spread[lighting] = (np.percentile(y, 5), np.percentile(y, 95))
        if lighting == "studio":  # the built-in sky is not seen: the background is empty
            assert img[0, 0, 3] == 0.0 and np.all(img[0, 0, :3] == 0.0)
    assert spread["paper"][0] < 0.05 * spread["paper"][1]  # the single light leaves black shadows
    assert spread["studio"][0] > 0.15 * spread["studio"][1]  # the studio's sky fills them


def test_exposure_from_the_render():
    from cdbrdf.render.picture import MAX_AUTO_EV, composite, exposure_from_render

    img = np.zeros((10, 10, 4), np.float32)
    img[2:8, 2:8, :3] = 0.425
    img[2:8, 2:8, 3] = 1.0
    img[0, 0, :3] = 50.0  # a background pixel: not the object's, not counted
    assert exposure_from_render(img) == pytest.approx(1.0)  # 0.425 * 2 = 0.85
    img[2:8, 2:8, :3] = 0.001  # a very dark object is raised at most MAX_AUTO_EV
    assert exposure_from_render(img) == pytest.approx(MAX_AUTO_EV)
    assert exposure_from_render(img, irradiance=4 * np.pi) == pytest.approx(MAX_AUTO_EV - 2.0)
    out = composite(img, exposure_ev=1.0, backdrop=0.5)
    assert np.allclose(out[0, 1], 0.25) and np.allclose(out[4, 4], 0.001)


def test_grey_card_exposure_is_the_cards_irradiance():
    from cdbrdf.colour import card_exposure_ev
    from cdbrdf.render.lighting import card_irradiance, studio_environment

    assert card_exposure_ev(np.pi) == 0.0 and card_exposure_ev(4 * np.pi) == pytest.approx(-2.0)
    assert card_irradiance((30.0, 10.0, 2.0), None) == 2.0
    # a uniform sky of radiance L gives pi L on any card; the studio sky adds to the key light's pi
    assert card_irradiance(None, np.full((64, 128, 3), 0.5)) == pytest.approx(0.5 * np.pi, rel=1e-3)
    assert np.pi < card_irradiance((45.0, 0.0, np.pi), studio_environment()) < 1.5 * np.pi
    with pytest.raises(ValueError, match="card irradiance"):
        card_exposure_ev(0.0)


def test_a_dark_fabric_shows_at_its_own_reflectance(variant):
    """Indigo (a Lambertian table of albedo (0.03, 0.05, 0.12)) on a square facing the light: the default
    exposure (grey card) shows it at its albedo; the picture-driven one pushes it 2 EV brighter."""
    from cdbrdf.mesh import Mesh
    from cdbrdf.render import render_table

    albedo = np.array([0.03, 0.05, 0.12])
    g = cdbrdf.Grid(kappa=[0.0], theta_l=[0, 45, 75], phi_l=[0, 180], theta_v=[0, 45, 75], phi_v=[0, 180])
    table = cdbrdf.CDBRDF(np.broadcast_to(albedo / np.pi, g.shape + (3,)).copy(), g,
                          attrs={"quantity": "brdf"})
    x, y = np.meshgrid(np.linspace(-50, 50, 11), np.linspace(-50, 50, 11), indexing="ij")
    v = np.c_[x.ravel(), y.ravel(), np.zeros(x.size)]
    q = (np.arange(10)[:, None] * 11 + np.arange(10)[None, :]).ravel()
    f = np.concatenate([np.c_[q, q + 11, q + 12], np.c_[q, q + 12, q + 1]])
    square = Mesh(v, f, None, np.c_[x.ravel(), y.ravel()] / 100 + 0.5, {}, metadata={"up": "z"})
    shown = {}
    for rule in ("card", "auto"):
        pic = render_table(table, RenderSpec(surface=square, size=(24, 24), spp=4,
                                             light=Light(lighting="paper", direction=(0.0, 0.0)),
                                             camera=Camera(view=(60.0, -90.0)), exposure=rule))
        img = pic.images["cdbrdf"]
        shown[rule] = img[10:14, 10:14, :3].reshape(-1, 3).mean(axis=0) * 2.0 ** pic.exposure_ev
        assert pic.exposure_source == {"card": "grey card", "auto": "auto"}[rule]
    assert shown["card"] == pytest.approx(albedo, rel=0.03)
    assert shown["auto"] == pytest.approx(4 * albedo, rel=0.03)  # the +2 EV cap: light periwinkle


# -- the commands -------------------------------------------------------------------------------
def test_curvature_command_records_the_unit_and_render_uses_it(variant, tmp_path, capsys):
    from cdbrdf.cli import main
    from cdbrdf.mesh import read_ply

    v, f, uv, interior = cylinder_patch(R_CYL / 10.0, n=40)  # in cm
    f = f.copy()
    f[::5] = f[::5][:, ::-1]  # mixed winding
    src = write_obj(tmp_path / "cyl.obj", v, f, uv)
    out = tmp_path / "cyl.ply"
    assert main(["curvature", str(src), "-o", str(out), "--units", "cm"]) == 0
    err = capsys.readouterr().err
    assert f"{src}: repaired: re-oriented 1 of 1 component" in err
    assert "units: cm (given)" in err and "neighbourhood: 5 mm (the default)" in err
    r = read_ply(out)
    assert r.metadata["units"] == "cm" and r.metadata["curvature_units"] == "1/mm"
    inner = np.all((r.uv > 0.15) & (r.uv < 0.85), axis=1)
    assert np.median(r.attributes["curvature"][inner]) == pytest.approx(0.22, rel=0.02)
    assert np.median(r.attributes["curvature_dir"][inner]) == pytest.approx(0.22, rel=0.02)
    table = tmp_path / "k.h5"
    kappa_table().save(table)
    common = ["render", str(table), "--size", "16x12", "--spp", "1", "--max-depth", "2"]
    assert main([*common, "--mesh", str(out), "-o", str(tmp_path / "a.png")]) == 0
    err = capsys.readouterr().err
    assert "units: cm (recorded in the file)" in err and "curvature: as recorded in the file" in err
    assert "repaired" not in err and "exposure" in err
    assert main([*common, "--mesh", str(out), "--units", "mm", "-o", str(tmp_path / "b.png")]) == 0
    err = capsys.readouterr().err
    assert "units: mm (given)" in err and "curvature: computed again" in err
    assert main([*common, "--mesh", str(out), "--compare", "--curvature", "directional",
                 "-o", str(tmp_path / "c.png")]) == 0
    assert (tmp_path / "c.png").stat().st_size > 1000


def test_render_warns_of_a_wrong_unit(variant, tmp_path, caplog):
    from cdbrdf.cli import main

    v, f, uv, _ = cylinder_patch(2 * R_CYL / 1000.0, n=20)  # kappa 0.11 / mm, in metres
    src = write_obj(tmp_path / "cyl.obj", v, f, uv)
    table = tmp_path / "k.h5"
    kappa_table().save(table)
    with caplog.at_level(logging.WARNING, logger="cdbrdf"):
        assert main(["-q", "render", str(table), "--mesh", str(src), "--units", "mm", "--size", "8x8", "--spp", "1",
                     "-o", str(tmp_path / "a.exr")]) == 0
    msgs = [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING]
    assert any("100% of the surface" in m and "--units m" in m for m in msgs), msgs
    for units in (["--units", "m"], []):  # given, or inferred from the size of the sheet (2.9 cm across in m)
        caplog.clear()
        with caplog.at_level(logging.WARNING, logger="cdbrdf"):
            assert main(["-q", "render", str(table), "--mesh", str(src), *units, "--size", "8x8", "--spp", "1",
                         "-o", str(tmp_path / "b.exr")]) == 0
        assert not [r for r in caplog.records if r.levelno == logging.WARNING and "curvature" in r.getMessage()]


def test_render_options_are_checked(variant, tmp_path, capsys):
    from cdbrdf.cli import main

    table = tmp_path / "k.h5"
    kappa_table().save(table)
    v, f, uv, _ = cylinder_patch(R_CYL, n=10)
    src = write_obj(tmp_path / "c.obj", v, f, uv)
    base = ["-q", "render", str(table), "-o", str(tmp_path / "x.png")]

    def status(argv):
        try:
            return main(argv)
        except SystemExit as exc:  # refused while parsing
            return exc.code

    for extra, word in ((["--mesh", str(src), "--units", "furlong"], "--units"),
                        (["--mesh", str(src), "--up", "x"], "--up"),
                        (["--mesh", str(src), "--lighting", "sun"], "--lighting"),
                        (["--mesh", str(src), "--frame", "polar"], "--frame"),
                        (["--mesh", str(src), "--curvature", "mean"], "--curvature"),
                        (["--mesh", str(src), "--neighbourhood", "-1"], "--neighbourhood"),
                        (["--scene", "sine", "--lighting", "studio"], "studio"),
                        (["--mesh", str(tmp_path / "c.fbx")], "--mesh")):
        assert status(base + extra) == 2, extra
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and word in err, (extra, err)
    assert not (tmp_path / "x.png").exists()


# -- hostile input, second round ------------------------------------------------------------------------
@pytest.mark.parametrize("name, data", [("env.exr", b"\x76\x2f\x31\x01" + bytes(300)), ("env.exr", b"junk"),
                                        ("env.hdr", b"#?RADIANCE\nFORMAT=junk\n\n-Y 4 +X x\n")])
def test_a_damaged_envmap_is_one_line(variant, tmp_path, capsys, name, data):
    """A damaged --envmap gave a traceback (Mitsuba's bitmap reader)."""
    from cdbrdf.cli import main

    table = tmp_path / "k.h5"
    kappa_table().save(table)
    v, f, uv, _ = cylinder_patch(R_CYL, n=10)
    src = write_obj(tmp_path / "c.obj", v, f, uv)
    env = tmp_path / name
    env.write_bytes(data)
    assert main(["-q", "render", str(table), "--mesh", str(src), "--envmap", str(env), "-o", str(tmp_path / "x.png"),
                 "--size", "16x12", "--spp", "1"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err and name in err, err
    assert not (tmp_path / "x.png").exists()
