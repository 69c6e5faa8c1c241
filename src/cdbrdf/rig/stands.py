"""Triangle meshes of the measurement stands for the simulated rig, and rays meeting their face.

The stand's centre is the origin; its face's normal there is +z, the bending
direction +x, the cylinder axis y (the conventions' local frame). The fabric
covers the face - the outside of a cylinder (``kappa > 0``), a flat face, or
the inside of a trough (``kappa < 0``) of :class:`~cdbrdf.measure.stands.Stand`
geometry, whose edges carry white walls; the rest of the body is white.
Lengths in mm.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from ..measure.registration import face_hits
from ..measure.stands import Stand

__all__ = ["stand_meshes", "surface_hits"]


def _strip(xz: NDArray, nrm: NDArray, u: NDArray, length_mm: float, *, max_step_mm: float = 0.5
           ) -> dict[str, NDArray]:
    """A ribbon extruded along y from a 2-D profile (points xz, normals, u per point).

    The ribbon is cut every ``max_step_mm`` along y as well, so that no
    triangle is a long sliver (ray-triangle tests on slivers let a few rays
    slip through shared edges).
    """
    n = xz.shape[0]
    ny = max(1, int(math.ceil(length_mm / max_step_mm)))
    ys = np.linspace(-0.5 * length_mm, 0.5 * length_mm, ny + 1)
    pos = np.zeros((ny + 1, n, 3))
    pos[..., 0] = xz[None, :, 0]
    pos[..., 1] = ys[:, None]
    pos[..., 2] = xz[None, :, 1]
    nor = np.zeros((ny + 1, n, 3))
    nor[..., 0] = nrm[None, :, 0]
    nor[..., 2] = nrm[None, :, 1]
    uv = np.zeros((ny + 1, n, 2))
    uv[..., 0] = u[None, :]
    uv[..., 1] = np.linspace(0.0, 1.0, ny + 1)[:, None]
    j, i = np.meshgrid(np.arange(ny), np.arange(n - 1), indexing="ij")
    a = (j * n + i).ravel()
    b, c, d = a + 1, a + n + 1, a + n
    faces = np.concatenate([np.stack([a, b, c], -1), np.stack([a, c, d], -1)]).astype(np.uint32)
    return {"positions": pos.reshape(-1, 3), "normals": nor.reshape(-1, 3), "uv": uv.reshape(-1, 2),
            "faces": faces}


def _cap(xz: NDArray, y: float, outward: float) -> dict[str, NDArray]:
    """A flat polygon (fan) closing a profile at ``y``, normal ``(0, outward, 0)``."""
    n = xz.shape[0]
    centre = xz.mean(axis=0)
    pos = np.zeros((n + 1, 3))
    pos[:n, 0], pos[:n, 2] = xz[:, 0], xz[:, 1]
    pos[n, 0], pos[n, 2] = centre
    pos[:, 1] = y
    nor = np.tile([0.0, outward, 0.0], (n + 1, 1))
    uv = np.zeros((n + 1, 2))
    i = np.arange(n)
    faces = np.stack([np.full(n, n), i, (i + 1) % n], -1).astype(np.uint32)
    return {"positions": pos, "normals": nor, "uv": uv, "faces": faces}


def _arc(stand: Stand, s0: float, s1: float, n: int) -> tuple[NDArray, NDArray]:
    """Profile points and normals of the stand's face for arc lengths s0..s1 (mm)."""
    s = np.linspace(s0, s1, n)
    if stand.kappa == 0:
        xz = np.stack([s, np.zeros_like(s)], axis=-1)
        nrm = np.tile([0.0, 1.0], (n, 1))
    else:
        r = stand.radius_mm
        a = s / r
        if stand.kappa > 0:
            xz = np.stack([r * np.sin(a), r * np.cos(a) - r], axis=-1)
            nrm = np.stack([np.sin(a), np.cos(a)], axis=-1)
        else:
            xz = np.stack([r * np.sin(a), r - r * np.cos(a)], axis=-1)
            nrm = np.stack([-np.sin(a), np.cos(a)], axis=-1)
    return xz, nrm


