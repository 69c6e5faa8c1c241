"""The sample axes of a table: :class:`Grid`, and the paper's grid.

Five axes, in the storage order of the conventions (``docs/conventions.md``):

- ``kappa``: surface curvature in mm^-1 (> 0 convex, < 0 concave), strictly
  increasing, any spacing, within +-:data:`MAX_ABS_KAPPA` (1e3 mm^-1, a
  radius of 1 um); a single value makes a plain BRDF.
- ``phi_l``, ``phi_v``: azimuth from the reference tangent x towards y in
  degrees, evenly spaced in [0, 360) and periodic.
- ``theta_l``, ``theta_v``: elevation from the normal in degrees, strictly
  increasing, in [0, 90).

A grid has a symmetry (:data:`cdbrdf.schema.SYMMETRIES`): ``"anisotropic"``
(the default) takes the five axes as they are; ``"isotropic"`` describes a
table whose value depends on the two elevations and the azimuth difference
only: ``phi_l`` is the single azimuth 0 and ``phi_v`` is the axis of the
azimuth difference ``phi_v - phi_l`` (every lookup rotates the query, see
:mod:`cdbrdf.interp`).

Neighbouring samples of every axis are at least :data:`MIN_AXIS_STEP` apart.
Axes must be real numbers (integer or float dtypes; bool, complex,
``datetime64``/``timedelta64``, object and string dtypes are refused). The
array checks here (:func:`read_array`) are also those of the table's values.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from . import limits
from .errors import TableError
from .schema import AXES, SYMMETRIES, check_symmetry

__all__ = [
    "Grid",
    "PAPER_KAPPA",
    "PAPER_THETA",
    "PAPER_PHI",
    "MAX_ABS_KAPPA",
    "MIN_AXIS_STEP",
    "SYMMETRIES",
    "read_array",
]

#: The paper's curvatures, mm^-1.
PAPER_KAPPA = np.array([-0.22, -0.13, 0.0, 0.13, 0.22])
#: The paper's elevations, degrees.
PAPER_THETA = np.arange(0.0, 76.0, 15.0)
#: The paper's azimuths, degrees.
PAPER_PHI = np.arange(0.0, 360.0, 30.0)

_PHI_TOL_DEG = 1e-6

#: Largest curvature magnitude an axis may hold, mm^-1 (a radius of 1 um).
MAX_ABS_KAPPA = 1e3
#: Smallest spacing of neighbouring samples on any axis (mm^-1 or degrees):
#: closer samples would make ``1 / spacing`` in the lookup overflow.
MIN_AXIS_STEP = 1e-9

#: dtype kinds accepted for numbers: signed/unsigned integers and real floats
#: (no bool, complex, timedelta64, datetime64, object, strings, records).
_NUMBER_KINDS = "iuf"


def read_array(name: str, value: Any, *, kinds: str = _NUMBER_KINDS, what: str = "numbers") -> np.ndarray:
    """``value`` as an ndarray whose dtype kind is in ``kinds``; refuse anything else.

    A numpy masked array is accepted only when nothing is masked (its data is
    used): a mask would otherwise be dropped silently.

    Parameters
    ----------
    name
        The argument's name, for messages.
    value
        What was given.
    kinds
        Accepted :attr:`numpy.dtype.kind` characters.
    what
        What is expected, for messages.

    Returns
    -------
    numpy.ndarray
        ``value`` as an array (not copied when it already is one).

    Raises
    ------
    TableError
        For a value that cannot be read as an array of those kinds.
    """
    if isinstance(value, np.ma.MaskedArray):
        n_masked = int(np.count_nonzero(np.ma.getmaskarray(value)))
        if n_masked:
            raise TableError(
                f"{name}: masked array with {n_masked} masked entries; fill them first "
                "(e.g. .filled(value)) or mark filled samples with 'measured'"
            )
        value = np.ma.getdata(value)
    try:
        a = np.asarray(value)
    except (TypeError, ValueError) as exc:
        raise TableError(f"{name}: cannot be read as {what} ({exc})") from None
    if a.dtype.kind not in kinds:
        raise TableError(f"{name}: expected {what}, got dtype {a.dtype}")
    return a


def _axis(name: str, value: ArrayLike) -> NDArray[np.float64]:
    a = read_array(name, value)
    with np.errstate(all="ignore"):  # out-of-range values become inf: refused below
        a = np.array(a, dtype=np.float64, ndmin=1)
    if a.ndim != 1:
        raise TableError(f"{name}: expected a 1-D axis, got shape {a.shape}")
    if a.size == 0:
        raise TableError(f"{name}: the axis is empty")
    if not np.all(np.isfinite(a)):
        raise TableError(f"{name}: contains NaN or infinite values")
    if name == "kappa" and np.abs(a).max() > MAX_ABS_KAPPA:
        raise TableError(
            f"{name}: curvatures must lie in [-{MAX_ABS_KAPPA:g}, {MAX_ABS_KAPPA:g}] 1/mm, "
            f"got {a[0]:g}..{a[-1]:g}"
        )
    if a.size > 1 and not np.all(np.diff(a) > 0):
        raise TableError(f"{name}: must be strictly increasing, got {a.tolist()}")
    if a.size > 1 and np.diff(a).min() < MIN_AXIS_STEP:
        raise TableError(
            f"{name}: neighbouring samples are {np.diff(a).min():g} apart, closer than {MIN_AXIS_STEP:g}"
        )
    a.setflags(write=False)
    return a


def _check_theta(name: str, a: NDArray[np.float64]) -> None:
    if a[0] < 0 or a[-1] >= 90:
        raise TableError(
            f"{name}: elevations must lie in [0, 90) degrees, got {a[0]:g}..{a[-1]:g}"
        )


def _check_phi(name: str, a: NDArray[np.float64]) -> None:
    if a[0] < 0 or a[-1] >= 360:
        raise TableError(
            f"{name}: azimuths must lie in [0, 360) degrees, got {a[0]:g}..{a[-1]:g}"
        )
    if a.size > 1:
        step = 360.0 / a.size
        expected = a[0] + step * np.arange(a.size)
        if not np.allclose(a, expected, rtol=0, atol=_PHI_TOL_DEG * max(1.0, step)):
            raise TableError(
                f"{name}: azimuths must be evenly spaced around the full circle "
                f"(step 360/{a.size} = {step:g} deg, periodic), got {a.tolist()}"
            )


@dataclass(frozen=True, eq=False, init=False)
class Grid:
    """The five sample axes of a table.

    Given by keyword only, in any order; stored, listed (:meth:`axes`) and
    indexed in one order, the table's: ``kappa, phi_l, theta_l, phi_v,
    theta_v`` (``Grid(**g.axes())`` is ``g``).

    Parameters
    ----------
    kappa
        Curvatures in mm^-1, strictly increasing (any spacing), in
        [-:data:`MAX_ABS_KAPPA`, :data:`MAX_ABS_KAPPA`].
    phi_l, theta_l
        Light azimuths in degrees, evenly spaced in [0, 360), and light
        elevations in degrees, strictly increasing in [0, 90). In an isotropic
        grid ``phi_l`` is ``[0]``.
    phi_v, theta_v
        View azimuths and elevations, the same rules; in an isotropic grid
        ``phi_v`` is the azimuth difference ``phi_v - phi_l``.
    symmetry
        ``"anisotropic"`` (default) or ``"isotropic"`` (:data:`SYMMETRIES`).

    Raises
    ------
    TableError
        For an axis that is not 1-D real numbers, not finite, not strictly
        increasing by at least :data:`MIN_AXIS_STEP`, or out of its range; an
        unknown symmetry, or an isotropic grid whose ``phi_l`` is not ``[0]``.
    LimitError
        When the grid has more samples than the ``table_samples`` limit.
    """

    kappa: NDArray[np.float64]
    phi_l: NDArray[np.float64]
    theta_l: NDArray[np.float64]
    phi_v: NDArray[np.float64]
    theta_v: NDArray[np.float64]
    symmetry: str = "anisotropic"

    def __init__(
        self,
        *,
        kappa: ArrayLike,
        phi_l: ArrayLike,
        theta_l: ArrayLike,
        phi_v: ArrayLike,
        theta_v: ArrayLike,
        symmetry: str = "anisotropic",
    ) -> None:
        # the fields are the checked arrays (frozen: set once, here)
        check_symmetry(symmetry)
        object.__setattr__(self, "symmetry", symmetry)
        for name, value in (("kappa", kappa), ("theta_l", theta_l), ("phi_l", phi_l),
                            ("theta_v", theta_v), ("phi_v", phi_v)):
            object.__setattr__(self, name, _axis(name, value))
        if self.symmetry == "isotropic" and not (self.phi_l.size == 1 and self.phi_l[0] == 0.0):
            raise TableError(
                f"phi_l: an isotropic grid has the single light azimuth [0] (its phi_v axis is the "
                f"azimuth difference phi_v - phi_l), got {self.phi_l.tolist()}"
            )
        _check_theta("theta_l", self.theta_l)
        _check_theta("theta_v", self.theta_v)
        _check_phi("phi_l", self.phi_l)
        _check_phi("phi_v", self.phi_v)
        limits.check(
            "table_samples", float(np.prod([float(n) for n in self.shape])),
            what=f"grid of {' x '.join(str(n) for n in self.shape)} samples",
        )

    @classmethod
    def paper(cls, *, kappa: ArrayLike | None = None, symmetry: str = "anisotropic") -> Grid:
        """The paper's grid: theta 0..75 step 15, phi 0..330 step 30, 5 curvatures.

        With ``symmetry="isotropic"`` the light azimuth is the single 0 and
        ``phi_v`` (the azimuth difference) steps by 30 degrees.

        Parameters
        ----------
        kappa
            Curvatures, mm^-1; default :data:`PAPER_KAPPA`.
        symmetry
            ``"anisotropic"`` or ``"isotropic"``.

        Returns
        -------
        Grid
            The grid.
        """
        return cls(
            kappa=PAPER_KAPPA if kappa is None else kappa,
            theta_l=PAPER_THETA,
            phi_l=np.zeros(1) if check_symmetry(symmetry) == "isotropic" else PAPER_PHI,
            theta_v=PAPER_THETA,
            phi_v=PAPER_PHI,
            symmetry=symmetry,
        )

    @classmethod
    def regular(
        cls,
        *,
        theta_step_deg: float,
        phi_step_deg: float,
        theta_max_deg: float = 75.0,
        kappa: ArrayLike = PAPER_KAPPA,
        symmetry: str = "anisotropic",
    ) -> Grid:
        """A grid with the same regular direction sampling for light and view.

        Elevations ``0, step, ..., <= theta_max_deg``; azimuths ``0, step, ...``
        below 360. With ``symmetry="isotropic"`` the light azimuth is the single
        0 and ``phi_v`` is the azimuth difference, so the grid has
        ``360 / phi_step_deg`` times fewer samples.

        Parameters
        ----------
        theta_step_deg, phi_step_deg
            Elevation and azimuth steps, degrees.
        theta_max_deg
            Largest elevation, degrees.
        kappa
            Curvatures, mm^-1.
        symmetry
            ``"anisotropic"`` or ``"isotropic"``.

        Returns
        -------
        Grid
            The grid.
        """
        iso = check_symmetry(symmetry) == "isotropic"
        for name, x in (("theta_step_deg", theta_step_deg), ("phi_step_deg", phi_step_deg),
                        ("theta_max_deg", theta_max_deg)):
            if not isinstance(x, (int, float, np.integer, np.floating)) or isinstance(x, (bool, np.bool_)):
                raise TableError(f"{name}: expected a number, got {type(x).__name__}")
        if not (math.isfinite(theta_step_deg) and theta_step_deg > 0):
            raise TableError(f"theta_step_deg: must be positive and finite, got {theta_step_deg}")
        if not (math.isfinite(phi_step_deg) and 0 < phi_step_deg <= 360):
            raise TableError(f"phi_step_deg: must lie in (0, 360], got {phi_step_deg}")
        if not (0 <= theta_max_deg < 90):
            raise TableError(f"theta_max_deg: must lie in [0, 90), got {theta_max_deg}")
        n_phi = 360.0 / phi_step_deg
        if abs(n_phi - round(n_phi)) > 1e-9:
            raise TableError(f"phi_step_deg: {phi_step_deg} does not divide 360")
        n_theta = math.floor((theta_max_deg + 1e-9) / theta_step_deg) + 1.0
        n_kappa = float(np.size(kappa))
        n_phi_l = 1.0 if iso else n_phi
        counts = " x ".join(f"{c:.0f}" if c < 1e12 else f"{c:.3g}" for c in (n_kappa, n_phi_l, n_theta, n_phi, n_theta))
        limits.check(  # before any axis is built (products of floats: inf, never an exception)
            "table_samples", n_kappa * n_phi_l * n_phi * n_theta * n_theta,
            what=f"regular grid of {counts} samples",
        )
        theta = np.arange(0.0, theta_max_deg + 1e-9, theta_step_deg)
        phi = np.arange(round(n_phi)) * phi_step_deg
        return cls(kappa=kappa, theta_l=theta, phi_l=np.zeros(1) if iso else phi,
                   theta_v=theta, phi_v=phi, symmetry=symmetry)

    @property
    def isotropic(self) -> bool:
        """Whether the grid is isotropic (``phi_v`` is the azimuth difference)."""
        return self.symmetry == "isotropic"

    @property
    def shape(self) -> tuple[int, int, int, int, int]:
        """Sample counts ``(kappa, phi_l, theta_l, phi_v, theta_v)``."""
        return (
            self.kappa.size,
            self.phi_l.size,
            self.theta_l.size,
            self.phi_v.size,
            self.theta_v.size,
        )

    def axes(self) -> dict[str, Any]:
        """The axes by name, in storage order.

        Float64 arrays, typed Any so that ``Grid(**g.axes())`` type-checks
        beside other keywords (a table takes the grid whole: ``CDBRDF(v, g)``).

        Returns
        -------
        dict
            ``kappa``, ``phi_l``, ``theta_l``, ``phi_v``, ``theta_v``.
        """
        return {name: getattr(self, name) for name in AXES[:-1]}

    def mesh(self) -> dict[str, NDArray[np.float64]]:
        """Every sample's coordinates.

        Returns
        -------
        dict
            The axes by name, each broadcast to :attr:`shape`.
        """
        grids = np.meshgrid(*self.axes().values(), indexing="ij")
        return dict(zip(AXES[:-1], grids))

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Grid):
            return NotImplemented
        return self.symmetry == other.symmetry and all(
            np.array_equal(getattr(self, n), getattr(other, n)) for n in AXES[:-1]
        )

    def __repr__(self) -> str:
        def r(a: NDArray[np.float64]) -> str:
            if a.size <= 6:
                return "[" + ", ".join(f"{x:g}" for x in a) + "]"
            return f"[{a[0]:g}..{a[-1]:g}] ({a.size})"

        sym = ", symmetry='isotropic'" if self.isotropic else ""
        return (
            f"Grid(kappa={r(self.kappa)}, theta_l={r(self.theta_l)}, phi_l={r(self.phi_l)}, "
            f"theta_v={r(self.theta_v)}, phi_v={r(self.phi_v)}{sym})"
        )
