"""Where the fabric lies in a photograph: the camera model and the fabric's (u, v) on each stand.

A CD-BTF is measured texel by texel (:mod:`cdbrdf.measure.btf`), so every
photograph must be mapped to the fabric's own coordinates: ``(u, v)`` in mm of
the flat fabric, ``u`` along the stand's bending direction x (arc length on
the face), ``v`` along the cylinder's axis y (the conventions' local frame).
``stands.json`` says how, under ``registration`` (``docs/capture.md``):

``version``
    1 (a newer major version is refused).
``camera``
    ``"orthographic"``: the rig's camera. It looks at the stand's centre (the
    origin) along ``-v`` (``v`` the row's view direction); the image's up is
    +z, or +y for a view along the normal (:func:`camera_up`); columns grow
    along ``right = up x v`` and rows along ``down = -(v x right)``
    (:func:`image_axes`); the stand's centre is the centre of pixel ``(cx,
    cy)`` (the row's, else ``(width // 2, height // 2)``), and one pixel is
    ``pixel_mm`` (``stands.json``) wide at the stand.
``repeat_mm``
    Optional: ``[size_u, size_v]``, the fabric's weave repeat in mm (the
    period of the CD-BTF measured from the capture).
``stands``
    Per stand, the fabric's coordinates at the stand's centre:
    ``{"kappa": k, "u_mm": u0, "v_mm": v0}``; a point of the face at arc
    length ``s`` from the centre (along x) and ``y`` along the axis has
    ``(u, v) = (u0 + s, v0 + y)``.

A row of ``capture.csv`` may give its own ``u_mm`` and ``v_mm`` (both, or
neither: :data:`ROW_COLUMNS`, :func:`row_origin`): the fabric's ``(u, v)`` at
the stand's centre in that photograph, for a rig that moves the fabric over
the stand between photographs (a scan: on a curved stand each texel is then
taken near the crest, where the normal is the stand's).

:func:`face_points` maps fabric offsets to points of the face, :func:`face_hits`
maps camera rays back to the face (the simulated rig's camera uses the same
geometry); both are exact for the cylinder of the stand.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..errors import CaptureError
from .stands import KAPPA_TOL_PER_MM, Stand, json_number

__all__ = ["ROW_COLUMNS", "row_origin", "REGISTRATION_VERSION", "CAMERA_MODELS", "Registration",
           "parse_registration", "camera_up", "image_axes", "face_points", "face_hits"]

#: The ``registration`` format version this code writes (its major number must not exceed ours).
REGISTRATION_VERSION = 1
#: Camera models a registration may name.
CAMERA_MODELS: tuple[str, ...] = ("orthographic",)
#: The columns of ``capture.csv`` that give a photograph's own origin.
ROW_COLUMNS: tuple[str, ...] = ("u_mm", "v_mm")
#: Largest fabric coordinate accepted, mm.
_MAX_MM = 1e6


@dataclass(frozen=True)
class Registration:
    """The camera model and the fabric's ``(u, v)`` (mm) at each stand's centre.

    Attributes
    ----------
    camera
        One of :data:`CAMERA_MODELS`.
    origins
        ``kappa -> (u0_mm, v0_mm)``.
    repeat_mm
        The fabric's repeat ``(size_u, size_v)``, mm, when known.
    """

    camera: str = "orthographic"
    origins: dict[float, tuple[float, float]] = field(default_factory=dict)
    repeat_mm: tuple[float, float] | None = None

    def origin(self, kappa: float) -> tuple[float, float] | None:
        """The fabric's ``(u, v)`` at the centre of the stand of curvature ``kappa``, or None."""
        for k, uv in self.origins.items():
            if abs(k - kappa) <= KAPPA_TOL_PER_MM:
                return uv
        return None

    def to_dict(self) -> dict[str, Any]:
        """The registration as ``stands.json`` holds it.

        Returns
        -------
        dict
            JSON-ready.
        """
        doc: dict[str, Any] = {"version": REGISTRATION_VERSION, "camera": self.camera}
        if self.repeat_mm is not None:
            doc["repeat_mm"] = [float(x) for x in self.repeat_mm]
        doc["stands"] = [{"kappa": k, "u_mm": u, "v_mm": v} for k, (u, v) in sorted(self.origins.items())]
        return doc


