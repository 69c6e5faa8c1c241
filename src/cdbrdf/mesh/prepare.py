"""A user's mesh made ready to render: repaired, in its unit, framed, upright, with its curvature.

:func:`prepare_mesh` reads a mesh file (or takes a :class:`~cdbrdf.mesh.Mesh`),
repairs it, gives it the material's frame and its curvatures in mm^-1
(:mod:`cdbrdf.mesh.curvature`) and checks them against a table's kappa range.

**Unit**: given, recorded by cdbrdf or stated by the file
(:mod:`cdbrdf.mesh.statements`), else inferred from the size of a garment or
a sheet (:func:`cdbrdf.mesh.units.infer_units`), else mm; the note
``units_note`` says which (``units: inferred dm from the size: 1.14 m tall,
1.05 m across as a garment (0.2-2.5 m)``). A stated unit that makes a garment
implausibly large or small is followed, with a warning.

**Up axis** (:func:`detect_up`): what the file states first (a PLY written by
cdbrdf, glTF's specification, a header comment such as ``# Y-up``, a
MakeHuman asset), else the geometry (:mod:`cdbrdf.mesh.shape`), by the first
rule that decides:

1. a flat object (its extent along y or z below a fifth of the other two)
   lies on that axis (a pattern laid out, a swatch);
2. a flat base (a plane capping the surface at its extreme across a crease:
   a scan's cut, a plinth, slanting up to 40 degrees);
3. the left-right mirror plane: when it is across y or z, the other is up;
4. the openings (a garment's neck, hem and cuffs, a scan's open base, with
   the seams closed: each points away from the cloth, weighted by its
   length) point along y or z 1.5 times as much as along the other;
5. separate panels (a CAD stage) hang around a body, so they face across
   the up axis 1.5 times less; one sheet (a drape) faces up 1.25 times more;
6. the taller of y and z (by 1.2 times).

Else the tool's default (Blender's, Maya's and 3ds Max's OBJ exports are
Y-up), else the format's convention (Y for OBJ, glTF and OFF, Z for PLY and
STL). A geometry that disagrees with the convention or with what the file
states is logged as a warning. ``up="y"`` or ``"z"`` overrides it.
:func:`z_up_mesh` turns a mesh into the z-up world frame by ``(x, y, z) ->
(x, -z, y)``, so a Y-up mesh's front (+z) faces a camera at azimuth -90
degrees.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable
from dataclasses import dataclass
from os import PathLike
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..errors import MeshError, OptionError
from .attributes import CURVATURE_MODES, SHAPE_ATTRIBUTES
from .core import Mesh
from .curvature import check_neighbourhood, neighbourhood_from_table, outside_by_location, surface_curvature
from .curvature_map import mesh_shape_operator
from .estimate import DEFAULT_NEIGHBOURHOOD_MM
from .frames import FRAMES
from .io import read_mesh
from .maps import SurfaceMaps, apply_maps
from .shape import Shape
from .units import Units, check_garment_size, check_kappa_range, check_size, infer_units, parse_units

__all__ = ["UP_AXES", "MeshSurface", "prepare_mesh", "has_own_uv", "detect_up", "to_z_up", "z_up_mesh", "check_up"]

_LOG = logging.getLogger(__name__)

#: Up axes a mesh can be given (``"auto"``: :func:`detect_up`).
UP_AXES: tuple[str, ...] = ("auto", "y", "z")

#: A flat object (its extent along y or z below this share of the other two) lies on that axis.
FLAT_SHARE = 0.2

#: A flat base decides when its normal's component along y or z is this many times that along the other
#: (a cut slanting up to 40 degrees, from under a chin to the nape).
BASE_RATIO = 1.15

#: The mirror plane's axis is the left-right axis when its asymmetry is below this share of the next axis's.
SYMMETRY_RATIO = 0.6

#: and when every other axis is at least this many vertex spacings off (a mirror image on two axes tells nothing).
ASYMMETRIC_SPACINGS = 0.5

#: An axis is the openings' when they point along it at least this many times as much as along the other.
OPENINGS_RATIO = 1.5

#: Separate panels (hanging around a body) face across the up axis at most 1 / this as much as the other.
PANELS_RATIO = 1.5

#: One sheet faces along the up axis at least this many times as much as along the other.
SHEET_RATIO = 1.25

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
        The mesh's length unit (``mm``, ``cm``, ``dm``, ``m``, ``in`` or mm
        per unit); default: the one the file records or states (a PLY written
        by cdbrdf, glTF's metre, a header comment, MakeHuman's decimetre),
        else the one a garment's or a sheet's size makes plausible, else mm
        (the metadata's ``"units_note"`` says which).
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
        (:data:`~cdbrdf.mesh.attributes.SHAPE_ATTRIBUTES`, mm^-1, frame
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
    u, units_note = _mesh_units(mesh, units, name)
    check_size(mesh.vertices, u, name=name)  # a vertex 1e10 mm away would leave the object invisible
    if neighbourhood_mm is not None:
        nb, nb_note = check_neighbourhood(neighbourhood_mm), "given"
    elif table is not None:
        nb, nb_note = neighbourhood_from_table(getattr(table, "attrs", None))
    else:
        nb, nb_note = DEFAULT_NEIGHBOURHOOD_MM, "the default"
    k_max, k_dir = CURVATURE_MODES["max"].attribute, CURVATURE_MODES["directional"].attribute
    reuse = (not recompute and k_max in mesh.attributes and k_dir in mesh.attributes
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
        if k_max in mesh.attributes and not recompute:
            notes.append("curvature: computed again (the file's has no recorded unit, or other settings)")
        given = maps is not None and any(m is not None for m in (maps.normal_map, maps.height_map, maps.hires_mesh))
        from_file = (maps is None or maps.from_file) and (meta.get("normal_map") is not None
                                                          or meta.get("height_map") is not None)
        mapped = mesh.uv is not None and (given or from_file)  # maps need the file's UVs, however cut
        s = surface_curvature(mesh.vertices, mesh.faces, uv=mesh.uv, normals=mesh.normals, tangents=mesh.tangents,
                              units=u, neighbourhood_mm=nb, frame=frame or ("uv" if mapped else "auto"), name=name,
                              progress=progress)
        repairs = list(s.repairs)
        notes.extend(s.notes)
        own = (k_max, k_dir, *SHAPE_ATTRIBUTES)
        attrs = {k: a[s.source] for k, a in mesh.attributes.items() if k not in own}
        attrs[k_max] = s.kappa
        attrs[k_dir] = s.directional
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
        chk = check_kappa_range(out.attributes[k_max], areas, kappa_range, units=u, size_units=diag)
        out.metadata["outside_share"] = chk.outside_share
        if chk.message:
            _LOG.warning("%s: %s", name, chk.message)
        loc = out.metadata.get("location")
        if isinstance(loc, np.ndarray) and loc.shape == (out.n_vertices,):
            by = outside_by_location(out.attributes[k_max], loc, kappa_range)
            out.metadata["outside_by_location"] = by
            n_out = sum(o for o, _ in by.values())
            notes.append(f"curvature outside the table's range [{min(kappa_range):g}, {max(kappa_range):g}] 1/mm: "
                         f"{n_out} of {out.n_vertices} vertices ({n_out / max(out.n_vertices, 1):.2%}; "
                         + ", ".join(f"{k} {o} of {t}" for k, (o, t) in by.items()) + ")")
    out.metadata["notes"] = notes
    return out


@dataclass(frozen=True)
class MeshSurface:
    """A user's mesh as a surface to render, with how it is prepared (:func:`prepare_mesh`) and turned upright.

    Parameters
    ----------
    mesh
        A mesh file (:data:`cdbrdf.mesh.MESH_FORMATS`) or a :class:`~cdbrdf.mesh.Mesh`.
    units
        Its length unit (:func:`~cdbrdf.mesh.parse_units`: a name of
        :data:`~cdbrdf.mesh.UNITS_MM` or mm per unit); None: the one the file
        records or states, else the one its size makes plausible, else mm.
    neighbourhood_mm
        Diameter of the curvature's neighbourhood, mm, in
        :data:`~cdbrdf.mesh.NEIGHBOURHOOD_RANGE_MM`; None: the table's
        measured patch, else :data:`~cdbrdf.mesh.DEFAULT_NEIGHBOURHOOD_MM`.
    frame
        Source of the material's x axis (:data:`~cdbrdf.mesh.FRAMES`); None: ``"auto"``.
    up
        ``"auto"`` (:func:`detect_up`), ``"y"`` or ``"z"`` (:data:`UP_AXES`).

    Raises
    ------
    OptionError, MeshError
        For a value of the wrong kind or out of its range (one line, naming it).
    """

    mesh: str | PathLike[str] | Mesh
    units: str | float | None = None
    neighbourhood_mm: float | None = None
    frame: str | None = None
    up: str = "auto"

    def __post_init__(self) -> None:
        if not isinstance(self.mesh, (str, PathLike, Mesh)):
            raise OptionError(f"mesh: expected a mesh file or a cdbrdf.mesh.Mesh, got {type(self.mesh).__name__}")
        if self.units is not None:
            parse_units(self.units)
        if self.neighbourhood_mm is not None:
            object.__setattr__(self, "neighbourhood_mm", check_neighbourhood(self.neighbourhood_mm))
        if self.frame is not None and self.frame not in FRAMES:
            raise OptionError(f"frame: {self.frame!r:.40} is not one of {', '.join(FRAMES)}")
        check_up(self.up)

    @property
    def name(self) -> str:
        """The file's name, or a :class:`~cdbrdf.mesh.Mesh`'s source (``"mesh"`` without one)."""
        if isinstance(self.mesh, Mesh):
            return str(self.mesh.metadata.get("source", "mesh"))
        return str(self.mesh)

    def prepare(self, *, table: Any = None, maps: SurfaceMaps | None = None,
                progress: Callable[[int, int], None] | None = None) -> Mesh:
        """The mesh read (a file) and prepared to render (:func:`prepare_mesh`) with these settings.

        Parameters
        ----------
        table, maps, progress
            As for :func:`prepare_mesh`.

        Returns
        -------
        Mesh
            The prepared mesh (the given :class:`~cdbrdf.mesh.Mesh` is not modified).
        """
        source = self.mesh if isinstance(self.mesh, Mesh) else read_mesh(self.mesh)
        return prepare_mesh(source, units=self.units, neighbourhood_mm=self.neighbourhood_mm, frame=self.frame,
                            table=table, maps=maps, progress=progress)


def _mesh_units(mesh: Mesh, units: str | float | None, name: str) -> tuple[Units, str]:
    """The mesh's unit and the note saying where it comes from (see :mod:`cdbrdf.mesh.units`)."""
    from .shape import describe

    meta = mesh.metadata
    if units is not None:
        return parse_units(units), f"units: {parse_units(units)} (given)"
    rec, source = meta.get("units"), meta.get("units_source")
    if rec is not None and not source:
        u = parse_units(rec)
        return u, f"units: {u} (recorded in the file)" if meta.get("format") == "ply" and meta.get("source") else \
            f"units: {u} (the mesh's own)"
    if mesh.n_vertices == 0 or mesh.faces.size == 0:
        u = parse_units(rec if rec is not None else "mm")
        return u, f"units: {u} ({source or 'none given or recorded'})"
    shape = describe(mesh)
    up_axis = meta.get("up") if meta.get("up") in ("y", "z") else (_geometry_up(mesh, shape) or (None,))[0]
    up = None if up_axis is None else "xyz".index(str(up_axis))
    if rec is not None:
        u = parse_units(rec)
        note = f"units: {u} ({source})"
        warning = check_garment_size(shape, u, up=up)
        if warning:
            _LOG.warning("%s: %s", name, warning)
            note += "; implausible for a garment: see the warning"
        return u, note
    inferred = infer_units(shape, up=up)
    if inferred is not None:
        return inferred[0], f"units: {inferred[1]}"
    return parse_units("mm"), ("units: mm (none given or recorded, and the geometry is no garment or sheet whose "
                               "size would tell; give the mesh's unit if it is not mm)")


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


