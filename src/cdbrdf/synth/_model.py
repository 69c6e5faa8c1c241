"""What every fabric model shares: its tabulation on a grid and its directional albedo.

:class:`SampledModel` is the base of :class:`~cdbrdf.synth.cloth.ClothModel`
and :class:`~cdbrdf.synth.pile.PileModel`; a model supplies its BRDF for
unit direction pairs at one curvature (``_sample``), its metadata
(``attrs``), its ``evaluate`` and, optionally, a check of the curvatures it
can be bent to (``_check_kappa``).
"""

from __future__ import annotations

import logging
from abc import ABC, abstractmethod
from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import QueryError
from ..frames import direction_from_angles
from ..table import CDBRDF, Grid

__all__ = ["SampledModel"]

log = logging.getLogger(__name__)


class SampledModel(ABC):
    """Tabulation and albedo of a fabric model (an abstract base; see the module's description)."""

    params: Any

    @abstractmethod
    def _sample(self, v: NDArray[np.float64], l: NDArray[np.float64], kappa: float) -> NDArray[np.float64]:
        """BRDF ``(n, 3)`` for unit direction pairs ``v``, ``l`` ``(n, 3)`` at one curvature (mm^-1)."""

    def _check_kappa(self, kappa: float) -> None:  # noqa: B027 (a hook: every curvature is fine by default)
        """Raise for a curvature the model cannot be bent to (none, by default)."""

    @abstractmethod
    def attrs(self) -> dict[str, Any]:
        """Table metadata: quantity, material, model and its parameters."""

    @abstractmethod
    def evaluate(self, theta_v: ArrayLike, phi_v: ArrayLike, theta_l: ArrayLike, phi_l: ArrayLike,
                 kappa: ArrayLike = 0.0) -> NDArray[np.float64]:
        """The BRDF at directions in degrees and a curvature in mm^-1 (broadcast), ``(..., 3)``."""

    @staticmethod
    def _by_kappa(pairs: Callable[[NDArray[np.float64], NDArray[np.float64], float], NDArray[np.float64]],
                  width: int, theta_v: ArrayLike, phi_v: ArrayLike, theta_l: ArrayLike, phi_l: ArrayLike,
                  kappa: ArrayLike) -> NDArray[np.float64]:
        """``pairs(v, l, kappa)`` (``(n, width)`` per curvature) at broadcast angles (degrees) and curvatures.

        The one query rule of the models' ``evaluate``: every argument finite,
        elevations in [0, 90] degrees (else :class:`~cdbrdf.errors.QueryError`),
        azimuths reduced to [0, 360) first (equal directions give equal values).
        Returns ``broadcast shape + (width,)``.
        """
        arrs = np.broadcast_arrays(*(np.asarray(a, dtype=np.float64) for a in (theta_v, phi_v, theta_l, phi_l, kappa)))
        shape = arrs[0].shape
        tv, pv, tl, pl, kk = (a.reshape(-1) for a in arrs)
        for name, a in (("theta_v", tv), ("phi_v", pv), ("theta_l", tl), ("phi_l", pl), ("kappa", kk)):
            if not np.all(np.isfinite(a)):
                raise QueryError(f"{name}: must be finite")
        for name, a in (("theta_v", tv), ("theta_l", tl)):
            if np.any((a < 0) | (a > 90)):
                raise QueryError(f"{name}: elevations must lie in [0, 90] degrees")
        v = direction_from_angles(tv, np.mod(pv, 360.0))
        l = direction_from_angles(tl, np.mod(pl, 360.0))
        out = np.zeros((tv.size, width))
        for k in np.unique(kk):
            sel = np.flatnonzero(kk == k)
            out[sel] = pairs(v[sel], l[sel], float(k))
        return out.reshape(shape + (width,))

    def tabulate(
        self,
        grid: Grid | None = None,
        *,
        progress: Callable[[int, int], None] | None = None,
    ) -> CDBRDF:
        """Sample the model on a grid into a :class:`cdbrdf.CDBRDF` (float32).

        Parameters
        ----------
        grid
            The sample axes; default :meth:`cdbrdf.Grid.paper`.
        progress
            Called as ``progress(done, total)`` after each curvature slice.

        Returns
        -------
        CDBRDF
            ``quantity = "brdf"``, every sample marked measured (computed),
            attrs with the material name, the model and all its parameters.
        """
        g = Grid.paper() if grid is None else grid
        if not isinstance(g, Grid):
            raise TypeError(f"grid: expected cdbrdf.Grid, got {type(g).__name__}")
        for k in g.kappa:
            self._check_kappa(float(k))
        PL, TL, PV, TV = np.meshgrid(g.phi_l, g.theta_l, g.phi_v, g.theta_v, indexing="ij")
        v = direction_from_angles(TV.reshape(-1), PV.reshape(-1))
        l = direction_from_angles(TL.reshape(-1), PL.reshape(-1))
        values = np.empty(g.shape + (3,), dtype=np.float32)
        for i, k in enumerate(g.kappa):
            log.debug("%s: tabulating kappa = %g (%d samples)", self.params.name, k, v.shape[0])
            values[i] = self._sample(v, l, float(k)).reshape(g.shape[1:] + (3,)).astype(np.float32)
            if progress is not None:
                progress(i + 1, g.kappa.size)
        return CDBRDF(values, g, attrs=self.attrs())

    def albedo(
        self,
        theta_v: ArrayLike,
        phi_v: ArrayLike,
        kappa: float = 0.0,
        *,
        n_theta: int = 24,
        n_phi: int = 48,
    ) -> NDArray[np.float64]:
        """Directional albedo ``int f cos(theta_l) dw_l`` (midpoint rule), RGB.

        Parameters
        ----------
        theta_v, phi_v
            View directions (1-D arrays of equal length or scalars), degrees.
        kappa
            Curvature, mm^-1.
        n_theta, n_phi
            Quadrature nodes over the light hemisphere.

        Returns
        -------
        numpy.ndarray
            ``(n_views, 3)``.
        """
        tv, pv = np.broadcast_arrays(np.atleast_1d(np.asarray(theta_v, float)), np.atleast_1d(np.asarray(phi_v, float)))
        dt = 90.0 / n_theta
        dp = 360.0 / n_phi
        TL, PL = np.meshgrid((np.arange(n_theta) + 0.5) * dt, (np.arange(n_phi) + 0.5) * dp, indexing="ij")
        w = np.cos(np.radians(TL)) * np.sin(np.radians(TL)) * np.radians(dt) * np.radians(dp)
        f = self.evaluate(tv[:, None, None], pv[:, None, None], TL[None], PL[None], kappa)
        return np.sum(f * w[None, ..., None], axis=(1, 2))