def _num(where: str, key: str, v: object) -> float:
    x = json_number(where, key, v)
    if abs(x) > _MAX_MM:
        raise CaptureError(f"{where}: {key}: expected at most {_MAX_MM:g} mm, got {x:.6g}")
    return x


def parse_registration(doc: object, where: str) -> Registration:
    """The ``registration`` object of ``stands.json``.

    Parameters
    ----------
    doc
        Its value.
    where
        The file, for messages.

    Returns
    -------
    Registration
        The parsed registration.

    Raises
    ------
    CaptureError
        One line naming the file and the problem: not an object, an unknown
        key, a newer version, an unknown camera model, a stand entry that is
        malformed or given twice.
    """
    if not isinstance(doc, Mapping):
        raise CaptureError(f"{where}: registration: expected an object")
    unknown = sorted(set(doc) - {"version", "camera", "repeat_mm", "stands"})
    if unknown:
        raise CaptureError(f"{where}: registration: unknown keys {unknown[:5]}; "
                           "valid: camera, repeat_mm, stands, version")
    ver = doc.get("version", 1)
    if isinstance(ver, bool) or not isinstance(ver, int) or ver < 1:
        raise CaptureError(f"{where}: registration: version: expected a positive whole number, got {ver!r:.40}")
    if ver > REGISTRATION_VERSION:
        raise CaptureError(f"{where}: registration: version {ver} is newer than this cdbrdf reads "
                           f"({REGISTRATION_VERSION}); update cdbrdf")
    camera = doc.get("camera", "orthographic")
    if camera not in CAMERA_MODELS:
        raise CaptureError(f"{where}: registration: camera: {camera!r:.40} is not one of {', '.join(CAMERA_MODELS)}")
    repeat = doc.get("repeat_mm")
    if repeat is not None:
        if not isinstance(repeat, list) or len(repeat) != 2:
            raise CaptureError(f"{where}: registration: repeat_mm: expected [size_u, size_v] in mm")
        repeat = tuple(_num(where, "registration: repeat_mm", x) for x in repeat)
        if min(repeat) <= 0:
            raise CaptureError(f"{where}: registration: repeat_mm: sizes must be positive, got {list(repeat)}")
    items = doc.get("stands", [])
    if not isinstance(items, list):
        raise CaptureError(f"{where}: registration: stands: expected a list")
    origins: dict[float, tuple[float, float]] = {}
    for i, it in enumerate(items):
        if not isinstance(it, Mapping) or set(it) != {"kappa", "u_mm", "v_mm"}:
            raise CaptureError(f"{where}: registration: stand {i}: expected an object with kappa, u_mm, v_mm")
        k = _num(where, f"registration: stand {i} kappa", it["kappa"])
        if any(abs(k - o) <= KAPPA_TOL_PER_MM for o in origins):
            raise CaptureError(f"{where}: registration: stand {i}: a second entry for kappa {k:g}")
        origins[k] = (_num(where, f"registration: stand {i} u_mm", it["u_mm"]),
                      _num(where, f"registration: stand {i} v_mm", it["v_mm"]))
    return Registration(str(camera), origins, repeat)


def row_origin(where: str, rec: Mapping[str, str | None]) -> tuple[float, float] | None:
    """The ``(u_mm, v_mm)`` of a ``capture.csv`` record, or None when both are blank.

    Raises
    ------
    CaptureError
        When one is given without the other or is not a finite number (names ``where``).
    """
    text = [(rec.get(c) or "").strip() for c in ROW_COLUMNS]
    if not any(text):
        return None
    if not all(text):
        raise CaptureError(f"{where}: give both u_mm and v_mm, or neither")
    out = []
    for c, t in zip(ROW_COLUMNS, text):
        try:
            x = float(t)
        except ValueError:
            raise CaptureError(f"{where}: column {c!r}: {t!r:.40} is not a number") from None
        out.append(_num(where, c, x))
    return out[0], out[1]


