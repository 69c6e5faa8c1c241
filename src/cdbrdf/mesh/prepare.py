"""A user's mesh made ready to render: repaired, in mm, framed, upright, with its curvature.

:func:`prepare_mesh` reads a mesh file (or takes a :class:`~cdbrdf.mesh.Mesh`),
repairs it, gives it the material's frame and its curvatures in mm^-1
(:mod:`cdbrdf.mesh.curvature`) and checks them against a table's kappa range.

**Up axis** (:func:`detect_up`): the one the file records (a PLY written by
cdbrdf; glTF is Y-up by its specification); else a flat object (its extent
along y or z below a fifth of the other two) lies on that axis; else the
format's convention: Y for OBJ, glTF and OFF, Z for PLY and STL (Blender's
PLY and STL exporters and most CAD and 3-D printing tools). ``up="y"`` or
``"z"`` overrides it. :func:`z_up_mesh` turns a mesh into the z-up world
frame by ``(x, y, z) -> (x, -z, y)``, so a Y-up mesh's front (+z) faces a
camera at azimuth -90 degrees.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable
from os import PathLike
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..errors import MeshError, OptionError
from .core import Mesh
from .curvature import check_neighbourhood, neighbourhood_from_table, surface_curvature
from .estimate import DEFAULT_NEIGHBOURHOOD_MM
from .io import read_mesh
from .units import check_kappa_range, check_size, parse_units

__all__ = ["UP_AXES", "prepare_mesh", "detect_up", "to_z_up", "z_up_mesh", "check_up"]

_LOG = logging.getLogger(__name__)

#: Up axes a mesh can be given (``"auto"``: :func:`detect_up`).
UP_AXES: tuple[str, ...] = ("auto", "y", "z")

_Y_TO_Z = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])


def prepare_mesh(
    source: str | PathLike[str] | Mesh,
    *,
    units: str | float | None = None,
    neighbourhood_mm: float | None = None,
    frame: str | None = None,
    table: Any = None,
    kappa_range: tuple[float, float] | None = None,
    recompute: bool = False,
    progress: Callable[[int, int], None] | None = None,
) -> Mesh:
    """Read a user mesh for rendering: repair it, give it a frame and its curvatures in mm^-1.

    Parameters
    ----------
    source
        A mesh file (any of :data:`cdbrdf.mesh.MESH_FORMATS`) or a
        :class:`~cdbrdf.mesh.Mesh` (not modified).
    units
        The mesh's length unit (``mm``, ``cm``, ``m``, ``in`` or mm per unit);
        default: the one the file records (a PLY written by cdbrdf, glTF's
        metre), else mm.
    neighbourhood_mm
        Diameter of the neighbourhood the curvature is fitted over, mm;
        default: the table's measured patch when its provenance records it
        (:func:`cdbrdf.mesh.neighbourhood_from_table`), else
        :data:`cdbrdf.mesh.DEFAULT_NEIGHBOURHOOD_MM`.
    frame
        Source of the material's x axis (:data:`cdbrdf.mesh.FRAMES`,
        default ``"auto"``).
    table
        The table to be rendered: its provenance gives the default
        neighbourhood, its kappa range the check of the curvature (a warning
        with the share of the surface outside it, and the likely unit).
    kappa_range
        Without a table: the kappa range to check the curvature against.
    recompute
        Compute the curvature even when the file has it.
    progress
        ``progress(done, total)`` while fitting, in vertices.

    Returns
    -------
    Mesh
        The renderable mesh: repaired faces, normals, UVs carrying the frame,
        attributes ``"curvature"`` (maximum) and ``"curvature_dir"``
        (directional) in mm^-1; its metadata says what was done
        (``"repairs"``, ``"notes"``, ``"units"``, ``"neighbourhood_mm"``,
        ``"frame"``, and with a table ``"outside_share"``).

    Raises
    ------
    MeshError
        For a file that cannot be read, a mesh with nothing to render, an
        unknown unit or frame, a mesh more than
        :data:`cdbrdf.mesh.MAX_SIZE_MM` across.

    Notes
    -----
    The curvature of a file written by ``cdbrdf curvature`` is used as it
    is when the file records its unit and was computed with the unit,
    neighbourhood and frame asked for (or none is asked for); otherwise it
    is computed again (a curvature of unknown unit is never used).
    """
    if isinstance(source, Mesh):
        mesh, name = source.copy(), str(source.metadata.get("source", "mesh"))
    else:
        mesh, name = read_mesh(source), str(source)
    meta = mesh.metadata
    notes: list[str] = list(meta.get("notes", []))
    recorded_units = meta.get("units")
    if units is not None:
        u = parse_units(units)
        units_note = f"units: {u} (given)"
    elif recorded_units is not None:
        u = parse_units(recorded_units)
        units_note = f"units: {u} (recorded in the file)" if meta.get("format") == "ply" else \
            f"units: {u} ({str(meta.get('format', '')).upper()}'s unit)"
    else:
        u = parse_units("mm")
        units_note = "units: mm (none given or recorded; give the mesh's unit if it is not mm)"
    check_size(mesh.vertices, u, name=name)  # a vertex 1e10 mm away would leave the object invisible
    if neighbourhood_mm is not None:
        nb, nb_note = check_neighbourhood(neighbourhood_mm), "given"
    elif table is not None:
        nb, nb_note = neighbourhood_from_table(getattr(table, "attrs", None))
    else:
        nb, nb_note = DEFAULT_NEIGHBOURHOOD_MM, "the default"
    reuse = (not recompute and "curvature" in mesh.attributes and "curvature_dir" in mesh.attributes
             and meta.get("curvature_units") == "1/mm" and recorded_units is not None
             and mesh.uv is not None
             and (units is None or parse_units(recorded_units) == u)
             and (neighbourhood_mm is None or _same_number(meta.get("neighbourhood_mm"), nb))
             and (frame is None or meta.get("frame") == frame))
    if reuse:
        repairs: list[str] = []
        notes.append("curvature: as recorded in the file")
        if _is_number(meta.get("neighbourhood_mm")):
            nb, nb_note = float(meta["neighbourhood_mm"]), "recorded in the file"
        out = mesh
    else:
        if "curvature" in mesh.attributes and not recompute:
            notes.append("curvature: computed again (the file's has no recorded unit, or other settings)")
        s = surface_curvature(mesh.vertices, mesh.faces, uv=mesh.uv, normals=mesh.normals, tangents=mesh.tangents,
                              units=u, neighbourhood_mm=nb, frame=frame or "auto", name=name, progress=progress)
        repairs = list(s.repairs)
        notes.extend(s.notes)
        attrs = {k: a[s.source] for k, a in mesh.attributes.items() if k not in ("curvature", "curvature_dir")}
        attrs["curvature"] = s.kappa
        attrs["curvature_dir"] = s.directional
        out = Mesh(mesh.vertices[s.source], s.faces, s.normals, s.uv, attrs,
                   None if mesh.tangents is None else mesh.tangents[s.source], dict(meta))
        out.metadata.update({"curvature_units": "1/mm", "neighbourhood_mm": nb, "frame": s.frame})
    out.metadata["units"] = u.name
    out.metadata["repairs"] = repairs
    out.metadata["neighbourhood_note"] = f"neighbourhood: {nb:g} mm ({nb_note})"
    out.metadata["units_note"] = units_note
    if table is not None:
        kappa = np.asarray(table.kappa, dtype=np.float64)
        kappa_range = (float(kappa.min()), float(kappa.max()))
    if kappa_range is not None:
        areas = _vertex_areas(out.vertices, out.faces)
        diag = float(np.linalg.norm(out.vertices.max(0) - out.vertices.min(0)))
        chk = check_kappa_range(out.attributes["curvature"], areas, kappa_range, units=u, size_units=diag)
        out.metadata["outside_share"] = chk.outside_share
        if chk.message:
            _LOG.warning("%s: %s", name, chk.message)
    out.metadata["notes"] = notes
    return out


def _is_number(x: Any) -> bool:
    try:
        return math.isfinite(float(x))
    except (TypeError, ValueError):
        return False


def _same_number(a: Any, b: float) -> bool:
    return _is_number(a) and math.isclose(float(a), b, rel_tol=1e-6)


def _vertex_areas(v: NDArray[np.float64], f: NDArray[np.int64]) -> NDArray[np.float64]:
    p = v[f]
    a = 0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)
    return np.bincount(f.reshape(-1), weights=np.repeat(a / 3.0, 3), minlength=v.shape[0]).astype(np.float64)


def detect_up(mesh: Mesh) -> tuple[str, str]:
    """The up axis of a mesh and why (see the module's description).

    Parameters
    ----------
    mesh
        The mesh.

    Returns
    -------
    up : str
        ``"y"`` or ``"z"``.
    reason : str
        Why, in a few words.
    """
    rec = mesh.metadata.get("up")
    if rec in ("y", "z"):
        why = "glTF's convention" if mesh.metadata.get("format") in ("gltf", "glb") else "recorded in the file"
        return str(rec), why
    e = mesh.vertices.max(0) - mesh.vertices.min(0) if mesh.n_vertices else np.ones(3)
    if e[2] < 0.2 * min(e[0], e[1]):
        return "z", "the object is flat along z"
    if e[1] < 0.2 * min(e[0], e[2]):
        return "y", "the object is flat along y"
    fmt = str(mesh.metadata.get("format", "ply"))
    if fmt in ("obj", "gltf", "glb", "off"):
        return "y", f"{fmt.upper()}'s usual convention"
    return "z", f"{fmt.upper()}'s usual convention"


def to_z_up(points: NDArray[np.float64], up: str) -> NDArray[np.float64]:
    """Points (or normals) of a mesh in the z-up world frame.

    Parameters
    ----------
    points
        ``(n, 3)`` points or directions.
    up
        The mesh's up axis, ``"y"`` or ``"z"``.

    Returns
    -------
    numpy.ndarray
        ``(n, 3)`` in the z-up frame.
    """
    if up == "z":
        return points
    if up == "y":
        return points @ _Y_TO_Z.T
    raise MeshError(f"up: {up!r} is not one of y, z")


def check_up(up: object) -> None:
    """Refuse an up axis that is not one of :data:`UP_AXES`.

    Parameters
    ----------
    up
        The value given.

    Raises
    ------
    MeshError
        For another value (the message lists the valid ones).
    """
    if up not in UP_AXES:
        raise OptionError(f"up: {up!r:.40} is not one of {', '.join(UP_AXES)}")


def z_up_mesh(mesh: Mesh, up: str = "auto") -> tuple[Mesh, str, str]:
    """A copy of ``mesh`` in the z-up world frame, the up axis it had and why.

    Vertices, normals and tangents are turned (:func:`to_z_up`) and the
    copy records ``up = "z"``.

    Parameters
    ----------
    mesh
        The mesh.
    up
        ``"auto"`` (:func:`detect_up`), ``"y"`` or ``"z"``.

    Returns
    -------
    mesh : Mesh
        The copy, z up.
    up : str
        The axis ``mesh`` had.
    reason : str
        Why; ``"given"`` for an explicit axis.
    """
    check_up(up)
    axis, why = detect_up(mesh) if up == "auto" else (up, "given")
    world = mesh.copy()
    world.vertices = to_z_up(mesh.vertices, axis)
    if mesh.normals is not None:
        world.normals = to_z_up(mesh.normals, axis)
    if mesh.tangents is not None:
        world.tangents = to_z_up(mesh.tangents, axis)
    world.metadata["up"] = "z"
    return world, axis, why
