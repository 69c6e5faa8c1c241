"""What bending does to the yarns of a woven cloth lying on a cylinder.

The cloth (thickness ``t``) lies on a cylinder of curvature ``kappa``
(mm^-1, > 0 convex) whose axis is y. Its yarns fall into two families:

- the *axial* yarns run along y, parallel to the axis, and are spaced along
  x (they do not bend; they move apart or together);
- the *hoop* yarns run along x, around the cylinder (they bend with the
  cloth and keep their length).

Lengths along x are measured on the *zero-strain surface*, at height ``z0``
above the mid-plane of the cloth: ``z0 = (neutral_fraction - 1/2) t``, so
``neutral_fraction = 0`` puts it at the back (a cloth bonded to a rigid
stand, as the paper mounts its samples: the back keeps the length it had
when flat) and ``1/2`` at the mid-plane (a cloth bent freely). Material at
height ``z`` is stretched along x by ``1 + kappa (z - z0)``.

1. **Axial yarns move apart.** Their centres are fixed in angle (they lie on
   the zero-strain surface's arc at the flat spacing), so at the height of
   their centres where they are on top (``+c_axial``) the spacing is stretched
   by ``1 + kappa (c_axial - z0)``; their cross-sections keep their size, so
   the gaps between them open (convex) or close (concave).
2. **Hoop yarns decrimp.** A hoop yarn's centre line ``z(x)`` keeps its length
   ``L = int sqrt((1 + kappa (z - z0))^2 + z'^2) dx`` over a repeat. On a convex
   bend the arc it must span is longer, so its crimp amplitude falls; on a
   concave bend it has length to spare and its crimp grows (Peirce 1937: the
   yarns are inextensible, the crimp takes up the strain).
3. **Crimp interchange.** Crossing yarns stay in contact, so the two crimp
   amplitudes keep their sum ``(h_axial + h_hoop) / 2``: what the hoop yarns
   lose, the axial yarns gain (their crowns rise above the hoop yarns).

At ``kappa = 0`` nothing changes (exactly). The yarns do not stretch: once a
bend has pulled the hoop yarns straight, a stronger one moves the zero-strain
surface up instead (the back slips on the stand or buckles), so that their
straight length still spans the arc; likewise once they hold all the crimp
(the axial yarns straight) on a concave bend.

References
----------
F. T. Peirce, "The geometry of cloth structure", Journal of the Textile
Institute Transactions 28(3), T45-T96, 1937.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from ..errors import OptionError
from .weave import YarnGeometry, _crimp

__all__ = ["Bend", "bend", "centre_line_length", "zero_strain_height"]

#: Samples per crossing interval of the centre-line length quadrature.
_LENGTH_SAMPLES = 512
#: Bisection steps of the bent crimp (the interval shrinks by 2^-60).
_BISECTION = 60
#: Doublings of the bracket before the root is given up (a bracket of 2^100 scales).
_BRACKET = 100


@dataclass(frozen=True)
class Bend:
    """The yarn geometry of a cloth on a cylinder of curvature ``kappa_per_mm``.

    Attributes
    ----------
    kappa_per_mm
        Curvature, mm^-1 (> 0 convex).
    zero_strain_mm
        Height ``z0`` of the zero-strain surface above the cloth's mid-plane.
    face_strain
        Strain of the outer face along x, ``kappa (t/2 - z0)``.
    axial_strain
        Strain of the spacing of the axial yarns at their centres,
        ``kappa (c_axial - z0)``: the height field's layout stretch is
        ``1 + axial_strain``.
    axial, hoop
        The two families' geometry on the bent cloth (crimp amplitudes after
        decrimping and crimp interchange; pitch, cross-section and twist as
        when flat).
    axial_is_warp
        True when the warp is the axial family.
    """

    kappa_per_mm: float
    zero_strain_mm: float
    face_strain: float
    axial_strain: float
    axial: YarnGeometry
    hoop: YarnGeometry
    axial_is_warp: bool

    @property
    def stretch_x(self) -> float:
        """Stretch of the axial yarns' spacing, ``1 + axial_strain``."""
        return 1.0 + self.axial_strain

    @property
    def warp(self) -> YarnGeometry:
        """The warp's geometry on the bent cloth."""
        return self.axial if self.axial_is_warp else self.hoop

    @property
    def weft(self) -> YarnGeometry:
        """The weft's geometry on the bent cloth."""
        return self.hoop if self.axial_is_warp else self.axial


