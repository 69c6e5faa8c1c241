"""A user's mesh made ready to render: repaired, in mm, framed, upright, with its curvature.

:func:`prepare_mesh` reads a mesh file (or takes a :class:`~cdbrdf.mesh.Mesh`),
repairs it, gives it the material's frame and its curvatures in mm^-1
(:mod:`cdbrdf.mesh.curvature`) and checks them against a table's kappa range.

**Up axis** (:func:`detect_up`), from the geometry first: the axis a PLY
written by cdbrdf records; else a flat object (its extent along y or z
below a fifth of the other two) lies on that axis; else the direction the
open boundaries point (a garment's neck, hem and sleeves, a figure's neck
and base: the boundaries after the seams are closed, each weighted by its
perimeter, decide when y or z has 1.5 times the other's share); else a flat
base (a planar cap at one end of an axis holding at least 2 % of the
surface, as scans are cut); else the taller of y and z (by 1.2 times). The
format's convention (Y for OBJ, glTF and OFF, Z for PLY and STL) decides
only when the geometry does not, and a geometry that disagrees with it is
logged as a warning. ``up="y"`` or ``"z"`` overrides it. :func:`z_up_mesh`
turns a mesh into the z-up world frame by ``(x, y, z) -> (x, -z, y)``, so a
Y-up mesh's front (+z) faces a camera at azimuth -90 degrees.
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
from .curvature import check_neighbourhood, neighbourhood_from_table, outside_by_location, surface_curvature
from .curvature_map import SHAPE_ATTRIBUTES, mesh_shape_operator
from .estimate import DEFAULT_NEIGHBOURHOOD_MM
from .io import read_mesh
from .maps import SurfaceMaps, apply_maps
from .units import check_kappa_range, check_size, parse_units

__all__ = ["UP_AXES", "prepare_mesh", "has_own_uv", "detect_up", "to_z_up", "z_up_mesh", "check_up"]

_LOG = logging.getLogger(__name__)

#: Up axes a mesh can be given (``"auto"``: :func:`detect_up`).
UP_AXES: tuple[str, ...] = ("auto", "y", "z")

#: An axis is the openings' when their length along it is at least this many times that along the other.
OPENINGS_RATIO = 1.5

#: Share of the surface a flat base must have (a scan's cut).
BASE_SHARE = 0.02

#: An axis is the tallest when the extent along it is at least this many times that along the other.
EXTENT_RATIO = 1.2

_Y_TO_Z = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])


def has_own_uv(mesh: Mesh) -> bool:
    """Whether a mesh's UVs are its own (read from its file), not the per-face ones :func:`prepare_mesh` makes.

    Without UVs of its own a prepared mesh gets per-face UVs carrying its
    frame (``"tangent"`` or ``"principal"``); they follow no fabric and jump
    at every edge, so a texture laid by UV (a CD-BTF's texels) must not use them.

    Parameters
    ----------
    mesh
        A mesh, prepared or not.

    Returns
    -------
    bool
        True when the mesh has UVs and they are not ones prepare_mesh made.
    """
    return mesh.uv is not None and mesh.metadata.get("frame", "uv") == "uv"


def prepare_mesh(
    source: str | PathLike[str] | Mesh,
    *,
    units: str | float | None = None,
    neighbourhood_mm: float | None = None,
    frame: str | None = None,
    table: Any = None,
    kappa_range: tuple[float, float] | None = None,
    recompute: bool = False,
    maps: SurfaceMaps | None = None,
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
    maps
        The maps laid on it by its UVs and their UV scale
        (:class:`~cdbrdf.mesh.SurfaceMaps`, :func:`cdbrdf.mesh.apply_maps`):
        baked per texel into ``metadata["curvature_map"]`` for the renderer,
        or per vertex into the curvature. Default: the maps the file names
        (an OBJ's MTL ``norm``/``bump``/``disp``, a glTF's ``normalTexture``),
        baked per texel. A map needs the mesh's own UVs.
    progress
        ``progress(done, total)`` while fitting, in vertices.

    Returns
    -------
    Mesh
        The renderable mesh: repaired faces, normals, UVs carrying the frame,
        attributes ``"curvature"`` (maximum) and ``"curvature_dir"``
        (directional) in mm^-1 and its shape operator
        (:data:`~cdbrdf.mesh.curvature_map.SHAPE_ATTRIBUTES`, mm^-1, frame
        x = dP/du, y = n x x); with maps ``"uv_scale"``, ``"uv_scale_rule"``
        and ``"curvature_map"`` (:func:`cdbrdf.mesh.apply_maps`); its metadata says what was done
        (``"repairs"``, ``"notes"``, ``"units"``, ``"neighbourhood_mm"``,
        ``"frame"``, ``"location"`` (:data:`cdbrdf.mesh.curvature.LOCATIONS`
        index per vertex), and with a table ``"outside_share"`` and
        ``"outside_by_location"``: per location the vertices outside the
        table's kappa range and all of them).

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
             and all(k in mesh.attributes for k in SHAPE_ATTRIBUTES)
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
        own = ("curvature", "curvature_dir", *SHAPE_ATTRIBUTES)
        attrs = {k: a[s.source] for k, a in mesh.attributes.items() if k not in own}
        attrs["curvature"] = s.kappa
        attrs["curvature_dir"] = s.directional
        attrs.update(zip(SHAPE_ATTRIBUTES, mesh_shape_operator(s.k1, s.k2, s.d1, s.d2, s.tangent, s.normals),
                         strict=True))
        out = Mesh(mesh.vertices[s.source], s.faces, s.normals, s.uv, attrs,
                   None if mesh.tangents is None else mesh.tangents[s.source], dict(meta))
        out.metadata.update({"curvature_units": "1/mm", "neighbourhood_mm": nb, "frame": s.frame,
                             "location": s.location})
    out.metadata["units"] = u.name
    out.metadata["repairs"] = repairs
    out.metadata["neighbourhood_note"] = f"neighbourhood: {nb:g} mm ({nb_note})"
    out.metadata["units_note"] = units_note
    if table is not None:
        kappa = np.asarray(table.kappa, dtype=np.float64)
        kappa_range = (float(kappa.min()), float(kappa.max()))
    out.metadata["notes"] = notes
    out = apply_maps(out, maps, name=name, kappa_range=kappa_range)
    notes = list(out.metadata["notes"])
    if kappa_range is not None:
        areas = _vertex_areas(out.vertices, out.faces)
        diag = float(np.linalg.norm(out.vertices.max(0) - out.vertices.min(0)))
        chk = check_kappa_range(out.attributes["curvature"], areas, kappa_range, units=u, size_units=diag)
        out.metadata["outside_share"] = chk.outside_share
        if chk.message:
            _LOG.warning("%s: %s", name, chk.message)
        loc = out.metadata.get("location")
        if isinstance(loc, np.ndarray) and loc.shape == (out.n_vertices,):
            by = outside_by_location(out.attributes["curvature"], loc, kappa_range)
            out.metadata["outside_by_location"] = by
            n_out = sum(o for o, _ in by.values())
            notes.append(f"curvature outside the table's range [{min(kappa_range):g}, {max(kappa_range):g}] 1/mm: "
                         f"{n_out} of {out.n_vertices} vertices ({n_out / max(out.n_vertices, 1):.2%}; "
                         + ", ".join(f"{k} {o} of {t}" for k, (o, t) in by.items()) + ")")
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


def _open_loops(v: NDArray[np.float64], f: NDArray[np.int64]) -> list[NDArray[np.int64]]:
    """The open boundaries of a mesh with its seams closed: vertex sets of its boundary loops (welded indices)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    from .repair import weld

    wid = weld(v)
    fw = wid[f]
    fw = fw[(fw[:, 0] != fw[:, 1]) & (fw[:, 1] != fw[:, 2]) & (fw[:, 2] != fw[:, 0])]
    e = np.sort(np.concatenate([fw[:, [0, 1]], fw[:, [1, 2]], fw[:, [2, 0]]]), axis=1)
    edges, count = np.unique(e, axis=0, return_counts=True)
    b = edges[count == 1]
    if b.size == 0:
        return []
    n = int(wid.max()) + 1
    g = coo_matrix((np.ones(b.shape[0]), (b[:, 0], b[:, 1])), shape=(n, n))
    _, label = connected_components(g, directed=False)
    verts = np.unique(b)
    first = np.zeros(n, np.int64)
    first[wid[::-1]] = np.arange(wid.size)[::-1]  # an input vertex of each welded one
    return [first[verts[label[verts] == c]] for c in np.unique(label[verts])]


def _openings_axis(mesh: Mesh) -> tuple[NDArray[np.float64], int]:
    """Per axis (x, y, z) the length of the open boundaries pointing along it, and the number of openings."""
    v = mesh.vertices
    score = np.zeros(3)
    loops = [lp for lp in _open_loops(v, mesh.faces) if lp.size >= 3]
    centre = v.mean(axis=0)
    for lp in loops:
        p = v[lp]
        c = p.mean(axis=0)
        # the loop's direction: its plane's normal (least spread), pointing away from the object
        _, _, vt = np.linalg.svd(p - c, full_matrices=False)
        d = vt[-1] if np.dot(vt[-1], c - centre) >= 0 else -vt[-1]
        length = float(np.sqrt(np.sum((p - c) ** 2, axis=1)).mean()) * 2 * math.pi  # about its perimeter
        score += length * np.abs(d)
    return score, len(loops)


def _base_axis(mesh: Mesh) -> tuple[int, float] | None:
    """The axis of a flat base (a planar cap at the bottom of a scan) and its share of the area, or None."""
    v, f = mesh.vertices, mesh.faces
    p = v[f]
    cr = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    area = 0.5 * np.linalg.norm(cr, axis=1)
    total = float(area.sum())
    if not total > 0:
        return None
    nrm = cr / np.maximum(2 * area, 1e-300)[:, None]
    lo, hi = v.min(axis=0), v.max(axis=0)
    best: tuple[int, float] | None = None
    for a in range(3):
        tol = 0.01 * float(hi[a] - lo[a])
        flat = np.abs(nrm[:, a]) > 0.999
        for end in (lo[a], hi[a]):
            at = flat & (np.abs(p[:, :, a] - end).max(axis=1) <= tol)
            share = float(area[at].sum()) / total
            if share >= BASE_SHARE and (best is None or share > best[1]):
                best = (a, share)
    return best


def detect_up(mesh: Mesh) -> tuple[str, str]:
    """The up axis of a mesh and why, from its geometry (see the module's description).

    A disagreement between the geometry and the file format's convention is
    logged as a warning (``--up`` overrides both).

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
    fmt = str(mesh.metadata.get("format", "ply"))
    rec = mesh.metadata.get("up")
    if rec in ("y", "z") and fmt not in ("gltf", "glb"):
        return str(rec), "recorded in the file"
    convention = "y" if fmt in ("obj", "gltf", "glb", "off") else "z"
    conv_why = "glTF's specification" if fmt in ("gltf", "glb") else f"{fmt.upper()}'s usual convention"
    if mesh.n_vertices == 0 or mesh.faces.size == 0:
        return convention, conv_why
    e = mesh.vertices.max(0) - mesh.vertices.min(0)
    axis: str | None = None
    why = ""
    if e[2] < 0.2 * min(e[0], e[1]):
        axis, why = "z", "the object is flat along z"
    elif e[1] < 0.2 * min(e[0], e[2]):
        axis, why = "y", "the object is flat along y"
    else:
        score, n_open = _openings_axis(mesh)
        yz = score[1:]
        if n_open and yz.max() > 0 and yz.max() >= OPENINGS_RATIO * yz.min() and yz.max() >= score[0]:
            axis = "yz"[int(np.argmax(yz))]
            why = (f"its {n_open} open boundar{'y points' if n_open == 1 else 'ies point'} mostly along {axis} "
                   "(a garment's neck, hem and sleeves, a scan's cut base)")
        else:
            base = _base_axis(mesh)
            if base is not None and base[0] > 0:
                axis = "xyz"[base[0]]
                why = f"a flat base across {axis} ({base[1]:.0%} of the surface)"
            elif max(e[1], e[2]) >= EXTENT_RATIO * min(e[1], e[2]) and max(e[1], e[2]) >= e[0]:
                axis = "y" if e[1] > e[2] else "z"
                why = f"the object is tallest along {axis}"
    if axis is None:
        return convention, conv_why + " (the geometry does not tell)"
    if axis != convention:
        name = str(mesh.metadata.get("source", "mesh"))
        _LOG.warning("%s: the geometry says the up axis is %s (%s) while %s is %s; using %s (--up overrides)",
                     name, axis, why, conv_why, convention, axis)
        why += f"; not {conv_why}, {convention}"
    return axis, why


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
