"""Repair of triangle meshes for the curvature and the renderer: weld, clean, orient, split.

Real meshes are not clean manifolds: garments from fashion CAD tools are sewn
panels with seams, mixed winding and double-sided parts; scans and game
models have duplicate and degenerate faces; STL files are triangle soups.
:func:`repair` fixes what can be fixed and says what it did, one phrase per
repair (``"welded 312 duplicate vertices"``, ``"re-oriented 1 of 3
components"``):

1. **weld** (:mod:`cdbrdf.mesh.weld`): vertices closer than :data:`~cdbrdf.mesh.weld.WELD_TOLERANCE` x the bounding-box
   diagonal become one for the curvature (UV and normal seams stay in the
   output; only vertices identical in position, UV and normal are merged
   there, and only those count as "welded"); so do the *seams*
   (:func:`cdbrdf.mesh.weld.weld_seams`): a boundary vertex within :data:`~cdbrdf.mesh.weld.SEAM_TOLERANCE` x
   the median edge length of another boundary vertex it shares no edge with
   (sewn panels whose seam vertices a simulation or an export left a hair
   apart) is one vertex of the analysis surface, so the seam is fitted as
   the one surface it is, while the output keeps both panels' vertices;
2. **clean**: faces with a repeated vertex or no area are dropped, and of
   faces on the same three vertices with the same winding all but the first;
3. **double-sided**: two faces on the same three vertices with opposite
   winding are a double-sided panel: the second becomes the *back layer*,
   with its own output vertices and the curvature of the front negated
   (relative to its own normal), so each side shows its own sign;
4. **orient**: every connected component (faces joined by edges with two
   faces) is made consistent by a breadth-first walk; which way it faces
   follows the file's vertex normals where given (by area-weighted
   majority), else outward for a closed component, else the winding of most
   of its area;
5. **split**: at edges with more than two faces (non-manifold: a pocket
   sewn onto a panel) or that cannot be oriented (a Moebius strip), the
   surface is cut: each side of the cut gets its own vertices and its own
   curvature; a vertex where separate sheets meet in a point is split too;
6. **normals**: the file's vertex normals that point against the oriented
   faces are flipped; without file normals, normals are computed per
   smoothing group (faces meeting at less than :data:`CREASE_DEG`), so a
   CAD part keeps its sharp edges.

Refused (:class:`~cdbrdf.errors.MeshError`): non-finite or absurd
coordinates (beyond :data:`MAX_COORDINATE`), face indices out of range,
and a mesh with no face of positive area left.
"""

from __future__ import annotations

import logging
import math
from collections import namedtuple
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import MeshError
from .weld import SEAM_TOLERANCE, _close_seams, _distinct, _unique_rows, weld

__all__ = [
    "CREASE_DEG",
    "MAX_COORDINATE",
    "RepairedMesh",
    "check_arrays",
    "repair",
]

_LOG = logging.getLogger(__name__)

#: Faces meeting at a larger angle are shaded separately when the file has no normals, degrees.
CREASE_DEG = 45.0

#: Largest coordinate magnitude accepted (any unit): beyond it squares of lengths lose all precision.
MAX_COORDINATE = 1e15


