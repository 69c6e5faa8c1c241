"""The checks of a scene that uses the ``cdbrdf`` plug-in: frames, curvature attributes, wrappers, maps.

:func:`check_scene` refuses the shapes with a ``cdbrdf`` BSDF that cannot
define its frame or curvature, warns of an implausible curvature and gives
every map the camera's angle per pixel and its shape's UV scale; cdbrdf's
loaders (:func:`cdbrdf.render.load_dict`, :func:`cdbrdf.render.load_file`)
and the scene builders call it.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Iterator
from typing import Any

import numpy as np

from ..errors import SceneError
from ..mesh import CURVATURE_MODES
from ..mesh.attributes import SHAPE_MESH_ATTRIBUTE
from ._units import curvature_warning

__all__ = ["check_scene", "cdbrdf_shapes", "pixel_angle"]

_LOG = logging.getLogger(__name__)


def _children(obj: Any) -> list[tuple[str, Any]]:
    """The objects ``obj`` exposes to Mitsuba's traversal (e.g. the BSDFs inside ``twosided``)."""
    import mitsuba as mi

    found: list[tuple[str, Any]] = []

    class _Collect(mi.TraversalCallback):
        def put(self, name: str, value: Any, flags: Any) -> None:
            if isinstance(value, mi.Object):
                found.append((name, value))

    obj.traverse(_Collect())
    return found


def cdbrdf_shapes(scene: Any) -> Iterator[tuple[Any, Any, Any]]:
    """``(shape, bsdf, wrapper)`` for every shape whose BSDF is, or wraps, a ``cdbrdf`` BSDF.

    ``wrapper`` is the shape's own BSDF when the plug-in sits inside another
    BSDF (e.g. ``twosided``), else None.

    Parameters
    ----------
    scene : mitsuba.Scene
        A loaded scene.

    Yields
    ------
    tuple
        ``(shape, bsdf, wrapper)`` per shape.
    """
    from ._bsdf import bsdf_class

    cls = bsdf_class()
    for shape in scene.shapes():
        bsdf = shape.bsdf()
        if isinstance(bsdf, cls):
            yield shape, bsdf, None
        elif bsdf is not None:
            for _, child in _children(bsdf):
                if isinstance(child, cls):
                    yield shape, child, bsdf
                    break


def check_scene(scene: Any, *, curvature: bool = True) -> None:
    """Refuse shapes with a ``cdbrdf`` BSDF that cannot define its frame or curvature; warn of an implausible one.

    With ``curvature``, the curvature the renderer will see on those meshes
    is checked against the tables' kappa range and a warning is logged once
    when it is implausible, with the likely scene unit
    (:func:`cdbrdf.render._units.curvature_warning`).

    Parameters
    ----------
    scene : mitsuba.Scene
        A loaded scene.
    curvature
        Also check the curvature those meshes carry (the warning above).

    Raises
    ------
    SceneError
        (a ValueError) when such a shape is a mesh without UVs (no anisotropy
        frame), when the BSDF reads a curvature attribute the shape does not
        have (it would read as kappa = 0), or when the plug-in is wrapped in
        Mitsuba's ``twosided`` (its back side would mirror z without the
        curvature's change of sign; the plug-in is two-sided by itself).
    """
    import mitsuba as mi

    for shape, bsdf, wrapper in cdbrdf_shapes(scene):
        name = shape.id() or type(shape).__name__
        if wrapper is not None:
            raise SceneError(
                f"shape {name!r}: the cdbrdf BSDF is wrapped in {wrapper.class_name()}; the plug-in is "
                "two-sided by itself (seen from the back, kappa changes sign), while Mitsuba's twosided "
                "mirrors z and keeps kappa: remove the wrapper (cdbrdf.render.load_file does so itself)"
            )
        # Analytic shapes (sphere, disk, ...) have a UV parametrisation; meshes need UVs.
        if isinstance(shape, mi.Mesh) and not shape.has_vertex_texcoords():
            raise SceneError(
                f"shape {name!r}: the cdbrdf BSDF needs a mesh with UV coordinates, whose dP/du "
                "is the material's reference direction x; this shape has none, so it has no "
                "anisotropy frame (add UVs, e.g. along the bending direction)"
            )
        attr = bsdf.curvature_attribute
        if attr is not None and not shape.has_attribute(attr):
            written = {m.mitsuba_attribute for m in CURVATURE_MODES.values()}  # by `cdbrdf curvature`
            hint = "write it with `cdbrdf curvature`" if attr in written else "check the attribute name"
            raise SceneError(
                f"shape {name!r}: the cdbrdf BSDF reads the curvature from mesh attribute "
                f"{attr!r}, which the shape does not have ({hint}, or give the BSDF a constant "
                "curvature); without it the curvature would read as 0"
            )
        if getattr(bsdf, "surface", None) is not None and isinstance(shape, mi.Mesh) and attr is not None:
            if not shape.has_attribute(SHAPE_MESH_ATTRIBUTE):
                raise SceneError(
                    f"shape {name!r}: the cdbrdf BSDF's map adds to the mesh's shape operator, and the shape has no "
                    f"{SHAPE_MESH_ATTRIBUTE} (write the mesh with `cdbrdf curvature`, which stores it as shape_x, "
                    "shape_y, shape_z, or give the BSDF a constant curvature)")
    _attach_maps(scene)
    if not curvature:
        return
    shapes = [(shape, bsdf) for shape, bsdf, _ in cdbrdf_shapes(scene) if isinstance(shape, mi.Mesh)]
    msg = curvature_warning(shapes)
    if msg:
        _LOG.warning("%s", msg)


def pixel_angle(scene: Any) -> float:
    """The angle (radians) one pixel of the scene's first sensor spans at its centre; 0 for a sensor without a fov.

    Parameters
    ----------
    scene : mitsuba.Scene
        A loaded scene.

    Returns
    -------
    float
        ``2 tan(x_fov / 2) / width``.
    """
    import mitsuba as mi

    if not scene.sensors():
        return 0.0
    sensor = scene.sensors()[0]
    params = mi.traverse(sensor)
    if "x_fov" not in params:
        return 0.0
    fov = float(np.asarray(params["x_fov"], dtype=np.float64).reshape(-1)[0])
    width = int(sensor.film().crop_size()[0])
    return 2.0 * math.tan(math.radians(fov) / 2.0) / max(width, 1)


def _attach_maps(scene: Any) -> None:
    """Give every ``cdbrdf`` BSDF with a map the camera's angle per pixel and, unless given, its shape's UV scale."""
    import mitsuba as mi

    from ..mesh import detect_uv_scale

    angle = None
    for shape, bsdf, _ in cdbrdf_shapes(scene):
        m = getattr(bsdf, "surface", None)
        if m is None:
            continue
        if not m.pixel_angle_given:
            angle = pixel_angle(scene) if angle is None else angle
            m.pixel_angle = angle
        if m.uv_scale is None and isinstance(shape, mi.Mesh) and shape.has_vertex_texcoords():
            p = mi.traverse(shape)
            v = np.asarray(p["vertex_positions"], dtype=np.float64).reshape(-1, 3)
            f = np.asarray(p["faces"], dtype=np.int64).reshape(-1, 3)
            uv = np.asarray(p["vertex_texcoords"], dtype=np.float64).reshape(-1, 2)
            uvs = detect_uv_scale(v, f, uv, units=bsdf.units.mm_per_unit)
            m.set_uv_scale(uvs.pair)
            _LOG.info("shape %r: UV scale of %s: %s", shape.id(), m.name, uvs)
