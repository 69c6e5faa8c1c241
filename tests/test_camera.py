"""The camera record (cdbrdf.render.camera.Camera): validation, framing, zoom, field of view, look-at.

The geometry is checked on Mitsuba's own sensor (the rays it shoots through
the film), the pictures on tiny renders' alpha (64 x 64, 1-2 spp): a flat
square seen from straight above, whose corner, given as the look-at point,
lands at the picture's centre, in the mesh's own coordinates whether the
file is Z-up or Y-up.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import cdbrdf
from cdbrdf.render.camera import (
    DEFAULT_MESH_FOV_DEG,
    DEFAULT_MESH_VIEW,
    LOOK_AT_ANCHORS,
    Camera,
    frame_camera,
    look_at_point,
    perspective_camera,
)

from .render_helpers import needs_llvm


@pytest.fixture
def variant():
    import cdbrdf.render as cr

    cr.set_variant("llvm_ad_rgb")
    return cr


def white_table():
    g = cdbrdf.Grid(kappa=[0.0], theta_l=[0, 45, 75], phi_l=[0, 180], theta_v=[0, 45, 75], phi_v=[0, 180])
    return cdbrdf.CDBRDF(np.full(g.shape + (3,), 1.0 / np.pi), g, attrs={"quantity": "brdf"})


# -- the record ------------------------------------------------------------------------------
def test_camera_defaults_and_resolution():
    c = Camera()
    assert (c.view, c.zoom, c.fov_deg, c.look_at) == (None, 1.0, None, None)
    r = c.resolved(view=DEFAULT_MESH_VIEW, fov_deg=DEFAULT_MESH_FOV_DEG)
    assert (r.view, r.fov_deg, r.elevation_deg, r.azimuth_deg) == ((20.0, -65.0), 30.0, 20.0, -65.0)
    given = Camera(view=[10, 20], zoom=3, fov_deg=50, look_at=[1, 2, 3])  # lists and ints are normalised
    assert (given.view, given.zoom, given.fov_deg, given.look_at) == ((10.0, 20.0), 3.0, 50.0, (1.0, 2.0, 3.0))
    assert given.resolved(view=(40.0, -90.0), fov_deg=40.0) == given  # what is given is kept
    # the lens narrows with the zoom: tan(lens / 2) = tan(fov / 2) / zoom
    assert Camera(fov_deg=40.0, zoom=2.0).lens_fov_deg == pytest.approx(
        2 * math.degrees(math.atan(math.tan(math.radians(20.0)) / 2)))
    assert Camera(fov_deg=40.0).lens_fov_deg == pytest.approx(40.0)
    assert Camera(look_at="fold").look_at == "fold"
    with pytest.raises(ValueError, match="fov_deg: not set"):
        Camera().lens_fov_deg  # noqa: B018
    with pytest.raises(ValueError, match="view: not set"):
        Camera().azimuth_deg  # noqa: B018


@pytest.mark.parametrize("kwargs, message", [
    ({"view": (95.0, 0.0)}, "view: elevation 95 degrees is not in [-90, 90]"),
    ({"view": (40.0,)}, "view: expected 2 numbers like (40, -90), got 1"),
    ({"view": "40,-90"}, "view: expected 2 numbers"),
    ({"view": (40.0, math.nan)}, "view: expected a finite number"),
    ({"zoom": 0.0}, "zoom: 0 is not in [0.05, 1000]"),
    ({"zoom": math.inf}, "zoom: expected a finite number"),
    ({"zoom": "2x"}, "zoom: expected a number, got '2x'"),
    ({"fov_deg": 0.0}, "fov_deg: 0 degrees is not in (0, 160]"),
    ({"fov_deg": 179.0}, "fov_deg: 179 degrees is not in (0, 160]"),
    ({"fov_deg": 150.0, "zoom": 0.2}, "zoom: 0.2 with a field of view of 150 degrees widens the lens"),
    ({"look_at": "collar"}, "look_at: 'collar' is not a point (x, y, z) nor one of centre, fold, crest, valley"),
    ({"look_at": (1.0, 2.0)}, "look_at: expected 3 numbers like (0, 10, -5), got 2"),
    ({"look_at": (1.0, 2.0, math.nan)}, "look_at: expected a finite number"),
])
def test_camera_refuses_bad_values_in_one_line(kwargs, message):
    with pytest.raises(ValueError) as info:
        Camera(**kwargs)
    assert str(info.value).startswith(message) and "\n" not in str(info.value)


def test_zoom_below_one_is_checked_against_the_default_lens_when_resolved():
    c = Camera(zoom=0.06)  # fine alone: the lens is not known yet
    assert c.resolved(view=DEFAULT_MESH_VIEW, fov_deg=30.0).lens_fov_deg == pytest.approx(154.8, abs=0.1)
    with pytest.raises(ValueError, match="zoom: 0.06 with a field of view of 40 degrees widens the lens to 161"):
        c.resolved(view=DEFAULT_MESH_VIEW, fov_deg=40.0).lens_fov_deg  # noqa: B018


def test_anchors_registry_is_documented():
    assert list(LOOK_AT_ANCHORS) == ["centre", "fold", "crest", "valley"]
    assert all(isinstance(v, str) and v for v in LOOK_AT_ANCHORS.values())


# -- anchors -------------------------------------------------------------------------------------
def test_anchors_on_the_swatch_find_its_tightest_folds():
    """The swatch's folds have known radii: crest +1/3 mm^-1 (the 3 mm ridge), valley -1/3, facing up."""
    from cdbrdf.mesh import Swatch, swatch_curvature, swatch_mesh

    sw = Swatch(depth_mm=10.0)
    m = swatch_mesh(sw)
    k = m.attributes["curvature"]
    cam = Camera(view=(35.0, -80.0), look_at="crest")
    p = look_at_point(cam, m.vertices, curvature=k, normals=m.normals)
    assert swatch_curvature(p[0], sw) == pytest.approx(1 / 3.0)
    assert abs(p[1]) <= 0.5 + 1e-9  # the candidate nearest the centre: the middle row (rows 1 mm apart)
    p = look_at_point(Camera(view=(35.0, -80.0), look_at="valley"), m.vertices, curvature=k, normals=m.normals)
    assert swatch_curvature(p[0], sw) == pytest.approx(-1 / 3.0)
    p = look_at_point(Camera(view=(35.0, -80.0), look_at="fold"), m.vertices, curvature=k, normals=m.normals)
    assert abs(swatch_curvature(p[0], sw)) == pytest.approx(1 / 3.0)
    centre = look_at_point(Camera(look_at="centre"), m.vertices)
    np.testing.assert_allclose(centre, 0.5 * (m.vertices.min(0) + m.vertices.max(0)))
    assert look_at_point(Camera(), m.vertices) is None
    # coordinates go through the surface's turn to the world (a Y-up file: (x, y, z) -> (x, -z, y))
    from cdbrdf.mesh import to_z_up

    q = look_at_point(Camera(look_at=(1.0, 2.0, 3.0)), m.vertices, to_world=lambda v: to_z_up(v, "y"))
    np.testing.assert_allclose(q, [1.0, -3.0, 2.0])
    with pytest.raises(ValueError, match="look_at: 'fold' needs the surface's curvature"):
        look_at_point(Camera(look_at="fold"), m.vertices)
    with pytest.raises(ValueError, match="look_at: 'valley': the surface has no valley facing the camera"):
        look_at_point(Camera(view=(35.0, -80.0), look_at="valley"), m.vertices, curvature=np.abs(k))