def stand_meshes(stand: Stand, *, segments: int = 256) -> dict[str, dict[str, NDArray]]:
    """Triangle meshes of a stand: ``"fabric"`` and the white body parts.

    Each mesh is a dict of ``positions``, ``normals`` (smooth, exact),
    ``uv`` (u along the bending direction x, so dP/du is the material's
    reference tangent) and ``faces``. Lengths in mm.

    Parameters
    ----------
    stand
        The stand.
    segments
        Segments along the curved face.

    Returns
    -------
    dict
        The meshes by part name.
    """
    w = stand.face_width_mm
    L = stand.length_mm
    xz, nrm = _arc(stand, -0.5 * w, 0.5 * w, segments + 1)
    out = {"fabric": _strip(xz, nrm, np.linspace(0.0, 1.0, segments + 1), L)}
    pad = 12.0
    if stand.kappa > 0:
        r = stand.radius_mm
        a0 = 0.5 * w / r
        ang = np.linspace(a0, 2 * math.pi - a0, segments + 1)
        bxz = np.stack([r * np.sin(ang), r * np.cos(ang) - r], axis=-1)
        bn = np.stack([np.sin(ang), np.cos(ang)], axis=-1)
        out["body"] = _strip(bxz, bn, np.linspace(0, 1, segments + 1), L)
        ring = np.concatenate([xz, bxz[1:-1]])  # the whole circle: close the tube's ends
        ring = ring[np.argsort(np.arctan2(ring[:, 0], ring[:, 1] + r))]
        out["capA"] = _cap(ring, -0.5 * L, -1.0)
        out["capB"] = _cap(ring, 0.5 * L, 1.0)
    elif stand.kappa == 0:
        for side in (-1, 1):
            x = np.array([0.5 * w, 0.5 * w + pad]) * side
            if side < 0:
                x = x[::-1]
            out[f"top{'LR'[side > 0]}"] = _strip(
                np.stack([x, np.zeros(2)], axis=-1), np.tile([0.0, 1.0], (2, 1)), np.array([0.0, 1.0]), L
            )
    else:
        x_e, z_e = stand.edge_mm
        top = z_e + stand.wall_height_mm
        for side in (-1, 1):
            xe = side * x_e
            if stand.wall_height_mm > 0:
                zz = np.array([z_e, top]) if side < 0 else np.array([top, z_e])
                out[f"wall{'LR'[side > 0]}"] = _strip(
                    np.stack([np.full(2, xe), zz], axis=-1), np.tile([-side, 0.0], (2, 1)).astype(float),
                    np.array([0.0, 1.0]), L,
                )
            x = np.array([xe, xe + side * pad])
            if side < 0:
                x = x[::-1]
            out[f"top{'LR'[side > 0]}"] = _strip(
                np.stack([x, np.full(2, top)], axis=-1), np.tile([0.0, 1.0], (2, 1)), np.array([0.0, 1.0]), L
            )
    return out


def surface_hits(stand: Stand, origins: NDArray, v: NDArray) -> tuple[NDArray, NDArray, NDArray]:
    """Where rays ``origins - s v`` (from the camera at s = -inf) meet the stand's face.

    The measurement's own geometry (:func:`cdbrdf.measure.registration.face_hits`).

    Parameters
    ----------
    stand
        The stand (its face: a cylinder of radius ``1 / |kappa|`` mm, or flat).
    origins
        ``(n, 3)`` points on the rays, mm.
    v
        ``(3,)`` the unit direction towards the camera.

    Returns
    -------
    points, normals, tangents : numpy.ndarray
        ``(n, 3)`` each: where the rays meet the face's cylinder (mm), the face
        normals there and the tangents x (dP/du).
    """
    p, n, t, _s = face_hits(stand, origins, v)
    return p, n, t
