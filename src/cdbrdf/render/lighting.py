"""The light of a rendered surface: the paper's directional light, a studio set-up, environment maps.

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
    background is a neutral backdrop (:func:`cdbrdf.render.picture.composite`).

A picture's light is one :class:`Light` record: the set-up, the direction
towards the directional (key) light, its irradiance and an environment map
(checked when the record is made; :meth:`Light.resolve` gives the light a
scene places).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from os import PathLike
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..errors import OptionError, SceneError
from ..frames import direction_from_angles
from ..ranges import Range

__all__ = ["DEFAULT_IRRADIANCE", "IRRADIANCE_RANGE", "LIGHT_THETA_RANGE_DEG", "LIGHTINGS", "PAPER_LIGHT",
           "STUDIO_KEY", "STUDIO_SKY", "Light", "directional_light", "studio_environment", "environment_map",
           "card_irradiance"]

#: Default irradiance of the directional light (W m^-2): white Lambertian -> radiance 1.
DEFAULT_IRRADIANCE = math.pi

#: Accepted irradiances of the directional light, W m^-2.
IRRADIANCE_RANGE = Range(0.0, 1e9, lo_open=True, unit="W/m^2")

#: Accepted elevations of the direction towards the light, from the up axis, degrees.
LIGHT_THETA_RANGE_DEG = Range(0.0, 90.0, hi_open=True, unit="degrees")

#: Lighting set-ups of mesh scenes (see the module's description).
LIGHTINGS: tuple[str, ...] = ("studio", "paper")

#: The paper's directional light: elevation from the up axis, azimuth from +x, degrees.
PAPER_LIGHT: tuple[float, float] = (45.0, 0.0)

#: The studio key light: elevation from the up axis, azimuth relative to the camera's, degrees.
STUDIO_KEY: tuple[float, float] = (45.0, -45.0)

#: Studio sky radiance at the zenith, at the horizon and below it, for a key of irradiance pi.
STUDIO_SKY: tuple[float, float, float] = (0.35, 0.25, 0.12)


def directional_light(theta_deg: float = 45.0, phi_deg: float = 0.0, irradiance: float = DEFAULT_IRRADIANCE) -> dict:
    """Mitsuba ``directional`` emitter dict for the direction towards the light (z-up world).

    Raises
    ------
    OptionError
        When ``theta_deg`` is not in [0, 90) degrees, ``phi_deg`` is not a
        finite number or ``irradiance`` is not a finite positive number.
    """
    theta_deg, phi_deg = _angles(theta_deg, phi_deg)
    irradiance = _irradiance(irradiance)
    # The world frame (z up) is the local frame of a horizontal surface: theta from +z, phi from +x towards +y.
    to_light = direction_from_angles(theta_deg, phi_deg).tolist()
    return {"type": "directional", "direction": [-c for c in to_light],
            "irradiance": {"type": "rgb", "value": float(irradiance)}}


def _number(name: str, v: Any) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)) or not math.isfinite(v):
        raise OptionError(f"{name}: expected a finite number, got {v!r:.40}")
    return float(v)


def _angles(theta_deg: Any, phi_deg: Any) -> tuple[float, float]:
    """The direction towards a light, checked: elevation in :data:`LIGHT_THETA_RANGE_DEG`, any finite azimuth."""
    theta, phi = _number("light theta", theta_deg), _number("light phi", phi_deg)
    if theta not in LIGHT_THETA_RANGE_DEG:
        r = LIGHT_THETA_RANGE_DEG
        raise OptionError(f"light theta: elevation must lie in [{r.lo:g}, {r.hi:g}) degrees, got {theta:g}")
    return theta, phi


def _irradiance(value: Any) -> float:
    """An irradiance, checked against :data:`IRRADIANCE_RANGE`."""
    return float(IRRADIANCE_RANGE.check("irradiance", _number("irradiance", value)))


@dataclass(frozen=True)
class Light:
    """The light of a picture (see the module's description).

    Parameters
    ----------
    lighting
        ``"paper"`` (one directional light) or ``"studio"`` (a key light and
        a soft sky) (:data:`LIGHTINGS`); None: the surface's default (paper
        for the sine sheet, studio for the swatch and a mesh).
    direction
        ``(theta_deg, phi_deg)``: the direction towards the directional (key)
        light, elevation from the up axis (in :data:`LIGHT_THETA_RANGE_DEG`)
        and azimuth from +x towards +y; ``"auto"``: the set-up's (paper:
        :data:`PAPER_LIGHT`; studio: :data:`STUDIO_KEY`, its azimuth
        relative to the camera's); None: no directional light.
    irradiance
        Of the directional light, W m^-2, in :data:`IRRADIANCE_RANGE` (pi: a
        white Lambertian surface facing it is just white at 0 EV).
    envmap
        An environment map file (.exr, .hdr): the swatch and meshes only;
        with the studio lighting instead of its sky.

    Raises
    ------
    OptionError
        For a value of the wrong kind or out of its range (one line, naming it).
    """

    lighting: str | None = None
    direction: tuple[float, float] | str | None = "auto"
    irradiance: float = DEFAULT_IRRADIANCE
    envmap: str | PathLike[str] | None = None

    def __post_init__(self) -> None:
        if self.lighting is not None and self.lighting not in LIGHTINGS:
            raise OptionError(f"lighting: {self.lighting!r:.40} is not one of {', '.join(LIGHTINGS)}")
        d = self.direction
        if isinstance(d, str):
            if d != "auto":
                raise OptionError(f"light: expected (theta, phi) in degrees, 'auto' or None, got {d!r:.40}")
        elif d is not None:
            try:
                theta, phi = d
            except (TypeError, ValueError):
                raise OptionError(f"light: expected (theta, phi) in degrees, 'auto' or None, got {d!r:.40}") from None
            object.__setattr__(self, "direction", _angles(theta, phi))
        object.__setattr__(self, "irradiance", _irradiance(self.irradiance))
        if self.envmap is not None and not isinstance(self.envmap, (str, PathLike)):
            raise OptionError(f"envmap: expected a file name, got {type(self.envmap).__name__}")

    def resolve(self, lighting: str, azimuth_deg: float) -> tuple[float, float, float] | None:
        """The directional light a scene places: ``(theta_deg, phi_deg, irradiance)``, or None.

        Parameters
        ----------
        lighting
            The set-up in use (:attr:`lighting`, or the surface's default).
        azimuth_deg
            The camera's azimuth (the studio key's is relative to it).

        Returns
        -------
        tuple or None
            The light, None without a directional light.
        """
        if self.direction is None:
            return None
        if isinstance(self.direction, str):  # "auto"
            theta, phi = PAPER_LIGHT if lighting == "paper" else (STUDIO_KEY[0], azimuth_deg + STUDIO_KEY[1])
            return (theta, phi, self.irradiance)
        return (self.direction[0], self.direction[1], self.irradiance)


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


def environment_map(path: str | PathLike[str]) -> NDArray[np.float32]:
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
            from .plugin import mitsuba_message

            raise SceneError(f"{p}: cannot be read as an environment map ({mitsuba_message(exc)})") from None
    px = px[..., None] if px.ndim == 2 else px
    if px.shape[-1] == 1:
        px = np.repeat(px, 3, axis=-1)
    if not np.all(np.isfinite(px[..., :3])):
        raise SceneError(f"{p}: the environment map holds NaN or infinite pixels")
    return np.ascontiguousarray(px[..., :3])


def card_irradiance(light: tuple[float, float, float] | None, environment: NDArray[np.floating] | None) -> float:
    """Irradiance (W m^-2) on a grey card facing the key light (or the zenith without one), for the exposure.

    Parameters
    ----------
    light
        ``(theta_deg, phi_deg, irradiance)`` of the directional light, or None.
    environment
        A latitude-longitude map as the scenes place it (rows from the
        zenith down, its +y the world's up), or None: its radiance over the
        card's hemisphere, cosine-weighted, is added.
    """
    n = np.array([0.0, 0.0, 1.0]) if light is None else direction_from_angles(light[0], light[1])
    e = 0.0 if light is None else float(light[2])
    if environment is not None:
        env = np.asarray(environment, dtype=np.float64)
        h, w = env.shape[:2]
        th = (np.arange(h) + 0.5) * math.pi / h
        ph = (np.arange(w) + 0.5) * 2 * math.pi / w
        T, P = np.meshgrid(th, ph, indexing="ij")
        # Mitsuba's envmap direction of a texel, turned by the scenes' 90 degrees about x: (x, y, z) -> (x, -z, y)
        d = np.stack([np.sin(T) * np.sin(P), np.sin(T) * np.cos(P), np.cos(T)], -1)
        cos = np.clip(d @ n, 0.0, None)
        lum = env[..., :3].mean(axis=-1) if env.ndim == 3 else env
        e += float((lum * cos * np.sin(T)).sum() * (math.pi / h) * (2 * math.pi / w))
    return e