def zero_strain_height(thickness_mm: float, neutral_fraction: float) -> float:
    """Height of the zero-strain surface above the mid-plane, ``(neutral_fraction - 1/2) t``."""
    return (float(neutral_fraction) - 0.5) * float(thickness_mm)


def _hoop_rows(weave: NDArray[np.int8], warp_along: str) -> NDArray[np.float64]:
    """Crossing heights (+1 over, -1 under) of each hoop yarn, ``(n_hoop, n_axial)``."""
    if warp_along == "y":  # hoop = weft; weave[i, j] = 1: warp (axial) over weft i
        return np.where(weave.astype(bool), -1.0, 1.0)
    # hoop = warp: warp j over weft i where weave[i, j] = 1; rows are warps, columns wefts
    return np.where(weave.astype(bool).T, 1.0, -1.0)


def centre_line_length(
    rows: NDArray[np.float64],
    crimp_mm: float,
    pitch_mm: float,
    transition: float,
    *,
    kappa_per_mm: float = 0.0,
    zero_strain_mm: float = 0.0,
) -> float:
    """Mean length (mm) of the hoop yarns' centre lines over one repeat.

    Parameters
    ----------
    rows
        Crossing heights in units of the crimp amplitude, ``(n_rows, n_crossings)``
        (see ``_hoop_rows``).
    crimp_mm, pitch_mm, transition
        Crimp amplitude, distance between crossings (measured on the
        zero-strain surface) and the crimp's transition fraction
        (:class:`~cdbrdf.synth.weave.YarnGeometry`).
    kappa_per_mm, zero_strain_mm
        The bend: a point at height ``z`` lies at radius ``R0 + z - z0`` on
        the cylinder, so an element ``dx`` of the zero-strain surface spans
        ``(1 + kappa (z - z0)) dx`` there.

    Returns
    -------
    float
        ``mean_rows int sqrt((1 + kappa (z - z0))^2 + z'^2) dx`` (midpoint rule).
    """
    n_cross = rows.shape[1]
    n = _LENGTH_SAMPLES * n_cross
    u = (np.arange(n) + 0.5) * (pitch_mm / _LENGTH_SAMPLES)
    total = 0.0
    for r in rows:
        z, dz = _crimp(u, r * crimp_mm, pitch_mm, transition)
        stretch = 1.0 + kappa_per_mm * (z - zero_strain_mm)
        total += float(np.sum(np.sqrt(stretch * stretch + dz * dz))) * (pitch_mm / _LENGTH_SAMPLES)
    return total / rows.shape[0]


def _root(f: Callable[[float], float], start: float, scale: float) -> float:
    """The root of the increasing function ``f`` nearest ``start``, by bisection.

    The bracket grows from ``start`` in steps doubling from ``scale`` until
    ``f`` changes sign.

    Raises
    ------
    ArithmeticError
        When ``f`` does not change sign within ``2^100`` scales.
    """
    lo = hi = start
    d = scale
    for _ in range(_BRACKET):
        if f(start) <= 0.0:
            if f(hi) >= 0.0:
                break
            lo, hi, d = hi, hi + d, 2.0 * d
        else:
            if f(lo) <= 0.0:
                break
            hi, lo, d = lo, lo - d, 2.0 * d
    else:
        raise ArithmeticError(f"no sign change of the bending equation within {d:g} mm of {start:g} mm")
    for _ in range(_BISECTION):
        mid = 0.5 * (lo + hi)
        if f(mid) > 0.0:
            hi = mid
        else:
            lo = mid
    return 0.5 * (lo + hi)


