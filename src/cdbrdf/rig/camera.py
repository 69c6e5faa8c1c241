"""The rig's camera and light, and what an ideal measurement of one photograph gives.

The camera is orthographic and looks at the stand's centre (the origin) from
the row's view direction from :data:`CAMERA_DISTANCE_MM` away; it is shifted
so that the centre falls on the middle of pixel ``(size // 2, size // 2)``.
Its image "up" is +z, or +y for a camera on the normal (:func:`camera_up`).
The light is directional, from the row's light direction.

:func:`camera_row` puts the cameras of many photographs side by side on one
film (one Mitsuba sensor), so that one launch renders them all. Each camera
is Mitsuba's own ``orthographic`` sensor at :func:`sensor_to_world`: the row
reads the affine map from film position to ray off that sensor and gives
every pixel exactly the ray it would give, at a fraction of the cost of
Mitsuba's ``batch`` sensor, whose generated code grows with the number of
cameras (17 ms of code generation per launch for 72 cameras).

:func:`expected_patch_value` integrates the table over the local directions
the N x N patch of that camera sees on the stand's face: the ideal
(noise-free, shadow-free) measurement the end-to-end tests compare with.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..frames import angles_from_direction, direction_from_angles
from ..measure.registration import camera_up
from ..measure.stands import Stand
from ..table import CDBRDF
from .stands import surface_hits

__all__ = ["CAMERA_DISTANCE_MM", "NEAR_CLIP_MM", "FAR_CLIP_MM", "camera_up", "sensor_to_world", "light_to_world",
           "camera_row", "expected_patch_value"]

#: Distance of the (orthographic) camera from the stand's centre, mm.
CAMERA_DISTANCE_MM = 60.0
#: The cameras' near and far clipping distances, mm.
NEAR_CLIP_MM = 1.0
FAR_CLIP_MM = 1000.0


def _up_for(d: NDArray) -> list[float]:
    """An up vector for the light's frame that is not parallel to ``d``."""
    return [0.0, 1.0, 0.0] if abs(d[1]) < 0.9 else [1.0, 0.0, 0.0]


