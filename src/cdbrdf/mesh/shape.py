"""What a mesh's geometry says about the object: its openings, panels, base, symmetry and size.

A garment, a scan or a draped sheet carries its orientation and its scale in
its shape. :func:`describe` reads them once, for the up axis
(:func:`cdbrdf.mesh.detect_up`) and the unit (:func:`cdbrdf.mesh.units.infer_units`):

- **openings**: the boundary loops of the surface with its seams closed
  (:func:`cdbrdf.mesh.weld.weld_seams`). Each loop points where the cloth
  is not: the sum over its edges of the edge's length times the direction
  from the cloth towards the edge (in the plane of the edge's face). A
  tube's end (a neck, a hem, a cuff, the cut under a scanned head) points
  along the tube, with an *openness* (that sum over the loop's perimeter)
  near 1; the outline of a flat panel points nowhere (openness 0);
- **components** and their kind: ``"closed"`` (no boundary: a watertight
  scan), ``"tube"`` (two or more openings: a garment, a sleeve), ``"bag"``
  (one opening, with the surface reaching out of its plane by at least
  :data:`BAG_DEPTH` of its diameter: a scan open at its base, a hood),
  ``"panel"`` (one loop, flat: a CAD pattern piece) or ``"sheet"`` (one
  loop, curved: a drape, a curved panel);
- **base**: the largest plane that caps a larger surface at its extreme,
  meeting it at a crease (the flat cut of a scan's base or a bust's plinth);
- **symmetry**: per axis, how far the surface is from its mirror image across
  the plane through its centroid (a garment or a figure is symmetric left to
  right, about a vertical plane);
- **normals**: per axis, the area-weighted mean of ``|n|`` (a worn garment's
  walls face sideways; a draped sheet faces up).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .core import Mesh
from .weld import _distinct

__all__ = ["Loop", "Component", "Shape", "describe", "COMPONENT_KINDS", "BAG_DEPTH", "PANEL_FLATNESS"]

#: The kinds of :attr:`Component.kind`.
COMPONENT_KINDS: tuple[str, ...] = ("closed", "tube", "bag", "panel", "sheet")

#: A component with one loop is a bag when it reaches out of the loop's plane by this share of the loop's diameter.
BAG_DEPTH = 0.75

#: A component with one loop is a flat panel when its thickness is below this share of its extent.
PANEL_FLATNESS = 0.02

#: Planar regions: faces joined when their normals are within this angle, degrees,
PLANE_DEG = 1.0

#: and a base is one whose faces all face within this angle of its mean normal, degrees,
BASE_FLAT_DEG = 3.0

#: that meets the rest of the surface at a crease of at least this angle along most of its rim, degrees,
BASE_CREASE_DEG = 30.0

#: and that holds at least this share of the surface's area.
BASE_SHARE = 0.02

#: A base has no vertex of its component beyond its plane by more than this share of the mesh's diagonal.
BASE_TOLERANCE = 0.01

#: At most this many vertices are mirrored to measure the symmetry.
SYMMETRY_SAMPLES = 20000


@dataclass(frozen=True)
class Loop:
    """A boundary loop of the surface with its seams closed.

    Attributes
    ----------
    perimeter
        Its length, model units.
    centre
        ``(3,)`` mean of its vertices.
    direction
        ``(3,)`` where it points, away from the cloth; its length is
        ``perimeter * openness``.
    openness
        1 for a tube's end, 0 for the outline of a flat panel.
    component
        The component it bounds (index into :attr:`Shape.components`).
    """

    perimeter: float
    centre: NDArray[np.float64]
    direction: NDArray[np.float64]
    openness: float
    component: int


@dataclass(frozen=True)
class Component:
    """A connected piece of the surface (faces joined by edges, seams closed).

    Attributes
    ----------
    kind
        One of :data:`COMPONENT_KINDS`.
    area
        Its area, model units squared.
    loops
        Its number of boundary loops.
    extent
        ``(3,)`` its bounding box's size.
    """

    kind: str
    area: float
    loops: int
    extent: NDArray[np.float64]


@dataclass(frozen=True)
class Shape:
    """What :func:`describe` found (lengths in the mesh's units).

    Attributes
    ----------
    extent
        ``(3,)`` the bounding box's size.
    median_edge
        The median edge length.
    area
        The surface's area.
    loops
        The boundary loops, longest first.
    components
        The components, largest first.
    normals
        ``(3,)`` area-weighted mean ``|n_x|, |n_y|, |n_z|`` of the faces.
    symmetry
        ``(3,)`` per axis: the median distance from the vertices (at most
        :data:`SYMMETRY_SAMPLES` of them) mirrored across the plane through
        the centroid normal to it to the nearest of them, over their median
        spacing (under 1 for a mirror image, more for none).
    base
        The flat cap at the surface's extreme, ``(normal, share of the
        area)``, or None.
    """

    extent: NDArray[np.float64]
    median_edge: float
    area: float
    loops: tuple[Loop, ...]
    components: tuple[Component, ...]
    normals: NDArray[np.float64]
    symmetry: NDArray[np.float64]
    base: tuple[NDArray[np.float64], float] | None

    def share(self, *kinds: str) -> float:
        """The share of the area in components of these kinds.

        Parameters
        ----------
        *kinds
            Values of :data:`COMPONENT_KINDS`.

        Returns
        -------
        float
            In [0, 1].
        """
        a = sum(c.area for c in self.components if c.kind in kinds)
        return a / self.area if self.area > 0 else 0.0

    def openings(self) -> tuple[Loop, ...]:
        """The loops of tubes and bags (a garment's neck, hem and cuffs, a scan's open base), longest first.

        Returns
        -------
        tuple of Loop
            The loops.
        """
        return tuple(lp for lp in self.loops if self.components[lp.component].kind in ("tube", "bag"))


def _faces_welded(mesh: Mesh) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """Positions and non-degenerate faces of the mesh with its seams closed."""
    from .repair import check_arrays
    from .weld import SEAM_TOLERANCE, _close_seams, _unique_rows

    v, f = check_arrays(mesh.vertices, mesh.faces, name=str(mesh.metadata.get("source", "mesh")))
    # identical positions, then the seams (the repair's near-weld of 1e-7 x the diagonal matters to no loop)
    first, group = _unique_rows(v)
    order = np.argsort(first, kind="stable")
    rank = np.empty_like(order)
    rank[order] = np.arange(order.size)
    wid = _close_seams(v, f, rank[group], SEAM_TOLERANCE)
    pos = np.zeros((int(wid.max()) + 1 if wid.size else 0, 3))
    pos[wid] = v
    fw = wid[f]
    fw = fw[(fw[:, 0] != fw[:, 1]) & (fw[:, 1] != fw[:, 2]) & (fw[:, 2] != fw[:, 0])]
    return pos, fw


def _edges(fw: NDArray[np.int64], n: int) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.int64]]:
    """Per corner edge (a -> b of face f): its key, and per distinct edge the number of faces."""
    a = fw.reshape(-1)
    b = fw[:, [1, 2, 0]].reshape(-1)
    key = np.minimum(a, b) * np.int64(n) + np.maximum(a, b)
    _, inv, count = np.unique(key, return_inverse=True, return_counts=True)
    return key, inv.reshape(-1), count


def _components(fw: NDArray[np.int64], n: int, inv: NDArray[np.int64], count: NDArray[np.int64]) -> NDArray[np.int64]:
    """The component of each face (faces joined through edges they share)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    m = fw.shape[0]
    owner = np.repeat(np.arange(m), 3)
    order = np.argsort(inv, kind="stable")
    e_sorted = inv[order]
    same = e_sorted[1:] == e_sorted[:-1]
    i, j = owner[order][:-1][same], owner[order][1:][same]
    _, lab = connected_components(coo_matrix((np.ones(i.size), (i, j)), shape=(m, m)), directed=False)
    return lab.astype(np.int64)


