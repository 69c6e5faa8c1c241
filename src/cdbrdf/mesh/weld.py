"""Welding a triangle mesh's vertices, and closing its seams, for the curvature (:func:`cdbrdf.mesh.repair`).

:func:`weld` makes vertices closer than :data:`WELD_TOLERANCE` x the
bounding-box diagonal one; :func:`weld_seams` also makes one the boundary
vertices within :data:`SEAM_TOLERANCE` x the median edge length of another
boundary vertex they share no edge with (sewn panels whose seam vertices a
simulation or an export left a hair apart), so that a seam is fitted as the
one surface it is.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["WELD_TOLERANCE", "SEAM_TOLERANCE", "weld", "weld_seams"]

#: Relative tolerance (of the bounding-box diagonal) under which vertices are welded.
WELD_TOLERANCE = 1e-7

#: Boundary vertices closer than this many median edge lengths (and sharing no edge) are one seam vertex
#: for the curvature. The seams of a draped, simulated dress meet within 1 % of an edge (a few are
#: 1-5 % apart); the layers of a pleat or a collar lie a cloth's thickness apart, 10 % of an edge and more.
SEAM_TOLERANCE = 0.05


def _by_first_appearance(group: NDArray[np.int64]) -> NDArray[np.int64]:
    """Group labels renumbered in order of the groups' first appearance."""
    _, first_g, inv_g = np.unique(group, return_index=True, return_inverse=True)
    order = np.argsort(first_g, kind="stable")
    rank = np.empty_like(order)
    rank[order] = np.arange(order.size)
    return rank[inv_g.reshape(-1)].astype(np.int64)


def _unique_rows(a: NDArray[Any]) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """For the rows of ``a``: the index of each distinct row's first occurrence, and each row's group.

    Groups are numbered in the rows' lexicographic order (like
    ``np.unique(a, axis=0)``, which is several times slower).
    """
    n = a.shape[0]
    if n == 0:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    order = np.lexsort(a.T[::-1])
    s = a[order]
    new = np.r_[True, np.any(s[1:] != s[:-1], axis=1)]
    gid = np.cumsum(new) - 1
    inv = np.empty(n, np.int64)
    inv[order] = gid
    return order[new].astype(np.int64), inv


def _distinct(a: NDArray[np.int64], n: int) -> NDArray[np.int64]:
    """The distinct values of ``a`` (integers in ``[0, n)``), sorted: a mask, linear in ``n`` (numpy 2's
    hashed ``unique`` takes seconds on a million face indices)."""
    mask = np.zeros(n, np.bool_)
    mask[a.reshape(-1)] = True
    return np.flatnonzero(mask)


def weld(vertices: NDArray[np.float64], *, tolerance: float = WELD_TOLERANCE) -> NDArray[np.int64]:
    """For every vertex the index of its welded vertex (vertices closer than ``tolerance`` x diagonal).

    Welded indices are numbered in order of first appearance; the welded
    position is that of the group's first vertex.

    Parameters
    ----------
    vertices
        ``(n, 3)`` positions.
    tolerance
        Weld distance as a fraction of the bounding-box diagonal.

    Returns
    -------
    numpy.ndarray
        ``(n,)`` welded index of every vertex.
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    n = vertices.shape[0]
    if n == 0:
        return np.zeros(0, np.int64)
    diag = float(np.linalg.norm(vertices.max(0) - vertices.min(0)))
    # exact duplicates first (seams, triangle soups), then near ones among the distinct positions
    first, inv = _unique_rows(vertices)
    uniq = vertices[first]
    label = np.arange(uniq.shape[0])
    if diag > 0 and uniq.shape[0] > 1:
        tree = cKDTree(uniq, balanced_tree=False, compact_nodes=False)
        pairs = tree.query_pairs(tolerance * diag, output_type="ndarray")
        if pairs.size:
            m = uniq.shape[0]
            g = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(m, m))
            _, label = connected_components(g, directed=False)
    return _by_first_appearance(label[inv])


def weld_seams(vertices: NDArray[np.float64], faces: NDArray[np.int64], *,
               tolerance: float = SEAM_TOLERANCE) -> NDArray[np.int64]:
    """For every vertex its welded index, the seams closed: :func:`weld`, then boundary vertices close together.

    A boundary vertex (on an edge of one face, after :func:`weld`) within
    ``tolerance`` x the median edge length of another boundary vertex is
    welded to it, unless the two share an edge or the weld would collapse a
    face (a short edge of one panel is not a seam).

    Parameters
    ----------
    vertices
        ``(n, 3)`` positions.
    faces
        ``(m, 3)`` vertex indices (checked).
    tolerance
        Weld distance of boundary vertices, in median edge lengths.

    Returns
    -------
    numpy.ndarray
        ``(n,)`` welded index of every vertex, numbered in order of first appearance.
    """
    return _close_seams(vertices, faces, weld(vertices), tolerance)


def _close_seams(vertices: NDArray[np.float64], faces: NDArray[np.int64], wid: NDArray[np.int64],
                 tolerance: float) -> NDArray[np.int64]:
    """:func:`weld_seams` on the result ``wid`` of :func:`weld`."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    if faces.size == 0 or not tolerance > 0:
        return wid
    n = int(wid.max()) + 1
    fw = wid[faces]
    pos = np.zeros((n, 3))
    pos[wid] = vertices
    e = np.sort(np.concatenate([fw[:, [0, 1]], fw[:, [1, 2]], fw[:, [2, 0]]]), axis=1)
    e = e[e[:, 0] != e[:, 1]]
    key = e[:, 0] * np.int64(n) + e[:, 1]
    ukey, count = np.unique(key, return_counts=True)
    length = np.linalg.norm(pos[ukey // n] - pos[ukey % n], axis=1)
    edge = float(np.median(length[length > 0])) if (length > 0).any() else 0.0
    b = _distinct(np.r_[ukey[count == 1] // n, ukey[count == 1] % n], n)
    if b.size < 2 or not edge > 0:
        return wid
    pairs = cKDTree(pos[b]).query_pairs(tolerance * edge, output_type="ndarray")
    if pairs.size == 0:
        return wid
    p = np.sort(b[pairs], axis=1)
    pk = p[:, 0] * np.int64(n) + p[:, 1]
    at = np.minimum(np.searchsorted(ukey, pk), ukey.size - 1)
    p = p[ukey[at] != pk]  # two ends of one edge stay apart (ukey is sorted)
    if p.size == 0:
        return wid
    _, label = connected_components(coo_matrix((np.ones(len(p)), (p[:, 0], p[:, 1])), shape=(n, n)),
                                    directed=False)
    lf = label[fw]
    collapsed = ((lf[:, 0] == lf[:, 1]) | (lf[:, 1] == lf[:, 2]) | (lf[:, 0] == lf[:, 2])) & \
        (fw[:, 0] != fw[:, 1]) & (fw[:, 1] != fw[:, 2]) & (fw[:, 0] != fw[:, 2])
    if collapsed.any():  # undo the welds that would collapse a face
        bad = np.zeros(n, np.bool_)
        bad[lf[collapsed].reshape(-1)] = True
        undo = bad[label]
        label = np.where(undo, n + np.arange(n), label)
    return _by_first_appearance(label[wid])