def _axis_pair(score: NDArray[np.float64], ratio: float, *, most: bool = True) -> tuple[str, str] | None:
    """``"y"`` or ``"z"``, whichever ``score`` (per axis x, y, z) favours by ``ratio`` (the larger, or with
    ``most=False`` the smaller), and how much more the larger is, in words; None when neither does."""
    y, z = float(score[1]), float(score[2])
    hi, lo = max(y, z), min(y, z)
    if not hi > 0 or hi < ratio * lo:
        return None
    r = hi / lo if lo > 0 else math.inf
    times = "more than 10 times" if not r <= 10 else f"{r:.1f} times"
    pick = ("y" if y > z else "z") if most else ("z" if y > z else "y")
    return pick, times


def _geometry_up(mesh: Mesh, shape: Shape | None = None) -> tuple[str, str] | None:
    """The up axis the geometry shows, and why (see the module's description); None when it does not tell."""
    from .shape import describe

    e = mesh.vertices.max(0) - mesh.vertices.min(0)
    if e[2] < FLAT_SHARE * min(e[0], e[1]):
        return "z", "the object is flat along z"
    if e[1] < FLAT_SHARE * min(e[0], e[2]):
        return "y", "the object is flat along y"
    shape = describe(mesh) if shape is None else shape
    if shape.base is not None:
        nrm, share = shape.base
        pick = _axis_pair(np.abs(nrm), BASE_RATIO)
        if pick is not None and abs(nrm[0]) < abs(nrm["xyz".index(pick[0])]):
            return pick[0], f"a flat base across {pick[0]} ({share:.0%} of the surface: a scan's cut, a plinth)"
    sym = shape.symmetry
    lateral = int(np.argmin(sym))
    others = np.delete(sym, lateral)
    if lateral > 0 and sym[lateral] <= SYMMETRY_RATIO * others.min() and others.min() >= ASYMMETRIC_SPACINGS:
        up = "z" if lateral == 1 else "y"
        return up, (f"it is mirror-symmetric across {'xyz'[lateral]}, its left-right axis ({sym[lateral]:.2f} "
                    f"vertex spacings off against {others.min():.2f} for the next axis), so {up} is up")
    openings = shape.openings()
    if openings:
        score = np.sum([np.abs(lp.direction) for lp in openings], axis=0)
        pick = _axis_pair(score, OPENINGS_RATIO)
        if pick is not None:
            n, other = len(openings), "yz".replace(pick[0], "")
            return pick[0], (f"its {n} opening{'s' if n > 1 else ''} (a garment's neck, hem and cuffs, a scan's open "
                             f"base) point along {pick[0]} {pick[1]} as much as along {other}")
    n_sheets = sum(c.kind in ("panel", "sheet") for c in shape.components)
    if n_sheets >= 2 and shape.share("panel", "sheet") >= 0.5:
        pick = _axis_pair(shape.normals, PANELS_RATIO, most=False)
        if pick is not None:
            other = "yz".replace(pick[0], "")
            return pick[0], (f"it is {n_sheets} separate panels hung around a body: they face along {other} "
                             f"{pick[1]} as much as along {pick[0]}")
    elif n_sheets == 1 and shape.share("panel", "sheet") >= 0.5:
        pick = _axis_pair(shape.normals, SHEET_RATIO)
        if pick is not None:
            other = "yz".replace(pick[0], "")
            return pick[0], f"it is one sheet, facing along {pick[0]} {pick[1]} as much as along {other}"
    pick = _axis_pair(e, EXTENT_RATIO)
    if pick is not None:
        other = "yz".replace(pick[0], "")
        return pick[0], f"the object is tallest along {pick[0]}, {pick[1]} its extent along {other}"
    return None


