"""Directions in the local shading frame (see ``docs/conventions.md``).

z is the shading normal, x the material's reference tangent (the bending
direction of a measurement stand), y = z x x. theta is the elevation from the
normal and phi the azimuth from +x towards +y, both in degrees; both the view
and the light direction point away from the surface.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["direction_from_angles", "angles_from_direction", "angular_distance_deg"]


def direction_from_angles(theta_deg: ArrayLike, phi_deg: ArrayLike) -> NDArray[np.float64]:
    """Unit vectors ``(..., 3)`` from elevation and azimuth in degrees.

    Parameters
    ----------
    theta_deg
        Elevation from the normal (z), degrees.
    phi_deg
        Azimuth from +x towards +y, degrees.

    Returns
    -------
    numpy.ndarray
        Unit vectors, shape ``broadcast(theta, phi).shape + (3,)``.
    """
    t = np.radians(np.asarray(theta_deg, dtype=np.float64))
    p = np.radians(np.asarray(phi_deg, dtype=np.float64))
    t, p = np.broadcast_arrays(t, p)
    s = np.sin(t)
    return np.stack([s * np.cos(p), s * np.sin(p), np.cos(t)], axis=-1)


def angles_from_direction(v: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Elevation and azimuth in degrees (phi in [0, 360)) of vectors ``(..., 3)``.

    The vectors need not be normalised. phi is 0 along the normal.

    Parameters
    ----------
    v
        Directions in the local frame (z = normal), ``(..., 3)``.

    Returns
    -------
    theta_deg : numpy.ndarray
        Elevation from the normal, degrees, shape ``(...)``.
    phi_deg : numpy.ndarray
        Azimuth, degrees, in [0, 360).
    """
    v = np.asarray(v, dtype=np.float64)
    if v.shape[-1:] != (3,):
        raise ValueError(f"v: expected shape (..., 3), got {v.shape}")
    n = np.linalg.norm(v, axis=-1)
    with np.errstate(invalid="ignore", divide="ignore"):
        theta = np.degrees(np.arccos(np.clip(v[..., 2] / n, -1.0, 1.0)))
    phi = np.degrees(np.arctan2(v[..., 1], v[..., 0])) % 360.0
    phi = np.where(phi >= 360.0, 0.0, phi)
    return theta, phi


def angular_distance_deg(
    theta1_deg: ArrayLike, phi1_deg: ArrayLike, theta2_deg: ArrayLike, phi2_deg: ArrayLike
) -> NDArray[np.float64]:
    """Great-circle angle in degrees between two directions given as angles.

    Parameters
    ----------
    theta1_deg, phi1_deg, theta2_deg, phi2_deg
        Elevations and azimuths of the two directions, degrees (broadcast).

    Returns
    -------
    numpy.ndarray
        The angle, degrees, in [0, 180].
    """
    a = direction_from_angles(theta1_deg, phi1_deg)
    b = direction_from_angles(theta2_deg, phi2_deg)
    c = np.clip(np.sum(a * b, axis=-1), -1.0, 1.0)
    return np.degrees(np.arccos(c))
