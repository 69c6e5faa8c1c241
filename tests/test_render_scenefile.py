"""Mitsuba XML scenes with ``<bsdf type="cdbrdf">``: cdbrdf.render.load_file, the checks, ``cdbrdf render SCENE.xml``.

A kappa-readable table (value 0.5 + kappa in every direction) on a half
cylinder of curvature 0.13 mm^-1 seen from above under a light from above:
the apex's radiance is pi (0.5 + kappa), so the curvature the plug-in used
can be read from the image (to_world scales, scene and file units).
"""

from __future__ import annotations

import logging

import numpy as np
import pytest

import cdbrdf
from cdbrdf.errors import SceneError

from .render_helpers import constant_table, local_si, mi, needs_llvm, vec

pytestmark = needs_llvm

KAPPA = 0.13


@pytest.fixture
def cr():
    import cdbrdf.render as cr

    cr.set_variant("llvm_ad_rgb")
    return cr


def kappa_table():
    g = cdbrdf.Grid.paper()
    return cdbrdf.CDBRDF(0.5 + np.broadcast_to(g.kappa[:, None, None, None, None, None], g.shape + (3,)), g)


def cylinder(radius=1 / KAPPA, n=40, *, uv=True, directional=None):
    """Half cylinder (axis y) with u across the axis, its curvature stored (and a directional one if given)."""
    from cdbrdf.mesh import Mesh

    a = np.linspace(-np.pi / 2, np.pi / 2, n)
    y = np.linspace(-radius, radius, n // 2)
    A, Y = np.meshgrid(a, y, indexing="ij")
    v = np.c_[radius * np.sin(A.ravel()), Y.ravel(), radius * np.cos(A.ravel())]
    tex = np.c_[(A.ravel() + np.pi / 2) / np.pi, (Y.ravel() + radius) / (2 * radius)] if uv else None
    ny = y.size
    i, j = np.meshgrid(np.arange(n - 1), np.arange(ny - 1), indexing="ij")
    p = (i * ny + j).ravel()
    f = np.concatenate([np.c_[p, p + ny, p + ny + 1], np.c_[p, p + ny + 1, p + 1]])
    attrs = {"curvature": np.full(len(v), 1 / radius)}
    if directional is not None:
        attrs["curvature_dir"] = np.full(len(v), directional)
    return Mesh(v, f.astype(np.int64), None, tex, attrs)


def write_scene(folder, *, shape_extra="", bsdf_extra="", unit_comment=None, wrap=False, mesh=None, name="s.xml",
                metres=False):
    """The scene; with ``metres`` the same scene in metres (the mm mesh scaled by 0.001, the camera too)."""
    from cdbrdf.mesh import write_ply

    folder.mkdir(parents=True, exist_ok=True)
    kappa_table().save(folder / "kappa.h5")
    write_ply(folder / "cyl.ply", mesh or cylinder())
    if unit_comment is not None:  # the unit as cdbrdf curvature records it: comment cdbrdf units 2
        raw = (folder / "cyl.ply").read_bytes()
        raw = raw.replace(b"end_header", f"comment cdbrdf units {unit_comment:g}\nend_header".encode(), 1)
        (folder / "cyl.ply").write_bytes(raw)
    bsdf = f'<bsdf type="cdbrdf"><string name="filename" value="kappa.h5"/>{bsdf_extra}</bsdf>'
    if wrap:
        bsdf = f'<bsdf type="twosided">{bsdf}</bsdf>'
    xml = f"""<scene version="3.0.0">
  <default name="spp" value="4"/>
  <integrator type="path"><integer name="max_depth" value="2"/></integrator>
  <sensor type="orthographic">
    <transform name="to_world"><scale value="{0.003 if metres else 3}"/>
      <lookat origin="0, 0, {0.1 if metres else 100}" target="0, 0, 0" up="0, 1, 0"/></transform>
    <film type="hdrfilm"><integer name="width" value="9"/><integer name="height" value="9"/>
      <rfilter type="box"/></film>
    <sampler type="independent"><integer name="sample_count" value="$spp"/></sampler>
  </sensor>
  <shape type="ply" id="cyl"><string name="filename" value="cyl.ply"/>{shape_extra}{bsdf}</shape>
  <emitter type="directional"><vector name="direction" value="0, 0, -1"/>
    <rgb name="irradiance" value="3.14159265"/></emitter>
</scene>
"""
    if metres:
        xml = xml.replace('<string name="filename" value="cyl.ply"/>',
                          '<string name="filename" value="cyl.ply"/><transform name="to_world"><scale value="0.001"/>'
                          '</transform>')
    (folder / name).write_text(xml)
    return folder / name


def apex(img):
    return float(img[4, 4].mean())


def test_relative_files_resolve_next_to_the_scene(cr, tmp_path, monkeypatch):
    path = write_scene(tmp_path / "scenes")
    monkeypatch.chdir(tmp_path)  # the scene's folder is not the working folder
    scene = cr.load_file(path, variables={"spp": 8})
    img = np.array(mi.render(scene))
    assert apex(img) == pytest.approx(np.pi * (0.5 + KAPPA), rel=0.01)
    assert scene.sensors()[0].sampler().sample_count() == 8
    # plain Mitsuba resolves the table the same way (its resolver holds the scene's folder while loading)
    plain = mi.load_file(str(path))
    cr.check_scene(plain)


def test_to_world_scale_and_units_change_the_curvature(cr, tmp_path):
    cases = [  # (to_world, unit_mm, comment in the PLY, expected kappa)
        ('<transform name="to_world"><scale value="2"/></transform>', 1.0, None, KAPPA / 2),
        ("", 2.0, None, KAPPA / 2),  # scene in units of 2 mm, file assumed in mm
        ("", 2.0, 2.0, KAPPA),  # the file says it is in units of 2 mm too
        ('<transform name="to_world"><scale value="0.5"/></transform>', 1.0, 0.5, KAPPA),  # a unit change
    ]
    for k, (tw, unit, comment, want) in enumerate(cases):
        path = write_scene(tmp_path / f"c{k}", shape_extra=tw, unit_comment=comment)
        scene = cr.load_file(path, unit_mm=unit)
        # keep the apex in the 9 x 9 view: the camera sees [-3, 3] mm
        img = np.array(mi.render(scene, spp=4))
        assert apex(img) == pytest.approx(np.pi * (0.5 + want), rel=0.01), (k, apex(img))


def test_a_scene_in_metres_renders_like_the_scene_in_mm_when_its_unit_is_given(cr, tmp_path, caplog):
    """The mm mesh scaled by 0.001 into a scene in metres: the scene unit, from the loader, the BSDF or nobody."""
    ref = np.array(mi.render(cr.load_file(write_scene(tmp_path / "mm")), spp=4))
    metres = write_scene(tmp_path / "m", metres=True)
    given = np.array(mi.render(cr.load_file(metres, unit_mm=1000.0), spp=4))
    in_bsdf = write_scene(tmp_path / "mb", metres=True, bsdf_extra='<string name="unit" value="m"/>')
    with caplog.at_level(logging.WARNING, logger="cdbrdf"):
        from_bsdf = np.array(mi.render(cr.load_file(in_bsdf), spp=4))
    assert not caplog.records
    for img in (given, from_bsdf):
        assert abs(img.mean() / ref.mean() - 1) < 0.005
    # not given: the curvature is 1000 times too large, and the warning names the unit
    with caplog.at_level(logging.WARNING, logger="cdbrdf"):
        wrong = np.array(mi.render(cr.load_file(metres), spp=4))
    assert abs(wrong.mean() / ref.mean() - 1) > 0.03
    assert any("with the scene unit m" in r.getMessage() and "tighter than a yarn" in r.getMessage()
               for r in caplog.records), caplog.text
    # Mitsuba's own loader: the attribute as it is, right for a to_world that turns mm into metres;
    # a unit there is reported as not applied
    caplog.clear()
    with caplog.at_level(logging.WARNING, logger="cdbrdf"):
        plain = np.array(mi.render(mi.load_file(str(in_bsdf)), spp=4))
    assert abs(plain.mean() / ref.mean() - 1) < 0.005
    assert "made by Mitsuba's own loader, which gives the plug-in no shape" in caplog.text
    assert "its unit (m)" in caplog.text


def test_dict_scenes_apply_the_unit_with_to_world(cr, tmp_path):
    from cdbrdf.mesh import write_ply

    write_ply(tmp_path / "cyl.ply", cylinder())
    table = kappa_table()

    def scene(scale, cam, **bsdf):
        return {"type": "scene", "integrator": {"type": "path", "max_depth": 2},
                "sensor": {"type": "orthographic",
                           "to_world": mi.ScalarTransform4f().look_at(origin=[0, 0, 100 * cam / 3], target=[0, 0, 0],
                                                                      up=[0, 1, 0]).scale(cam),
                           "film": {"type": "hdrfilm", "width": 9, "height": 9, "rfilter": {"type": "box"}}},
                "cyl": {"type": "ply", "filename": str(tmp_path / "cyl.ply"),
                        "to_world": mi.ScalarTransform4f().scale(scale),
                        "bsdf": {"type": "cdbrdf", "table": table, **bsdf}},
                "sun": {"type": "directional", "direction": [0, 0, -1], "irradiance": np.pi}}

    ref = apex(np.array(mi.render(cr.load_dict(scene(1.0, 3.0)), spp=4)))
    assert ref == pytest.approx(np.pi * (0.5 + KAPPA), rel=0.01)
    for kw in ({"unit": "m"}, {}):
        got = apex(np.array(mi.render(cr.load_dict(scene(0.001, 0.003, **kw), unit_mm=None if kw else 1000.0),
                                      spp=4)))
        assert got == pytest.approx(ref, rel=0.005)
    doubled = apex(np.array(mi.render(cr.load_dict(scene(2.0, 6.0)), spp=4)))
    assert doubled == pytest.approx(np.pi * (0.5 + KAPPA / 2), rel=0.01)


def test_non_uniform_scale_is_refused(cr, tmp_path):
    path = write_scene(tmp_path, shape_extra='<transform name="to_world"><scale x="2" y="1" z="1"/></transform>')
    with pytest.raises(SceneError, match=r"non-uniform scale .*cdbrdf curvature"):
        cr.load_file(path)


def test_twosided_wrapper_is_removed_or_refused(cr, tmp_path, caplog):
    path = write_scene(tmp_path, wrap=True)
    with caplog.at_level(logging.WARNING, logger="cdbrdf.render.scenefile"):
        scene = cr.load_file(path)
    assert "removed the twosided wrapper" in caplog.text
    assert [w for _, _, w in cr.cdbrdf_shapes(scene)] == [None]
    with pytest.raises(SceneError, match="wrapped in TwoSided.*remove the wrapper"):
        cr.check_scene(mi.load_file(str(path)))


def test_what_twosided_does_to_the_back(cr):
    """Documented: wrapped, the back is the front mirrored in z with the same kappa (the plug-in flips y and kappa)."""
    g = cdbrdf.Grid.paper()
    m = g.mesh()
    v = 0.1 + 0.05 * np.sin(np.radians(m["phi_l"])) + 0.3 * np.clip(m["kappa"], 0, None)
    t = cdbrdf.CDBRDF(np.repeat(v[..., None], 3, -1), g)
    inner = cr.make_bsdf(t, curvature=0.13)
    wrapped = mi.load_dict({"type": "twosided", "bsdf": inner})
    rng = np.random.default_rng(0)
    wi, wo = rng.normal(size=(2, 400, 3))
    wi[:, 2], wo[:, 2] = -np.abs(wi[:, 2]), -np.abs(wo[:, 2])  # the back side
    wi /= np.linalg.norm(wi, axis=1, keepdims=True)
    wo /= np.linalg.norm(wo, axis=1, keepdims=True)
    ctx = mi.BSDFContext()
    got = np.array(wrapped.eval(ctx, local_si(wi), vec(wo))).T
    mirror = np.array([1.0, 1.0, -1.0])
    want = np.array(inner.eval(ctx, local_si(wi * mirror), vec(wo * mirror))).T
    np.testing.assert_allclose(got, want, rtol=1e-5, atol=1e-7)
    own = np.array(inner.eval(ctx, local_si(wi), vec(wo))).T  # the plug-in's own back side
    assert np.abs(own - got).max() > 0.01


def test_curvature_mode_selects_the_attribute(cr, tmp_path):
    path = write_scene(tmp_path / "d", mesh=cylinder(directional=-0.1),
                       bsdf_extra='<string name="curvature_mode" value="directional"/>')
    img = np.array(mi.render(cr.load_file(path), spp=4))
    assert apex(img) == pytest.approx(np.pi * (0.5 - 0.1), rel=0.01)
    path = write_scene(tmp_path / "m", bsdf_extra='<string name="curvature_mode" value="directional"/>')
    with pytest.raises(SceneError, match="'vertex_curvature_dir', which the shape does not have"):
        cr.load_file(path)
    with pytest.raises(ValueError, match="curvature_mode: 'min' is not one of max, directional"):
        cr.make_bsdf(kappa_table(), curvature_mode="min")
    with pytest.raises(ValueError, match="not both"):
        cr.make_bsdf(kappa_table(), curvature_mode="max", curvature=0.1)


def test_scene_checks_run_on_load(cr, tmp_path):
    path = write_scene(tmp_path / "nouv", mesh=cylinder(uv=False))
    with pytest.raises(SceneError, match="UV coordinates"):
        cr.load_file(path)
    mesh = cylinder()
    mesh.attributes.clear()
    path = write_scene(tmp_path / "noattr", mesh=mesh)
    with pytest.raises(SceneError, match="'vertex_curvature', which the shape does not have.*read as 0"):
        cr.load_file(path)
    cr.load_file(path, check=False)  # loads; the user asked for no checks
    with pytest.raises(SceneError, match="no such scene file"):
        cr.load_file(tmp_path / "missing.xml")
    with pytest.raises(SceneError, match=r"unused parameters.*\$bogus"):
        cr.load_file(path, variables={"bogus": 1})
    (tmp_path / "noattr" / "kappa.h5").unlink()
    with pytest.raises(SceneError, match=r"line \d+.*table file 'kappa.h5' not found") as exc:
        cr.load_file(path)
    assert "Traceback" not in str(exc.value) and "\n" not in str(exc.value)


def test_scale_texture_multiplies_the_reflectance(cr):
    t = constant_table([0.2, 0.2, 0.2])
    b = cr.make_bsdf(t, curvature=0.0, sampling="cosine",
                     scale={"type": "checkerboard", "color0": {"type": "rgb", "value": [1.0, 0.5, 0.25]},
                            "color1": {"type": "rgb", "value": [0.1, 0.1, 0.1]}})
    si = local_si(np.tile([0.0, 0.0, 1.0], (2, 1)))
    si.uv = mi.Point2f([0.25, 0.75], [0.25, 0.25])  # one square of each colour
    f = np.array(b.eval(mi.BSDFContext(), si, vec(np.tile([0.0, 0.0, 1.0], (2, 1))))).T
    np.testing.assert_allclose(f, 0.2 * np.array([[1.0, 0.5, 0.25], [0.1, 0.1, 0.1]]), rtol=1e-5)
    params = mi.traverse(b)
    assert any(k.startswith("scale.") for k in params.keys())


def test_render_command_with_a_scene_file(cr, tmp_path):
    from cdbrdf.cli import main

    path = write_scene(tmp_path)
    exr = tmp_path / "out.exr"
    assert main(["-q", "render", str(path), "-o", str(exr), "-D", "spp=8", "--variant", "llvm_ad_rgb"]) == 0
    img = np.array(mi.Bitmap(str(exr)))[..., :3]
    assert apex(img) == pytest.approx(np.pi * (0.5 + KAPPA), rel=0.01)
    png = tmp_path / "out.png"
    assert main(["-q", "render", str(path), "-o", str(png), "--spp", "2", "--units", "cm",
                 "--variant", "llvm_ad_spectral"]) == 0
    assert png.stat().st_size > 0
    grey = tmp_path / "grey.png"  # mono: one channel, written as grey
    assert main(["-q", "render", str(path), "-o", str(grey), "--spp", "2", "--variant", "llvm_ad_mono"]) == 0
    assert grey.stat().st_size > 0


def test_a_scene_files_summary_says_the_samples_that_ran(cr, tmp_path, capsys):
    """Without --spp the sensor's count renders (in passes of 16) and the summary says that count, not a pass's."""
    from cdbrdf.cli import main

    path = write_scene(tmp_path)
    capsys.readouterr()
    assert main(["render", str(path), "-o", str(tmp_path / "a.exr"), "-D", "spp=40"]) == 0
    assert "(9x9, 40 spp, llvm_ad_rgb)" in capsys.readouterr().err
    def status(argv):
        try:
            return main(argv)
        except SystemExit as exc:  # argparse's own errors
            return exc.code

    for bad in (["--light", "30,0"], ["--compare"], ["--scene", "sine"], ["-D", "bogus=1"], ["-D", "no-equals"]):
        out = tmp_path / "bad.png"
        assert status(["-q", "render", str(path), "-o", str(out), *bad]) == 2, bad
        assert not out.exists()
    assert main(["-q", "render", str(tmp_path / "kappa.h5"), "-o", str(tmp_path / "x.png"), "-D", "spp=1",
                 "--scene", "sine"]) == 2


# -- hostile input, second round: limits on what is rendered, special files, clamped curvature ----------------
def param_scene(folder, **kw):
    """write_scene with the film's size as $w x $h (defaults 9) and the sampler's count as $spp."""
    path = write_scene(folder, **kw)
    xml = path.read_text().replace('<default name="spp" value="4"/>', '<default name="spp" value="4"/>'
                                   '<default name="w" value="9"/><default name="h" value="9"/>')
    xml = xml.replace('<integer name="width" value="9"/><integer name="height" value="9"/>',
                      '<integer name="width" value="$w"/><integer name="height" value="$h"/>')
    path.write_text(xml)
    return path


@pytest.mark.parametrize("defines, match", [
    ({"w": "0"}, r"film size 0 x 9; a film needs at least 1 x 1 pixels"),
    ({"h": "-3"}, r"film size 9 x -3"),
    ({"w": "9000", "h": "9000"}, r"9000 x 9000 film: 81,000,000 pixels exceed the limit of 67,108,864 "
                                 r"\(raise it with CDBRDF_MAX_RENDER_PIXELS\)"),
    ({"spp": "2000000000"}, r"sample_count 2,000,000,000; a render takes 1 to 65,536 samples per pixel"),
])
def test_the_limits_apply_to_the_film_and_sampler_a_scene_really_has(cr, tmp_path, defines, match):
    """A 9000 x 9000 film rendered for minutes, -D spp=2e9 promised 967 h, -D w=0 gave a traceback."""
    from cdbrdf.errors import LimitError

    path = param_scene(tmp_path)
    with pytest.raises((SceneError, LimitError), match=match) as exc:
        cr.load_file(path, variables=defines)
    assert "\n" not in str(exc.value)


def test_the_command_checks_the_scene_s_film_not_its_unused_size_option(cr, tmp_path, monkeypatch, capsys):
    """An 8 x 8 scene was refused by the default --size; -D w=0 gave a traceback."""
    from cdbrdf.cli import main

    path = param_scene(tmp_path)
    out = tmp_path / "o.exr"
    monkeypatch.setenv("CDBRDF_MAX_RENDER_PIXELS", "100")
    assert main(["-q", "render", str(path), "-o", str(out), "-D", "w=8", "-D", "h=8", "-D", "spp=1"]) == 0
    assert main(["-q", "render", str(path), "-o", str(out), "-D", "w=20", "-D", "h=20"]) == 2
    assert "20 x 20 film: 400 pixels exceed the limit of 100" in capsys.readouterr().err
    for defines, words in ((["-D", "w=0"], "film size 0 x 9"), (["-D", "spp=2000000000"], "sample_count"),
                           (["--spp", "1", "-D", "w=1"], None)):
        status = main(["-q", "render", str(path), "-o", str(out), *defines])
        err = capsys.readouterr().err
        if words is None:
            assert status == 0
        else:
            assert status == 2 and words in err and err.count("\n") == 1 and "Traceback" not in err


@pytest.mark.parametrize("kind", ["fifo", "/dev/zero"])
@pytest.mark.parametrize("where", ["shape", "include"])
def test_files_a_scene_names_are_never_opened_when_special(cr, tmp_path, kind, where):
    """A <shape type="ply"> naming a FIFO hung for ever, one naming /dev/zero grew to 5.5 GB in 30 s."""
    import os

    path = write_scene(tmp_path)
    special = tmp_path / ("special.ply" if where == "shape" else "special.xml")
    if kind == "fifo":
        os.mkfifo(special)
    else:
        special.symlink_to(kind)
    xml = path.read_text()
    if where == "shape":
        xml = xml.replace('value="cyl.ply"', f'value="{special.name}"')
    else:
        xml = xml.replace("<integrator", f'<include filename="{special.name}"/><integrator')
    path.write_text(xml)
    with pytest.raises(SceneError, match=rf"{special.name}.*not a regular file"):
        cr.load_file(path)
    from cdbrdf.render.scenefile import ply_unit_mm

    assert ply_unit_mm(special) is None  # the header reader never blocks or reads without end


def test_an_output_over_a_file_the_scene_reads_is_refused(cr, tmp_path, capsys):
    from cdbrdf.cli import main

    path = write_scene(tmp_path)
    env = tmp_path / "env.exr"
    mi.Bitmap(np.ones((4, 8, 3), np.float32)).write(str(env))
    path.write_text(path.read_text().replace("<integrator", '<emitter type="envmap"><string name="filename" '
                                             'value="env.exr"/></emitter><integrator'))
    before = env.read_bytes()
    assert main(["-q", "render", str(path), "-o", str(env), "-D", "spp=1"]) == 2
    err = capsys.readouterr().err
    assert "env.exr: is the input" in err and err.count("\n") == 1 and env.read_bytes() == before


def test_a_scene_without_integrator_is_one_line(cr, tmp_path, capsys):
    from cdbrdf.cli import main

    path = write_scene(tmp_path)
    path.write_text(path.read_text().replace('<integrator type="path"><integer name="max_depth" value="2"/>'
                                             '</integrator>', ""))
    assert main(["-q", "render", str(path), "-o", str(tmp_path / "o.exr")]) == 2
    err = capsys.readouterr().err
    assert "the scene has no integrator" in err and err.count("\n") == 1 and "Traceback" not in err


@pytest.mark.parametrize("scale", ["0.001", "0.0001", "0.05"])
def test_the_plugin_clamps_any_curvature_and_never_crashes(cr, tmp_path, scale):
    """A garment in metres under <scale value="0.001"/> without --units: 1000 x the curvature (a bus error
    was reported). Curvatures of any size, infinite or NaN give a finite image, clamped to the table's ends."""
    mesh = cylinder()
    k = mesh.attributes["curvature"]
    k[::7] = np.nan
    k[1::7] = 1e30
    k[2::7] = -np.inf
    path = write_scene(tmp_path, mesh=mesh, shape_extra=f'<transform name="to_world"><scale value="{scale}"/>'
                       "</transform>")
    xml = path.read_text().replace('<scale value="3"/>', f'<scale value="{3 * float(scale)!r}"/>')
    xml = xml.replace('origin="0, 0, 100"', f'origin="0, 0, {100 * float(scale)!r}"')
    path.write_text(xml)
    img = np.array(mi.render(cr.load_file(path), spp=4))
    assert np.all(np.isfinite(img)) and img[..., :3].max() > 0
    lo, hi = np.pi * (0.5 - 0.22), np.pi * (0.5 + 0.22)  # the kappa table's values at its ends
    assert lo * 0.99 <= apex(img) <= hi * 1.01


def test_plugin_errors_of_cdbrdf_load_dict_are_one_line(cr, tmp_path):
    with pytest.raises(SceneError) as exc:
        cr.load_dict({"type": "cdbrdf", "filename": str(tmp_path / "missing.h5")})
    msg = str(exc.value)
    assert "\n" not in msg and "Traceback" not in msg and "missing.h5' not found" in msg
    bsdf_file = tmp_path / "ibiza.bsdf"
    bsdf_file.write_bytes(b"tensor_file\0\x01\x00" + bytes(64))
    with pytest.raises(SceneError, match=r"ibiza\.bsdf: not an HDF5 file .*`cdbrdf import FILE -o OUT\.h5`"):
        cr.load_dict({"type": "cdbrdf", "filename": str(bsdf_file)})


def test_mitsubas_own_loader_says_the_checks_are_not_applied(cr, tmp_path, caplog):
    """Mitsuba gives a BSDF no shape: a plain load warns at the plug-in's set-up; cdbrdf's loader refuses."""
    path = write_scene(tmp_path, mesh=cylinder(uv=False))
    with caplog.at_level(logging.WARNING, logger="cdbrdf"):
        mi.load_file(str(path))
    assert "made by Mitsuba's own loader" in caplog.text and "UV coordinates" in caplog.text
    caplog.clear()
    with caplog.at_level(logging.WARNING, logger="cdbrdf"), pytest.raises(SceneError, match="UV coordinates"):
        cr.load_file(path)
    assert "own loader" not in caplog.text


def test_inline_bsdf_under_a_scaled_shape_loads_in_a_fresh_process(tmp_path):
    """A shape with a to_world scale and its cdbrdf BSDF inline, unnamed, seen by a perspective camera.

    The curvature factor of the scale was once given to a copy of the BSDF
    node appended after the scene's nodes, which made Mitsuba's loader crash
    the process (a bus error) on this scene; run in a child so that a crash
    fails this test instead of the suite.
    """
    import subprocess
    import sys

    from cdbrdf.mesh import SineSheet, sine_sheet_mesh, write_ply

    write_ply(tmp_path / "sheet.ply", sine_sheet_mesh(SineSheet(vertices_per_wavelength=8)))
    kappa_table().save(tmp_path / "t.h5")
    (tmp_path / "scene.xml").write_text("""<scene version="3.0.0">
  <integrator type="path"/>
  <sensor type="perspective">
    <transform name="to_world"><lookat origin="0, -60, 40" target="0, 0, 0" up="0, 0, 1"/></transform>
    <film type="hdrfilm"><integer name="width" value="16"/><integer name="height" value="12"/></film>
    <sampler type="independent"><integer name="sample_count" value="2"/></sampler>
  </sensor>
  <emitter type="directional"><vector name="direction" value="0, 0, -1"/></emitter>
  <shape type="ply"><string name="filename" value="sheet.ply"/>
    <transform name="to_world"><scale value="5"/></transform>
    <bsdf type="cdbrdf"><string name="filename" value="t.h5"/></bsdf>
  </shape>
</scene>
""")
    code = ("import sys, cdbrdf.render as cr, mitsuba as mi\n"
            "with cr.variant('llvm_ad_rgb'):\n"
            "    img = mi.render(cr.load_file(sys.argv[1]))\n"
            "    print(img.shape)\n")
    r = subprocess.run([sys.executable, "-c", code, str(tmp_path / "scene.xml")], capture_output=True, text=True,
                       timeout=300, cwd=tmp_path)
    assert r.returncode == 0, (r.returncode, r.stderr[-2000:])
    assert "(12, 16, 3)" in r.stdout


@pytest.mark.parametrize("defect", ["duplicate-attribute", "undefined-entity"])
def test_a_scene_that_is_not_well_formed_xml_is_refused_before_mitsuba_reads_it(cr, tmp_path, defect):
    """pugixml accepts both, so the include check was skipped and Mitsuba opened a FIFO the include named."""
    import os

    path = write_scene(tmp_path)
    os.mkfifo(tmp_path / "pipe.xml")
    xml = path.read_text()
    bad = '<integrator type="path" type="path"/>' if defect == "duplicate-attribute" else "<!-- &nbsp; -->&nbsp;"
    xml = xml.replace("<integrator", f'<include filename="pipe.xml"/>{bad}<integrator', 1)
    path.write_text(xml)
    with pytest.raises(SceneError, match=r"s\.xml: not well-formed XML"):
        cr.load_file(path)


@pytest.mark.parametrize("nested", [False, True])
def test_an_include_is_read_only_from_beside_the_including_file(cr, tmp_path, monkeypatch, nested):
    """Mitsuba's resolver found an include that is not beside the scene in the current folder (or the scene's)."""
    path = write_scene(tmp_path / "scene")
    elsewhere = tmp_path / "cwd"
    elsewhere.mkdir()
    (elsewhere / "inc.xml").write_text('<scene version="3.0.0"><shape type="sphere" id="from_cwd"/></scene>')
    monkeypatch.chdir(elsewhere)
    xml = path.read_text()
    if nested:  # scene -> sub/a.xml -> inc.xml, which exists only beside the scene (Mitsuba's second guess)
        (path.parent / "sub").mkdir()
        (path.parent / "sub" / "a.xml").write_text('<scene version="3.0.0"><include filename="inc.xml"/></scene>')
        (path.parent / "inc.xml").write_text('<scene version="3.0.0"><shape type="sphere" id="top"/></scene>')
        xml = xml.replace("<integrator", '<include filename="sub/a.xml"/><integrator', 1)
    else:
        xml = xml.replace("<integrator", '<include filename="inc.xml"/><integrator', 1)
    path.write_text(xml)
    with pytest.raises(SceneError, match=r"<include filename='inc\.xml'>: no such file beside"):
        cr.load_file(path)


def test_a_to_world_with_nan_is_one_line_naming_the_shape(cr, tmp_path):
    path = write_scene(tmp_path, shape_extra='<transform name="to_world"><scale value="nan"/></transform>')
    with pytest.raises(SceneError, match=r"to_world.*NaN or infinite"):
        cr.load_file(path)
