"""The curvature of a mesh in mm^-1, for the CDBRDF lookup: repaired faces, normals, frame and curvatures.

The CDBRDF is indexed by "the curvature" of a surface point: as in the paper,
the principal curvature of larger magnitude, with its sign, in mm^-1
(``docs/conventions.md``: positive where the surface is convex, bending away
from its normal). Beside it, the *directional* mode: the signed normal
curvature along the material's x axis (the stands bend the fabric along x).

:func:`surface_curvature` runs the whole path: :func:`~cdbrdf.mesh.repair.repair`,
the scale-aware fit (:func:`~cdbrdf.mesh.estimate.fit_curvatures`) in mm^-1
for the given unit and neighbourhood, the material's x axis
(:mod:`cdbrdf.mesh.frames`) and both curvatures (:data:`cdbrdf.mesh.CURVATURE_MODES`).
:func:`principal_curvatures` and :func:`max_curvature` give the same on
arrays, one value per input vertex; :func:`neighbourhood_from_table` the
default neighbourhood, the size of a table's measured patch.

Each curvature's name in a mesh, a PLY file and Mitsuba is given by
:mod:`cdbrdf.mesh.attributes` (``curvature`` -> ``curvature_x`` ->
``vertex_curvature``).
"""

from __future__ import annotations

import logging
import math
from collections import namedtuple
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import MeshError
from .attributes import curvature_mode
from .estimate import DEFAULT_NEIGHBOURHOOD_MM, NEIGHBOURHOOD_RANGE_MM, PrincipalCurvatures, fit_curvatures
from .frames import FRAMES, face_frame_uv, face_uv_tangents, project_tangents, seam_jumps, vertex_tangents
from .repair import RepairedMesh, repair
from .units import Units, parse_units

__all__ = [
    "LOCATIONS",
    "outside_by_location",
    "dihedral_curvature",
    "SurfaceCurvature",
    "surface_curvature",
    "principal_curvatures",
    "max_curvature",
    "check_neighbourhood",
    "neighbourhood_from_table",
]

_LOG = logging.getLogger(__name__)

#: Smallest neighbourhood (diameter) in median edge lengths of the mesh: on a mesh coarser than the
#: neighbourhood asked for, the fit is made over this many edges (a CAD garment's 9-14 mm edges).
ADAPT_EDGES = 2.0

#: Where a vertex lies, for the report of curvature outside a table's range (:attr:`SurfaceCurvature.location`).
LOCATIONS: tuple[str, ...] = ("interior", "boundary", "seam")

#: Smallest panel, in faces: the boundary of a smaller UV chart is no seam (a UV atlas cut at nearly
#: every edge, as some remeshing tools leave it, has charts of 1-20 faces; a garment's panels have hundreds).
PANEL_FACES = 20

#: Largest neighbourhood, as a share of the mesh's size (bounding-box diagonal): a larger one is
#: reduced to it, with a note (a wrong unit?); beyond it a quadric cannot follow the surface.
MAX_NEIGHBOURHOOD_SHARE = 0.5