def sensor_to_world(mi, v: NDArray, size: int, field_mm: float):  # noqa: ANN001, ANN201
    """The orthographic sensor's transform for a camera in direction ``v``, ``field_mm`` wide.

    ``mi`` is the :mod:`mitsuba` module (its variant set). The centre of
    pixel ``(size // 2, size // 2)`` lies on the optical axis, which passes
    through the stand's centre.
    """
    T = mi.ScalarTransform4f
    px = field_mm / size
    shift = (size // 2 + 0.5 - 0.5 * size) * px  # centre of pixel size//2 on the optical axis
    up = camera_up(v).tolist()
    return (
        T().look_at(origin=list(v * CAMERA_DISTANCE_MM), target=[0.0, 0.0, 0.0], up=up)
        @ T().translate([shift, shift, 0.0])
        @ T().scale([0.5 * field_mm, 0.5 * field_mm, 1.0])
    )


def light_to_world(mi, l: NDArray):  # noqa: ANN001, ANN201, E741
    """The directional light's transform for light arriving from direction ``l``."""
    T = mi.ScalarTransform4f
    return T().look_at(origin=[0.0, 0.0, 0.0], target=list(-l), up=_up_for(l))


def _ray_map(mi, views: Sequence[NDArray], size: int, field_mm: float) -> tuple[NDArray, ...]:  # noqa: ANN001
    """Per camera: the ray origin at film corner (0, 0), its change across the film in x and in y, the direction.

    Read off Mitsuba's ``orthographic`` sensor at :func:`sensor_to_world`, so
    the row's rays are that sensor's (origins on the near plane).
    """
    rows = []
    corners = mi.Point2f(mi.Float([0.0, 1.0, 0.0]), mi.Float([0.0, 0.0, 1.0]))
    for v in views:
        cam = mi.load_dict({"type": "orthographic", "to_world": sensor_to_world(mi, np.asarray(v), size, field_mm),
                            "near_clip": NEAR_CLIP_MM, "far_clip": FAR_CLIP_MM,
                            "film": {"type": "hdrfilm", "width": size, "height": size}})
        ray, _ = cam.sample_ray(mi.Float(0.0), mi.Float(0.0), corners, mi.Point2f(0.5, 0.5))
        o = np.stack([np.asarray(ray.o.x), np.asarray(ray.o.y), np.asarray(ray.o.z)], axis=-1)
        d = np.stack([np.asarray(ray.d.x), np.asarray(ray.d.y), np.asarray(ray.d.z)], axis=-1)
        rows.append((o[0], o[1] - o[0], o[2] - o[0], d[0]))
    return tuple(np.array([r[i] for r in rows], dtype=np.float64) for i in range(4))


def camera_row(mi, views: Sequence[NDArray], *, size: int, field_mm: float, spp: int):  # noqa: ANN001, ANN201
    """One Mitsuba sensor holding a camera per view direction, side by side on a ``size * n`` x ``size`` film.

    Camera ``i`` (the rig's orthographic camera for unit view direction
    ``views[i]``, :func:`sensor_to_world`) fills film columns ``i * size`` to
    ``(i + 1) * size``; each pixel is sampled ``spp`` times (stratified) and
    box-filtered, as the rig's photographs are. ``mi`` is the :mod:`mitsuba`
    module with its variant set.
    """
    import drjit as dr

    if not views:
        raise ValueError("views: a camera row needs at least one view direction")
    origin, d_u, d_v, direction = _ray_map(mi, views, size, field_mm)
    n = len(views)

    def vec(cls, a):  # noqa: ANN001, ANN202
        return cls(*(mi.Float(np.ascontiguousarray(a[:, i])) for i in range(3)))

    class CameraRow(mi.Sensor):
        """The rig's cameras side by side (see :func:`camera_row`)."""

        def __init__(self, props: Any) -> None:
            mi.Sensor.__init__(self, props)
            self.origin = vec(mi.Point3f, origin)
            self.d_u = vec(mi.Vector3f, d_u)
            self.d_v = vec(mi.Vector3f, d_v)
            self.direction = vec(mi.Vector3f, direction)

        def sample_ray(self, time: Any, sample1: Any, sample2: Any, sample3: Any,  # noqa: ARG002
                       active: Any = True) -> tuple[Any, Any]:
            x = sample2.x * n
            cam = mi.UInt32(dr.clip(dr.floor(x), 0, n - 1))
            u = x - mi.Float(cam)
            o = (dr.gather(mi.Point3f, self.origin, cam, active)
                 + u * dr.gather(mi.Vector3f, self.d_u, cam, active)
                 + sample2.y * dr.gather(mi.Vector3f, self.d_v, cam, active))
            ray = mi.Ray3f(o, dr.gather(mi.Vector3f, self.direction, cam, active), FAR_CLIP_MM - NEAR_CLIP_MM,
                           time, [])
            return ray, mi.Spectrum(1.0)

        def sample_ray_differential(self, time: Any, sample1: Any, sample2: Any, sample3: Any,
                                    active: Any = True) -> tuple[Any, Any]:
            ray, weight = self.sample_ray(time, sample1, sample2, sample3, active)
            return mi.RayDifferential3f(ray), weight

        def to_string(self) -> str:
            return f"CameraRow[cameras={n}, size={size}, field_mm={field_mm:g}]"

    props = mi.Properties("camera_row")
    props["film"] = mi.load_dict({"type": "hdrfilm", "width": size * n, "height": size,
                                  "rfilter": {"type": "box"}, "pixel_format": "rgb"})
    props["sampler"] = mi.load_dict({"type": "stratified", "sample_count": spp})
    return CameraRow(props)


def expected_patch_value(
    table: CDBRDF,
    stand: Stand,
    theta_v: float,
    phi_v: float,
    theta_l: float,
    phi_l: float,
    *,
    size: int = 64,
    field_mm: float = 2.0,
    n: int = 7,
    sub: int = 4,
) -> NDArray[np.float64]:
    """What an ideal (noise-free) measurement of one rig photograph gives.

    The N x N patch of the rig's camera covers a small area of the stand's
    face, over which the normal turns on a curved stand; the measurement
    therefore averages the table over nearby local directions. This
    integrates ``f(v_local, l_local, kappa) * cos(theta_l_local)`` over the
    patch (``sub x sub`` points per pixel, shadows ignored) and divides by
    ``cos(theta_l)`` at the centre, as :func:`cdbrdf.measure.measure` does.
    With a tiny field it tends to the table's own value at the grid node.

    Parameters
    ----------
    table
        The material the rig renders.
    stand
        The stand the photograph shows.
    theta_v, phi_v, theta_l, phi_l
        The row's view and light directions, degrees.
    size, field_mm
        The rig's image size (pixels) and field width at the stand (mm).
    n
        Patch size N, pixels.
    sub
        Integration points per pixel along each side.

    Returns
    -------
    numpy.ndarray
        ``(channels,)``.
    """
    v = direction_from_angles(theta_v, phi_v)
    light = direction_from_angles(theta_l, phi_l)
    up = camera_up(v)
    fwd = -v
    left = np.cross(up, fwd)
    left /= np.linalg.norm(left)
    cam_up = np.cross(fwd, left)
    px = field_mm / size
    k = n * sub
    off = (np.arange(k) + 0.5) / sub - 0.5 * n  # pixel units, centred on the patch
    a, b = np.meshgrid(off * px, off * px, indexing="ij")
    origins = a.reshape(-1, 1) * left + b.reshape(-1, 1) * cam_up
    _p, nrm, tx = surface_hits(stand, origins, v)
    ty = np.cross(nrm, tx)
    loc_v = np.stack([tx @ v, ty @ v, nrm @ v], axis=-1)
    loc_l = np.stack([tx @ light, ty @ light, nrm @ light], axis=-1)
    tv, pv = angles_from_direction(loc_v)
    tl, pl = angles_from_direction(loc_l)
    ok = (tv < 90.0) & (tl < 90.0)
    f = table.evaluate(np.minimum(tv, 90.0), pv, np.minimum(tl, 90.0), pl, stand.kappa)
    rad = np.where(ok[:, None], f * np.maximum(loc_l[:, 2], 0.0)[:, None], 0.0)
    return rad.mean(axis=0) / math.cos(math.radians(theta_l))
