"""Scenes for rendering a CDBRDF: the paper's sine sheet and any prepared mesh, framed and lit.

World frame: z up, lengths in the mesh's unit (the curvature is in mm^-1
whatever the unit: :func:`cdbrdf.mesh.prepare_mesh`); a mesh is turned
upright by :func:`cdbrdf.mesh.z_up_mesh`.

**Camera** (:func:`frame_camera`): perspective, looking at the object from
an elevation above the ground plane and an azimuth (from +x towards +y), at
the distance at which its projected vertices fill :data:`FRAME_FILL` of the
frame's limiting side, centred.

**Lighting** (:data:`LIGHTINGS`):

``"paper"``
    one directional light (Mitsuba's ``directional``), given by the direction
    *towards* it as elevation ``theta`` from the up axis and azimuth ``phi``
    from +x towards +y (degrees) and its irradiance (W m^-2 on a surface
    facing it); plus the user's environment map if any. The default
    irradiance is pi, so a white Lambertian surface (f = 1/pi) facing the
    light has radiance 1: with an exposure of 0 EV it is just white.
``"studio"``
    a key light (the same ``directional`` light; by default from 45 degrees
    above and 45 degrees to the camera's left) and an environment: the
    user's map, or a soft studio sky (:func:`studio_environment`: radiance
    0.35 at the zenith falling to 0.25 at the horizon and 0.12 below it,
    relative to the key's pi), which fills the shadows as a photo studio's
    walls do. The built-in sky is not seen by the camera: the picture's
    background is a neutral backdrop (:func:`composite`).

**Exposure** (:func:`exposure_from_render`): the exposure (EV) that maps the
99th percentile of the object's luminance (pixels it covers) to 0.85 of
display white (:func:`cdbrdf.colour.auto_exposure_ev`), but at most
:data:`MAX_AUTO_EV` stops above the physical exposure (at which a white
Lambertian surface facing a key light of the default irradiance pi is
white), so that a dark fabric such as denim stays dark instead of being
pushed to pastel.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable
from os import PathLike
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..errors import MeshError, OptionError, SceneError
from ..frames import direction_from_angles
from ..limits import MAX_SPP
from ..mesh import Mesh, SineSheet, check_up, prepare_mesh, sine_sheet_mesh, z_up_mesh

__all__ = [
    "DEFAULT_IRRADIANCE",
    "LIGHTINGS",
    "FRAME_FILL",
    "DEFAULT_MESH_VIEW",
    "DEFAULT_SINE_VIEW",
    "STUDIO_KEY",
    "BACKDROP",
    "MAX_AUTO_EV",
    "frame_camera",
    "directional_light",
    "studio_environment",
    "sine_scene",
    "mesh_scene",
    "mitsuba_mesh",
    "render_scene",
    "exposure_from_render",
    "composite",
]

_LOG = logging.getLogger(__name__)

#: Default irradiance of the directional light (W m^-2): white Lambertian -> radiance 1.
DEFAULT_IRRADIANCE = math.pi

#: Lighting set-ups of mesh scenes (see the module's description).
LIGHTINGS: tuple[str, ...] = ("studio", "paper")

#: Share of the frame's limiting side that the framed object fills.
FRAME_FILL = 0.75

#: Default camera (elevation above the ground plane, azimuth) for meshes, degrees.
DEFAULT_MESH_VIEW: tuple[float, float] = (20.0, -65.0)

#: Default camera for the sine sheet, degrees.
DEFAULT_SINE_VIEW: tuple[float, float] = (40.0, -90.0)

#: The studio key light: elevation from the up axis, azimuth relative to the camera's, degrees.
STUDIO_KEY: tuple[float, float] = (45.0, -45.0)

#: Studio sky radiance at the zenith, at the horizon and below it, for a key of irradiance pi.
STUDIO_SKY: tuple[float, float, float] = (0.35, 0.25, 0.12)

#: Display value (linear, before encoding) of the backdrop behind a studio render.
BACKDROP = 0.5

#: Largest automatic exposure, in stops above the physical one (see the module's description).
MAX_AUTO_EV = 2.0

#: Vertices used to frame the camera (a subsample of larger meshes).
FRAME_POINTS = 20000

def frame_camera(
    points: NDArray[np.float64], *, width: int, height: int, elevation_deg: float, azimuth_deg: float,
    fov_deg: float, fill: float = FRAME_FILL,
) -> tuple[NDArray[np.float64], NDArray[np.float64], float]:
    """Camera origin and target that frame ``points`` (z-up world) to fill ``fill`` of the frame.

    The view direction comes from the elevation (above the ground plane)
    and azimuth (from +x towards +y, of the camera seen from the object);
    the distance is the smallest at which every point projects inside
    ``fill`` of the half-frame, after centring the projected extent (two
    passes). Returns origin, target and the distance.
    """
    if not 0.0 < fill <= 1.0:
        raise OptionError(f"fill: expected (0, 1], got {fill}")
    d = direction_from_angles(90.0 - elevation_deg, azimuth_deg)
    up0 = np.array([0.0, 0.0, 1.0]) if abs(d[2]) < 0.999 else np.array([0.0, 1.0, 0.0])
    right = np.cross(up0, d)
    right /= np.linalg.norm(right)
    up = np.cross(d, right)
    t = math.tan(math.radians(fov_deg) / 2)
    t_x = t * max(1.0, width / height)
    t_y = t * max(1.0, height / width)
    p = np.asarray(points, dtype=np.float64)
    target = 0.5 * (p.min(0) + p.max(0))
    dist = 1.0
    for _ in range(4):
        q = p - target
        a, x, y = q @ d, q @ right, q @ up
        dist = float(np.max(a + np.maximum(np.abs(x) / (fill * t_x), np.abs(y) / (fill * t_y))))
        depth = np.maximum(dist - a, 1e-12 * max(dist, 1e-300))
        u, v = x / depth, y / depth
        mid_u, mid_v = 0.5 * (u.min() + u.max()), 0.5 * (v.min() + v.max())
        target = target + right * mid_u * dist + up * mid_v * dist
    q = p - target
    a, x, y = q @ d, q @ right, q @ up
    dist = float(np.max(a + np.maximum(np.abs(x) / (fill * t_x), np.abs(y) / (fill * t_y))))
    dist = max(dist, 1e-6 * float(np.linalg.norm(p.max(0) - p.min(0))), 1e-9)
    return target + dist * d, target, dist


def directional_light(theta_deg: float = 45.0, phi_deg: float = 0.0, irradiance: float = DEFAULT_IRRADIANCE) -> dict:
    """Mitsuba ``directional`` emitter dict for the direction towards the light (z-up world).

    Raises
    ------
    OptionError
        When ``theta_deg`` is not in [0, 90) degrees, ``phi_deg`` is not a
        finite number or ``irradiance`` is not a finite positive number.
    """
    def number(name: str, v: Any) -> float:
        if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)) \
                or not math.isfinite(v):
            raise OptionError(f"{name}: expected a finite number, got {v!r:.40}")
        return float(v)

    theta_deg = number("light theta", theta_deg)
    phi_deg = number("light phi", phi_deg)
    irradiance = number("irradiance", irradiance)
    if not (0.0 <= theta_deg < 90.0):
        raise OptionError(f"light theta: elevation must lie in [0, 90) degrees, got {theta_deg:g}")
    if not irradiance > 0:
        raise OptionError(f"irradiance: must be positive, got {irradiance:g}")
    # The world frame (z up) is the local frame of a horizontal surface: theta from +z, phi from +x towards +y.
    to_light = direction_from_angles(theta_deg, phi_deg).tolist()
    return {"type": "directional", "direction": [-c for c in to_light],
            "irradiance": {"type": "rgb", "value": float(irradiance)}}


def studio_environment(*, width: int = 64, scale: float = 1.0) -> NDArray[np.float32]:
    """The studio sky as a latitude-longitude map (rows from the zenith down), radiance per :data:`STUDIO_SKY`.

    Radiance ``zenith`` at the top falling as ``horizon + (zenith - horizon)
    sin(elevation)`` to the horizon, ``ground`` below it; times ``scale``.
    """
    top, horizon, ground = STUDIO_SKY
    h = width // 2
    elev = 90.0 - (np.arange(h) + 0.5) * 180.0 / h  # degrees above the horizon, row centres
    row = np.where(elev > 0, horizon + (top - horizon) * np.sin(np.radians(np.maximum(elev, 0))), ground)
    img = np.broadcast_to((row * scale)[:, None, None], (h, width, 3))
    return np.ascontiguousarray(img, dtype=np.float32)


def _camera(mi: Any, points: NDArray[np.float64], width: int, height: int, *, elevation_deg: float,
            azimuth_deg: float, fov_deg: float, spp: int, fill: float = FRAME_FILL) -> dict:
    """Perspective camera framing ``points`` from the given direction."""
    origin, target, dist = frame_camera(points, width=width, height=height, elevation_deg=elevation_deg,
                                        azimuth_deg=azimuth_deg, fov_deg=fov_deg, fill=fill)
    d = (origin - target) / dist
    up0 = [0.0, 0.0, 1.0] if abs(d[2]) < 0.999 else [0.0, 1.0, 0.0]
    extent = float(np.linalg.norm(points.max(0) - points.min(0)))
    near = max(dist - extent, dist * 1e-3)
    return {
        "type": "perspective",
        "fov": fov_deg,
        "fov_axis": "smaller",
        "near_clip": near,
        "far_clip": dist + 2 * extent + near,
        "to_world": mi.ScalarTransform4f().look_at(origin=origin.tolist(), target=target.tolist(), up=up0),
        "film": {"type": "hdrfilm", "width": int(width), "height": int(height), "pixel_format": "rgba",
                 "rfilter": {"type": "gaussian"}},
        "sampler": {"type": "independent", "sample_count": int(spp)},
    }


def _bsdf_entry(table: Any, mode: str, scale: float, curvature_mode: str = "max") -> dict:
    from ..mesh import ATTRIBUTES, CURVATURE_MODES

    if curvature_mode not in ATTRIBUTES:
        raise OptionError(f"curvature mode: {curvature_mode!r} is not one of {', '.join(CURVATURE_MODES)}")
    return {"type": "cdbrdf", "table": table, "mode": mode, "curvature": ATTRIBUTES[curvature_mode], "scale": scale}


def _subsample(v: NDArray[np.float64]) -> NDArray[np.float64]:
    if v.shape[0] <= FRAME_POINTS:
        return v
    idx = np.linspace(0, v.shape[0] - 1, FRAME_POINTS).astype(np.int64)
    extremes = np.r_[np.argmin(v, axis=0), np.argmax(v, axis=0)]
    return v[np.unique(np.r_[idx, extremes])]


def _build(mesh: Mesh, table: Any, *, mode: str, scale: float, size: tuple[int, int], spp: int,
           lights: list[dict], envmap: Any, hide_env: bool, max_depth: int, elevation_deg: float,
           azimuth_deg: float, fov_deg: float, bsdf: Any = None, curvature_mode: str = "max",
           fill: float = FRAME_FILL) -> Any:
    import mitsuba as mi

    from . import load_dict

    if bsdf is None:
        bsdf = _bsdf_entry(table, mode, scale, curvature_mode)
    if not lights and envmap is None:
        raise OptionError("the scene needs a light: give a directional light or an environment map")
    d: dict[str, Any] = {
        "type": "scene",
        "integrator": {"type": "path", "max_depth": int(max_depth), "hide_emitters": bool(hide_env)},
        "sensor": _camera(mi, _subsample(mesh.vertices), size[0], size[1], elevation_deg=elevation_deg,
                          azimuth_deg=azimuth_deg, fov_deg=fov_deg, spp=spp, fill=fill),
        "object": mitsuba_mesh(mesh, bsdf=load_dict(bsdf, check=False) if isinstance(bsdf, dict) else bsdf),
    }
    if envmap is not None:
        # the map's up (+y) is the world's up (+z)
        d["envmap"] = {"type": "envmap", "bitmap": mi.Bitmap(np.ascontiguousarray(envmap, dtype=np.float32)),
                       "to_world": mi.ScalarTransform4f().rotate([1.0, 0.0, 0.0], 90.0)}
    for i, light in enumerate(lights):
        d[f"light{i}"] = light
    return load_dict(d)


def mitsuba_mesh(mesh: Mesh, *, bsdf: Any = None, name: str = "object") -> Any:
    """A Mitsuba mesh built in memory from a :class:`~cdbrdf.mesh.Mesh` (the active variant's).

    Positions, faces, UVs and normals (computed by Mitsuba, smooth, where the
    mesh has none), and every per-vertex attribute ``NAME`` as the
    one-channel mesh attribute ``vertex_NAME`` (the curvatures: what the
    ``cdbrdf`` BSDF reads, :data:`cdbrdf.mesh.ATTRIBUTES`). Nothing is
    written to a file.
    """
    import mitsuba as mi

    n, m = mesh.n_vertices, int(mesh.faces.shape[0])
    if n == 0 or m == 0:
        raise MeshError("mesh: no triangles to render")
    out = mi.Mesh(name, vertex_count=n, face_count=m, has_vertex_normals=True,
                  has_vertex_texcoords=mesh.uv is not None)
    params = mi.traverse(out)
    params["vertex_positions"] = np.ascontiguousarray(mesh.vertices, dtype=np.float32).ravel()
    params["faces"] = np.ascontiguousarray(mesh.faces, dtype=np.uint32).ravel()
    if mesh.uv is not None:
        params["vertex_texcoords"] = np.ascontiguousarray(mesh.uv, dtype=np.float32).ravel()
    if mesh.normals is not None:
        params["vertex_normals"] = np.ascontiguousarray(mesh.normals, dtype=np.float32).ravel()
    params.update()
    if mesh.normals is None:
        out.recompute_vertex_normals()
    for key, values in mesh.attributes.items():
        data: Any = np.ascontiguousarray(values, dtype=np.float32)
        out.add_attribute(f"vertex_{key}", 1, data)
    if bsdf is not None:
        out.set_bsdf(bsdf)
    return out


def sine_scene(
    table: Any,
    *,
    mode: str = "cdbrdf",
    sheet: SineSheet = SineSheet(),
    light: tuple[float, float, float] | None = (45.0, 0.0, DEFAULT_IRRADIANCE),
    size: tuple[int, int] = (512, 384),
    spp: int = 64,
    max_depth: int = 3,
    scale: float = 1.0,
    elevation_deg: float = DEFAULT_SINE_VIEW[0],
    azimuth_deg: float = DEFAULT_SINE_VIEW[1],
    fov_deg: float = 40.0,
    bsdf: Any = None,
    curvature_mode: str = "max",
) -> Any:
    """The paper's sine sheet under a directional light, seen by a perspective camera.

    Parameters
    ----------
    table
        A :class:`~cdbrdf.table.CDBRDF` or a file name.
    mode
        ``"cdbrdf"`` or ``"brdf"`` (the plug-in's mode).
    sheet
        The sheet's geometry.
    light
        ``(theta_deg, phi_deg, irradiance)`` of the directional light
        (direction towards the light, world frame; x = bending direction).
    size
        Film ``(width, height)`` in pixels.
    spp, max_depth
        Samples per pixel and Mitsuba path length (2 = direct light only; the
        default 3 adds one inter-reflection between the corrugations).
    elevation_deg, azimuth_deg, fov_deg
        Camera elevation above the sheet, azimuth (from +x; -90 looks along
        +y, across the corrugations) and field of view (smaller axis).
    bsdf
        A BSDF dict or instance used instead of the plug-in (e.g. Mitsuba's
        ``diffuse`` for comparisons).
    curvature_mode
        ``"max"`` or ``"directional"`` (identical on the sheet).

    Returns
    -------
    mitsuba.Scene
    """
    lights = [directional_light(*light)] if light is not None else []
    return _build(sine_sheet_mesh(sheet), table, mode=mode, scale=scale, size=size, spp=spp,
                  lights=lights, envmap=None, hide_env=False, max_depth=max_depth, elevation_deg=elevation_deg,
                  azimuth_deg=azimuth_deg, fov_deg=fov_deg, bsdf=bsdf, curvature_mode=curvature_mode, fill=0.9)


def mesh_scene(
    table: Any,
    mesh: Mesh | str | PathLike[str],
    *,
    units: str | float | None = None,
    mode: str = "cdbrdf",
    curvature_mode: str = "max",
    lighting: str = "studio",
    light: tuple[float, float, float] | None | str = "auto",
    envmap: str | PathLike[str] | None = None,
    size: tuple[int, int] = (512, 384),
    spp: int = 64,
    max_depth: int = 3,
    scale: float = 1.0,
    elevation_deg: float = DEFAULT_MESH_VIEW[0],
    azimuth_deg: float = DEFAULT_MESH_VIEW[1],
    fov_deg: float = 30.0,
    up: str = "auto",
    fill: float = FRAME_FILL,
) -> Any:
    """A user mesh with the CDBRDF, framed by the camera and lit (see the module's description).

    Parameters
    ----------
    table
        A :class:`~cdbrdf.table.CDBRDF` or a file name.
    mesh
        A mesh file or a :class:`Mesh`; without a ``"curvature"`` attribute it
        goes through :func:`prepare_mesh` first (with ``units``).
    mode
        ``"cdbrdf"`` or ``"brdf"``.
    curvature_mode
        The curvature the BSDF reads: ``"max"`` (the paper's) or
        ``"directional"`` (normal curvature along the material's x).
    lighting
        ``"studio"`` or ``"paper"`` (:data:`LIGHTINGS`).
    light
        ``(theta_deg, phi_deg, irradiance)`` of the directional light (the
        key light in the studio), ``"auto"`` for the lighting's default
        (paper: (45, 0, pi); studio: :data:`STUDIO_KEY` relative to the
        camera, pi), or None for none.
    envmap
        An environment map (.exr/.hdr) instead of the studio sky, or beside
        the paper's light.
    up
        ``"auto"`` (:func:`detect_up`), ``"y"`` or ``"z"``.
    size, spp, max_depth, scale, elevation_deg, azimuth_deg, fov_deg
        As in :func:`sine_scene`; the elevation is above the ground plane of
        the up axis.
    fill
        Share of the frame's limiting side the object fills.
    """
    if lighting not in LIGHTINGS:
        raise OptionError(f"lighting: {lighting!r} is not one of {', '.join(LIGHTINGS)}")
    check_up(up)
    from ..mesh import MESH_ATTRIBUTES

    if curvature_mode not in MESH_ATTRIBUTES:
        raise OptionError(f"curvature mode: {curvature_mode!r} is not one of {', '.join(MESH_ATTRIBUTES)}")
    if not isinstance(mesh, Mesh) or MESH_ATTRIBUTES[curvature_mode] not in mesh.attributes:
        mesh = prepare_mesh(mesh, units=units, table=table if not isinstance(table, (str, PathLike)) else None)
    if mesh.uv is None:
        raise MeshError("mesh: no UV coordinates, so no anisotropy frame (dP/du) for the CDBRDF")
    world = z_up_mesh(mesh, up)[0]
    lights: list[dict] = []
    if light == "auto":
        if lighting == "paper":
            lights.append(directional_light(45.0, 0.0, DEFAULT_IRRADIANCE))
        else:
            lights.append(directional_light(STUDIO_KEY[0], azimuth_deg + STUDIO_KEY[1], DEFAULT_IRRADIANCE))
    elif light is not None:
        if isinstance(light, str):
            raise OptionError(f"light: expected (theta, phi, irradiance), 'auto' or None, got {light!r}")
        lights.append(directional_light(*light))
    env: Any = None if envmap is None else _environment_map(envmap)
    hide = False
    if lighting == "studio" and envmap is None:
        env, hide = studio_environment(), True
    return _build(world, table, mode=mode, scale=scale, size=size, spp=spp, lights=lights, envmap=env,
                  hide_env=hide, max_depth=max_depth, elevation_deg=elevation_deg, azimuth_deg=azimuth_deg,
                  fov_deg=fov_deg, curvature_mode=curvature_mode, fill=fill)


def _environment_map(path: str | PathLike[str]) -> NDArray[np.float32]:
    """The pixels of an environment map file (linear RGB), read by cdbrdf's image reader or Mitsuba's.

    OpenEXR goes through :func:`cdbrdf.images.read_image` (its checks, one
    :class:`~cdbrdf.errors.ImageError` line for a damaged file); other
    formats (Radiance ``.hdr``) through Mitsuba's bitmap reader, its errors
    as one :class:`~cdbrdf.errors.SceneError` line naming the file.
    """
    import mitsuba as mi

    from ..fsutil import check_regular
    from ..images import read_image

    p = Path(path)
    try:
        check_regular(p)
    except OSError as exc:
        raise SceneError(f"environment map {exc}") from None
    if p.suffix.lower() == ".exr":
        px = np.asarray(read_image(p)[0], dtype=np.float32)
    else:
        try:
            px = np.array(mi.Bitmap(str(p)).convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.Float32, False),
                          dtype=np.float32)
        except (RuntimeError, ValueError, OSError) as exc:  # Mitsuba's reader: std::exception subclasses
            from .scenefile import _message

            raise SceneError(f"{p}: cannot be read as an environment map ({_message(exc)})") from None
    px = px[..., None] if px.ndim == 2 else px
    if px.shape[-1] == 1:
        px = np.repeat(px, 3, axis=-1)
    if not np.all(np.isfinite(px[..., :3])):
        raise SceneError(f"{p}: the environment map holds NaN or infinite pixels")
    return np.ascontiguousarray(px[..., :3])


def render_scene(
    scene: Any,
    *,
    spp: int | None = None,
    seed: int = 0,
    passes: int | None = None,
    progress: Callable[[int, int], None] | None = None,
    alpha: bool = False,
) -> NDArray[np.float32]:
    """Render ``scene`` in passes; returns linear RGB ``(H, W, 3)`` float32 (RGBA with ``alpha``).

    Parameters
    ----------
    spp
        Samples per pixel (default: the sensor's).
    seed
        Seed of the first pass (pass ``i`` uses ``seed + i``).
    passes
        Number of passes (default: about 16 spp each); the image is their mean.
    progress
        Called as ``progress(samples_done, samples_total)`` after each pass.
    alpha
        Also return the coverage (1 where the object is seen; with the
        studio lighting's hidden sky, 0 on the background), as a 4th channel.

    Raises
    ------
    OptionError
        For ``spp`` (given, or the sensor's) outside 1 to :data:`cdbrdf.limits.MAX_SPP`.
    SceneError
        For a scene without integrator or sensor, or a film of size 0.
    LimitError
        For a film of more pixels than the ``render_pixels`` limit: checked on
        what is rendered, whatever made the scene.
    """
    import mitsuba as mi

    from .. import limits

    if scene.integrator() is None:
        raise SceneError("the scene has no integrator (add one, e.g. <integrator type=\"path\"/>)")
    if not scene.sensors():
        raise SceneError("the scene has no sensor to render from")
    sensor = scene.sensors()[0]
    total = int(spp if spp is not None else sensor.sampler().sample_count())
    if not 1 <= total <= MAX_SPP:
        raise OptionError(f"spp: {total:,} samples per pixel; a render takes 1 to {MAX_SPP:,}")
    w, h = (int(x) for x in sensor.film().crop_size())
    if w < 1 or h < 1:
        raise SceneError(f"the film's size is {w} x {h}; a render needs at least 1 x 1 pixels")
    limits.check("render_pixels", w * h, what=f"a {w} x {h} render")
    n = passes if passes is not None else max(1, math.ceil(total / 16))
    n = min(n, total)
    chunks = [total // n + (1 if i < total % n else 0) for i in range(n)]
    acc = None
    done = 0
    for i, c in enumerate(chunks):
        img = np.asarray(mi.render(scene, spp=c, seed=seed + i), dtype=np.float64)  # type: ignore[arg-type]
        acc = img * c if acc is None else acc + img * c
        done += c
        if progress is not None:
            progress(done, total)
    assert acc is not None
    out = (acc / total).astype(np.float32)
    if alpha:
        if out.shape[-1] >= 4:
            return out[..., :4]
        return np.concatenate([out[..., :3], np.ones(out.shape[:-1] + (1,), np.float32)], axis=-1)
    return out[..., :3]


def exposure_from_render(image: NDArray[np.floating], *, irradiance: float = DEFAULT_IRRADIANCE) -> float:
    """The exposure (EV) of a render: its object's 99th luminance percentile to 0.85 of white.

    ``image`` is RGB or RGBA; with alpha only the pixels the object covers
    (alpha >= 0.5) count. At most :data:`MAX_AUTO_EV` stops above the
    physical exposure for a key light of ``irradiance`` (``log2(pi /
    irradiance)``). See :func:`cdbrdf.colour.auto_exposure_ev`.
    """
    from ..colour import auto_exposure_ev

    if not (math.isfinite(irradiance) and irradiance > 0):
        raise OptionError(f"irradiance: must be positive, got {irradiance}")
    top = MAX_AUTO_EV + math.log2(DEFAULT_IRRADIANCE / irradiance)
    img = np.asarray(image, dtype=np.float64)
    if img.shape[-1] >= 4:
        cover = img[..., 3] >= 0.5
        if cover.any():
            return auto_exposure_ev(img[cover][:, :3], max_ev=top)
    return auto_exposure_ev(img[..., :3], max_ev=top)


def composite(image: NDArray[np.floating], *, exposure_ev: float, backdrop: float = BACKDROP) -> NDArray[np.float32]:
    """An RGBA render over a uniform backdrop that shows as ``backdrop`` (display value) at ``exposure_ev``.

    Returns linear RGB ``rgb + (1 - alpha) * backdrop * 2**-exposure_ev``; an
    RGB image is returned as it is.
    """
    img = np.asarray(image, dtype=np.float64)
    if img.shape[-1] < 4:
        return img.astype(np.float32)
    a = np.clip(img[..., 3:4], 0.0, 1.0)
    return (img[..., :3] + (1.0 - a) * backdrop * 2.0 ** (-exposure_ev)).astype(np.float32)