def test_anchor_skips_folds_facing_away():
    """On a closed cylinder the tightest bend seen from +x is on the +x side, not behind."""
    t = np.linspace(0, 2 * np.pi, 73)[:-1]
    v = np.c_[np.cos(t), np.sin(t), np.zeros_like(t)] * 10.0
    n = v / 10.0
    k = np.where(np.cos(t) < 0, 0.2, 0.1)  # "tighter" behind the object
    p = look_at_point(Camera(view=(0.0, 0.0), look_at="crest"), v, curvature=k, normals=n)
    assert p[0] > 0  # facing the camera, which looks from +x
    p = look_at_point(Camera(view=(0.0, 0.0), look_at="crest"), v, curvature=k)  # without normals: all count
    assert p[0] < 0


# -- the sensor: look-at at the centre, zoom halves the extent, fov --------------------------------
def _sensor(points, camera, target=None, size=(64, 48)):
    import mitsuba as mi

    return mi.load_dict(perspective_camera(mi, points, size[0], size[1], camera=camera, spp=1, target=target))


def _ray(sensor, x, y):
    import mitsuba as mi

    ray, _ = sensor.sample_ray(0.0, 0.5, mi.Point2f(x, y), mi.Point2f(0.5, 0.5))
    return np.array(ray.o, dtype=np.float64).ravel(), np.array(ray.d, dtype=np.float64).ravel()