def detect_up(mesh: Mesh) -> tuple[str, str]:
    """The up axis of a mesh and why, from the file's own statement or its geometry (see the module's description).

    A disagreement between the geometry and the file format's convention, or
    between the geometry and what the file states, is logged as a warning
    (``--up`` overrides both).

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
    name = str(mesh.metadata.get("source", "mesh"))
    rec = mesh.metadata.get("up")
    stated = mesh.metadata.get("up_source")
    if rec in ("y", "z") and not stated:
        return str(rec), "recorded in the file"
    convention = "y" if fmt in ("obj", "gltf", "glb", "off") else "z"
    conv_why = f"{fmt.upper()}'s usual convention"
    if mesh.n_vertices == 0 or mesh.faces.size == 0:
        return (str(rec), str(stated)) if rec in ("y", "z") else (convention, conv_why)
    geometry = _geometry_up(mesh)
    if rec in ("y", "z"):
        if geometry is not None and geometry[0] != rec:
            _LOG.warning("%s: the geometry says the up axis is %s (%s) while %s says %s; using %s (--up overrides)",
                         name, geometry[0], geometry[1], stated, rec, rec)
        return str(rec), str(stated)
    if geometry is None:
        default = mesh.metadata.get("up_default")
        if isinstance(default, tuple) and len(default) == 2 and default[0] in ("y", "z"):
            return str(default[0]), f"{default[1]} (the geometry does not tell)"
        return convention, conv_why + " (the geometry does not tell)"
    axis, why = geometry
    if axis != convention:
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
