"""The camera of a rendered surface: a perspective lens framing the object, close-ups by zoom and look-at.

:class:`Camera` is what a user chooses: the direction it looks from
(``view``: elevation above the ground plane and azimuth from +x towards +y,
degrees), a magnification about the framed view (``zoom``), the lens's
field of view (``fov_deg``) and the point it looks at (``look_at``: a point
in the surface's own coordinates and unit, or a named anchor of
:data:`LOOK_AT_ANCHORS`). Defaults that depend on the surface (a sheet's
view, a mesh's lens) are filled by :meth:`Camera.resolved`.

How the picture follows (:func:`frame_camera`, :func:`perspective_camera`):

- **framing**: at zoom 1 the camera stands, in the view's direction, at
  the distance at which the object's projected vertices fill
  :data:`FRAME_FILL` of the frame's limiting side, centred. The field of
  view changes the perspective (wide: strong, narrow: flat), not how much of
  the frame the object fills;
- **look-at**: the camera keeps that direction and distance and turns
  towards the point, which is then at the centre of the picture;
- **zoom**: magnification about the picture's centre: the lens narrows to
  ``2 atan(tan(fov / 2) / zoom)``, the camera does not move, so zoom 2
  halves the visible extent (a close-up of the centre, with the same
  perspective) and zoom 0.5 doubles it.

World frame: z up, lengths in the surface's unit.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import OptionError
from ..frames import direction_from_angles

__all__ = ["FRAME_FILL", "DEFAULT_MESH_VIEW", "DEFAULT_SINE_VIEW", "DEFAULT_SWATCH_VIEW", "DEFAULT_MESH_FOV_DEG",
           "DEFAULT_SHEET_FOV_DEG", "FRAME_POINTS", "LOOK_AT_ANCHORS", "ZOOM_RANGE", "FOV_RANGE_DEG", "Camera",
           "frame_camera", "look_at_point", "perspective_camera"]

#: Share of the frame's limiting side that the framed object fills.
FRAME_FILL = 0.75

#: Default camera (elevation above the ground plane, azimuth) for meshes, degrees.
DEFAULT_MESH_VIEW: tuple[float, float] = (20.0, -65.0)

#: Default camera for the sine sheet, degrees.
DEFAULT_SINE_VIEW: tuple[float, float] = (40.0, -90.0)

#: Default camera for the swatch (:class:`cdbrdf.mesh.Swatch`): along its folds, a little from the side.
DEFAULT_SWATCH_VIEW: tuple[float, float] = (45.0, -75.0)

#: Default field of view of a mesh's lens (smaller side of the picture), degrees.
DEFAULT_MESH_FOV_DEG = 30.0

#: Default field of view for the sine sheet and the swatch, degrees.
DEFAULT_SHEET_FOV_DEG = 40.0

#: Vertices used to frame the camera (a subsample of larger meshes).
FRAME_POINTS = 20000

#: Accepted zoom factors (magnification about the framed view).
ZOOM_RANGE: tuple[float, float] = (0.05, 1000.0)

#: Accepted fields of view, degrees (exclusive of 0); also the widest lens a zoom below 1 may make.
FOV_RANGE_DEG: tuple[float, float] = (0.0, 160.0)

#: Named points :attr:`Camera.look_at` may give instead of coordinates.
LOOK_AT_ANCHORS: Mapping[str, str] = {
    "centre": "the centre of the object's bounding box",
    "fold": "the tightest fold: the vertex of largest |curvature| facing the camera",
    "crest": "the tightest convex fold (largest curvature) facing the camera",
    "valley": "the tightest concave fold (most negative curvature) facing the camera",
}

#: Share of the extreme curvature within which an anchor's candidates lie (the one nearest the centre wins).
_ANCHOR_TIE = 0.98


def _finite(name: str, value: Any) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise OptionError(f"{name}: expected a number, got {value!r:.40}") from None
    if not math.isfinite(v):
        raise OptionError(f"{name}: expected a finite number, got {value!r:.40}")
    return v


def _numbers(name: str, value: Any, n: int, example: str) -> tuple[float, ...]:
    if isinstance(value, str):
        raise OptionError(f"{name}: expected {n} numbers like {example}, got {value!r:.40}")
    try:
        items = list(value)
    except TypeError:
        raise OptionError(f"{name}: expected {n} numbers like {example}, got {value!r:.40}") from None
    if len(items) != n:
        raise OptionError(f"{name}: expected {n} numbers like {example}, got {len(items)}")
    return tuple(_finite(name, x) for x in items)


@dataclass(frozen=True)
class Camera:
    """A camera for :func:`cdbrdf.render.render_table` and the built-in scenes.

    Parameters
    ----------
    view
        ``(elevation_deg, azimuth_deg)``: elevation above the ground plane of
        the up axis (-90 to 90) and azimuth from +x towards +y, of the
        camera seen from the object; None: the surface's default
        (:data:`DEFAULT_SINE_VIEW`, :data:`DEFAULT_SWATCH_VIEW`,
        :data:`DEFAULT_MESH_VIEW`).
    zoom
        Magnification about the framed view, in :data:`ZOOM_RANGE`: 2 halves
        the visible extent (see the module's description).
    fov_deg
        Field of view of the lens along the picture's smaller side, degrees,
        in :data:`FOV_RANGE_DEG`; None: the surface's default
        (:data:`DEFAULT_SHEET_FOV_DEG`, :data:`DEFAULT_MESH_FOV_DEG`).
    look_at
        The point at the picture's centre: ``(x, y, z)`` in the surface's own
        coordinates and unit (a mesh file's, before it is turned upright),
        a name of :data:`LOOK_AT_ANCHORS`, or None (the framed object's
        centre).

    Raises
    ------
    OptionError
        For a value out of its range or of the wrong kind (one line, naming it).
    """

    view: tuple[float, float] | None = None
    zoom: float = 1.0
    fov_deg: float | None = None
    look_at: tuple[float, float, float] | str | None = None

    def __post_init__(self) -> None:
        if self.view is not None:
            elevation, azimuth = _numbers("view", self.view, 2, "(40, -90)")
            if not -90.0 <= elevation <= 90.0:
                raise OptionError(f"view: elevation {elevation:g} degrees is not in [-90, 90]")
            object.__setattr__(self, "view", (elevation, azimuth))
        zoom = _finite("zoom", self.zoom)
        if not ZOOM_RANGE[0] <= zoom <= ZOOM_RANGE[1]:
            raise OptionError(f"zoom: {zoom:g} is not in [{ZOOM_RANGE[0]:g}, {ZOOM_RANGE[1]:g}]")
        object.__setattr__(self, "zoom", zoom)
        if self.fov_deg is not None:
            fov = _finite("fov_deg", self.fov_deg)
            if not FOV_RANGE_DEG[0] < fov <= FOV_RANGE_DEG[1]:
                raise OptionError(f"fov_deg: {fov:g} degrees is not in ({FOV_RANGE_DEG[0]:g}, {FOV_RANGE_DEG[1]:g}]")
            object.__setattr__(self, "fov_deg", fov)
            _lens_deg(fov, zoom)  # a zoom below 1 must not widen the lens past the range
        if isinstance(self.look_at, str):
            if self.look_at not in LOOK_AT_ANCHORS:
                raise OptionError(f"look_at: {self.look_at!r:.40} is not a point (x, y, z) nor one of "
                                  f"{', '.join(LOOK_AT_ANCHORS)}")
        elif self.look_at is not None:
            object.__setattr__(self, "look_at", _numbers("look_at", self.look_at, 3, "(0, 10, -5)"))

    def resolved(self, *, view: tuple[float, float], fov_deg: float) -> Camera:
        """This camera with the surface's defaults filled in where it has None.

        Parameters
        ----------
        view
            The surface's default ``(elevation_deg, azimuth_deg)``.
        fov_deg
            The surface's default field of view, degrees.

        Returns
        -------
        Camera
            A camera whose ``view`` and ``fov_deg`` are set.
        """
        return Camera(view=self.view if self.view is not None else view,
                      fov_deg=self.fov_deg if self.fov_deg is not None else fov_deg,
                      zoom=self.zoom, look_at=self.look_at)

    @property
    def elevation_deg(self) -> float:
        """The view's elevation, degrees (the camera resolved: :meth:`resolved`)."""
        return self._view()[0]

    @property
    def azimuth_deg(self) -> float:
        """The view's azimuth, degrees (the camera resolved: :meth:`resolved`)."""
        return self._view()[1]

    def _view(self) -> tuple[float, float]:
        if self.view is None:
            raise OptionError("view: not set (resolve the camera against its surface first)")
        return self.view

    @property
    def lens_fov_deg(self) -> float:
        """The field of view the lens is set to, degrees: ``2 atan(tan(fov_deg / 2) / zoom)``.

        Raises
        ------
        OptionError
            When ``fov_deg`` is not set yet (:meth:`resolved`), or when a zoom
            below 1 widens the lens past :data:`FOV_RANGE_DEG`.
        """
        if self.fov_deg is None:
            raise OptionError("fov_deg: not set (resolve the camera against its surface first)")
        return _lens_deg(self.fov_deg, self.zoom)


def _lens_deg(fov_deg: float, zoom: float) -> float:
    """The lens's field of view for ``fov_deg`` at ``zoom``, refused past :data:`FOV_RANGE_DEG`."""
    lens = 2.0 * math.degrees(math.atan(math.tan(math.radians(fov_deg) / 2.0) / zoom))
    if lens > FOV_RANGE_DEG[1]:
        raise OptionError(f"zoom: {zoom:g} with a field of view of {fov_deg:g} degrees widens the lens to "
                          f"{lens:.0f} degrees (at most {FOV_RANGE_DEG[1]:g}); zoom in or narrow the fov")
    return lens


def _view_frame(elevation_deg: float, azimuth_deg: float) -> tuple[NDArray[np.float64], ...]:
    """Unit vectors: towards the camera, the picture's right and up."""
    d = direction_from_angles(90.0 - elevation_deg, azimuth_deg)
    up0 = np.array([0.0, 0.0, 1.0]) if abs(d[2]) < 0.999 else np.array([0.0, 1.0, 0.0])
    right = np.cross(up0, d)
    right /= np.linalg.norm(right)
    return d, right, np.cross(d, right)


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
    d, right, up = _view_frame(elevation_deg, azimuth_deg)
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


def look_at_point(
    camera: Camera,
    points: NDArray[np.float64],
    *,
    to_world: Callable[[NDArray[np.float64]], NDArray[np.float64]] | None = None,
    curvature: ArrayLike | None = None,
    normals: ArrayLike | None = None,
) -> NDArray[np.float64] | None:
    """The world point ``camera.look_at`` names, or None when it names none.

    Parameters
    ----------
    camera
        The camera, resolved (:meth:`Camera.resolved`).
    points
        The object's vertices in the z-up world frame, ``(n, 3)``.
    to_world
        Turns points of the surface's own coordinates into the world frame
        (a Y-up mesh's turn, :func:`cdbrdf.mesh.to_z_up`); default: they are
        the same.
    curvature
        The curvature the plug-in reads, per vertex (mm^-1): needed by the
        anchors ``fold``, ``crest`` and ``valley``.
    normals
        Vertex normals in the world frame: an anchor's vertex faces the
        camera (all vertices count without them, or when none faces it).

    Returns
    -------
    numpy.ndarray or None
        The point, ``(3,)``.

    Raises
    ------
    OptionError
        For a curvature anchor on a surface without curvature.
    """
    look = camera.look_at
    if look is None:
        return None
    p = np.asarray(points, dtype=np.float64)
    if not isinstance(look, str):
        q = np.asarray([look], dtype=np.float64)
        return np.asarray(to_world(q) if to_world is not None else q, dtype=np.float64)[0]
    centre = 0.5 * (p.min(0) + p.max(0))
    if look == "centre":
        return centre
    if curvature is None:
        raise OptionError(f"look_at: {look!r} needs the surface's curvature, which it does not have")
    k = np.nan_to_num(np.asarray(curvature, dtype=np.float64), nan=0.0)
    score = np.abs(k) if look == "fold" else (k if look == "crest" else -k)
    ok = np.ones(len(p), dtype=bool)
    if normals is not None and camera.view is not None:
        d = _view_frame(camera.elevation_deg, camera.azimuth_deg)[0]
        facing = np.asarray(normals, dtype=np.float64) @ d > 0.0
        ok = facing if facing.any() else ok
    best = float(score[ok].max())
    if best <= 0.0:
        raise OptionError(f"look_at: {look!r}: the surface has no {'bend' if look == 'fold' else look} "
                          "facing the camera")
    cand = np.flatnonzero(ok & (score >= _ANCHOR_TIE * best))
    return p[cand[np.argmin(np.linalg.norm(p[cand] - centre, axis=1))]]


def _subsample(v: NDArray[np.float64]) -> NDArray[np.float64]:
    if v.shape[0] <= FRAME_POINTS:
        return v
    idx = np.linspace(0, v.shape[0] - 1, FRAME_POINTS).astype(np.int64)
    extremes = np.r_[np.argmin(v, axis=0), np.argmax(v, axis=0)]
    return v[np.unique(np.r_[idx, extremes])]


def perspective_camera(mi: Any, points: NDArray[np.float64], width: int, height: int, *, camera: Camera,
                       spp: int, fill: float = FRAME_FILL, target: ArrayLike | None = None) -> dict:
    """Mitsuba ``perspective`` sensor dict for ``camera`` on ``points``; ``mi`` is :mod:`mitsuba`.

    Parameters
    ----------
    mi
        The :mod:`mitsuba` module (a variant set).
    points
        The object's vertices in the z-up world frame (a subsample will do).
    width, height
        Film size, pixels.
    camera
        The camera, resolved (:meth:`Camera.resolved`).
    spp
        Samples per pixel of the sensor's sampler.
    fill
        Share of the frame's limiting side the object fills at zoom 1.
    target
        The world point at the picture's centre (:func:`look_at_point`);
        None: the framed object's centre.

    Returns
    -------
    dict
        The sensor, framed as the module's description says.
    """
    lens = camera.lens_fov_deg
    p = np.asarray(points, dtype=np.float64)
    origin, aim, dist = frame_camera(p, width=width, height=height, elevation_deg=camera.elevation_deg,
                                     azimuth_deg=camera.azimuth_deg, fov_deg=float(camera.fov_deg or 0.0),
                                     fill=fill)
    d = (origin - aim) / dist
    if target is not None:
        aim = np.asarray(target, dtype=np.float64).reshape(3)
        origin = aim + dist * d
    up0 = [0.0, 0.0, 1.0] if abs(d[2]) < 0.999 else [0.0, 1.0, 0.0]
    extent = float(np.linalg.norm(p.max(0) - p.min(0)))
    # every point lies within `reach` of the point looked at (the framed view: the object's extent)
    reach = extent if target is None else extent + float(np.linalg.norm(aim - 0.5 * (p.min(0) + p.max(0))))
    near = max(dist - reach, dist * 1e-3)
    return {
        "type": "perspective",
        "fov": lens,
        "fov_axis": "smaller",
        "near_clip": near,
        "far_clip": dist + 2 * reach + near,
        "to_world": mi.ScalarTransform4f().look_at(origin=origin.tolist(), target=aim.tolist(), up=up0),
        "film": {"type": "hdrfilm", "width": int(width), "height": int(height), "pixel_format": "rgba",
                 "rfilter": {"type": "gaussian"}},
        "sampler": {"type": "independent", "sample_count": int(spp)},
    }