def _position(sensor):
    """Where the camera stands (the rays start on the near plane, not there)."""
    return np.array(sensor.world_transform().translation(), dtype=np.float64).ravel()


def _cross_plane(o, d, point, normal):
    t = np.dot(point - o, normal) / np.dot(d, normal)
    return o + t * d


@needs_llvm
def test_sensor_centre_ray_passes_through_the_look_at_and_zoom_halves_the_extent(variant):
    rng = np.random.default_rng(2)
    pts = rng.uniform([-40, -20, 0], [40, 30, 15], (500, 3))
    target = np.array([25.0, -10.0, 5.0])
    base = Camera(view=(30.0, -60.0), fov_deg=35.0)
    widths = {}
    for zoom in (1.0, 2.0, 4.0):
        cam = Camera(view=base.view, fov_deg=base.fov_deg, zoom=zoom)
        s = _sensor(pts, cam, target=target)
        o, d = _ray(s, 0.5, 0.5)
        # the centre ray passes through the look-at point
        off = np.linalg.norm(np.cross(target - o, d)) / np.linalg.norm(target - o)
        assert off < 1e-5, off
        # the visible extent across the picture, in the plane through the look-at facing the camera
        left = _cross_plane(*_ray(s, 0.0, 0.5), target, d)
        right = _cross_plane(*_ray(s, 1.0, 0.5), target, d)
        widths[zoom] = float(np.linalg.norm(right - left))
        if zoom == 1.0:
            origin = _position(s)
        np.testing.assert_allclose(_position(s), origin, rtol=1e-5)  # zoom does not move the camera
    assert widths[2.0] == pytest.approx(widths[1.0] / 2, rel=1e-4)
    assert widths[4.0] == pytest.approx(widths[1.0] / 4, rel=1e-4)
    # the look-at keeps the framed view's direction and distance
    framed = _sensor(pts, base)
    o0, d0 = _ray(framed, 0.5, 0.5)
    o1, d1 = _ray(_sensor(pts, base, target=target), 0.5, 0.5)
    np.testing.assert_allclose(d1, d0, atol=1e-5)
    origin0, _, dist = frame_camera(pts, width=64, height=48, elevation_deg=30.0, azimuth_deg=-60.0, fov_deg=35.0)
    np.testing.assert_allclose(_position(framed), origin0, rtol=1e-5)
    assert np.linalg.norm(_position(_sensor(pts, base, target=target)) - target) == pytest.approx(dist, rel=1e-5)


@needs_llvm
def test_sensor_lens_is_the_zoomed_fov(variant):
    pts = np.array([[-10.0, -10, 0], [10, 10, 2]])
    d = _sensor_dict(pts, Camera(view=(40.0, -90.0), fov_deg=40.0, zoom=3.0))
    assert d["fov"] == pytest.approx(2 * math.degrees(math.atan(math.tan(math.radians(20.0)) / 3)))
    assert d["fov_axis"] == "smaller"


def _sensor_dict(points, camera):
    import mitsuba as mi

    return perspective_camera(mi, points, 64, 64, camera=camera, spp=1)