def camera_up(v: NDArray) -> NDArray[np.float64]:
    """The image's up vector for a camera in direction ``v``: +z, or +y when ``v`` is the normal."""
    return np.array([0.0, 0.0, 1.0]) if math.hypot(v[0], v[1]) > 1e-6 else np.array([0.0, 1.0, 0.0])


def image_axes(v: NDArray) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The world directions along which the image's columns and rows grow, for view direction ``v``.

    Parameters
    ----------
    v
        ``(3,)`` unit direction towards the camera.

    Returns
    -------
    right, down : numpy.ndarray
        ``(3,)`` unit vectors, both perpendicular to ``v``.
    """
    v = np.asarray(v, dtype=np.float64)
    right = np.cross(camera_up(v), v)
    right /= np.linalg.norm(right)
    return right, -np.cross(v, right)


def face_points(stand: Stand, s_mm: NDArray, y_mm: NDArray) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Points and normals of the stand's face at arc length ``s`` (along x) and ``y`` (along the axis).

    Returns
    -------
    points, normals : numpy.ndarray
        ``s.shape + (3,)`` each, mm and unit vectors.
    """
    s, y = np.broadcast_arrays(np.asarray(s_mm, dtype=np.float64), np.asarray(y_mm, dtype=np.float64))
    if stand.kappa == 0:
        p = np.stack([s, y, np.zeros_like(s)], axis=-1)
        n = np.broadcast_to(np.array([0.0, 0.0, 1.0]), p.shape).copy()
        return p, n
    r = stand.radius_mm
    a = s / r
    sin, cos = np.sin(a), np.cos(a)
    if stand.kappa > 0:
        p = np.stack([r * sin, y, r * cos - r], axis=-1)
        n = np.stack([sin, np.zeros_like(s), cos], axis=-1)
    else:
        p = np.stack([r * sin, y, r - r * cos], axis=-1)
        n = np.stack([-sin, np.zeros_like(s), cos], axis=-1)
    return p, n


def face_hits(stand: Stand, origins: NDArray, v: NDArray) -> tuple[NDArray, NDArray, NDArray, NDArray]:
    """Where rays ``origins - t v`` (from the camera at t = -inf) meet the stand's face (its whole cylinder).

    Parameters
    ----------
    stand
        The stand (a cylinder of radius ``1 / |kappa|`` mm, or flat).
    origins
        ``(n, 3)`` points on the rays, mm.
    v
        ``(3,)`` the unit direction towards the camera.

    Returns
    -------
    points, normals, tangents, s_mm : numpy.ndarray
        Where the rays meet the face (mm), the normals there, the tangents x
        (dP/du) and the arc length from the centre along x (mm).
    """
    origins = np.asarray(origins, dtype=np.float64)
    ox, oz = origins[:, 0], origins[:, 2]
    vx, vz = float(v[0]), float(v[2])
    if stand.kappa == 0:
        t = oz / vz
        p = origins - t[:, None] * v
        n = np.tile([0.0, 0.0, 1.0], (len(p), 1))
        return p, n, np.tile([1.0, 0.0, 0.0], (len(p), 1)), p[:, 0].copy()
    r = stand.radius_mm
    cz = -r if stand.kappa > 0 else r  # the cylinder's axis (x = 0, z = cz)
    a = vx * vx + vz * vz
    b = -2.0 * (ox * vx + (oz - cz) * vz)
    c = ox * ox + (oz - cz) ** 2 - r * r
    disc = np.sqrt(np.maximum(b * b - 4 * a * c, 0.0))
    # the camera sits at t -> -inf: convex, the first hit (smaller root); concave, the
    # ray enters the circle above the trough and meets the face on the way out (larger root)
    t = (-b - disc) / (2 * a) if stand.kappa > 0 else (-b + disc) / (2 * a)
    p = origins - t[:, None] * v
    if stand.kappa > 0:
        n = np.stack([p[:, 0], np.zeros(len(p)), p[:, 2] + r], axis=-1) / r
    else:
        n = np.stack([-p[:, 0], np.zeros(len(p)), r - p[:, 2]], axis=-1) / r
    tx = np.stack([n[:, 2], np.zeros(len(p)), -n[:, 0]], axis=-1)
    s = r * np.arctan2(p[:, 0], r * n[:, 2])
    return p, n, tx, s