def _loops(pos: NDArray[np.float64], fw: NDArray[np.int64], inv: NDArray[np.int64], count: NDArray[np.int64],
           face_comp: NDArray[np.int64]) -> list[Loop]:
    """The boundary loops with their direction and openness."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    corner = np.flatnonzero(count[inv] == 1)  # boundary edges, as corners k of faces f: f[k] -> f[k + 1]
    if corner.size == 0:
        return []
    f, k = corner // 3, corner % 3
    a, b, c = fw[f, k], fw[f, (k + 1) % 3], fw[f, (k + 2) % 3]
    n = pos.shape[0]
    _, lab = connected_components(coo_matrix((np.ones(a.size), (a, b)), shape=(n, n)), directed=False)
    t = pos[b] - pos[a]
    length = np.linalg.norm(t, axis=1)
    tu = t / np.maximum(length, 1e-300)[:, None]
    w = pos[c] - pos[a]
    inward = w - np.einsum("ij,ij->i", w, tu)[:, None] * tu
    inward /= np.maximum(np.linalg.norm(inward, axis=1), 1e-300)[:, None]
    out = []
    loop_of = lab[a]
    for lp in _distinct(loop_of, n):
        sel = loop_of == lp
        if sel.sum() < 3:
            continue
        per = float(length[sel].sum())
        d = -(inward[sel] * length[sel][:, None]).sum(axis=0)
        verts = _distinct(np.r_[a[sel], b[sel]], n)
        out.append(Loop(per, pos[verts].mean(axis=0), d, float(np.linalg.norm(d)) / per if per > 0 else 0.0,
                        int(face_comp[f[sel][0]])))
    out.sort(key=lambda lp: -lp.perimeter)
    return out


def _kind(pts: NDArray[np.float64], loops: list[Loop], area: float) -> str:
    """The kind of a component (:data:`COMPONENT_KINDS`) from its vertices and loops."""
    if not loops:
        return "closed"
    if len(loops) > 1:
        return "tube"
    centre = pts.mean(axis=0)
    _, s, vt = np.linalg.svd(pts - centre, full_matrices=False)
    span = float(np.ptp(pts @ vt[0])) if pts.shape[0] else 0.0
    if float(np.ptp(pts @ vt[-1])) <= PANEL_FLATNESS * span:
        return "panel"
    lp = loops[0]
    d = lp.direction / max(float(np.linalg.norm(lp.direction)), 1e-300)
    depth = float(np.max(np.abs((pts - lp.centre) @ d)))
    diameter = lp.perimeter / math.pi
    return "bag" if depth >= BAG_DEPTH * diameter else "sheet"


def _base(pos: NDArray[np.float64], fw: NDArray[np.int64], inv: NDArray[np.int64], count: NDArray[np.int64],
          fn: NDArray[np.float64], area: NDArray[np.float64], face_comp: NDArray[np.int64]
          ) -> tuple[NDArray[np.float64], float] | None:
    """The largest plane that caps a larger component at its extreme across a crease, ``(outward normal, share)``."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    m = fw.shape[0]
    total = float(area.sum())
    if m == 0 or not total > 0:
        return None
    owner = np.repeat(np.arange(m), 3)
    order = np.argsort(inv, kind="stable")
    e_sorted = inv[order]
    same = e_sorted[1:] == e_sorted[:-1]
    i, j = owner[order][:-1][same], owner[order][1:][same]
    cos_ij = np.abs(np.einsum("ij,ij->i", fn[i], fn[j]))  # the file's winding: either side
    flat = cos_ij >= math.cos(math.radians(PLANE_DEG))
    _, region = connected_components(coo_matrix((np.ones(int(flat.sum())), (i[flat], j[flat])), shape=(m, m)),
                                     directed=False)
    reg_area = np.bincount(region, weights=area)
    comp_area = np.bincount(face_comp, weights=area)
    diag = float(np.linalg.norm(np.ptp(pos, axis=0)))
    for r in np.argsort(-reg_area)[:8]:
        share = float(reg_area[r]) / total
        if share < BASE_SHARE:
            break
        sel = region == r
        comp = int(np.bincount(face_comp[sel]).argmax())
        if reg_area[r] > comp_area[comp] / 3.0:  # a panel or a sheet, not the cap of a larger surface
            continue
        f_sel = fn[sel] * np.sign(fn[sel] @ fn[sel][int(np.argmax(area[sel]))])[:, None]
        nrm = (f_sel * area[sel][:, None]).sum(axis=0)
        nrm /= max(float(np.linalg.norm(nrm)), 1e-300)
        if float((f_sel @ nrm).min()) < math.cos(math.radians(BASE_FLAT_DEG)):
            continue  # a gently curved region (the front of a garment), not a plane
        pv = pos[_distinct(fw[sel], pos.shape[0])]
        off = float(np.median(pv @ nrm))
        if np.abs(pv @ nrm - off).max() > 0.005 * diag:
            continue  # not planar
        rim = sel[i] != sel[j]  # edges between the region and the rest: a cut meets the surface at a crease
        if not rim.any() or float(np.mean(cos_ij[rim] < math.cos(math.radians(BASE_CREASE_DEG)))) < 0.5:
            continue
        h = pos[_distinct(fw[face_comp == comp], pos.shape[0])] @ nrm - off
        for sign in (1.0, -1.0):  # the faces' winding is the file's: try both sides
            if (sign * h).max() <= BASE_TOLERANCE * diag:  # the whole component lies behind it
                return sign * nrm, share
    return None