@dataclass(frozen=True)
class RepairedMesh:
    """A mesh after :func:`repair`: the surface for the curvature and the mesh for the renderer.

    The *analysis* surface (``vertices``, ``faces``) is welded, cleaned,
    oriented and cut where it must be; the *output* mesh (``out_*``) keeps
    the input's vertices (its UV and normal seams), references the analysis
    vertex of each of its vertices and the side it shows.

    Attributes
    ----------
    vertices, faces
        Analysis surface: ``(n_a, 3)`` positions, ``(m_a, 3)`` oriented faces.
    normals
        ``(n_a, 3)`` unit area-weighted normals of the oriented faces.
    areas
        ``(n_a,)`` vertex areas (a third of each incident face's).
    out_source
        ``(n_o,)`` the input vertex of each output vertex.
    out_vertex
        ``(n_o,)`` its analysis vertex.
    out_side
        ``(n_o,)`` +1, or -1 on the back layer of a double-sided panel
        (whose normal is the opposite of the analysis vertex's).
    out_faces
        ``(m_o, 3)`` faces of the output mesh: the analysis faces first (same
        order), then the back layer.
    out_normals
        ``(n_o, 3)`` unit shading normals (the file's, repaired, or computed).
    adjacent
        ``(k, 2)`` pairs of analysis faces sharing a consistently oriented
        edge (for checks of the UV frame across seams).
    components
        ``(n_a,)`` connected component of each analysis vertex.
    representative
        ``(n,)`` for every input vertex the input vertex standing for it in
        the output (itself, or the first of its identical twins).
    repairs
        What was repaired, one phrase each.
    """

    vertices: NDArray[np.float64]
    faces: NDArray[np.int64]
    normals: NDArray[np.float64]
    areas: NDArray[np.float64]
    out_source: NDArray[np.int64]
    out_vertex: NDArray[np.int64]
    out_side: NDArray[np.float64]
    out_faces: NDArray[np.int64]
    out_normals: NDArray[np.float64]
    adjacent: NDArray[np.int64]
    components: NDArray[np.int64]
    representative: NDArray[np.int64]
    repairs: tuple[str, ...]

    @property
    def n_components(self) -> int:
        """Connected components of the analysis surface."""
        return int(self.components.max()) + 1 if self.components.size else 0

    @property
    def mean_edge_length(self) -> float:
        """Mean edge length of the analysis surface."""
        v, f = self.vertices, self.faces
        e = np.linalg.norm(v[f] - v[np.roll(f, 1, axis=1)], axis=2)
        return float(e.mean()) if e.size else 0.0


def check_arrays(
    vertices: ArrayLike, faces: ArrayLike, *, name: str = "mesh"
) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """Vertices ``(n, 3)`` as float64 and faces ``(m, 3)`` as int64, checked.

    Raises
    ------
    MeshError
        For shapes, non-numbers, non-finite or absurd coordinates, or face
        indices out of range; the message starts with ``name``.
    """
    try:
        with np.errstate(all="ignore"):
            v = np.asarray(vertices, dtype=np.float64)
    except (TypeError, ValueError, OverflowError) as exc:
        raise MeshError(f"{name}: vertices cannot be read as numbers ({exc})") from None
    if v.ndim != 2 or v.shape[1] != 3:
        raise MeshError(f"{name}: vertices: expected shape (n, 3), got {v.shape}")
    finite = np.isfinite(v).all(axis=1)
    if not finite.all():
        raise MeshError(f"{name}: {int((~finite).sum())} vertices have NaN or infinite coordinates")
    if v.size and float(np.abs(v).max()) > MAX_COORDINATE:
        raise MeshError(f"{name}: coordinates up to {float(np.abs(v).max()):.3g}: beyond {MAX_COORDINATE:g} "
                        "they are not lengths (a corrupt file?)")
    f = np.asarray(faces)
    if f.ndim != 2 or f.shape[1] != 3:
        raise MeshError(f"{name}: faces: expected triangles, shape (m, 3), got {f.shape}")
    if f.size and not np.issubdtype(f.dtype, np.integer):
        raise MeshError(f"{name}: faces: expected integer vertex indices, got dtype {f.dtype}")
    f = f.astype(np.int64)
    if f.size and (int(f.min()) < 0 or int(f.max()) >= v.shape[0]):
        raise MeshError(f"{name}: faces refer to vertices {int(f.min())}..{int(f.max())} "
                        f"but there are {v.shape[0]}")
    return v, f


def _face_normals(v: NDArray[np.float64], f: NDArray[np.int64]) -> NDArray[np.float64]:
    """Unnormalised face normals (length = twice the area)."""
    return np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])


