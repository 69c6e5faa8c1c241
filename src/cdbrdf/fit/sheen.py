"""The analytic cloth baseline: Lambert plus the "Charlie" sheen lobe (Estevez & Kulla 2017, Filament's cloth).

    f = rho / pi + c_s D(theta_h) V(theta_l, theta_v)

- ``D(theta_h) = (2 + 1/alpha) sin(theta_h)^(1/alpha) / (2 pi)``: the
  "Charlie" distribution of Estevez & Kulla (2017), a sheen from fibres
  standing on the surface (``theta_h`` the angle of the half vector from the
  normal, ``alpha`` in (0, 1] the roughness);
- ``V = 1 / (4 (cos theta_l + cos theta_v - cos theta_l cos theta_v))``: the
  visibility term of Neubelt & Pettineo (2013), which Filament's cloth model
  uses with the Charlie distribution;
- ``rho`` the diffuse albedo, ``c_s`` the sheen colour (RGB, [0, 1]).

The model is isotropic and reciprocal. It is the baseline the physical models
are compared with (:mod:`cdbrdf.fit.models`): the standard analytic cloth
BRDF of real-time and production renderers, fitted the same way.

References
----------
A. C. Estevez, C. Kulla, "Production friendly microfacet sheen BRDF",
Sony Pictures Imageworks technical report, 2017.
D. Neubelt, M. Pettineo, "Crafting a next-gen material pipeline for The Order:
1886", SIGGRAPH 2013 course: Physically Based Shading in Theory and Practice.
R. Guy, M. Agopian, "Physically based rendering in Filament" (cloth model), 2018.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import OptionError

__all__ = ["SheenParams", "sheen_brdf"]

RGB = tuple[float, float, float]


@dataclass(frozen=True)
class SheenParams:
    """Parameters of the baseline (see the module's description).

    Attributes
    ----------
    diffuse_rgb
        Lambertian albedo ``rho``, [0, 1] per channel.
    sheen_rgb
        Sheen colour ``c_s``, [0, 1] per channel.
    roughness
        ``alpha`` of the Charlie distribution, in [0.02, 1].
    """

    diffuse_rgb: RGB = (0.5, 0.5, 0.5)
    sheen_rgb: RGB = (0.5, 0.5, 0.5)
    roughness: float = 0.5

    def __post_init__(self) -> None:
        for f in ("diffuse_rgb", "sheen_rgb"):
            a = np.asarray(getattr(self, f), dtype=np.float64)
            if a.shape != (3,) or not np.all(np.isfinite(a)) or np.any(a < 0) or np.any(a > 1):
                raise OptionError(f"{f}: expected three values in [0, 1], got {getattr(self, f)!r}")
            object.__setattr__(self, f, tuple(float(x) for x in a))
        r = self.roughness
        if not (isinstance(r, (int, float)) and math.isfinite(r) and 0.02 <= r <= 1.0):
            raise OptionError(f"roughness: must lie in [0.02, 1], got {r!r}")
        object.__setattr__(self, "roughness", float(r))

    def to_dict(self) -> dict[str, object]:
        """JSON-ready parameters.

        Returns
        -------
        dict
            The parameters by name (colours as lists).
        """
        return {"diffuse_rgb": list(self.diffuse_rgb), "sheen_rgb": list(self.sheen_rgb), "roughness": self.roughness}


def sheen_brdf(params: SheenParams, theta_v: ArrayLike, phi_v: ArrayLike, theta_l: ArrayLike,
               phi_l: ArrayLike) -> NDArray[np.float64]:
    """The baseline's BRDF at direction pairs.

    Parameters
    ----------
    params
        The baseline's parameters.
    theta_v, phi_v, theta_l, phi_l
        View and light elevations and azimuths, degrees (broadcast together).

    Returns
    -------
    numpy.ndarray
        The BRDF in sr^-1, ``broadcast shape + (3,)``.
    """
    tv, pv, tl, pl = np.broadcast_arrays(*(np.radians(np.asarray(a, dtype=np.float64))
                                           for a in (theta_v, phi_v, theta_l, phi_l)))
    cv, cl = np.cos(tv), np.cos(tl)
    sv, sl = np.sin(tv), np.sin(tl)
    hx = sv * np.cos(pv) + sl * np.cos(pl)
    hy = sv * np.sin(pv) + sl * np.sin(pl)
    hz = cv + cl
    norm = np.sqrt(hx * hx + hy * hy + hz * hz)
    cos_h = np.where(norm > 0, hz / np.where(norm > 0, norm, 1.0), 1.0)
    sin_h = np.sqrt(np.maximum(0.0, 1.0 - cos_h * cos_h))
    inv = 1.0 / params.roughness
    d = (2.0 + inv) * sin_h ** inv / (2.0 * math.pi)
    cv, cl = np.maximum(cv, 0.0), np.maximum(cl, 0.0)
    vis = 1.0 / (4.0 * np.maximum(cl + cv - cl * cv, 1e-6))
    lobe = (d * vis)[..., None]
    return np.asarray(params.diffuse_rgb) / math.pi + np.asarray(params.sheen_rgb) * lobe