def _symmetry(pos: NDArray[np.float64], vertex_area: NDArray[np.float64]) -> NDArray[np.float64]:
    """Per axis the median distance of the mirrored points to the nearest point, in spacings of the points."""
    from scipy.spatial import cKDTree

    used = vertex_area > 0
    p, w = pos[used], vertex_area[used]
    if p.shape[0] < 4:
        return np.full(3, np.inf)
    centre = (p * w[:, None]).sum(axis=0) / w.sum()
    if p.shape[0] > SYMMETRY_SAMPLES:  # a sample of the vertices, mirrored onto itself
        p = p[np.random.default_rng(0).choice(p.shape[0], SYMMETRY_SAMPLES, replace=False)]
    tree = cKDTree(p)
    d, _ = tree.query(p, k=2)
    spacing = float(np.median(d[:, 1]))
    if not spacing > 0:
        return np.full(3, np.inf)
    out = np.empty(3)
    for a in range(3):
        q = p.copy()
        q[:, a] = 2 * centre[a] - q[:, a]
        out[a] = float(np.median(tree.query(q)[0])) / spacing
    return out


def describe(mesh: Mesh) -> Shape:
    """The openings, components, base, symmetry and normals of a mesh (see the module's description).

    Parameters
    ----------
    mesh
        The mesh, in any unit and orientation.

    Returns
    -------
    Shape
        What the geometry says.

    Raises
    ------
    MeshError
        For vertices or faces the repair would refuse (:func:`cdbrdf.mesh.repair.check_arrays`).
    """
    pos, fw = _faces_welded(mesh)
    n = pos.shape[0]
    extent = np.ptp(pos, axis=0) if n else np.zeros(3)
    if fw.shape[0] == 0:
        return Shape(extent, 0.0, 0.0, (), (), np.zeros(3), np.full(3, np.inf), None)
    cr = np.cross(pos[fw[:, 1]] - pos[fw[:, 0]], pos[fw[:, 2]] - pos[fw[:, 0]])
    a2 = np.linalg.norm(cr, axis=1)
    area = 0.5 * a2
    fn = cr / np.maximum(a2, 1e-300)[:, None]
    _, inv, count = _edges(fw, n)
    el = np.linalg.norm(pos[fw[:, [1, 2, 0]]] - pos[fw], axis=2).reshape(-1)
    edge = float(np.median(el[el > 0])) if (el > 0).any() else 0.0
    face_comp = _components(fw, n, inv, count)
    loops = _loops(pos, fw, inv, count, face_comp)
    comp_area = np.bincount(face_comp, weights=area)
    comps = []
    # the vertices of each component, at once (one sort, not one pass over the faces per component)
    vc = np.full(n, -1, np.int64)
    vc[fw.reshape(-1)] = np.repeat(face_comp, 3)
    by_comp = np.argsort(vc, kind="stable")
    starts = np.searchsorted(vc[by_comp], np.arange(comp_area.size + 1))
    for ci in range(comp_area.size):
        verts = by_comp[starts[ci]:starts[ci + 1]]
        mine = [lp for lp in loops if lp.component == ci]
        comps.append(Component(_kind(pos[verts], mine, float(comp_area[ci])), float(comp_area[ci]), len(mine),
                               np.ptp(pos[verts], axis=0)))
    # components largest first; loops renumbered to match
    order = np.argsort([-c.area for c in comps], kind="stable")
    rank = np.empty_like(order)
    rank[order] = np.arange(order.size)
    comps_sorted = tuple(comps[i] for i in order)
    loops_out = tuple(Loop(lp.perimeter, lp.centre, lp.direction, lp.openness, int(rank[lp.component]))
                      for lp in loops)
    total = float(area.sum())
    normals = (np.abs(fn) * area[:, None]).sum(axis=0) / total if total > 0 else np.zeros(3)
    v_area = np.bincount(fw.reshape(-1), weights=np.repeat(area / 3.0, 3), minlength=n).astype(np.float64)
    return Shape(extent, edge, total, loops_out, comps_sorted, normals, _symmetry(pos, v_area),
                 _base(pos, fw, inv, count, fn, area, face_comp))
