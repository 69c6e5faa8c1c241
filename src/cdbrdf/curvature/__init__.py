"""Curvature of meshes, in mm^-1, for the CDBRDF lookup; and the paper's analytic sine sheet.

The CDBRDF is indexed by "the curvature" of a surface point: as in the paper,
the principal curvature of larger magnitude, with its sign, in mm^-1.
Sign convention (``docs/conventions.md``): positive where the surface is
convex, i.e. bends away from its normal. Beside it, the *directional* mode
of the conventions: the signed normal curvature along the material's x axis
(the stands bend the fabric along x).

- :func:`surface_curvature`: a user's mesh, in any unit, repaired
  (:mod:`~cdbrdf.curvature.repair`), its curvatures fitted over a
  neighbourhood given in mm (:mod:`~cdbrdf.curvature.estimate`), its
  material frame (:mod:`~cdbrdf.curvature.frames`);
- :func:`principal_curvatures`, :func:`max_curvature`: the same on arrays,
  one value per input vertex;
- :func:`neighbourhood_from_table`: the default neighbourhood, the size of
  the table's measured patch when its provenance records it;
- :mod:`~cdbrdf.curvature.units`: units and the check against a table's
  kappa range.

The per-vertex attributes the ``cdbrdf`` BSDF reads (:data:`ATTRIBUTES`) are
written as PLY vertex properties (:data:`PLY_PROPERTIES`) that Mitsuba's PLY
loader turns into exactly those mesh attributes: it keeps an unknown vertex
property only when its name ends in a channel suffix, and strips it
(``curvature_x`` -> ``vertex_curvature``, ``curvature_dir_x`` ->
``vertex_curvature_dir``; checked in ``tests/test_mesh_render.py``).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import MeshError
from .estimate import DEFAULT_NEIGHBOURHOOD_MM, NEIGHBOURHOOD_RANGE_MM, PrincipalCurvatures
from .frames import FRAMES
from .repair import WELD_TOLERANCE, RepairedMesh, repair, weld
from .surface import CURVATURE_MODES, SurfaceCurvature, check_neighbourhood, surface_curvature
from .units import MAX_SIZE_MM, UNITS_MM, KappaRangeCheck, Units, check_kappa_range, check_size, parse_units

__all__ = [
    "ATTRIBUTES",
    "PLY_PROPERTIES",
    "MESH_ATTRIBUTES",
    "CURVATURE_MODES",
    "FRAMES",
    "UNITS_MM",
    "DEFAULT_NEIGHBOURHOOD_MM",
    "NEIGHBOURHOOD_RANGE_MM",
    "WELD_TOLERANCE",
    "MeshError",
    "Units",
    "parse_units",
    "KappaRangeCheck",
    "check_kappa_range",
    "check_size",
    "MAX_SIZE_MM",
    "PrincipalCurvatures",
    "SurfaceCurvature",
    "RepairedMesh",
    "surface_curvature",
    "principal_curvatures",
    "max_curvature",
    "repair",
    "weld",
    "check_neighbourhood",
    "neighbourhood_from_table",
    "sine_sheet_height",
    "sine_sheet_curvature",
]

#: Mitsuba mesh attribute of each curvature mode (what the ``cdbrdf`` BSDF reads), mm^-1.
ATTRIBUTES: Mapping[str, str] = {"max": "vertex_curvature", "directional": "vertex_curvature_dir"}

#: PLY vertex property that Mitsuba loads as each attribute of :data:`ATTRIBUTES`.
PLY_PROPERTIES: Mapping[str, str] = {"max": "curvature_x", "directional": "curvature_dir_x"}

#: Name of each mode's per-vertex array in :attr:`cdbrdf.render.meshio.Mesh.attributes`.
MESH_ATTRIBUTES: Mapping[str, str] = {"max": "curvature", "directional": "curvature_dir"}


def neighbourhood_from_table(attrs: Mapping[str, Any] | None) -> tuple[float, str]:
    """The default neighbourhood (mm) for a table, and where it comes from.

    The size of the measured patch, when the table's provenance records it:
    ``patch_mm`` (a measured table), ``patch_px`` x ``pixel_mm``, or the
    cloth model's ``footprint_mm`` (a synthesised table's measured spot);
    else :data:`DEFAULT_NEIGHBOURHOOD_MM`.

    Parameters
    ----------
    attrs
        The table's attributes (``table.attrs``), or None.
    """
    prov = attrs.get("provenance") if attrs else None
    if isinstance(prov, Mapping):
        candidates: list[tuple[Any, str]] = [(prov.get("patch_mm"), "the measured patch")]
        if prov.get("patch_px") is not None and prov.get("pixel_mm") is not None:
            try:
                candidates.append((float(prov["patch_px"]) * float(prov["pixel_mm"]), "the measured patch"))
            except (TypeError, ValueError):
                pass
        params = prov.get("parameters")
        if isinstance(params, Mapping):
            candidates.append((params.get("footprint_mm"), "the cloth model's measured spot"))
        lo, hi = NEIGHBOURHOOD_RANGE_MM
        for value, what in candidates:
            try:
                x = float(value)
            except (TypeError, ValueError):
                continue
            if np.isfinite(x) and lo <= x <= hi:
                return x, f"{what}, from the table's provenance"
    return DEFAULT_NEIGHBOURHOOD_MM, "the default"


def principal_curvatures(
    vertices: ArrayLike,
    faces: ArrayLike,
    *,
    normals: ArrayLike | None = None,
    units: str | float | Units = "mm",
    neighbourhood_mm: float = DEFAULT_NEIGHBOURHOOD_MM,
    progress: Callable[[int, int], None] | None = None,
) -> PrincipalCurvatures:
    """Per-vertex principal curvatures (mm^-1) and directions of a triangle mesh.

    The mesh is repaired first (:func:`repair`): the sign is relative to the
    repaired orientation, i.e. the given ``normals`` where there are any,
    outward on a closed surface, else the winding of most of each
    component. See :func:`surface_curvature` for the parameters.

    Returns
    -------
    PrincipalCurvatures
        One row per input vertex; a vertex the repair split (a double-sided
        panel, a non-manifold edge) gets its front copy's values, a vertex
        on no face 0.
    """
    s = surface_curvature(vertices, faces, normals=normals, units=units, neighbourhood_mm=neighbourhood_mm,
                          frame=None, progress=progress)
    n = np.asarray(vertices).shape[0]
    k1, k2 = np.zeros(n), np.zeros(n)
    d1, d2 = np.zeros((n, 3)), np.zeros((n, 3))
    # the first output copy of each input vertex, front copies first
    order = np.lexsort((np.arange(s.source.size), -s.side, s.source))
    first = order[np.r_[True, s.source[order][1:] != s.source[order][:-1]]] if order.size else order
    src = s.source[first]
    k1[src], k2[src] = s.k1[first], s.k2[first]
    d1[src], d2[src] = s.d1[first], s.d2[first]
    # twins merged into one output vertex get its values
    rep = s.representative
    return PrincipalCurvatures(k1[rep], k2[rep], d1[rep], d2[rep])


def max_curvature(
    vertices: ArrayLike,
    faces: ArrayLike,
    *,
    normals: ArrayLike | None = None,
    units: str | float | Units = "mm",
    neighbourhood_mm: float = DEFAULT_NEIGHBOURHOOD_MM,
) -> NDArray[np.float64]:
    """Per-vertex signed principal curvature of larger magnitude (the paper's kappa), mm^-1.

    A sphere of radius 10 mm gives 0.1 everywhere, a cylinder of radius r
    gives 1/r across its axis (> 0 on the outside when its faces wind
    outward). See :func:`principal_curvatures`.
    """
    return principal_curvatures(vertices, faces, normals=normals, units=units,
                                neighbourhood_mm=neighbourhood_mm).kappa


# -- the paper's test surface: a sine curve swept in depth ------------------------
def sine_sheet_height(x_mm: ArrayLike, *, amplitude_mm: float, wavelength_mm: float) -> NDArray[np.float64]:
    """Height ``z = A sin(2 pi x / L)`` of the sine sheet (mm)."""
    x = np.asarray(x_mm, dtype=np.float64)
    return amplitude_mm * np.sin(2.0 * np.pi * x / wavelength_mm)


def sine_sheet_curvature(x_mm: ArrayLike, *, amplitude_mm: float, wavelength_mm: float) -> NDArray[np.float64]:
    """Signed curvature (mm^-1) of the sine sheet seen from +z.

    For ``z = A sin(k x)``, ``k = 2 pi / L``, with the normal towards +z the
    curvature across the sheet is ``-z'' / (1 + z'^2)^(3/2)`` (> 0 at crests,
    convex; < 0 in troughs); along the sweep it is 0, so this is also the
    principal curvature of larger magnitude.
    """
    x = np.asarray(x_mm, dtype=np.float64)
    k = 2.0 * np.pi / wavelength_mm
    d1 = amplitude_mm * k * np.cos(k * x)
    d2 = -amplitude_mm * k * k * np.sin(k * x)
    return -d2 / (1.0 + d1 * d1) ** 1.5
