"""Length units of meshes, and the check that a mesh's curvature fits a table's range.

A mesh file stores numbers; its unit is a convention of the tool that wrote it
(fashion CAD tools export millimetres, Blender and glTF metres, many CAD and
3-D printing tools inches, scans and game models are often unitless). The
curvature the CDBRDF is looked up with is in mm^-1, so every path from a mesh
to a render takes a unit: a name (:data:`UNITS_MM`) or a number, the
millimetres per model unit (a free scale for unitless models).

A mesh's unit is, in this order: given (``--units``), recorded by cdbrdf or
stated by the file (glTF's metre, a header comment, MakeHuman's decimetre:
:mod:`cdbrdf.mesh.statements`), inferred from the size of a garment or a
sheet (:func:`infer_units`: a garment is 0.2-2.5 m across, a sheet or a
swatch 5 mm to 3 m; millimetres first when they fit), or else millimetres, and the notes say which. A stated
unit that makes a garment implausibly large or small is followed (it is the
file's own statement) with a warning (:func:`check_garment_size`).

A wrong unit shows as curvature outside the table's kappa range: a garment in
metres read as millimetres is 1000 times too small and 1000 times too curved,
so all of it would be clamped to the table's last kappa. :func:`check_kappa_range`
measures the share of the surface (by area) outside the range and, when most
of it is *and* the surface bends tighter than cloth can (a median bend
radius below :data:`YARN_SCALE_MM`, the thickness of a yarn), names the unit
under which the least would be. A small object that is really small (an 8 mm
teapot in mm) bends at radii cloth can have: its curvature is beyond the
table's stands but no other unit is suggested.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from ..errors import MeshError

__all__ = [
    "UNITS_MM",
    "Units",
    "parse_units",
    "KappaRangeCheck",
    "check_kappa_range",
    "WARN_OUTSIDE_SHARE",
    "SUGGEST_OUTSIDE_SHARE",
    "MAX_SIZE_MM",
    "YARN_SCALE_MM",
    "check_size",
    "GARMENT_SIZE_M",
    "SHEET_SIZE_M",
    "OPENING_SIZE_M",
    "object_kind",
    "infer_units",
    "check_garment_size",
]

#: Named length units: millimetres per unit.
UNITS_MM: dict[str, float] = {"mm": 1.0, "cm": 10.0, "m": 1000.0, "in": 25.4, "dm": 100.0}

#: Smallest and largest free scale accepted (millimetres per model unit).
SCALE_RANGE_MM: tuple[float, float] = (1e-9, 1e9)

#: Share of the surface (by area) outside the table's kappa range above which a warning is given.
WARN_OUTSIDE_SHARE = 0.10

#: Share above which the likely unit is suggested.
SUGGEST_OUTSIDE_SHARE = 0.5

#: The smallest bend radius cloth can have, mm (about a yarn's thickness): a surface whose median
#: bend radius is smaller has a wrong unit.
YARN_SCALE_MM = 0.5

#: Largest extent of a mesh in mm (1 km). The renderer holds positions in float32: at 1 km they are
#: still resolved to 0.06 mm, finer than any curvature neighbourhood, while the camera frames the whole
#: mesh, so one triangle 1e10 mm long shrinks the object to less than a pixel (an all-black image).
#: Nothing cdbrdf renders (a garment, a sample, a set) is larger; a larger mesh has a wrong unit or a
#: damaged vertex.
MAX_SIZE_MM = 1e6


def check_size(vertices: ArrayLike, units: Units, *, name: str = "mesh") -> float:
    """The mesh's extent (bounding-box diagonal) in mm.

    Parameters
    ----------
    vertices
        ``(n, 3)`` positions in ``units``.
    units
        Their unit.
    name
        For messages (the file's name).

    Returns
    -------
    float
        The diagonal, mm; NaN when the vertices are not all finite numbers
        (left to the mesh's own checks).

    Raises
    ------
    MeshError
        Beyond :data:`MAX_SIZE_MM`.
    """
    v = np.asarray(vertices, dtype=np.float64)
    if v.size == 0 or v.ndim != 2 or not np.isfinite(v).all():
        return math.nan if v.size else 0.0
    with np.errstate(over="ignore", invalid="ignore"):
        size = float(np.linalg.norm(v.max(axis=0) - v.min(axis=0))) * units.mm_per_unit
    if not size <= MAX_SIZE_MM:
        raise MeshError(f"{name}: {size:.3g} mm across (unit {units}), beyond {MAX_SIZE_MM:g} mm: a wrong unit or a "
                        "vertex far from the rest (a triangle that long leaves the object less than a pixel)")
    return size


#: The largest extent of a garment or a figure, m (a glove, a child's shirt, ..., a gown in a T-pose).
GARMENT_SIZE_M: tuple[float, float] = (0.2, 2.5)

#: The largest extent of a sheet of cloth, a swatch (a sample on the paper's stands is 15 mm across) or a
#: drape, m.
SHEET_SIZE_M: tuple[float, float] = (0.005, 3.0)

#: Around the smallest of a garment's three or more tube ends (its cuffs, ankles or neck), m: wrists
#: and ankles are 0.15-0.25 m around, a neck 0.35-0.45 m, a wide sleeve's hem up to 0.8 m.
OPENING_SIZE_M: tuple[float, float] = (0.1, 0.9)

#: The units a unit is inferred among, in the order preferred when the size fits more than one.
INFER_UNITS: tuple[str, ...] = ("mm", "m", "cm", "dm")

#: A loop is a tube's end (a cuff, a neck, a hem; not a slit or a pleat's edge) from this openness on,
TUBE_END_OPENNESS = 0.7

#: and when it is at least this share of the garment's largest extent around (not a hole).
TUBE_END_SIZE = 0.05


@dataclass(frozen=True)
class Units:
    """A mesh's length unit.

    Attributes
    ----------
    mm_per_unit
        Millimetres per model unit (1 for mm, 25.4 for inches, any positive
        number for a free scale).
    name
        The unit's name (``"mm"``, ``"cm"``, ``"m"``, ``"in"``) or the number
        as given (``"2.5"``).
    """

    mm_per_unit: float
    name: str

    def __str__(self) -> str:
        if self.name in UNITS_MM:
            return self.name
        return f"{self.mm_per_unit:g} mm per unit"


def parse_units(value: str | float | Units) -> Units:
    """The :class:`Units` of a name or a number.

    Parameters
    ----------
    value
        ``"mm"``, ``"cm"``, ``"m"``, ``"in"``, millimetres per unit, or Units.

    Returns
    -------
    Units
        The unit.

    Raises
    ------
    MeshError
        For an unknown name or a number that is not positive and finite (the
        message lists the valid values).
    """
    if isinstance(value, Units):
        return value
    if isinstance(value, str):
        text = value.strip()
        if text in UNITS_MM:
            return Units(UNITS_MM[text], text)
        try:
            x = float(text)
        except ValueError:
            raise MeshError(
                f"units: {value!r} is neither one of {', '.join(UNITS_MM)} nor a number of "
                "millimetres per model unit") from None
    else:
        try:
            x = float(value)
        except (TypeError, ValueError):
            raise MeshError(f"units: expected one of {', '.join(UNITS_MM)} or a number, got {value!r}") from None
        text = f"{x:g}"
    lo, hi = SCALE_RANGE_MM
    if not (math.isfinite(x) and lo <= x <= hi):
        raise MeshError(f"units: a scale must be a number of millimetres per model unit in "
                        f"[{lo:g}, {hi:g}], got {value!r}")
    for name, mm in UNITS_MM.items():
        if x == mm:
            return Units(mm, name)
    return Units(x, text)


@dataclass(frozen=True)
class KappaRangeCheck:
    """How much of a surface lies outside a table's kappa range.

    Attributes
    ----------
    outside_share
        Share of the surface (by area) with kappa outside ``kappa_range``
        (rendered with the clamped, nearest end of the table).
    kappa_range
        The table's ``(min, max)`` kappa, mm^-1.
    likely_units
        When most of the surface is outside: the named unit under which the
        least would be, with that share; else None.
    message
        A one-line warning when :attr:`outside_share` exceeds
        :data:`WARN_OUTSIDE_SHARE`, else None.
    """

    outside_share: float
    kappa_range: tuple[float, float]
    likely_units: tuple[str, float] | None
    message: str | None


def _outside(kappa: np.ndarray, weights: np.ndarray, lo: float, hi: float, tol: float) -> float:
    out = (kappa < lo - tol) | (kappa > hi + tol)
    total = float(weights.sum())
    return float(weights[out].sum() / total) if total > 0 else 0.0


def _weighted_median(x: np.ndarray, w: np.ndarray) -> float:
    order = np.argsort(x)
    c = np.cumsum(w[order])
    if not c.size or c[-1] <= 0:
        return float(np.median(x)) if x.size else 0.0
    return float(x[order][np.searchsorted(c, 0.5 * c[-1])])


def check_kappa_range(
    kappa_mm: ArrayLike,
    areas: ArrayLike,
    kappa_range: tuple[float, float],
    *,
    units: Units,
    size_units: float | None = None,
) -> KappaRangeCheck:
    """The share of a surface outside a table's kappa range, and the likely unit when it is large.

    Parameters
    ----------
    kappa_mm
        Per-vertex curvature (mm^-1) computed with ``units``.
    areas
        Per-vertex area (any unit; only the shares matter).
    kappa_range
        The table's smallest and largest kappa (mm^-1).
    units
        The unit the curvature was computed with.
    size_units
        The mesh's size (bounding-box diagonal) in model units, for the
        message.

    Returns
    -------
    KappaRangeCheck
        The likely unit is looked for, when the median bend radius of the
        curved part (``|kappa|`` above half the range's end) is below
        :data:`YARN_SCALE_MM`, among the named units that make it at least
        that, by rescaling the curvature (``kappa / mm_per_unit`` per unit); with a different
        unit the neighbourhood of the estimate changes too, so the shares it
        quotes are estimates.
    """
    k = np.asarray(kappa_mm, dtype=np.float64)
    w = np.asarray(areas, dtype=np.float64)
    ok = np.isfinite(k) & np.isfinite(w) & (w >= 0)
    k, w = k[ok], w[ok]
    lo, hi = float(min(kappa_range)), float(max(kappa_range))
    tol = 1e-9 * max(1.0, abs(lo), abs(hi))
    share = _outside(k, w, lo, hi, tol)
    if hi - lo <= tol:
        # one curvature (a plain BRDF, e.g. an imported file): the table does not depend on kappa,
        # so clamping changes nothing and there is nothing to warn about or to suggest
        return KappaRangeCheck(share, (lo, hi), None, None)
    likely = None
    curved = np.abs(k) > 0.5 * max(abs(lo), abs(hi))
    median_k = _weighted_median(np.abs(k[curved]), w[curved]) if curved.any() else 0.0
    if share > SUGGEST_OUTSIDE_SHARE and median_k * YARN_SCALE_MM > 1.0:
        k_model = k * units.mm_per_unit  # per model unit
        best = min(((name, _outside(k_model / mm, w, lo, hi, tol)) for name, mm in UNITS_MM.items()
                    if median_k * units.mm_per_unit / mm * YARN_SCALE_MM <= 1.0), key=lambda t: t[1],
                   default=None)
        if best is not None and best[0] != units.name:
            likely = best
    message = None
    if share > WARN_OUTSIDE_SHARE:
        size = ""
        if size_units is not None and math.isfinite(size_units):
            size = f"; the mesh is {size_units * units.mm_per_unit:.4g} mm across in unit {units}"
        message = (f"{share:.0%} of the surface (by area) has a curvature outside the table's range "
                   f"[{lo:g}, {hi:g}] 1/mm and is rendered with the nearest end{size}")
        if likely is not None:
            message += (f"; the unit is probably wrong (a median bend radius of {1 / median_k:.3g} mm is "
                        f"tighter than a yarn): with --units {likely[0]} about {likely[1]:.0%} would be outside")
        elif share > SUGGEST_OUTSIDE_SHARE:
            message += (f"; its median bend radius, {1 / median_k:.3g} mm, is one cloth can have: the object "
                        "bends more tightly than the table's stands (the unit is not the cause)")
    return KappaRangeCheck(share, (lo, hi), likely, message)


def object_kind(shape: Any) -> str | None:
    """What the geometry is, for the plausible sizes: ``"garment"``, ``"sheet"`` or None (anything else).

    A garment: most of the surface is tubes or bags with openings (a worn
    garment, a figure's clothes, a scan open at its base), or separate panels
    (a CAD pattern, a sewing stage). A sheet: one sheet or flat panel (a
    drape, a swatch).

    Parameters
    ----------
    shape
        :func:`cdbrdf.mesh.shape.describe` of the mesh.

    Returns
    -------
    str or None
        The kind.
    """
    sheets = sum(c.kind in ("panel", "sheet") for c in shape.components)
    if shape.share("tube", "bag") >= 0.5 or (sheets >= 2 and shape.share("panel", "sheet") >= 0.5):
        return "garment"
    if sheets == 1 and shape.share("panel", "sheet") >= 0.5:
        return "sheet"
    return None


def _describe_size(extent_m: np.ndarray, up: int | None) -> str:
    if up is None:
        return f"{float(extent_m.max()):.3g} m across"
    across = max(float(extent_m[a]) for a in range(3) if a != up)
    return f"{float(extent_m[up]):.3g} m tall, {across:.3g} m across"


def infer_units(shape: Any, *, up: int | None = None) -> tuple[Units, str] | None:
    """The unit a garment's or a sheet's size makes plausible, and the reason, or None.

    The largest extent of a garment must be in :data:`GARMENT_SIZE_M`, of a
    sheet in :data:`SHEET_SIZE_M`; of the units in :data:`INFER_UNITS` that
    put it there, the first is taken.

    Parameters
    ----------
    shape
        :func:`cdbrdf.mesh.shape.describe` of the mesh.
    up
        Its up axis (0, 1, 2) for the message, or None.

    Returns
    -------
    (Units, str) or None
        The unit and why (``"inferred dm from the size: 1.47 m tall, ... as a
        garment (0.2-2.5 m)"``); None for another kind of object or a size
        no unit makes plausible.
    """
    kind = object_kind(shape)
    if kind is None:
        return None
    lo, hi = GARMENT_SIZE_M if kind == "garment" else SHEET_SIZE_M
    size = float(np.max(shape.extent))
    fits = [u for u in INFER_UNITS if lo <= size * UNITS_MM[u] / 1000.0 <= hi]
    if not fits:
        return None
    u = parse_units(fits[0])
    also = f"; {', '.join(fits[1:])} would fit too" if len(fits) > 1 else ""
    ext = np.asarray(shape.extent, dtype=np.float64) * u.mm_per_unit / 1000.0
    return u, f"inferred {u} from the size: {_describe_size(ext, up)} as a {kind} ({lo:g}-{hi:g} m){also}"


def check_garment_size(shape: Any, units: Units, *, up: int | None = None) -> str | None:
    """A warning when a unit makes a garment implausibly large or small, else None.

    Implausible: a largest extent outside :data:`GARMENT_SIZE_M`, or, for a
    garment with three or more tube ends (cuffs, ankles, a neck), the
    smallest of them outside :data:`OPENING_SIZE_M` around.

    Parameters
    ----------
    shape
        :func:`cdbrdf.mesh.shape.describe` of the mesh.
    units
        The unit (given or stated by the file).
    up
        Its up axis (0, 1, 2) for the message, or None.

    Returns
    -------
    str or None
        The warning, naming the sizes.
    """
    if object_kind(shape) != "garment":
        return None
    k = units.mm_per_unit / 1000.0
    ext = np.asarray(shape.extent, dtype=np.float64) * k
    lo, hi = GARMENT_SIZE_M
    size = _describe_size(ext, up)
    if not lo <= float(ext.max()) <= hi:
        return f"in unit {units} the garment is {size}: a garment is {lo:g}-{hi:g} m across; is the unit right?"
    smallest = TUBE_END_SIZE * float(np.max(shape.extent))  # not a hole or a pleat's slit
    ends = sorted(lp.perimeter * k for lp in shape.openings()
                  if lp.openness >= TUBE_END_OPENNESS and lp.perimeter >= smallest)
    olo, ohi = OPENING_SIZE_M
    if len(ends) >= 3 and not olo <= ends[0] <= ohi:
        big = "large" if ends[0] > ohi else "small"
        return (f"in unit {units} the garment is {size} and the smallest of its {len(ends)} openings is "
                f"{ends[0]:.2g} m around (a garment's cuffs, ankles or neck are {olo:g}-{ohi:g} m): it is "
                f"implausibly {big} for a garment worn by a person; give --units if it is life size")
    return None