@dataclass(frozen=True)
class SurfaceCurvature:
    """The renderable mesh of :func:`surface_curvature`, with its curvatures (mm^-1).

    Every per-vertex array has one row per *output* vertex; ``source`` maps
    it to the input vertex it was made from (for positions and other
    attributes), ``faces`` index them.

    Attributes
    ----------
    source
        ``(n,)`` input vertex of each output vertex.
    faces
        ``(m, 3)`` oriented faces.
    normals
        ``(n, 3)`` unit shading normals; every curvature's sign is relative to them.
    uv
        ``(n, 2)`` texture coordinates whose dP/du is the material's x axis:
        the input's for ``frame == "uv"``, generated per face otherwise;
        None when the input had none and none were generated.
    kappa
        Signed principal curvature of larger magnitude (> 0 convex).
    directional
        Signed normal curvature along the material's x axis.
    k1, k2
        Principal curvatures, ``k1 >= k2``.
    d1, d2
        ``(n, 3)`` their unit directions.
    side
        ``(n,)`` +1, or -1 on the back layer of a double-sided panel (whose
        normal is the opposite of its front twin's).
    tangent
        ``(n, 3)`` unit material x axis at each vertex (NaN where undefined).
    frame
        Where x comes from: ``"uv"``, ``"tangent"`` or ``"principal"``.
    units
        The mesh's unit.
    neighbourhood_mm
        Diameter of the fitted neighbourhood, mm.
    areas
        ``(n,)`` area around each output vertex (model units squared).
    representative
        For every *input* vertex the input vertex standing for it in the
        output (itself, or the first of its identical twins).
    location
        ``(n,)`` where each vertex lies, an index into :data:`LOCATIONS`:
        0 interior, 1 on an open boundary or a cut (its curvature is taken
        from the fits on the surface's side, not from half a neighbourhood),
        2 on a seam (the boundary of a panel or UV chart that another
        panel's coincident vertices close: fitted as one surface).
    repairs, notes
        What was repaired; what else the user should know (one line each).
    """

    source: NDArray[np.int64]
    faces: NDArray[np.int64]
    normals: NDArray[np.float64]
    uv: NDArray[np.float64] | None
    kappa: NDArray[np.float64]
    directional: NDArray[np.float64]
    k1: NDArray[np.float64]
    k2: NDArray[np.float64]
    d1: NDArray[np.float64]
    d2: NDArray[np.float64]
    side: NDArray[np.float64]
    tangent: NDArray[np.float64]
    frame: str
    units: Units
    neighbourhood_mm: float
    areas: NDArray[np.float64]
    representative: NDArray[np.int64]
    repairs: tuple[str, ...]
    notes: tuple[str, ...]
    location: NDArray[np.int8]

    def curvature(self, mode: str) -> NDArray[np.float64]:
        """One of the curvatures, mm^-1.

        Parameters
        ----------
        mode
            ``"max"`` (:attr:`kappa`) or ``"directional"`` (:attr:`directional`).

        Returns
        -------
        numpy.ndarray
            ``(n,)`` per output vertex.
        """
        return self.kappa if curvature_mode(mode).name == "max" else self.directional


def check_neighbourhood(neighbourhood_mm: float) -> float:
    """Check a curvature neighbourhood.

    Parameters
    ----------
    neighbourhood_mm
        Diameter of the fitted patch, mm.

    Returns
    -------
    float
        The neighbourhood.

    Raises
    ------
    MeshError
        Outside :data:`NEIGHBOURHOOD_RANGE_MM`.
    """
    lo, hi = NEIGHBOURHOOD_RANGE_MM
    try:
        x = float(neighbourhood_mm)
    except (TypeError, ValueError):
        raise MeshError(f"neighbourhood: expected a number of mm, got {neighbourhood_mm!r}") from None
    if not (math.isfinite(x) and lo <= x <= hi):
        raise MeshError(f"neighbourhood: expected {lo:g} to {hi:g} mm, got {neighbourhood_mm!r}")
    return x


def _per_output(rep: RepairedMesh, pc: PrincipalCurvatures, mm_per_unit: float) -> PrincipalCurvatures:
    """The analysis curvatures at the output vertices, in mm^-1, relative to each side's normal."""
    a = rep.out_vertex
    front = rep.out_side > 0
    k1a, k2a = pc.k1[a] / mm_per_unit, pc.k2[a] / mm_per_unit
    k1 = np.where(front, k1a, -k2a)
    k2 = np.where(front, k2a, -k1a)
    d1 = np.where(front[:, None], pc.d1[a], pc.d2[a])
    d2 = np.where(front[:, None], pc.d2[a], pc.d1[a])
    return PrincipalCurvatures(k1, k2, d1, d2)