def _scatter(f: NDArray[np.int64], per_face: NDArray[np.float64], n: int) -> NDArray[np.float64]:
    """Per-vertex sums of a per-face vector over the faces' three corners."""
    idx = f.reshape(-1)
    return np.stack([np.bincount(idx, weights=np.repeat(per_face[:, c], 3), minlength=n) for c in range(3)], 1)


def _unit(a: NDArray[np.float64]) -> NDArray[np.float64]:
    ln = np.linalg.norm(a, axis=-1, keepdims=True)
    return np.divide(a, ln, out=np.zeros_like(a), where=ln > 0)


@dataclass(frozen=True)
class _Edges:
    """The edges of a face list: manifold pairs and counts."""

    f1: NDArray[np.int64]  # faces of each two-face edge
    f2: NDArray[np.int64]
    k1: NDArray[np.int64]  # the edge's index in each face (edge k: corner k -> corner k + 1)
    k2: NDArray[np.int64]
    same: NDArray[np.bool_]  # both faces traverse it in the same direction
    n_boundary_of_face: NDArray[np.int64]  # per face: its edges with one face
    n_nonmanifold: int  # edges with more than two faces


def _edges(f: NDArray[np.int64], n_vertices: int) -> _Edges:
    m = f.shape[0]
    a = f.reshape(-1)
    b = f[:, [1, 2, 0]].reshape(-1)
    lo = np.minimum(a, b)
    hi = np.maximum(a, b)
    key = lo * np.int64(n_vertices) + hi
    order = np.argsort(key, kind="stable")
    ks = key[order]
    starts = np.flatnonzero(np.r_[True, ks[1:] != ks[:-1]])
    counts = np.diff(np.r_[starts, ks.size])
    two = starts[counts == 2]
    e1 = order[two]
    e2 = order[two + 1]
    fwd = a < b
    one = order[starts[counts == 1]]
    nb = np.bincount(one // 3, minlength=m).astype(np.int64)
    return _Edges(e1 // 3, e2 // 3, e1 % 3, e2 % 3, fwd[e1] == fwd[e2], nb, int((counts > 2).sum()))


def _components(n: int, i: NDArray[np.int64], j: NDArray[np.int64]) -> tuple[int, NDArray[np.int64]]:
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    g = coo_matrix((np.ones(i.size, np.int8), (i, j)), shape=(n, n))
    nc, lab = connected_components(g, directed=False)
    return int(nc), lab.astype(np.int64)


def _orient(
    v: NDArray[np.float64], f: NDArray[np.int64], edges: _Edges, ref: NDArray[np.float64] | None
) -> tuple[NDArray[np.bool_], NDArray[np.int64], int, int]:
    """Faces to flip so that every component is consistent and faces the chosen way.

    Returns the flip mask, the component of each face, the number of
    components and the number of edges that could not be made consistent.
    """
    from ._kernels import orient_faces

    m = f.shape[0]
    src = np.r_[edges.f1, edges.f2]
    dst = np.r_[edges.f2, edges.f1]
    same = np.r_[edges.same, edges.same].astype(np.int8)
    order = np.argsort(src, kind="stable")
    ptr = np.r_[0, np.cumsum(np.bincount(src, minlength=m))].astype(np.int64)
    parity, comp, n_comp, conflicts = orient_faces(m, ptr, dst[order].astype(np.int64), same[order])
    flip0 = parity.astype(bool)
    fn = _face_normals(v, f)
    area = 0.5 * np.linalg.norm(fn, axis=1)
    # agreement of each face, as wound in the input, with the reference way
    if ref is not None:
        agree = np.sign(np.einsum("ij,ij->i", ref, fn)) * area
    else:
        agree = area.copy()
        closed = np.bincount(comp, weights=edges.n_boundary_of_face, minlength=n_comp) == 0
        closed &= conflicts == 0 and edges.n_nonmanifold == 0
        if closed.any():
            vol = np.einsum("ij,ij->i", v[f[:, 0]], np.cross(v[f[:, 1]], v[f[:, 2]])) / 6.0
            agree = np.where(closed[comp], vol, agree)
    signed = np.where(flip0, -agree, agree)
    score = np.bincount(comp, weights=signed, minlength=n_comp)
    flip_comp = score < 0
    flip = flip0 ^ flip_comp[comp]
    return flip, comp, n_comp, conflicts


def _duplicates(fw: NDArray[np.int64]) -> tuple[NDArray[np.bool_], NDArray[np.int64], NDArray[np.int64]]:
    """Faces to keep as the front layer, and the (back, front) pairs of double-sided faces."""
    m = fw.shape[0]
    s = np.sort(fw, axis=1)
    # winding parity: is (a, b, c) an even permutation of its sorted vertices?
    rot = np.argmin(fw, axis=1)
    nxt = fw[np.arange(m), (rot + 1) % 3]
    even = nxt == s[:, 1]
    order = np.lexsort((s[:, 2], s[:, 1], s[:, 0]))
    ss = s[order]
    new = np.r_[True, np.any(ss[1:] != ss[:-1], axis=1)]
    gid = np.cumsum(new) - 1
    first = order[np.flatnonzero(new)]
    front_even = even[first][gid]
    e = even[order]
    is_first = new
    opposite = e != front_even
    # the first face of the other winding in each group is the back layer
    cum = np.cumsum(opposite)
    before = np.r_[0, cum[:-1]]
    group_start_cum = before[np.flatnonzero(new)][gid]
    first_opposite = opposite & (before == group_start_cum)
    keep = np.zeros(m, bool)
    keep[order[is_first]] = True
    back = order[first_opposite]
    front_of_back = first[gid[first_opposite]]
    return keep, back, front_of_back


def _normals_ok(normals: ArrayLike | None, n: int, name: str) -> tuple[NDArray[np.float64] | None, str | None]:
    if normals is None:
        return None, None
    nn = np.asarray(normals, dtype=np.float64)
    if nn.shape != (n, 3):
        raise MeshError(f"{name}: normals: expected shape {(n, 3)}, got {nn.shape}")
    with np.errstate(all="ignore"):
        ln = np.linalg.norm(nn, axis=1)
    bad = ~(np.isfinite(ln) & (ln > 0))
    if bad.any():
        return None, f"ignored the file's vertex normals ({int(bad.sum())} are zero or not finite)"
    return nn / ln[:, None], None


def repair(
    vertices: ArrayLike,
    faces: ArrayLike,
    *,
    normals: ArrayLike | None = None,
    uv: ArrayLike | None = None,
    name: str = "mesh",
) -> RepairedMesh:
    """Weld, clean, orient and cut a triangle mesh; see the module's description.

    Parameters
    ----------
    vertices, faces
        ``(n, 3)`` positions (any unit) and ``(m, 3)`` vertex indices.
    normals
        Optional ``(n, 3)`` vertex normals of the file: they decide which way
        each component faces, and are kept (flipped where they disagree).
    uv
        Optional ``(n, 2)`` texture coordinates: vertices are merged in the
        output only where position, UV and normal agree.
    name
        For messages (the file's name).

    Returns
    -------
    RepairedMesh
        The analysis surface, the output mesh and what was repaired.

    Raises
    ------
    MeshError
        When nothing renderable is left (no faces, all degenerate) or the
        arrays are unusable.
    """
    v_in, f_in = check_arrays(vertices, faces, name=name)
    n_in = v_in.shape[0]
    repairs: list[str] = []
    n_file, note = _normals_ok(normals, n_in, name)
    if note:
        repairs.append(note)
    if f_in.shape[0] == 0:
        raise MeshError(f"{name}: the mesh has no faces")
    wid, vw, ident = _welded(v_in, f_in, uv, n_file)
    f_in, fw = _non_degenerate(f_in, wid[f_in], vw, name, repairs)
    lay = _layers(f_in, fw, ident, n_in, int(wid.max()) + 1, repairs)
    edges, comp = _orient_layers(vw, lay, n_file, repairs)
    a = _analysis_surface(vw, lay, edges, repairs)
    out_source, out_vertex, out_side, out_faces = _output_vertices(lay, a, edges, ident, n_in, n_file)
    out_normals = _output_normals(lay, a, out_source, out_vertex, out_side, out_faces, n_file, repairs)
    pairs = np.c_[edges.f1[a.ok], edges.f2[a.ok]].astype(np.int64)
    for r in repairs:
        _LOG.info("%s: %s", name, r)
    return RepairedMesh(a.va, a.fa.astype(np.int64), a.na, a.areas, out_source.astype(np.int64),
                        out_vertex.astype(np.int64), out_side, out_faces.astype(np.int64), out_normals,
                        pairs, _vertex_components(a.fa, comp, a.n_cls), ident, tuple(repairs))


def _welded(v_in: NDArray[np.float64], f_in: NDArray[np.int64], uv: ArrayLike | None,
            n_file: NDArray[np.float64] | None) -> tuple[NDArray[np.int64], NDArray[np.float64], NDArray[np.int64]]:
    """The welded vertex of every input vertex (seams closed), the welded positions, and every input vertex's
    stand-in: the first input vertex of the same position (a seam's two sides stay apart), UV and normal."""
    exact = weld(v_in)
    wid = _close_seams(v_in, f_in, exact, SEAM_TOLERANCE)
    _, first_w = np.unique(wid, return_index=True)
    vw = v_in[first_w]  # the first vertex of each group
    cols = [exact[:, None].astype(np.float64)]
    if uv is not None:
        cols.append(np.asarray(uv, dtype=np.float64))
    if n_file is not None:
        cols.append(np.round(n_file, 6))
    first_id, ident = _unique_rows(np.hstack(cols))
    return wid, vw, first_id[ident]


def _non_degenerate(f_in: NDArray[np.int64], fw: NDArray[np.int64], vw: NDArray[np.float64], name: str,
                    repairs: list[str]) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """The faces (input and welded indices) without repeated vertices or area."""
    diag = float(np.linalg.norm(vw.max(0) - vw.min(0))) if vw.shape[0] else 0.0
    fn = _face_normals(vw, fw)
    area2 = np.linalg.norm(fn, axis=1)
    good = (fw[:, 0] != fw[:, 1]) & (fw[:, 1] != fw[:, 2]) & (fw[:, 0] != fw[:, 2])
    good &= area2 > 1e-14 * diag * diag
    if not good.any():
        raise MeshError(f"{name}: every face is degenerate (repeated vertices or no area); nothing to render")
    if not good.all():
        repairs.append(f"dropped {int((~good).sum())} degenerate faces")
    return f_in[good], fw[good]


#: The front layer's faces (input and welded indices), the back layer's, each back face's front partner, and
#: the number of welded vertices.
_Layers = namedtuple("_Layers", "ff_in ffw fb_in fbw partner n_w")


def _layers(f_in: NDArray[np.int64], fw: NDArray[np.int64], ident: NDArray[np.int64], n_in: int, n_w: int,
            repairs: list[str]) -> _Layers:
    """Duplicate faces dropped; a double-sided panel's second faces as a back layer, each with its front partner."""
    keep, back, front_of_back = _duplicates(fw)
    n_dup = int(fw.shape[0] - keep.sum() - back.size)
    if n_dup:
        repairs.append(f"dropped {n_dup} duplicate faces")
    # the front layer, its indices; back faces map to their front partner's position in it
    front_idx = np.flatnonzero(keep)
    pos_in_front = np.full(fw.shape[0], -1, np.int64)
    pos_in_front[front_idx] = np.arange(front_idx.size)
    ff_in, ffw = f_in[front_idx].copy(), fw[front_idx].copy()
    used_front = _distinct(ff_in, n_in)
    n_twins = int(used_front.size) - int(_distinct(ident[used_front], n_in).size)
    if n_twins:
        repairs.insert(0, f"welded {n_twins} duplicate vertices")
    return _Layers(ff_in, ffw, f_in[back].copy(), fw[back].copy(), pos_in_front[front_of_back], n_w)


def _orient_layers(vw: NDArray[np.float64], lay: _Layers, n_file: NDArray[np.float64] | None,
                   repairs: list[str]) -> tuple[_Edges, NDArray[np.int64]]:
    """Orient the front layer's components (the file's normals decide, else the winding) and the back layer
    opposite to it; the front layer's edges and the component of each of its faces."""
    edges = _edges(lay.ffw, lay.n_w)
    ref = None if n_file is None else n_file[lay.ff_in].sum(axis=1)
    flip, comp, n_comp, _ = _orient(vw, lay.ffw, edges, ref)
    if flip.any():
        n_flipped_comp = int(_distinct(comp[flip], n_comp).size)
        repairs.append(f"re-oriented {n_flipped_comp} of {n_comp} component{'s' if n_comp > 1 else ''}")
        lay.ff_in[flip] = lay.ff_in[flip][:, ::-1]
        lay.ffw[flip] = lay.ffw[flip][:, ::-1]
        edges = _edges(lay.ffw, lay.n_w)
    if lay.partner.size:
        # the back face winds opposite to its (oriented) front partner
        fb_flip = flip[lay.partner]
        lay.fb_in[fb_flip] = lay.fb_in[fb_flip][:, ::-1]
        lay.fbw[fb_flip] = lay.fbw[fb_flip][:, ::-1]
        repairs.append(f"kept {lay.partner.size} double-sided faces as a back layer with its own curvature sign")
    return edges, comp


#: The analysis surface: positions, faces, face and vertex normals, vertex areas; the class (analysis vertex)
#: of every front corner, how many, and which front edges join consistently oriented faces.
_Analysis = namedtuple("_Analysis", "va fa fna na areas cls n_cls ok")


def _analysis_surface(vw: NDArray[np.float64], lay: _Layers, edges: _Edges, repairs: list[str]) -> _Analysis:
    """The front layer's corners joined across consistently oriented two-face edges: one analysis vertex each."""
    m_a = lay.ffw.shape[0]
    ok = ~edges.same
    c_a1 = 3 * edges.f1[ok] + edges.k1[ok]
    c_b1 = 3 * edges.f1[ok] + (edges.k1[ok] + 1) % 3
    c_a2 = 3 * edges.f2[ok] + (edges.k2[ok] + 1) % 3
    c_b2 = 3 * edges.f2[ok] + edges.k2[ok]
    n_cls, cls = _components(3 * m_a, np.r_[c_a1, c_b1], np.r_[c_a2, c_b2])
    corner_w = lay.ffw.reshape(-1)
    n_used_w = int(_distinct(corner_w, lay.n_w).size)
    if n_cls > n_used_w:
        n_cut = int(edges.same.sum()) + edges.n_nonmanifold
        repairs.append(f"split {n_cls - n_used_w} vertices along {n_cut} non-manifold or non-orientable "
                       "edges (curvature per side)")
    va = np.zeros((n_cls, 3))
    va[cls] = vw[corner_w]
    fa = cls.reshape(m_a, 3)
    fna = _face_normals(va, fa)
    na = _unit(_scatter(fa, fna, n_cls))
    areas = np.bincount(fa.reshape(-1), weights=np.repeat(0.5 * np.linalg.norm(fna, axis=1) / 3.0, 3),
                        minlength=n_cls).astype(np.float64)
    return _Analysis(va, fa, fna, na, areas, cls, n_cls, ok)


def _output_vertices(lay: _Layers, a: _Analysis, edges: _Edges, ident: NDArray[np.int64], n_in: int,
                     n_file: NDArray[np.float64] | None) -> tuple[NDArray[np.int64], NDArray[np.int64],
                                                                  NDArray[np.float64], NDArray[np.int64]]:
    """The output mesh: one vertex per (input vertex standing for its twins, smoothing group), front then back;
    its source, analysis vertex, side and faces."""
    m_a, m_b = lay.ffw.shape[0], lay.fbw.shape[0]
    # back layer corners: the analysis vertex of the front partner's corner on the same welded vertex
    back_cls = np.zeros((m_b, 3), np.int64)
    if m_b:
        pw = lay.ffw[lay.partner]
        pc = a.fa[lay.partner]
        for k in range(3):
            match = pw == lay.fbw[:, k : k + 1]
            back_cls[:, k] = pc[np.arange(m_b), np.argmax(match, axis=1)]
    # smoothing groups for computed shading normals: also cut where faces meet at a crease
    if n_file is None:
        un = _unit(a.fna)
        dots = np.einsum("ij,ij->i", un[edges.f1], un[edges.f2])
        smooth = a.ok & (dots >= math.cos(math.radians(CREASE_DEG)))
        c1 = np.r_[3 * edges.f1[smooth] + edges.k1[smooth], 3 * edges.f1[smooth] + (edges.k1[smooth] + 1) % 3]
        c2 = np.r_[3 * edges.f2[smooth] + (edges.k2[smooth] + 1) % 3, 3 * edges.f2[smooth] + edges.k2[smooth]]
        n_grp, grp = _components(3 * m_a, c1, c2)
    else:
        n_grp, grp = a.n_cls, a.cls
    corner_src = np.r_[ident[lay.ff_in.reshape(-1)], ident[lay.fb_in.reshape(-1)]]
    if m_b:
        back_grp = n_grp + grp.reshape(m_a, 3)[lay.partner][np.arange(m_b)[:, None],
                                                             np.argmax(lay.ffw[lay.partner][:, None, :]
                                                                       == lay.fbw[:, :, None], axis=2)]
    else:
        back_grp = np.zeros((0, 3), np.int64)
    corner_grp = np.r_[grp, back_grp.reshape(-1)]
    corner_cls = np.r_[a.cls, back_cls.reshape(-1)]
    corner_side = np.r_[np.ones(3 * m_a), -np.ones(3 * m_b)]
    key = corner_grp * np.int64(n_in) + corner_src
    _, first_c, out_of_corner = np.unique(key, return_index=True, return_inverse=True)
    out_of_corner = out_of_corner.reshape(-1)
    return corner_src[first_c], corner_cls[first_c], corner_side[first_c], out_of_corner.reshape(-1, 3)


def _output_normals(lay: _Layers, a: _Analysis, out_source: NDArray[np.int64], out_vertex: NDArray[np.int64],
                    out_side: NDArray[Any], out_faces: NDArray[np.int64], n_file: NDArray[np.float64] | None,
                    repairs: list[str]) -> NDArray[np.float64]:
    """The output vertices' shading normals: the file's, flipped where they disagree with the faces, or computed."""
    if n_file is not None:
        out_normals = n_file[out_source].copy()
        wrong = np.einsum("ij,ij->i", out_normals, a.na[out_vertex] * out_side[:, None]) < 0
        if wrong.any():
            out_normals[wrong] *= -1.0
            repairs.append(f"flipped {int(wrong.sum())} vertex normals to match the faces")
        return out_normals
    fn_all = np.r_[a.fna, -a.fna[lay.partner]] if lay.partner.size else a.fna
    return _unit(_scatter(out_faces, fn_all, out_source.size))


def _vertex_components(fa: NDArray[np.int64], face_comp: NDArray[np.int64], n: int) -> NDArray[np.int64]:
    """The component of every analysis vertex: that of its faces (a vertex's faces, joined through
    consistently oriented edges, are all of one orientation component), numbered 0, 1, ..."""
    out = np.zeros(n, np.int64)
    out[fa.reshape(-1)] = np.repeat(face_comp, 3)
    _, inv = np.unique(out, return_inverse=True)
    return inv.reshape(-1).astype(np.int64)
