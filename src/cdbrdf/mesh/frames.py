"""The material's x axis on a mesh: from the UVs, a tangent attribute or the principal directions.

The CDBRDF is anisotropic: its azimuths are measured from the material's
reference tangent x, which on the measurement stands is the bending
direction. Mitsuba's shading frame takes x as dP/du of the UV map
(``si.sh_frame.s``), so a frame reaches the renderer through UVs:

``uv``
    dP/du of the mesh's own UV map (the default when there are UVs; for
    cloth, u should run along the direction the fabric's x is measured in).
``tangent``
    a per-vertex tangent attribute of the file (PLY ``tx ty tz`` or
    ``tangent_x`` ...); each face gets UVs whose dP/du is the mean of its
    corners' tangents.
``principal``
    the direction of the principal curvature of larger magnitude (the
    bending direction, as on the stands); each face gets UVs whose dP/du is
    the mean of its corners' directions. Its sign is arbitrary (a principal
    direction is an axis), so it is chosen per face towards a fixed world
    direction, (1, 0.5, 0.25) normalised; at umbilics (spheres, flat parts)
    the direction is noise. The choice for meshes without UVs, and for
    UV-mapped models that are not cloth, whose UV charts would show as seams.
``auto``
    ``uv`` if the mesh has UVs, else ``tangent`` if it has tangents, else
    ``principal`` (announced).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

__all__ = [
    "FRAMES",
    "SEAM_ANGLE_DEG",
    "PRINCIPAL_SIGN_REFERENCE",
    "face_uv_tangents",
    "vertex_tangents",
    "project_tangents",
    "face_frame_uv",
    "align_axes",
    "seam_jumps",
]

#: Sources of the material's x axis (see the module's description).
FRAMES: tuple[str, ...] = ("auto", "uv", "tangent", "principal")

#: Angle by which the x axis may turn across a UV seam without a note, degrees.
SEAM_ANGLE_DEG = 30.0

#: World direction the sign of a principal direction is chosen towards.
PRINCIPAL_SIGN_REFERENCE: tuple[float, float, float] = (1.0, 0.5, 0.25)


def face_uv_tangents(
    positions: NDArray[np.float64], faces: NDArray[np.int64], uv: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """Unit dP/du of every face (Mitsuba's ``dp_du``) and whether it is defined.

    Undefined where the face's UVs are degenerate (zero UV area) or dP/du
    vanishes.
    """
    p0, p1, p2 = positions[faces[:, 0]], positions[faces[:, 1]], positions[faces[:, 2]]
    t0, t1, t2 = uv[faces[:, 0]], uv[faces[:, 1]], uv[faces[:, 2]]
    du1, dv1 = t1[:, 0] - t0[:, 0], t1[:, 1] - t0[:, 1]
    du2, dv2 = t2[:, 0] - t0[:, 0], t2[:, 1] - t0[:, 1]
    det = du1 * dv2 - du2 * dv1
    scale = np.maximum(np.abs(du1 * dv2) + np.abs(du2 * dv1), 1e-300)
    ok = np.isfinite(det) & (np.abs(det) > 1e-9 * scale)
    with np.errstate(all="ignore"):
        dpdu = ((p1 - p0) * dv2[:, None] - (p2 - p0) * dv1[:, None]) / np.where(ok, det, 1.0)[:, None]
    ln = np.linalg.norm(dpdu, axis=1)
    ok &= np.isfinite(ln) & (ln > 0)
    out = np.zeros_like(dpdu)
    out[ok] = dpdu[ok] / ln[ok, None]
    return out, ok


def vertex_tangents(
    faces: NDArray[np.int64], face_tangent: NDArray[np.float64], weights: NDArray[np.float64],
    normals: NDArray[np.float64],
) -> NDArray[np.float64]:
    """Per-vertex unit tangents: weighted sums of the faces' tangents, projected into the tangent plane.

    NaN rows where no face gives a tangent or it is along the normal.
    """
    n = normals.shape[0]
    idx = faces.reshape(-1)
    acc = np.stack([np.bincount(idx, weights=np.repeat(face_tangent[:, c] * weights, 3), minlength=n)
                    for c in range(3)], 1).astype(np.float64)
    return project_tangents(acc, normals)


def project_tangents(t: NDArray[np.float64], normals: NDArray[np.float64]) -> NDArray[np.float64]:
    """``t`` projected into the planes of ``normals`` and normalised; NaN where that vanishes."""
    p = t - np.einsum("ij,ij->i", t, normals)[:, None] * normals
    ln = np.linalg.norm(p, axis=1)
    out = np.full_like(p, np.nan)
    ok = np.isfinite(ln) & (ln > 1e-9 * np.maximum(np.linalg.norm(t, axis=1), 1e-300))
    out[ok] = p[ok] / ln[ok, None]
    return out


def align_axes(d: NDArray[np.float64], reference: NDArray[np.float64]) -> NDArray[np.float64]:
    """Axes ``d`` (rows, sign arbitrary) flipped to point along ``reference`` (rows or one vector)."""
    s = np.sign(np.einsum("ij,ij->i", d, np.broadcast_to(reference, d.shape)))
    return d * np.where(s < 0, -1.0, 1.0)[:, None]


def face_frame_uv(
    positions: NDArray[np.float64], faces: NDArray[np.int64], corner_tangent: NDArray[np.float64],
    *, align: bool,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Per-corner UVs whose dP/du on every face is its corners' mean tangent (in the face's plane).

    Parameters
    ----------
    positions, faces
        The mesh.
    corner_tangent
        ``(m, 3, 3)`` tangent of every corner (NaN where undefined).
    align
        The tangents are axes of arbitrary sign (principal directions):
        align each face's corners with its first, and the face's mean with
        :data:`PRINCIPAL_SIGN_REFERENCE`.

    Returns
    -------
    uv, tangent
        ``(m, 3, 2)`` corner UVs and ``(m, 3)`` unit face tangents. A face
        whose corners give no usable tangent gets its first edge's direction.
    """
    p = positions[faces]  # (m, 3, 3)
    e1 = p[:, 1] - p[:, 0]
    e2 = p[:, 2] - p[:, 0]
    n = np.cross(e1, e2)
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
    t = np.nan_to_num(corner_tangent.copy())
    if align:
        first = t[:, 0]
        for k in (1, 2):
            s = np.sign(np.einsum("ij,ij->i", t[:, k], first))
            t[:, k] *= np.where(s < 0, -1.0, 1.0)[:, None]
    tf = t.sum(axis=1)
    tf -= np.einsum("ij,ij->i", tf, n)[:, None] * n
    ln = np.linalg.norm(tf, axis=1)
    fallback = ~(ln > 1e-12 * np.maximum(np.linalg.norm(e1, axis=1), 1e-300))
    tf[fallback] = e1[fallback]
    tf /= np.maximum(np.linalg.norm(tf, axis=1, keepdims=True), 1e-300)
    if align:
        ref = np.asarray(PRINCIPAL_SIGN_REFERENCE, dtype=np.float64)
        tf = align_axes(tf, ref / np.linalg.norm(ref))
    b = np.cross(n, tf)
    d = p - p[:, :1]
    uv = np.stack([np.einsum("ikj,ij->ik", d, tf), np.einsum("ikj,ij->ik", d, b)], axis=-1)
    return uv, tf


def seam_jumps(
    positions: NDArray[np.float64], uv: NDArray[np.float64], face_tangent: NDArray[np.float64],
    ok: NDArray[np.bool_], adjacent: NDArray[np.int64], faces: NDArray[np.int64], out_faces: NDArray[np.int64],
) -> tuple[int, int]:
    """Seam edges of a UV map and those across which the x axis turns by more than :data:`SEAM_ANGLE_DEG`.

    ``adjacent`` pairs faces sharing an edge of the surface (``faces``: the
    surface's vertex indices); the edge is a UV seam when a vertex of the
    edge has different UVs (``uv`` at ``out_faces``) in the two faces. The
    angle is measured in the plane of the two faces' mean normal (the
    surface's own bending across the edge is not a turn of the frame).
    """
    if adjacent.size == 0:
        return 0, 0
    f1, f2 = adjacent[:, 0], adjacent[:, 1]
    # faces sharing two output vertices share their UVs there: only the others can be seams
    shared = (out_faces[f1][:, :, None] == out_faces[f2][:, None, :]).sum(axis=(1, 2))
    cand = np.flatnonzero(shared < 2)
    c1, c2 = f1[cand], f2[cand]
    match = faces[c1][:, :, None] == faces[c2][:, None, :]  # (k, 3, 3)
    u1 = uv[out_faces[c1]]  # (k, 3, 2)
    u2 = uv[out_faces[c2]]
    diff = np.abs(u1[:, :, None, :] - u2[:, None, :, :]).max(axis=-1) if cand.size else np.zeros((0, 3, 3))
    scale = max(float(np.ptp(uv)) if uv.size else 1.0, 1e-300)
    seam = np.zeros(f1.size, bool)
    seam[cand] = np.any(match & (diff > 1e-6 * scale), axis=(1, 2))
    both = seam & ok[f1] & ok[f2]
    g1, g2 = f1[both], f2[both]

    def unit_normal(f: NDArray[np.int64]) -> NDArray[np.float64]:
        p = positions[out_faces[f]]
        n = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
        return n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)

    n = unit_normal(g1) + unit_normal(g2)
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
    t1 = project_tangents(face_tangent[g1], n)
    t2 = project_tangents(face_tangent[g2], n)
    c = np.nan_to_num(np.einsum("ij,ij->i", t1, t2), nan=1.0)
    return int(seam.sum()), int((c < math.cos(math.radians(SEAM_ANGLE_DEG))).sum())