def _single_edges(faces: NDArray[np.int64], n: int) -> tuple[NDArray[np.int64], NDArray[np.bool_]]:
    """The faces' corner edges (``(3m, 2)``, edge k of face f at row ``k m + f``) and which of them are
    an edge of one face only (an integer key per edge: much faster than unique rows)."""
    e = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    key = np.minimum(e[:, 0], e[:, 1]) * np.int64(n) + np.maximum(e[:, 0], e[:, 1])
    _, inv, count = np.unique(key, return_inverse=True, return_counts=True)
    return e, count[inv.reshape(-1)] == 1


def _boundary_vertices(faces: NDArray[np.int64], n: int) -> NDArray[np.bool_]:
    """Vertices on an edge of one face only (open boundaries and cuts)."""
    e, one = _single_edges(faces, n)
    out = np.zeros(n, np.bool_)
    out[e[one].reshape(-1)] = True
    return out


def _chart_sizes(faces: NDArray[np.int64], n: int) -> NDArray[np.int64]:
    """Per face, the number of faces of its piece of the file's mesh (faces joined through shared vertices:
    a panel, a UV chart)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    m = faces.shape[0]
    if m == 0:
        return np.zeros(0, np.int64)
    # one graph of faces and vertices, each face joined to its three (linear in the mesh's size)
    g = coo_matrix((np.ones(3 * m), (np.repeat(np.arange(m), 3), m + faces.reshape(-1))), shape=(m + n, m + n))
    _, label = connected_components(g, directed=False)
    piece = label[:m]
    return np.bincount(piece)[piece].astype(np.int64)


def _uv_scraps(v: NDArray[np.float64], faces: NDArray[np.int64], chart: NDArray[np.int64]) -> bool:
    """Whether most faces lie in pieces of fewer than :data:`PANEL_FACES` faces cut out of a larger surface
    (a UV map cut at nearly every edge; a quad of two faces is one piece, and whole)."""
    from .weld import weld

    small = chart < PANEL_FACES
    if not float(np.mean(small)) > 0.5:
        return False
    wid = weld(v)
    whole = _chart_sizes(wid[faces], int(wid.max()) + 1 if wid.size else 0)  # the surface's own pieces
    return float(np.mean(small & (chart < whole))) > 0.5


def _seam_vertices(faces: NDArray[np.int64], chart: NDArray[np.int64], n: int) -> NDArray[np.bool_]:
    """Vertices on the boundary of a panel: a piece of the file's mesh of at least :data:`PANEL_FACES`
    faces (``chart``: :func:`_chart_sizes`).

    A UV map cut at nearly every edge (an atlas of a few faces per chart) has no panels, so no seams.
    """
    m = faces.shape[0]
    if m == 0:
        return np.zeros(n, np.bool_)
    e, one = _single_edges(faces, n)
    one &= np.tile(chart, 3) >= PANEL_FACES
    out = np.zeros(n, np.bool_)
    out[e[one].reshape(-1)] = True
    return out


def _median_edge(v: NDArray[np.float64], f: NDArray[np.int64]) -> float:
    if f.size == 0:
        return 0.0
    return float(np.median(np.linalg.norm(v[f[:, [1, 2, 0]]] - v[f], axis=2)))


def _vertex_areas(positions: NDArray[np.float64], faces: NDArray[np.int64], n: int) -> NDArray[np.float64]:
    p = positions[faces]
    a = 0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)
    return np.bincount(faces.reshape(-1), weights=np.repeat(a / 3.0, 3), minlength=n).astype(np.float64)


def surface_curvature(
    vertices: ArrayLike,
    faces: ArrayLike,
    *,
    uv: ArrayLike | None = None,
    normals: ArrayLike | None = None,
    tangents: ArrayLike | None = None,
    units: str | float | Units = "mm",
    neighbourhood_mm: float = DEFAULT_NEIGHBOURHOOD_MM,
    frame: str | None = "auto",
    name: str = "mesh",
    progress: Callable[[int, int], None] | None = None,
) -> SurfaceCurvature:
    """Repair a mesh and compute its curvatures and frame for rendering.

    Parameters
    ----------
    vertices, faces
        ``(n, 3)`` positions in ``units`` and ``(m, 3)`` triangles (any
        winding; see :mod:`cdbrdf.mesh.repair`).
    uv, normals, tangents
        Optional ``(n, 2)`` texture coordinates, ``(n, 3)`` vertex normals
        (the shading normals; they decide which side is the front) and
        ``(n, 3)`` tangents.
    units
        The vertices' length unit: ``"mm"``, ``"cm"``, ``"m"``, ``"in"`` or
        millimetres per unit (:func:`~cdbrdf.mesh.units.parse_units`).
    neighbourhood_mm
        Diameter of the surface patch each vertex's curvature is fitted over, mm.
    frame
        Source of the material's x axis, one of :data:`~cdbrdf.mesh.frames.FRAMES`;
        None for none (no UVs are generated; ``directional`` is NaN).
    name
        For messages (the file's name).
    progress
        ``progress(done, total)`` during the fit, in vertices.

    Returns
    -------
    SurfaceCurvature
        The repaired mesh's faces, normals, frame and curvatures (mm^-1).

    Raises
    ------
    MeshError
        For an unusable mesh, an unknown frame or unit, a frame the mesh has
        no data for, or a neighbourhood out of range.
    """
    if frame is not None and frame not in FRAMES:
        raise MeshError(f"frame: {frame!r} is not one of {', '.join(FRAMES)}")
    u = parse_units(units)
    nb = check_neighbourhood(neighbourhood_mm)
    v = np.asarray(vertices, dtype=np.float64) if not isinstance(vertices, np.ndarray) else vertices
    uv_in, tan_in = _frame_inputs(v, uv, tangents, frame, name)
    notes: list[str] = []
    rep = repair(v, faces, normals=normals, uv=uv_in, name=name)
    f_in = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    chart = _chart_sizes(f_in, v.shape[0])
    if frame == "auto":
        frame = _auto_frame(v, f_in, chart, uv_in, tan_in, notes)
    radius = _fit_radius(rep, nb, u, notes)
    boundary_a = _boundary_vertices(rep.faces, rep.vertices.shape[0])
    pc_a, _, n_bad = fit_curvatures(rep.vertices, rep.normals, components=rep.components, radius=radius,
                                    edge_length=rep.mean_edge_length, one_sided=boundary_a, progress=progress)
    if n_bad:
        notes.append(f"{n_bad} vertices have too few neighbours with a similar normal to fit; their curvature is 0")
    o = _framed(frame, v, rep, _per_output(rep, pc_a, u.mm_per_unit), uv_in, tan_in, notes)
    undefined = ~np.isfinite(o.directional)
    if frame is not None and undefined.any():
        notes.append(f"{int(undefined.sum())} vertices have no material x axis; their directional curvature "
                     "is the maximum one")
        o = o._replace(directional=np.where(undefined, o.pc.kappa, o.directional))
    areas = _vertex_areas(v[o.src], o.faces, o.src.size)
    # a seam: a panel's (or UV chart's) boundary in the file that the analysis surface closes
    location = np.where(boundary_a[rep.out_vertex[o.src_first]], 1,
                        np.where(_seam_vertices(f_in, chart, v.shape[0])[o.src], 2, 0))
    for note in notes:
        _LOG.info("%s: %s", name, note)
    pc = o.pc
    return SurfaceCurvature(o.src, o.faces, o.normals, o.uv, pc.kappa, o.directional, pc.k1, pc.k2, pc.d1, pc.d2,
                            o.side, o.tangent, frame or "none", u, nb, areas, rep.representative, rep.repairs,
                            tuple(notes), location.astype(np.int8))


def _frame_inputs(v: NDArray[np.float64], uv: ArrayLike | None, tangents: ArrayLike | None, frame: str | None,
                  name: str) -> tuple[NDArray[np.float64] | None, NDArray[np.float64] | None]:
    """The UVs and tangents given, checked, and refused when the frame asked for needs them and they are missing."""
    uv_in = None
    if uv is not None:
        uv_in = np.asarray(uv, dtype=np.float64)
        if uv_in.shape != (len(v), 2):
            raise MeshError(f"{name}: uv: expected shape {(len(v), 2)}, got {uv_in.shape}")
        if not np.isfinite(uv_in).all():
            raise MeshError(f"{name}: {int((~np.isfinite(uv_in).all(axis=1)).sum())} vertices have NaN or "
                            "infinite texture coordinates")
    tan_in = None
    if tangents is not None:
        tan_in = np.asarray(tangents, dtype=np.float64)
        if tan_in.shape != (len(v), 3):
            raise MeshError(f"{name}: tangents: expected shape {(len(v), 3)}, got {tan_in.shape}")
    if frame == "uv" and uv_in is None:
        raise MeshError(f"{name}: the mesh has no UV coordinates, so frame 'uv' has no x axis (dP/du); "
                        "use frame 'principal' (or 'auto')")
    if frame == "tangent" and tan_in is None:
        raise MeshError(f"{name}: the mesh has no tangent attribute for frame 'tangent'")
    return uv_in, tan_in


def _auto_frame(v: NDArray[np.float64], f_in: NDArray[np.int64], chart: NDArray[np.int64],
                uv_in: NDArray[np.float64] | None, tan_in: NDArray[np.float64] | None, notes: list[str]) -> str:
    """Frame ``"auto"``: the UVs unless they are scraps, else the tangents, else the principal directions."""
    scraps = uv_in is not None and _uv_scraps(v, f_in, chart)
    frame = "uv" if uv_in is not None and not scraps else "tangent" if tan_in is not None else "principal"
    why = (f"the UV map is cut at nearly every edge ({int(np.count_nonzero(chart < PANEL_FACES))} of "
           f"{chart.size} faces in pieces of fewer than {PANEL_FACES}), so it follows no fabric"
           if scraps else "no UV coordinates")
    if frame == "tangent":
        notes.append(f"{why}: the material's x axis is the file's tangent attribute")
    elif frame == "principal":
        notes.append(f"{why}: the material's x axis is the bending direction "
                     "(of the principal curvature of larger magnitude)")
    return frame


def _fit_radius(rep: RepairedMesh, nb: float, u: Units, notes: list[str]) -> float:
    """The radius of the fit (model units): the neighbourhood's, reduced on a small mesh, widened on a coarse one."""
    pos_in = np.asarray(rep.vertices)
    diag = float(np.linalg.norm(pos_in.max(0) - pos_in.min(0)))
    radius = 0.5 * nb / u.mm_per_unit
    if diag > 0 and 2 * radius > MAX_NEIGHBOURHOOD_SHARE * diag:
        used = MAX_NEIGHBOURHOOD_SHARE * diag * u.mm_per_unit
        notes.append(f"the neighbourhood ({nb:g} mm) is {2 * radius / diag:.0%} of the mesh's size "
                     f"({diag * u.mm_per_unit:.4g} mm across in unit {u}): fitted over {used:.3g} mm instead; "
                     "is the unit right?")
        radius = 0.5 * MAX_NEIGHBOURHOOD_SHARE * diag
    edge_mm = _median_edge(rep.vertices, rep.faces) * u.mm_per_unit
    if ADAPT_EDGES * edge_mm > 2 * radius * u.mm_per_unit and 2 * radius < MAX_NEIGHBOURHOOD_SHARE * diag:
        wide = min(ADAPT_EDGES * edge_mm / u.mm_per_unit, MAX_NEIGHBOURHOOD_SHARE * diag)
        notes.append(f"the mesh is coarser than the neighbourhood (median edge {edge_mm:.3g} mm): fitted over "
                     f"{wide * u.mm_per_unit:.3g} mm ({ADAPT_EDGES:g} edge lengths) instead of "
                     f"{2 * radius * u.mm_per_unit:.3g} mm")
        radius = 0.5 * wide
    return radius


#: The output mesh with its material frame: each vertex's input vertex and the repair's output vertex, faces,
#: normals, UVs, principal curvatures, directional curvature, side and material x axis.
_Framed = namedtuple("_Framed", "src src_first faces normals uv pc directional side tangent")


def _framed(frame: str | None, v: NDArray[np.float64], rep: RepairedMesh, pc: PrincipalCurvatures,
            uv_in: NDArray[np.float64] | None, tan_in: NDArray[np.float64] | None, notes: list[str]) -> _Framed:
    """The material's x axis and the directional curvature along it, by ``frame``; without UVs of the frame's, one
    output vertex per face corner with UVs whose dP/du is the face's mean x axis."""
    src = rep.out_source
    src_first = np.arange(src.size)  # the repair's output vertex of each output vertex
    out_faces, normals_o = rep.out_faces, rep.out_normals
    positions_o = v[src]
    if frame is None:
        return _Framed(src, src_first, out_faces, normals_o, None, pc, np.full(src.size, np.nan), rep.out_side,
                       np.full((src.size, 3), np.nan))
    if frame == "uv":
        assert uv_in is not None
        uv_o = uv_in[src]
        ft, ok = face_uv_tangents(positions_o, out_faces, uv_o)
        w = 0.5 * np.linalg.norm(np.cross(positions_o[out_faces[:, 1]] - positions_o[out_faces[:, 0]],
                                          positions_o[out_faces[:, 2]] - positions_o[out_faces[:, 0]]), axis=1)
        tangent = vertex_tangents(out_faces, ft, w * ok, normals_o)
        n_seam, n_jump = seam_jumps(positions_o, uv_o, ft, ok, rep.adjacent, rep.faces, out_faces)
        if n_jump:
            notes.append(f"the UV map turns the material's x axis by more than 30 degrees across {n_jump} of "
                         f"its {n_seam} seam edges: an anisotropic table shows seams there (for a model that is "
                         "not cloth, take the frame from the principal directions)")
        if (~ok).any():
            notes.append(f"{int((~ok).sum())} faces have degenerate UVs (no dP/du there)")
        return _Framed(src, src_first, out_faces, normals_o, uv_o, pc, pc.normal_curvature(np.nan_to_num(tangent)),
                       rep.out_side, tangent)
    if frame == "tangent":
        assert tan_in is not None
        tangent = project_tangents(tan_in[src], normals_o)
        directional = pc.normal_curvature(np.nan_to_num(tangent))
    else:
        tangent = pc.kappa_direction.copy()
        directional = pc.kappa.copy()
    # per-face UVs whose dP/du is the face's mean tangent: one output vertex per corner
    corner_uv, _ = face_frame_uv(positions_o, out_faces, tangent[out_faces], align=frame == "principal")
    corners = out_faces.reshape(-1)
    return _Framed(src[corners], src_first[corners], np.arange(corners.size, dtype=np.int64).reshape(-1, 3),
                   normals_o[corners], corner_uv.reshape(-1, 2),
                   PrincipalCurvatures(pc.k1[corners], pc.k2[corners], pc.d1[corners], pc.d2[corners]),
                   directional[corners], rep.out_side[corners], tangent[corners])


def outside_by_location(kappa: NDArray[np.float64], location: NDArray[np.int8],
                        kappa_range: tuple[float, float]) -> dict[str, tuple[int, int]]:
    """Per location (:data:`LOCATIONS`): the vertices with ``kappa`` outside ``kappa_range``, and all of them."""
    lo, hi = float(min(kappa_range)), float(max(kappa_range))
    tol = 1e-9 * max(1.0, abs(lo), abs(hi))
    out = (kappa < lo - tol) | (kappa > hi + tol)
    return {name: (int(np.count_nonzero(out & (location == i))), int(np.count_nonzero(location == i)))
            for i, name in enumerate(LOCATIONS)}


def dihedral_curvature(vertices: ArrayLike, faces: ArrayLike, *, units: str | float | Units = "mm",
                       name: str = "mesh") -> NDArray[np.float64]:
    """The sharpest bend the tessellation itself shows at each vertex, mm^-1, unsigned: a check of the fit.

    For every edge of the surface (seams closed, :func:`cdbrdf.mesh.weld.weld_seams`)
    the angle between its two faces' planes over the mean height of the
    two triangles on it: the normal curvature across that edge a circle
    through the faces would have (a cylinder of radius R tessellated along
    its axis gives 1 / R). A vertex gets the largest of its edges'. It uses
    no neighbourhood: where a fitted curvature (:func:`surface_curvature`)
    exceeds it several times, the fit shows more than the mesh does (a
    spike); where both exceed a table's range, the cloth bends that tightly.

    Parameters
    ----------
    vertices, faces
        ``(n, 3)`` positions in ``units`` and ``(m, 3)`` triangles.
    units
        Their length unit.
    name
        For messages.

    Returns
    -------
    numpy.ndarray
        ``(n,)`` per input vertex, mm^-1 (0 on a vertex of no two-face edge).
    """
    from .repair import check_arrays
    from .weld import weld_seams

    v, f = check_arrays(vertices, faces, name=name)
    u = parse_units(units)
    out = np.zeros(v.shape[0])
    if f.size == 0:
        return out
    wid = weld_seams(v, f)
    pos = np.zeros((int(wid.max()) + 1, 3))
    pos[wid] = v * u.mm_per_unit
    fw = wid[f]
    cr = np.cross(pos[fw[:, 1]] - pos[fw[:, 0]], pos[fw[:, 2]] - pos[fw[:, 0]])
    a2 = np.linalg.norm(cr, axis=1)
    good = a2 > 0
    fn = np.divide(cr, a2[:, None], out=np.zeros_like(cr), where=good[:, None])
    a = fw.reshape(-1)
    b = fw[:, [1, 2, 0]].reshape(-1)
    face = np.repeat(np.arange(fw.shape[0]), 3)
    key = np.minimum(a, b) * np.int64(pos.shape[0]) + np.maximum(a, b)
    order = np.argsort(key, kind="stable")
    ks = key[order]
    pair = np.flatnonzero(ks[1:] == ks[:-1])  # the two faces of an edge (more on a non-manifold one: pairwise)
    f1, f2 = face[order][pair], face[order][pair + 1]
    ea, eb = a[order][pair], b[order][pair]
    ok = good[f1] & good[f2]
    f1, f2, ea, eb = f1[ok], f2[ok], ea[ok], eb[ok]
    length = np.linalg.norm(pos[ea] - pos[eb], axis=1)
    height = 0.5 * (a2[f1] + a2[f2]) / np.maximum(length, 1e-300)
    # the faces' windings are the file's: the angle between their planes, not their sides
    angle = np.arccos(np.clip(np.abs(np.einsum("ij,ij->i", fn[f1], fn[f2])), 0.0, 1.0))
    bend = np.divide(angle, height, out=np.zeros_like(angle), where=height > 0)
    per = np.zeros(pos.shape[0])
    np.maximum.at(per, ea, bend)
    np.maximum.at(per, eb, bend)
    return per[wid]


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

    Returns
    -------
    neighbourhood_mm : float
        The neighbourhood's diameter, mm.
    source : str
        Where it comes from, for messages.
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
    component.

    Parameters
    ----------
    vertices, faces, normals, units, neighbourhood_mm, progress
        As for :func:`surface_curvature`.

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
    outward).

    Parameters
    ----------
    vertices, faces, normals, units, neighbourhood_mm
        As for :func:`principal_curvatures`.

    Returns
    -------
    numpy.ndarray
        ``(n,)`` per input vertex, mm^-1.
    """
    return principal_curvatures(vertices, faces, normals=normals, units=units,
                                neighbourhood_mm=neighbourhood_mm).kappa
