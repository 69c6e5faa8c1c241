"""Vertex tangents as MikkTSpace computes them, for a glTF asset's ``TANGENT`` attribute.

glTF recommends MikkTSpace tangents (the normal maps of most bakers are
encoded in that frame). :func:`mikktspace_tangents` follows the reference
implementation's rule on an indexed mesh: per triangle, the direction of
increasing u (``dP/du``) and its handedness from the signed UV area; per
corner, that direction projected into the vertex normal's tangent plane and
weighted by the corner's angle (measured in the same plane); summed over the
triangles of the same handedness around a vertex and normalised. A vertex
whose triangles disagree in handedness (mirrored UVs) is split, one copy per
handedness, as the reference's per-corner output does. ``w`` is +1 where
the UV map keeps the orientation (``bitangent = w * cross(normal,
tangent)`` points along increasing v of a v-up UV map, the OBJ convention;
glTF's v runs downwards, so the same ``w`` is right there: the reference
implementation run on glTF's UVs gives ``-w``).

Degenerate UV triangles add nothing; a vertex left without a direction gets
any unit vector in its tangent plane. ``tests/test_export.py`` checks the
rule against the reference implementation (compiled to WebAssembly, npm
``mikktspace``).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

__all__ = ["mikktspace_tangents", "any_tangent"]

_TINY = 1e-20


def _unit(a: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    n = np.linalg.norm(a, axis=-1, keepdims=True)
    ok = n[..., 0] > _TINY
    return np.where(ok[..., None], a / np.where(n > _TINY, n, 1.0), 0.0), ok


def any_tangent(normals: NDArray[np.float64]) -> NDArray[np.float64]:
    """A unit vector perpendicular to each normal (x projected, or y where the normal is near x).

    Parameters
    ----------
    normals
        ``(n, 3)`` unit normals.

    Returns
    -------
    numpy.ndarray
        ``(n, 3)`` unit tangents.
    """
    n = np.asarray(normals, dtype=np.float64)
    a = np.where(np.abs(n[:, 0:1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    p = a - np.einsum("ij,ij->i", a, n)[:, None] * n
    return p / np.linalg.norm(p, axis=1, keepdims=True)


def mikktspace_tangents(
    positions: NDArray[np.float64], normals: NDArray[np.float64], uv: NDArray[np.float64], faces: NDArray[np.int64]
) -> tuple[NDArray[np.float64], NDArray[np.int64], NDArray[np.int64]]:
    """MikkTSpace tangents of an indexed triangle mesh (see the module's description).

    Parameters
    ----------
    positions, normals
        ``(n, 3)`` vertex positions and unit normals.
    uv
        ``(n, 2)`` texture coordinates, v up (OBJ's convention).
    faces
        ``(m, 3)`` triangles.

    Returns
    -------
    tangents : numpy.ndarray
        ``(n', 4)``: unit ``xyz`` in each vertex's tangent plane, ``w`` = +1 or -1;
        ``n' >= n`` (vertices split by handedness come last).
    source : numpy.ndarray
        ``(n',)``: the input vertex each output vertex copies.
    faces : numpy.ndarray
        ``(m, 3)``: the triangles on the output vertices.
    """
    p = np.asarray(positions, dtype=np.float64)
    nrm = np.asarray(normals, dtype=np.float64)
    t = np.asarray(uv, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    n_v = p.shape[0]
    d1 = p[f[:, 1]] - p[f[:, 0]]
    d2 = p[f[:, 2]] - p[f[:, 0]]
    t21 = t[f[:, 1]] - t[f[:, 0]]
    t31 = t[f[:, 2]] - t[f[:, 0]]
    area = t21[:, 0] * t31[:, 1] - t21[:, 1] * t31[:, 0]
    preserving = area > 0
    vos = t31[:, 1:2] * d1 - t21[:, 1:2] * d2  # dP/du times the UV area
    sign = np.where(preserving, 1.0, -1.0)[:, None]
    vos, _ = _unit(vos)
    vos = np.where(np.abs(area)[:, None] > _TINY, sign * vos, 0.0)
    # per corner: the face's direction in the vertex's tangent plane, weighted by the corner's angle
    corner_v = f.reshape(-1)
    n_c = nrm[corner_v]
    os_c = np.repeat(vos, 3, axis=0)
    os_c, _ = _unit(os_c - np.einsum("ij,ij->i", os_c, n_c)[:, None] * n_c)
    prev = np.roll(f, 1, axis=1).reshape(-1)
    nxt = np.roll(f, -1, axis=1).reshape(-1)
    e1 = p[prev] - p[corner_v]
    e2 = p[nxt] - p[corner_v]
    e1, _ = _unit(e1 - np.einsum("ij,ij->i", e1, n_c)[:, None] * n_c)
    e2, _ = _unit(e2 - np.einsum("ij,ij->i", e2, n_c)[:, None] * n_c)
    angle = np.arccos(np.clip(np.einsum("ij,ij->i", e1, e2), -1.0, 1.0))
    orient = np.repeat(preserving, 3)
    # one group per (vertex, handedness); a vertex's majority handedness keeps its index
    key = corner_v * 2 + orient
    groups, inverse = np.unique(key, return_inverse=True)
    acc = np.zeros((groups.size, 3))
    np.add.at(acc, inverse, angle[:, None] * os_c)
    g_vertex = groups // 2
    g_orient = (groups % 2).astype(bool)
    count = np.bincount(inverse, minlength=groups.size)
    # where a vertex has both handednesses, the larger group keeps the vertex, the other is a new one
    order = np.lexsort((-count, g_vertex))
    first = np.ones(groups.size, dtype=bool)
    first[order[1:]] = g_vertex[order[1:]] != g_vertex[order[:-1]]
    new_index = np.empty(groups.size, dtype=np.int64)
    new_index[first] = g_vertex[first]
    extra = np.flatnonzero(~first)
    new_index[extra] = n_v + np.arange(extra.size)
    source = np.r_[np.arange(n_v), g_vertex[extra]]
    tan, ok = _unit(acc)
    xyz = np.zeros((n_v + extra.size, 3))
    w = np.ones(n_v + extra.size)
    xyz[new_index] = tan
    w[new_index] = np.where(g_orient, 1.0, -1.0)
    have = np.zeros(n_v + extra.size, dtype=bool)
    have[new_index] = ok
    if not have.all():
        xyz[~have] = any_tangent(nrm[source[~have]])
    out_faces = new_index[inverse].reshape(-1, 3)
    return np.concatenate([xyz, w[:, None]], axis=1), source, out_faces
