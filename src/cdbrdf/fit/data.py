"""What a fit is held against: a flat BRDF sampled at fixed direction pairs up to a largest elevation.

A :class:`FitData` holds direction pairs (degrees) and the measured BRDF at
them (sr^-1, RGB, no cosine), and whether the measurement is isotropic (then
the models, which have a weave direction, are compared by their mean over
turns of the fabric: :data:`ISOTROPIC_TURNS_DEG`). The pairs are a scrambled
Sobol sequence (deterministic for a seed) mapped to directions uniform over
the solid angle of the cap ``theta <= theta_max_deg`` (default 70 degrees),
for the light and the view alike.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..errors import OptionError

__all__ = ["FitData", "THETA_MAX_DEG", "ISOTROPIC_TURNS_DEG", "directions", "sample"]

#: Largest elevation of the light and the view in a fit and its error (degrees).
THETA_MAX_DEG = 70.0
#: Turns of the fabric (degrees about the normal) over which a model is averaged against an isotropic measurement.
ISOTROPIC_TURNS_DEG: tuple[float, ...] = (0.0, 45.0, 90.0, 135.0)


@dataclass(frozen=True, eq=False)
class FitData:
    """A flat BRDF at fixed direction pairs.

    Attributes
    ----------
    theta_v, phi_v, theta_l, phi_l
        ``(n,)`` degrees.
    values
        ``(n, 3)`` the measured BRDF, sr^-1 (or the relative unit of the source).
    isotropic
        Whether the measurement is isotropic (the models are then averaged
        over :data:`ISOTROPIC_TURNS_DEG`).
    """

    theta_v: NDArray[np.float64]
    phi_v: NDArray[np.float64]
    theta_l: NDArray[np.float64]
    phi_l: NDArray[np.float64]
    values: NDArray[np.float64]
    isotropic: bool = True

    @property
    def n(self) -> int:
        """Number of direction pairs."""
        return int(self.theta_v.size)

    def angles(self) -> tuple[NDArray[np.float64], ...]:
        """The direction pairs.

        Returns
        -------
        tuple of numpy.ndarray
            ``(theta_v, phi_v, theta_l, phi_l)``, degrees.
        """
        return self.theta_v, self.phi_v, self.theta_l, self.phi_l

    def subset(self, n: int) -> FitData:
        """The first ``n`` pairs (a Sobol sequence's prefix is itself well spread).

        Parameters
        ----------
        n
            Number of pairs.

        Returns
        -------
        FitData
            The first ``n`` pairs and their values.
        """
        k = min(int(n), self.n)
        return FitData(self.theta_v[:k], self.phi_v[:k], self.theta_l[:k], self.phi_l[:k], self.values[:k],
                       self.isotropic)


def directions(n: int, *, theta_max_deg: float = THETA_MAX_DEG, seed: int = 0) -> tuple[NDArray[np.float64], ...]:
    """``n`` direction pairs ``(theta_v, phi_v, theta_l, phi_l)`` in degrees, uniform over the cap's solid angle.

    Parameters
    ----------
    n
        Number of pairs (the first ``n`` of a power-of-two Sobol set).
    theta_max_deg
        Largest elevation, in (0, 90).
    seed
        Scrambling of the Sobol sequence.

    Returns
    -------
    tuple of numpy.ndarray
        Four ``(n,)`` arrays.
    """
    from scipy.stats import qmc

    if not (isinstance(n, int) and n >= 1):
        raise OptionError(f"n: expected a positive number of direction pairs, got {n!r}")
    if not (0.0 < theta_max_deg < 90.0):
        raise OptionError(f"theta_max_deg: must lie in (0, 90) degrees, got {theta_max_deg!r}")
    u = qmc.Sobol(d=4, scramble=True, seed=seed).random_base2(max(0, math.ceil(math.log2(n))))[:n]
    c0 = math.cos(math.radians(theta_max_deg))
    tv = np.degrees(np.arccos(1.0 - u[:, 0] * (1.0 - c0)))
    tl = np.degrees(np.arccos(1.0 - u[:, 2] * (1.0 - c0)))
    return tv, 360.0 * u[:, 1], tl, 360.0 * u[:, 3]


def sample(evaluate: Callable[..., Any], *, isotropic: bool, n: int = 256, theta_max_deg: float = THETA_MAX_DEG,
           seed: int = 0) -> FitData:
    """A measurement at ``n`` direction pairs (:func:`directions`).

    Parameters
    ----------
    evaluate
        ``evaluate(theta_v, phi_v, theta_l, phi_l)`` -> ``(n, 3)`` values, or
        a tuple whose first item they are (an importer's
        :attr:`~cdbrdf.importers.Source.evaluate`).
    isotropic
        Whether the measurement is isotropic.
    n, theta_max_deg, seed
        As :func:`directions`.

    Returns
    -------
    FitData
        The pairs and values.
    """
    tv, pv, tl, pl = directions(n, theta_max_deg=theta_max_deg, seed=seed)
    out = evaluate(tv, pv, tl, pl)
    values = np.asarray(out[0] if isinstance(out, tuple) else out, dtype=np.float64)
    if values.shape != (n, 3):
        raise OptionError(f"evaluate: expected RGB values ({n}, 3), got shape {values.shape}")
    if not np.all(np.isfinite(values)):
        raise OptionError("evaluate: returned NaN or infinite values")
    return FitData(tv, pv, tl, pl, np.maximum(values, 0.0), bool(isotropic))
