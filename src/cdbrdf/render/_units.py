"""Lengths in scenes: the scene's unit, shapes' ``to_world`` scales, and whether the curvature is plausible.

The curvature attribute of a mesh is in mm^-1 of the mesh as stored in its
file; the curvature the plug-in looks up is

    kappa = attribute x curvature_scale x m_file / (s x unit_mm)

with ``s`` the uniform scale of the shape's ``to_world``, ``unit_mm`` the
scene's unit (mm per scene unit: the ``cdbrdf`` BSDF's ``unit``, or the
loader's ``unit_mm``) and ``m_file`` the mesh file's unit when its PLY
header records one, else 1 (:func:`scene_factor`). cdbrdf's loaders
(:func:`cdbrdf.render.load_file`, :func:`cdbrdf.render.load_dict`) apply it
per shape. Mitsuba's own loaders give a plug-in no shape, so there the
attribute is used as it is (right when each ``to_world`` turns its mesh's
unit into the scene's, as in a scene in metres whose mm meshes are scaled
by 0.001).

:func:`curvature_warning` is the check of the curvature the renderer sees
against the table's kappa range (:func:`cdbrdf.mesh.check_kappa_range`,
with the likely unit).
"""

from __future__ import annotations

import math
from os import PathLike
from typing import Any

import numpy as np

from ..errors import SceneError
from ..mesh import UNITS_MM, Units, check_kappa_range, parse_units, ply_metadata

__all__ = ["uniform_scale", "ply_unit_mm", "scene_factor", "scene_units", "curvature_warning"]

#: Relative tolerance on the singular values of a "uniform" scale.
_UNIFORM_RTOL = 1e-5


def uniform_scale(matrix: Any, *, what: str = "to_world") -> float:
    """The uniform scale of an affine 4x4 (or 3x3) matrix; a :class:`SceneError` for a non-uniform one."""
    m = np.asarray(matrix, dtype=np.float64)
    m3 = m[:3, :3]
    if not np.isfinite(m).all():  # SVD of NaN raises LinAlgError naming nothing
        raise SceneError(f"{what}: the transform has NaN or infinite entries")
    sv = np.linalg.svd(m3, compute_uv=False)
    if not np.all(np.isfinite(sv)) or sv[-1] <= 0.0:
        raise SceneError(f"{what}: the transform is singular or not finite")
    if sv[0] - sv[-1] > _UNIFORM_RTOL * sv[0]:
        raise SceneError(
            f"{what}: non-uniform scale (factors {', '.join(f'{x:.6g}' for x in sv)}) changes the "
            "curvature differently along each direction; bake the transform into the mesh and compute "
            "its curvature with `cdbrdf curvature`"
        )
    return float(np.prod(sv) ** (1.0 / 3.0))


def ply_unit_mm(path: str | PathLike[str]) -> float | None:
    """The unit (mm per file unit) a PLY header records (``comment cdbrdf units ...``), or None.

    Reads the header only (:func:`cdbrdf.mesh.ply_metadata`, the reader of
    :func:`cdbrdf.mesh.read_ply`); a file that cannot be read, a damaged
    header or a unit :func:`cdbrdf.mesh.parse_units` does not accept counts
    as none recorded (Mitsuba's loader then says what is wrong with the file).
    """
    from ..errors import MeshError

    try:
        unit = ply_metadata(path).get("units")  # never a FIFO or /dev/zero; the header only
        return None if unit is None else float(parse_units(unit).mm_per_unit)
    except (OSError, MeshError):
        return None


def scene_units(value: Any, *, what: str = "unit") -> Units:
    """The scene unit of a ``unit`` parameter (a name of :data:`cdbrdf.mesh.UNITS_MM` or mm per unit)."""
    from ..errors import MeshError

    try:
        return parse_units(value if isinstance(value, str) else float(value))
    except (MeshError, TypeError, ValueError):
        raise SceneError(f"cdbrdf BSDF: {what} {value!r:.40} is neither one of {', '.join(UNITS_MM)} nor a "
                         "positive number of millimetres per scene unit") from None


def scene_factor(*, m_file: float | None, scale: float, unit_mm: float) -> float:
    """The factor on a curvature attribute: ``m_file / (scale x unit_mm)`` (see the module's description)."""
    return (m_file if m_file is not None else 1.0) / (scale * unit_mm)


def curvature_warning(shapes: list[tuple[Any, Any]]) -> str | None:
    """One line when the curvature the renderer sees is implausible for cloth, else None.

    Parameters
    ----------
    shapes
        ``(mesh, bsdf)`` for every mesh with a ``cdbrdf`` BSDF that reads a
        curvature attribute: the attribute times the BSDF's
        ``curvature_scale`` is the curvature looked up (mm^-1).

    Returns
    -------
    str or None
        The share of the surface (by area) outside the tables' kappa range,
        over all those meshes, with the likely scene unit when the surface
        bends tighter than a yarn (:func:`cdbrdf.mesh.check_kappa_range`).
    """
    ks, ws = [], []
    lo, hi = math.inf, -math.inf
    unit = None
    for mesh, bsdf in shapes:
        attr = bsdf.curvature_attribute
        if attr is None or not mesh.has_attribute(attr):
            continue
        k = np.asarray(mesh.attribute_buffer(attr), dtype=np.float64).reshape(-1) * bsdf.settings.curvature_scale
        v = np.asarray(mesh.vertex_positions_buffer(), dtype=np.float64).reshape(-1, 3)
        f = np.asarray(mesh.faces_buffer(), dtype=np.int64).reshape(-1, 3)
        if k.size != v.shape[0] or f.size == 0:
            continue
        p = v[f]
        a = 0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)
        unit = bsdf.units
        ws.append(np.bincount(f.reshape(-1), np.repeat(a / 3.0, 3), v.shape[0]) * unit.mm_per_unit**2)
        ks.append(k)
        kappa = np.asarray(bsdf.table.kappa, dtype=np.float64)
        lo, hi = min(lo, float(kappa.min())), max(hi, float(kappa.max()))
    if not ks or unit is None:
        return None
    chk = check_kappa_range(np.concatenate(ks), np.concatenate(ws), (lo, hi), units=unit)
    if chk.message is None:
        return None
    msg = f"the scene's curvature (scene unit {unit}): {chk.message}"
    if chk.likely_units is None:
        return msg
    return (msg.replace("with --units", "with the scene unit")
            + " (the cdbrdf BSDF's 'unit', or --units of cdbrdf render SCENE.xml)")
