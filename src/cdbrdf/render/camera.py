"""The camera of a rendered surface: perspective, framing the object from an elevation and azimuth.

:func:`frame_camera` places it: looking at the object from an elevation above
the ground plane and an azimuth (from +x towards +y), at the distance at which
its projected vertices fill :data:`FRAME_FILL` of the frame's limiting side,
centred. World frame: z up.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..errors import OptionError
from ..frames import direction_from_angles

__all__ = ["FRAME_FILL", "DEFAULT_MESH_VIEW", "DEFAULT_SINE_VIEW", "FRAME_POINTS", "frame_camera",
           "perspective_camera"]

#: Share of the frame's limiting side that the framed object fills.
FRAME_FILL = 0.75

#: Default camera (elevation above the ground plane, azimuth) for meshes, degrees.
DEFAULT_MESH_VIEW: tuple[float, float] = (20.0, -65.0)

#: Default camera for the sine sheet, degrees.
DEFAULT_SINE_VIEW: tuple[float, float] = (40.0, -90.0)

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


def _subsample(v: NDArray[np.float64]) -> NDArray[np.float64]:
    if v.shape[0] <= FRAME_POINTS:
        return v
    idx = np.linspace(0, v.shape[0] - 1, FRAME_POINTS).astype(np.int64)
    extremes = np.r_[np.argmin(v, axis=0), np.argmax(v, axis=0)]
    return v[np.unique(np.r_[idx, extremes])]


def perspective_camera(mi: Any, points: NDArray[np.float64], width: int, height: int, *, elevation_deg: float,
            azimuth_deg: float, fov_deg: float, spp: int, fill: float = FRAME_FILL) -> dict:
    """Mitsuba ``perspective`` sensor dict framing ``points`` (:func:`frame_camera`); ``mi`` is :mod:`mitsuba`."""
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