# -- pictures ---------------------------------------------------------------------------------
def _square(up="z", n=11, half=50.0):
    """A flat square of side 2 * half, with zero curvature, written Z-up or Y-up."""
    from cdbrdf.mesh import Mesh

    x, y = np.meshgrid(np.linspace(-half, half, n), np.linspace(-half, half, n), indexing="ij")
    v = np.c_[x.ravel(), y.ravel(), np.zeros(x.size)]
    if up == "y":  # the same square in a Y-up file: world (x, y, z) is file (x, z, -y)
        v = np.c_[v[:, 0], v[:, 2], -v[:, 1]]
    q = (np.arange(n - 1)[:, None] * n + np.arange(n - 1)[None, :]).ravel()
    f = np.concatenate([np.c_[q, q + n, q + n + 1], np.c_[q, q + n + 1, q + 1]])
    zeros = np.zeros(x.size)
    return Mesh(v, f, None, np.c_[x.ravel(), y.ravel()] / (2 * half) + 0.5,
                {"curvature": zeros, "curvature_dir": zeros.copy()}, metadata={"up": up, "units": "mm"})


def _alpha(mesh, camera, up="z", size=(64, 64)):
    from cdbrdf.mesh import MeshSurface
    from cdbrdf.render import Light, RenderSpec
    from cdbrdf.render.picture import render_scene
    from cdbrdf.render.scenes import mesh_scene

    scene = mesh_scene(white_table(), RenderSpec(surface=MeshSurface(mesh, up=up), camera=camera,
                                                 light=Light(lighting="paper", direction=(0.0, 0.0)), size=size,
                                                 spp=2, max_depth=2))
    return render_scene(scene, alpha=True)[..., 3]


@needs_llvm
@pytest.mark.parametrize("up", ["z", "y"])
def test_look_at_a_corner_puts_it_at_the_picture_centre(variant, up):
    """Seen from straight above, the square's corner (its own coordinates) at the centre: one quadrant covered."""
    corner = (50.0, 50.0, 0.0) if up == "z" else (50.0, 0.0, -50.0)  # the same corner in the Y-up file
    a = _alpha(_square(up), Camera(view=(90.0, -90.0), look_at=corner), up=up)
    # looking down -z with +y up in the picture: the square (x, y < the corner) lies to the lower left
    quads = {"lower left": a[36:, :28], "lower right": a[36:, 36:], "upper left": a[:28, :28],
             "upper right": a[:28, 36:]}
    means = {k: float(v.mean()) for k, v in quads.items()}
    assert means["lower left"] > 0.99 and max(means["lower right"], means["upper left"], means["upper right"]) < 0.01
    # the edges cross at the centre: the covered part begins within a pixel of the middle
    row, col = a[48], a[:, 16]
    assert abs(int(np.argmax(row < 0.5)) - 32) <= 1 and abs(int(np.argmax(col > 0.5)) - 32) <= 1


@needs_llvm
def test_zoom_and_fov_change_the_visible_extent_as_promised(variant):
    """Zoom 0.5 doubles the visible extent (the square shows half as wide); another fov frames it the same."""
    sq = _square()

    def width(alpha):  # pixels the square covers along the middle row
        return float((alpha[32] > 0.5).sum())

    w1 = width(_alpha(sq, Camera(view=(90.0, -90.0))))
    assert w1 == pytest.approx(0.75 * 64, abs=1.5)  # framed: fills 75 % of the frame
    w_half = width(_alpha(sq, Camera(view=(90.0, -90.0), zoom=0.5)))
    assert w_half == pytest.approx(w1 / 2, abs=1.5)
    for fov in (15.0, 60.0):
        assert width(_alpha(sq, Camera(view=(90.0, -90.0), fov_deg=fov))) == pytest.approx(w1, abs=1.5)
    # zoom 2 about a look-at point: a 25 mm wide window around it (100 mm fill 75 % at zoom 1)
    a = _alpha(sq, Camera(view=(90.0, -90.0), zoom=2.0, look_at=(50.0, 0.0, 0.0)))
    assert width(a) == pytest.approx(32, abs=1.5)  # the right half of the picture is beyond the edge


@needs_llvm
def test_render_table_takes_the_camera(variant):
    from cdbrdf.render import RenderSpec, render_table

    pic = render_table(white_table(), RenderSpec(size=(24, 16), spp=1, camera=Camera(zoom=2.0, look_at="crest")))
    assert pic.images["cdbrdf"].shape == (16, 24, 4)
    with pytest.raises(ValueError, match="camera: expected a cdbrdf.render.Camera, got tuple"):
        RenderSpec(size=(24, 16), spp=1, camera=(40.0, -90.0))
