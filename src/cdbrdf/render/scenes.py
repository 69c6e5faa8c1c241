"""Mitsuba scenes of a table: the built-in scenes and any prepared mesh, framed and lit, from a :class:`RenderSpec`.

The built-in scenes are the paper's sine sheet (:func:`sine_scene`) and a
cloth swatch laid in folds of known radii (:func:`swatch_scene`), both with
their analytic curvature; a user's mesh is :func:`mesh_scene`;
:func:`table_scene` picks the one of a spec's surface. Each takes one
:class:`~cdbrdf.render.spec.RenderSpec` (surface, camera, light, film,
curvature mode: checked when it was made) and the plug-in's mode. World
frame: z up, lengths in the mesh's unit (the curvature is in mm^-1 whatever
the unit: :func:`cdbrdf.mesh.prepare_mesh`); a mesh is turned upright by
:func:`cdbrdf.mesh.z_up_mesh`. The camera is framed by
:mod:`cdbrdf.render.camera`, the lights are those of
:mod:`cdbrdf.render.lighting`. Meshes go to Mitsuba in memory
(:func:`mitsuba_mesh`), the curvatures as vertex attributes.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from os import PathLike
from typing import Any

import numpy as np

from ..errors import MeshError, OptionError
from ..mesh import Mesh, MeshSurface, prepare_mesh, sine_sheet_mesh, swatch_mesh, to_z_up, z_up_mesh
from ..mesh.attributes import SHAPE_ATTRIBUTES, SHAPE_MESH_ATTRIBUTE, mitsuba_attribute
from .camera import FRAME_FILL, Camera, _subsample, look_at_point, perspective_camera
from .checks import check_scene
from .lighting import directional_light, environment_map, studio_environment
from .plugin import load_dict
from .spec import SCENES, RenderSpec, check_scene_name

__all__ = ["SCENES", "check_scene_name", "table_scene", "sine_scene", "swatch_scene", "mesh_scene",
           "mitsuba_mesh", "SHEET_FILL", "SWATCH_FILL"]

_LOG = logging.getLogger(__name__)

#: Share of the frame the sine sheet fills.
SHEET_FILL = 0.9

#: Share of the frame the swatch fills.
SWATCH_FILL = 0.85


def _bsdf_entry(table: Any, spec: RenderSpec, mode: str, scale: float) -> dict:
    return {"type": "cdbrdf", "table": table, "mode": mode, "curvature": spec.curvature.mitsuba_attribute,
            "scale": scale}


def _map_entry(mesh: Mesh) -> dict[str, Any]:
    """The plug-in's parameters of a prepared mesh's curvature map and UV scale (none without them)."""
    out: dict[str, Any] = {}
    if mesh.metadata.get("uv_scale") is not None:
        out["uv_scale"] = tuple(float(x) for x in mesh.metadata["uv_scale"])
    if mesh.metadata.get("curvature_map") is not None:
        out["curvature_map"] = mesh.metadata["curvature_map"]
        out["neighbourhood"] = float(mesh.metadata.get("neighbourhood_mm", 5.0))
    return out


def _lights(spec: RenderSpec, camera: Camera) -> tuple[list[dict], Any, bool]:
    """The spec's emitters: its directional lights, the environment map's pixels (or None), whether it is hidden."""
    sun = spec.light.resolve(spec.lighting, camera.azimuth_deg)
    lights = [] if sun is None else [directional_light(*sun)]
    env: Any = None if spec.light.envmap is None else environment_map(spec.light.envmap)
    if spec.backdrop:  # the studio's own sky, hidden behind a backdrop
        return lights, studio_environment(), True
    return lights, env, False


def _build(mesh: Mesh, table: Any, spec: RenderSpec, *, mode: str, scale: float, bsdf: Any, fill: float,
           to_world: Callable[[Any], Any] | None = None) -> Any:
    """The scene of a z-up ``mesh`` with the plug-in (or ``bsdf``), the spec's camera, lights and film."""
    import mitsuba as mi

    if bsdf is None:
        bsdf = _bsdf_entry(table, spec, mode, scale)
    if isinstance(bsdf, dict) and bsdf.get("type") == "cdbrdf":
        bsdf = {**_map_entry(mesh), **bsdf}
    camera = spec.resolved_camera()
    lights, envmap, hide_env = _lights(spec, camera)
    if not lights and envmap is None:
        raise OptionError("the scene needs a light: give a directional light or an environment map")
    kappa = mesh.attributes.get(spec.curvature.attribute)
    target = look_at_point(camera, mesh.vertices, to_world=to_world, normals=mesh.normals, curvature=kappa)
    if target is not None and isinstance(camera.look_at, str) and camera.look_at != "centre" and kappa is not None:
        i = int(np.argmin(np.linalg.norm(mesh.vertices - target, axis=1)))
        _LOG.info("look-at %s: vertex %d at %s (z-up world), curvature %.3g / mm", camera.look_at, i,
                  np.round(target, 3).tolist(), float(kappa[i]))
    w, h = spec.size
    d: dict[str, Any] = {
        "type": "scene",
        "integrator": {"type": "path", "max_depth": int(spec.max_depth), "hide_emitters": bool(hide_env)},
        "sensor": perspective_camera(mi, _subsample(mesh.vertices), w, h, camera=camera, spp=spec.spp,
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
    ``cdbrdf`` BSDF reads, :data:`cdbrdf.mesh.CURVATURE_MODES`), but the shape
    operator's three as the three-channel ``vertex_shape``
    (:mod:`cdbrdf.mesh.attributes`). Nothing is written to a file.

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
        out.add_attribute(mitsuba_attribute(key), 1, data)
    if shape:  # the shape operator as one three-channel attribute, as Mitsuba's PLY loader makes it
        three: Any = np.ascontiguousarray(np.stack([mesh.attributes[k] for k in SHAPE_ATTRIBUTES], axis=1),
                                          dtype=np.float32).ravel()
        out.add_attribute(SHAPE_MESH_ATTRIBUTE, 3, three)
    if bsdf is not None:
        out.set_bsdf(bsdf)
    return out


def _spec(spec: RenderSpec | None, kind: str, builder: str) -> RenderSpec:
    """``spec`` (default: the built-in surface's defaults), refused when its surface is not of ``kind``."""
    if spec is None:
        if kind == "mesh":
            raise OptionError(f"{builder}: give a RenderSpec whose surface is a mesh")
        spec = RenderSpec(surface=kind)
    if not isinstance(spec, RenderSpec):
        raise OptionError(f"spec: expected a cdbrdf.render.RenderSpec, got {type(spec).__name__:.40}")
    if spec.kind != kind:
        raise OptionError(f"{builder}: the spec's surface is a {spec.kind}; use {_BUILDERS[spec.kind]}")
    return spec


#: The scene builder of each kind of surface.
_BUILDERS = {"sine": "sine_scene", "swatch": "swatch_scene", "mesh": "mesh_scene"}


def table_scene(table: Any, spec: RenderSpec, *, mode: str = "cdbrdf", bsdf: Any = None, scale: float = 1.0) -> Any:
    """The scene of ``spec``'s surface (:func:`sine_scene`, :func:`swatch_scene` or :func:`mesh_scene`).

    Parameters
    ----------
    table
        A :class:`~cdbrdf.table.CDBRDF` or a file name.
    spec
        What to render (:class:`~cdbrdf.render.spec.RenderSpec`): the
        surface, camera, light, film and curvature mode.
    mode
        ``"cdbrdf"`` or ``"brdf"`` (the plug-in's mode).
    bsdf
        A BSDF dict or instance used instead of the plug-in (e.g. Mitsuba's
        ``diffuse`` for comparisons).
    scale
        Factor on the table's values (the plug-in's ``scale``).

    Returns
    -------
    mitsuba.Scene
        The scene, loaded in the active variant.
    """
    build = {"sine": sine_scene, "swatch": swatch_scene, "mesh": mesh_scene}[spec.kind]
    return build(table, spec, mode=mode, bsdf=bsdf, scale=scale)


def sine_scene(table: Any, spec: RenderSpec | None = None, *, mode: str = "cdbrdf", bsdf: Any = None,
               scale: float = 1.0) -> Any:
    """The paper's sine sheet under a directional light, seen by a perspective camera.

    The camera's defaults here: the view :data:`~cdbrdf.render.camera.DEFAULT_SINE_VIEW`
    (elevation 40 degrees, azimuth -90: looking along +y, across the
    corrugations) and a 40-degree lens; a look-at point in the sheet's
    coordinates (mm, centred on the origin). The light's direction is in
    the world frame, x the bending direction. ``curvature_mode`` ``"max"``
    and ``"directional"`` are identical on the sheet.

    Parameters
    ----------
    table, spec, mode, bsdf, scale
        As for :func:`table_scene`; ``spec``'s surface a :class:`~cdbrdf.mesh.SineSheet` (default ``RenderSpec()``).

    Returns
    -------
    mitsuba.Scene
        The sine sheet's scene, loaded in the active variant.
    """
    spec = _spec(spec, "sine", "sine_scene")
    return _build(sine_sheet_mesh(spec.surface), table, spec, mode=mode, scale=scale,  # type: ignore[arg-type]
                  bsdf=bsdf, fill=SHEET_FILL)


def swatch_scene(table: Any, spec: RenderSpec | None = None, *, mode: str = "cdbrdf", bsdf: Any = None,
                 scale: float = 1.0) -> Any:
    """A cloth swatch laid in folds of known radii (:class:`cdbrdf.mesh.Swatch`), in the studio.

    The swatch's curvature is analytic (:func:`cdbrdf.mesh.swatch_curvature`),
    so no fit is made. By default it is seen along its folds, a little from
    the side (:data:`~cdbrdf.render.camera.DEFAULT_SWATCH_VIEW`, a 40-degree
    lens, filling :data:`SWATCH_FILL` of the frame), under the studio
    lighting, whose key light (45 degrees above, 45 degrees to the camera's
    left) falls across the folds: every fold shows its lit flank, its crest
    and its shaded flank. A look-at point is in the swatch's coordinates (mm,
    centred on the origin, the flat cloth at z = 0).

    Parameters
    ----------
    table, spec, mode, bsdf, scale
        As for :func:`table_scene`; ``spec``'s surface a :class:`~cdbrdf.mesh.Swatch`
        (default ``RenderSpec(surface="swatch")``).

    Returns
    -------
    mitsuba.Scene
        The scene, loaded in the active variant.
    """
    spec = _spec(spec, "swatch", "swatch_scene")
    return _build(swatch_mesh(spec.surface), table, spec, mode=mode, scale=scale,  # type: ignore[arg-type]
                  bsdf=bsdf, fill=SWATCH_FILL)


def mesh_scene(table: Any, spec: RenderSpec, *, mode: str = "cdbrdf", bsdf: Any = None, scale: float = 1.0) -> Any:
    """A user's mesh with the CDBRDF, framed by the camera and lit (see the module's description).

    A mesh without the spec's curvature attribute (a file, or a
    :class:`~cdbrdf.mesh.Mesh` not prepared) goes through
    :func:`~cdbrdf.mesh.prepare_mesh` first, with the
    :class:`~cdbrdf.mesh.MeshSurface`'s unit, neighbourhood and frame. The
    camera's defaults here: :data:`~cdbrdf.render.camera.DEFAULT_MESH_VIEW`
    (the elevation is above the ground plane of the up axis) and a 30-degree
    lens; a look-at point is in the mesh's own coordinates and unit (before
    it is turned upright). The studio light's ``"auto"`` key is relative to
    the camera's azimuth.

    Parameters
    ----------
    table, spec, mode, bsdf, scale
        As for :func:`table_scene`; ``spec``'s surface a mesh (a file, a :class:`~cdbrdf.mesh.Mesh` or a
        :class:`~cdbrdf.mesh.MeshSurface`).

    Returns
    -------
    mitsuba.Scene
        The scene, loaded in the active variant.
    """
    spec = _spec(spec, "mesh", "mesh_scene")
    surface = spec.surface
    assert isinstance(surface, MeshSurface)
    mesh = surface.mesh
    if not isinstance(mesh, Mesh) or spec.curvature.attribute not in mesh.attributes:
        mesh = prepare_mesh(mesh, units=surface.units, neighbourhood_mm=surface.neighbourhood_mm,
                            frame=surface.frame, table=table if not isinstance(table, (str, PathLike)) else None)
    if mesh.uv is None:
        raise MeshError("mesh: no UV coordinates, so no anisotropy frame (dP/du) for the CDBRDF")
    world, axis, _ = z_up_mesh(mesh, surface.up)
    return _build(world, table, spec, mode=mode, scale=scale, bsdf=bsdf, fill=FRAME_FILL,
                  to_world=lambda p: to_z_up(p, axis))
