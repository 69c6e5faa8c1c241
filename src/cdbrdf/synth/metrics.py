"""Summary numbers of a cloth's appearance, used by the presets' targets.

All take a reflectance array whose last axis is linear Rec. 709 RGB.
``REC709_Y`` and ``luminance`` are :data:`cdbrdf.colour.LUMINANCE_WEIGHTS`
and :func:`cdbrdf.colour.luminance`, re-exported.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..colour import LUMINANCE_WEIGHTS as REC709_Y
from ..colour import luminance
from ..table import CDBRDF

__all__ = ["REC709_Y", "luminance", "chromaticity", "low_elevation_slice", "in_plane_luminance"]


def chromaticity(rgb: ArrayLike) -> NDArray[np.float64]:
    """rgb chromaticity ``(r, g, b) / (r + g + b)`` of the *mean* of ``rgb (..., 3)``."""
    m = np.asarray(rgb, dtype=np.float64).reshape(-1, 3).mean(axis=0)
    return m / m.sum()


def low_elevation_slice(table: CDBRDF, kappa: float, max_theta_deg: float = 30.0) -> NDArray[np.float64]:
    """Samples at one curvature with view and light elevations <= ``max_theta_deg``."""
    i = int(np.flatnonzero(np.isclose(table.kappa, kappa))[0])
    tl = table.theta_l <= max_theta_deg + 1e-9
    tv = table.theta_v <= max_theta_deg + 1e-9
    return np.asarray(table.values[i][:, tl][:, :, :, tv], dtype=np.float64)


def in_plane_luminance(table: CDBRDF, kappa: float, plane_phi_deg: float) -> float:
    """Mean luminance of the samples whose view and light lie in the plane at
    azimuth ``plane_phi_deg`` (azimuths ``phi`` and ``phi + 180``), all elevations."""
    i = int(np.flatnonzero(np.isclose(table.kappa, kappa))[0])
    az = [plane_phi_deg % 360.0, (plane_phi_deg + 180.0) % 360.0]
    il = [int(np.flatnonzero(np.isclose(table.phi_l, a))[0]) for a in az]
    iv = [int(np.flatnonzero(np.isclose(table.phi_v, a))[0]) for a in az]
    v = np.asarray(table.values[i], dtype=np.float64)[il][:, :, iv]
    return float(luminance(v).mean())