def bend(
    weave: NDArray[np.int8],
    warp: YarnGeometry,
    weft: YarnGeometry,
    *,
    warp_along: str,
    kappa_per_mm: float,
    thickness_mm: float,
    neutral_fraction: float,
) -> Bend:
    """The yarn geometry of a cloth bent to curvature ``kappa_per_mm`` (see the module notes).

    Parameters
    ----------
    weave
        Validated weave matrix ``(n_weft, n_warp)``.
    warp, weft
        The flat cloth's yarn geometry (the two crimps add up to the two half
        heights: crossing yarns touch).
    warp_along
        ``"x"`` or ``"y"``: the axis the warp runs along (y = axial).
    kappa_per_mm
        Curvature, mm^-1; ``|kappa| * thickness_mm < 1``.
    thickness_mm
        Cloth thickness; the yarns are centred in it.
    neutral_fraction
        Height of the zero-strain surface above the back, as a fraction of
        the thickness (0 = back, 1/2 = mid-plane).

    Returns
    -------
    Bend

    Raises
    ------
    OptionError
        For a non-finite curvature or one tighter than the cloth's thickness allows.
    """
    k = float(kappa_per_mm)
    if not math.isfinite(k):
        raise OptionError(f"kappa: must be finite, got {kappa_per_mm!r}")
    if abs(k) * thickness_mm >= 1.0:
        raise OptionError(
            f"kappa: |kappa| = {abs(k):g} /mm bends a cloth of thickness {thickness_mm:g} mm "
            f"tighter than its own thickness; need |kappa| < {1.0 / thickness_mm:g} /mm"
        )
    if warp_along not in ("x", "y"):
        raise OptionError(f"warp_along: expected 'x' or 'y', got {warp_along!r}")
    axial, hoop = (warp, weft) if warp_along == "y" else (weft, warp)
    z0 = zero_strain_height(thickness_mm, neutral_fraction)
    if k == 0.0:
        return Bend(k, z0, 0.0, 0.0, axial, hoop, warp_along == "y")
    rows = _hoop_rows(weave, warp_along)
    total = axial.crimp_mm + hoop.crimp_mm
    flat = centre_line_length(rows, hoop.crimp_mm, axial.pitch_mm, hoop.transition)

    def excess(c: float, z: float) -> float:
        return centre_line_length(rows, c, axial.pitch_mm, hoop.transition, kappa_per_mm=k,
                                  zero_strain_mm=z) - flat

    # The hoop yarns' length fixes their crimp. At a bound of the crimp (pulled
    # straight, or holding all of it) the zero-strain surface moves instead: the
    # back slips or buckles rather than the yarn stretching.
    if excess(0.0, z0) >= 0.0:
        c_hoop = 0.0
        # A straight centre line at z = 0 spans n p (1 - kappa z0) on the cylinder.
        z0 = (1.0 - flat / (rows.shape[1] * axial.pitch_mm)) / k
    elif excess(total, z0) <= 0.0:
        c_hoop = total
        # excess grows with z0 for kappa < 0 and falls for kappa > 0.
        z0 = _root(lambda z: -np.sign(k) * excess(total, z), z0, thickness_mm)
    else:
        c_hoop = _root(lambda c: excess(c, z0), 0.0, total)
    c_axial = total - c_hoop
    return Bend(
        kappa_per_mm=k,
        zero_strain_mm=z0,
        face_strain=k * (0.5 * thickness_mm - z0),
        axial_strain=k * (c_axial - z0),
        axial=replace(axial, crimp_mm=c_axial),
        hoop=replace(hoop, crimp_mm=c_hoop),
        axial_is_warp=warp_along == "y",
    )
