"""Mitsuba scenes of a table: the built-in scenes (:data:`SCENES`) and any prepared mesh, framed and lit.

The built-in scenes are the paper's sine sheet (:func:`sine_scene`) and a
cloth swatch laid in folds of known radii (:func:`swatch_scene`), both with
their analytic curvature. World frame: z up, lengths in the mesh's unit (the
curvature is in mm^-1 whatever the unit: :func:`cdbrdf.mesh.prepare_mesh`);
a mesh is turned upright by :func:`cdbrdf.mesh.z_up_mesh`. The camera is a
:class:`cdbrdf.render.camera.Camera` (framing, zoom, look-at), the lights
those of :mod:`cdbrdf.render.lighting`. Meshes go to Mitsuba in memory
(:func:`mitsuba_mesh`), the curvatures as vertex attributes.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Mapping
from os import PathLike
from typing import Any

import numpy as np

from ..errors import MeshError, OptionError
from ..mesh import Mesh, SineSheet, Swatch, check_up, prepare_mesh, sine_sheet_mesh, swatch_mesh, to_z_up, z_up_mesh
from ..mesh.curvature_map import SHAPE_ATTRIBUTES, SHAPE_MESH_ATTRIBUTE
from .camera import (
    DEFAULT_MESH_FOV_DEG,
    DEFAULT_MESH_VIEW,
    DEFAULT_SHEET_FOV_DEG,
    DEFAULT_SINE_VIEW,
    DEFAULT_SWATCH_VIEW,
    FRAME_FILL,
    Camera,
    _subsample,
    look_at_point,
    perspective_camera,
)
from .lighting import DEFAULT_IRRADIANCE, LIGHTINGS, STUDIO_KEY, directional_light, environment_map, studio_environment
from .plugin import check_scene, load_dict

__all__ = ["SCENES", "check_scene_name", "sine_scene", "swatch_scene", "mesh_scene", "mitsuba_mesh"]

_LOG = logging.getLogger(__name__)

#: The built-in scenes, by name (``cdbrdf render --scene NAME``, ``render_table(table, NAME)``).
SCENES: Mapping[str, str] = {
    "sine": "the paper's sine sheet (Figs. 9-10) under its one directional light",
    "swatch": "a cloth swatch laid in folds of radius 20, 10, 5 and 3 mm, in the studio: a material at a glance",
}


def check_scene_name(name: object) -> str:
    """Refuse a name that is not one of :data:`SCENES`.

    Parameters
    ----------
    name
        The value given.

    Returns
    -------
    str
        The name.

    Raises
    ------
    OptionError
        For another value (the message lists the valid ones).
    """
    if not isinstance(name, str) or name not in SCENES:
        raise OptionError(f"scene: {name!r:.40} is not one of {', '.join(SCENES)}")
    return name

def _bsdf_entry(table: Any, mode: str, scale: float, curvature_mode: str = "max") -> dict:
    from ..mesh import ATTRIBUTES, CURVATURE_MODES

    if curvature_mode not in ATTRIBUTES:
        raise OptionError(f"curvature mode: {curvature_mode!r} is not one of {', '.join(CURVATURE_MODES)}")
    return {"type": "cdbrdf", "table": table, "mode": mode, "curvature": ATTRIBUTES[curvature_mode], "scale": scale}


def _map_entry(mesh: Mesh) -> dict[str, Any]:
    """The plug-in's parameters of a prepared mesh's curvature map and UV scale (none without them)."""
    out: dict[str, Any] = {}
    if mesh.metadata.get("uv_scale") is not None:
        out["uv_scale"] = tuple(float(x) for x in mesh.metadata["uv_scale"])
    if mesh.metadata.get("curvature_map") is not None:
        out["curvature_map"] = mesh.metadata["curvature_map"]
        out["neighbourhood"] = float(mesh.metadata.get("neighbourhood_mm", 5.0))
    return out


def _build(mesh: Mesh, table: Any, *, mode: str, scale: float, size: tuple[int, int], spp: int,
           lights: list[dict], envmap: Any, hide_env: bool, max_depth: int, camera: Camera, bsdf: Any = None,
           curvature_mode: str = "max", fill: float = FRAME_FILL,
           to_world: Callable[[Any], Any] | None = None) -> Any:
    import mitsuba as mi

    from ..mesh import MESH_ATTRIBUTES

    if bsdf is None:
        bsdf = _bsdf_entry(table, mode, scale, curvature_mode)
    if isinstance(bsdf, dict) and bsdf.get("type") == "cdbrdf":
        bsdf = {**_map_entry(mesh), **bsdf}
    if not lights and envmap is None:
        raise OptionError("the scene needs a light: give a directional light or an environment map")
    kappa = mesh.attributes.get(MESH_ATTRIBUTES.get(curvature_mode, ""))
    target = look_at_point(camera, mesh.vertices, to_world=to_world, normals=mesh.normals, curvature=kappa)
    if target is not None and isinstance(camera.look_at, str) and camera.look_at != "centre" and kappa is not None:
        i = int(np.argmin(np.linalg.norm(mesh.vertices - target, axis=1)))
        _LOG.info("look-at %s: vertex %d at %s (z-up world), curvature %.3g / mm", camera.look_at, i,
                  np.round(target, 3).tolist(), float(kappa[i]))
    d: dict[str, Any] = {
        "type": "scene",
        "integrator": {"type": "path", "max_depth": int(max_depth), "hide_emitters": bool(hide_env)},
        "sensor": perspective_camera(mi, _subsample(mesh.vertices), size[0], size[1], camera=camera, spp=spp,
                                     fill=fill, target=target),
        "object": mitsuba_mesh(mesh, bsdf=load_dict(bsdf, check=False) if isinstance(bsdf, dict) else bsdf),
    }
    if envmap is not None:
        # the map's up (+y) is the world's up (+z)
        d["envmap"] = {"type": "envmap", "bitmap": mi.Bitmap(np.ascontiguousarray(envmap, dtype=np.float32)),
                       "to_world": mi.ScalarTransform4f().rotate([1.0, 0.0, 0.0], 90.0)}
    for i, light in enumerate(lights):
        d[f"light{i}"] = light
    scene = load_dict(d, check=False)
    check_scene(scene, curvature=False)  # the mesh's curvature was checked when it was prepared
    return scene


def mitsuba_mesh(mesh: Mesh, *, bsdf: Any = None, name: str = "object") -> Any:
    """A Mitsuba mesh built in memory from a :class:`~cdbrdf.mesh.Mesh` (the active variant's).

    Positions, faces, UVs and normals (computed by Mitsuba, smooth, where the
    mesh has none), and every per-vertex attribute ``NAME`` as the
    one-channel mesh attribute ``vertex_NAME`` (the curvatures: what the
    ``cdbrdf`` BSDF reads, :data:`cdbrdf.mesh.ATTRIBUTES`), but the shape
    operator's three as the three-channel ``vertex_shape``. Nothing is
    written to a file.

    Parameters
    ----------
    mesh
        The mesh.
    bsdf
        Its BSDF (a Mitsuba BSDF object); None leaves Mitsuba's default.
    name
        The shape's id.

    Returns
    -------
    mitsuba.Mesh
        The shape.
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
    shape = all(k in mesh.attributes for k in SHAPE_ATTRIBUTES)
    for key, values in mesh.attributes.items():
        if shape and key in SHAPE_ATTRIBUTES:
            continue
        data: Any = np.ascontiguousarray(values, dtype=np.float32)
        out.add_attribute(f"vertex_{key}", 1, data)
    if shape:  # the shape operator as one three-channel attribute, as Mitsuba's PLY loader makes it
        three: Any = np.ascontiguousarray(np.stack([mesh.attributes[k] for k in SHAPE_ATTRIBUTES], axis=1),
                                          dtype=np.float32).ravel()
        out.add_attribute(SHAPE_MESH_ATTRIBUTE, 3, three)
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
    camera: Camera = Camera(),
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
    scale
        Factor on the table's values (the plug-in's ``scale``).
    camera
        The camera (:class:`~cdbrdf.render.camera.Camera`); its defaults
        here: the view :data:`~cdbrdf.render.camera.DEFAULT_SINE_VIEW`
        (elevation 40 degrees, azimuth -90: looking along +y, across the
        corrugations) and a 40-degree lens; a look-at point in the sheet's
        coordinates (mm, centred on the origin).
    bsdf
        A BSDF dict or instance used instead of the plug-in (e.g. Mitsuba's
        ``diffuse`` for comparisons).
    curvature_mode
        ``"max"`` or ``"directional"`` (identical on the sheet).

    Returns
    -------
    mitsuba.Scene
        The sine sheet's scene, loaded in the active variant.
    """
    lights = [directional_light(*light)] if light is not None else []
    cam = camera.resolved(view=DEFAULT_SINE_VIEW, fov_deg=DEFAULT_SHEET_FOV_DEG)
    return _build(sine_sheet_mesh(sheet), table, mode=mode, scale=scale, size=size, spp=spp,
                  lights=lights, envmap=None, hide_env=False, max_depth=max_depth, camera=cam, bsdf=bsdf,
                  curvature_mode=curvature_mode, fill=0.9)


def swatch_scene(
    table: Any,
    *,
    swatch: Swatch = Swatch(),
    camera: Camera = Camera(),
    **options: Any,
) -> Any:
    """A cloth swatch laid in folds of known radii (:class:`cdbrdf.mesh.Swatch`), in the studio.

    The swatch's curvature is analytic (:func:`cdbrdf.mesh.swatch_curvature`),
    so no fit is made. By default it is seen along its folds, a little from
    the side (:data:`~cdbrdf.render.camera.DEFAULT_SWATCH_VIEW`, a 40-degree
    lens, filling 85 % of the frame), under the studio lighting, whose key
    light (45 degrees above, 45 degrees to the camera's left) falls across
    the folds: every fold shows its lit flank, its crest and its shaded flank.

    Parameters
    ----------
    table
        A :class:`~cdbrdf.table.CDBRDF` or a file name.
    swatch
        The swatch's geometry.
    camera
        The camera; a look-at point in the swatch's coordinates (mm, centred
        on the origin, the flat cloth at z = 0).
    **options
        Those of :func:`mesh_scene` (``mode``, ``curvature_mode``,
        ``lighting``, ``light``, ``envmap``, ``size``, ``spp``,
        ``max_depth``, ``scale``, ``bsdf``), but not ``units``, ``up`` and ``fill``.

    Returns
    -------
    mitsuba.Scene
        The scene, loaded in the active variant.
    """
    bad = sorted(set(options) & {"units", "up", "fill"})
    if bad:
        raise OptionError(f"{bad[0]}: not an option of the swatch (it is in mm, z up and framed by its scene)")
    cam = camera.resolved(view=DEFAULT_SWATCH_VIEW, fov_deg=DEFAULT_SHEET_FOV_DEG)
    return mesh_scene(table, swatch_mesh(swatch), up="z", fill=SWATCH_FILL, camera=cam, **options)


#: Share of the frame the swatch fills.
SWATCH_FILL = 0.85


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
    camera: Camera = Camera(),
    up: str = "auto",
    fill: float = FRAME_FILL,
    bsdf: Any = None,
) -> Any:
    """A user mesh with the CDBRDF, framed by the camera and lit (see the module's description).

    Parameters
    ----------
    table
        A :class:`~cdbrdf.table.CDBRDF` or a file name.
    mesh
        A mesh file or a :class:`Mesh`; without a ``"curvature"`` attribute it
        goes through :func:`prepare_mesh` first (with ``units``).
    units
        The mesh's length unit (:func:`~cdbrdf.mesh.parse_units`); default: the file's, else mm.
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
    size, spp, max_depth, scale
        As in :func:`sine_scene`.
    camera
        The camera (:class:`~cdbrdf.render.camera.Camera`); its defaults
        here: :data:`~cdbrdf.render.camera.DEFAULT_MESH_VIEW` (the elevation
        is above the ground plane of the up axis) and a 30-degree lens; a
        look-at point in the mesh's own coordinates and unit (before it is
        turned upright).
    up
        ``"auto"`` (:func:`detect_up`), ``"y"`` or ``"z"``.
    fill
        Share of the frame's limiting side the object fills.
    bsdf
        A BSDF dict or instance used instead of the plug-in of ``table``.

    Returns
    -------
    mitsuba.Scene
        The scene, loaded in the active variant.
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
    world, axis, _ = z_up_mesh(mesh, up)
    cam = camera.resolved(view=DEFAULT_MESH_VIEW, fov_deg=DEFAULT_MESH_FOV_DEG)
    lights: list[dict] = []
    if light == "auto":
        if lighting == "paper":
            lights.append(directional_light(45.0, 0.0, DEFAULT_IRRADIANCE))
        else:
            lights.append(directional_light(STUDIO_KEY[0], cam.azimuth_deg + STUDIO_KEY[1], DEFAULT_IRRADIANCE))
    elif light is not None:
        if isinstance(light, str):
            raise OptionError(f"light: expected (theta, phi, irradiance), 'auto' or None, got {light!r}")
        lights.append(directional_light(*light))
    env: Any = None if envmap is None else environment_map(envmap)
    hide = False
    if lighting == "studio" and envmap is None:
        env, hide = studio_environment(), True
    return _build(world, table, mode=mode, scale=scale, size=size, spp=spp, lights=lights, envmap=env,
                  hide_env=hide, max_depth=max_depth, camera=cam, bsdf=bsdf, curvature_mode=curvature_mode,
                  fill=fill, to_world=lambda p: to_z_up(p, axis))
