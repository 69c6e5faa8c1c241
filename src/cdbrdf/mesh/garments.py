"""Test garments and figures as their makers export them: sewn panels in mm, a scan-like bust.

:func:`garment_mesh` is a sleeved top as a fashion CAD tool exports it:
Z-up, in millimetres, coarse (edges of 9-14 mm), made of separate panels
(front, back, two sleeves) *sewn* along seams: the panels' boundary vertices
on a seam coincide but are not shared, and each panel has its own UV chart.
It is open at the neck (pointing up), the hem (down) and the cuffs (out and
down), and carries soft vertical folds growing towards the hem. The body is
an elliptic tube narrowing to the neck; above the armpits a lens-shaped gap
at each side is the armhole, sewn to the sleeve's first ring.

:func:`bust_mesh` is a scan-like bust: Y-up, a closed surface with a flat
base (or open at the base), fine and unitless as scans are.
:func:`head_mesh` is a scanned head and neck, Y-up, facing +z: the neck cut
at a slant (from under the chin to the nape) and left open or capped flat,
with a nose and a chin, noisy.

They exercise what real files do to the up axis, the units and the
curvature (``tests/test_garments.py``); the documentation's pictures are
rendered from them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..errors import OptionError
from .core import Mesh

__all__ = ["Garment", "garment_mesh", "bust_mesh", "head_mesh"]


@dataclass(frozen=True)
class Garment:
    """The sleeved top of :func:`garment_mesh` (lengths in mm).

    Attributes
    ----------
    half_width_mm, half_depth_mm
        Half axes of the body's elliptic cross-section (x: across, y: front to back).
    armpit_mm, height_mm
        Height of the armpits and of the neck above the hem.
    neck_scale
        Size of the neck opening relative to the body's cross-section.
    sleeve_length_mm, cuff_radius_mm, sleeve_drop_deg
        Length of the sleeves, radius of their cuffs, and how far they point
        down from the horizontal.
    folds, fold_amplitude_mm
        Vertical folds around the body and their radial amplitude at the hem.
    edge_mm
        The target edge length (the CAD tools' coarse tessellation).
    """

    half_width_mm: float = 170.0
    half_depth_mm: float = 110.0
    armpit_mm: float = 470.0
    height_mm: float = 620.0
    neck_scale: float = 0.55
    sleeve_length_mm: float = 190.0
    cuff_radius_mm: float = 55.0
    sleeve_drop_deg: float = 45.0
    folds: int = 14
    fold_amplitude_mm: float = 7.0
    edge_mm: float = 11.0

    def __post_init__(self) -> None:
        for name in ("half_width_mm", "half_depth_mm", "armpit_mm", "height_mm", "sleeve_length_mm",
                     "cuff_radius_mm", "edge_mm"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise OptionError(f"{name}: must be a positive length in mm, got {v!r}")
        if not self.armpit_mm < self.height_mm:
            raise OptionError(f"armpit_mm: must be below height_mm ({self.height_mm:g}), got {self.armpit_mm!r}")
        if not 0.1 <= self.neck_scale <= 1.0:
            raise OptionError(f"neck_scale: must be in [0.1, 1], got {self.neck_scale!r}")
        if not (math.isfinite(self.fold_amplitude_mm) and 0 <= self.fold_amplitude_mm < 0.2 * self.half_depth_mm):
            raise OptionError(f"fold_amplitude_mm: must be in [0, 0.2 x half_depth_mm), got {self.fold_amplitude_mm!r}")


def _ring_faces(n_around: int, n_rows: int, offset: int, *, closed: bool) -> NDArray[np.int64]:
    """Quads of a grid ``(around, rows)`` split in two, wrapping around when ``closed``."""
    na = n_around if closed else n_around - 1
    i, j = np.meshgrid(np.arange(na), np.arange(n_rows - 1), indexing="ij")
    a = i * n_rows + j
    b = ((i + 1) % n_around) * n_rows + j
    f = np.concatenate([np.stack([a, b, b + 1], -1).reshape(-1, 3), np.stack([a, b + 1, a + 1], -1).reshape(-1, 3)])
    return (f + offset).astype(np.int64)


def _body_point(g: Garment, phi: NDArray[np.float64], z: NDArray[np.float64]) -> NDArray[np.float64]:
    top = np.clip((z - g.armpit_mm) / (g.height_mm - g.armpit_mm), 0.0, 1.0)
    s = 1.0 - (1.0 - g.neck_scale) * np.sin(0.5 * np.pi * top) ** 2  # narrows smoothly to the neck
    hem = np.clip(1.0 - z / g.armpit_mm, 0.0, 1.0) ** 1.5
    r = 1.0 + g.fold_amplitude_mm / g.half_depth_mm * hem * np.cos(g.folds * phi)
    return np.stack([g.half_width_mm * s * r * np.cos(phi), g.half_depth_mm * s * r * np.sin(phi), z], axis=-1)


def garment_mesh(garment: Garment = Garment()) -> Mesh:
    """The sewn top of :class:`Garment` (see the module's description).

    Parameters
    ----------
    garment
        Its sizes.

    Returns
    -------
    Mesh
        Z-up vertices in mm, the panels' triangles (each wound as drawn), one
        UV chart per panel, no normals; metadata ``units = "mm"``,
        ``format = "obj"`` and ``"panels"`` (the panel of each face). The
        seams' vertices are duplicated per panel, not welded.
    """
    g = garment
    e = g.edge_mm
    rows = max(4, round(g.height_mm / e)) + 1
    z = np.linspace(0.0, g.height_mm, rows)
    half = math.pi * math.sqrt(0.5 * (g.half_width_mm**2 + g.half_depth_mm**2))
    cols = max(4, round(half / e)) + 1
    # the armhole's half opening angle: round at the armpit and at the shoulder
    lens = np.sqrt(np.sin(np.pi * np.clip((z - g.armpit_mm) / (g.height_mm - g.armpit_mm), 0.0, 1.0)))
    lens = lens * math.radians(30.0)
    vs, uvs, fs, panel = [], [], [], []
    offset = 0
    grids = []
    # back panel: phi in [lens, pi - lens] (y > 0); front: [pi + lens, 2 pi - lens] (y < 0, facing -y)
    for k, base in enumerate((0.0, math.pi)):
        t = np.linspace(0.0, 1.0, cols)
        phi = base + lens[None, :] + t[:, None] * (math.pi - 2 * lens[None, :])
        Z = np.broadcast_to(z[None, :], phi.shape)
        P = _body_point(g, phi, Z)
        grids.append(P)
        vs.append(P.reshape(-1, 3))
        uvs.append(np.stack(np.broadcast_arrays(t[:, None], z[None, :] / g.height_mm), -1).reshape(-1, 2))
        fs.append(_ring_faces(cols, rows, offset, closed=False))
        panel.append(np.full(fs[-1].shape[0], k))
        offset += P.shape[0] * P.shape[1]
    back, front = grids
    ia = int(np.searchsorted(z, g.armpit_mm, side="right")) - 1  # last row at or below the armpit
    drop = math.radians(g.sleeve_drop_deg)
    for side, (fcol, bcol) in enumerate(((-1, 0), (0, -1))):  # right (x > 0): front's last, back's first column
        sign = 1.0 if side == 0 else -1.0
        # the armhole loop: up the front panel's edge, down the back panel's edge
        loop = np.concatenate([front[fcol, ia:], back[bcol, rows - 2:ia:-1]])
        centre = loop.mean(axis=0)
        d = np.array([sign * math.cos(drop), 0.0, -math.sin(drop)])
        e1 = np.array([0.0, 1.0, 0.0])
        e2 = np.array([0.0, 0.0, -1.0]) - (-d[2]) * d  # across the sleeve, towards the ground
        e2 /= np.linalg.norm(e2)
        rel = loop - centre
        # the cuff's angle of each loop vertex: by arc length from the armpit (at the cuff's lowest point,
        # psi = 90 degrees), up the front edge (y < 0) first
        seg = np.linalg.norm(np.roll(loop, -1, axis=0) - loop, axis=1)
        arc = np.r_[0.0, np.cumsum(seg)[:-1]] / seg.sum()
        psi = 0.5 * np.pi + 2 * np.pi * arc
        ring = np.cos(psi)[:, None] * e1 + np.sin(psi)[:, None] * e2
        cuff = centre + g.sleeve_length_mm * d + g.cuff_radius_mm * ring
        n_r = max(3, round(g.sleeve_length_mm / e)) + 1
        w = np.linspace(0.0, 1.0, n_r)
        bulge = 0.15 * g.cuff_radius_mm * np.sin(np.pi * w)
        radial = rel / np.linalg.norm(rel, axis=1, keepdims=True)
        S = (1 - w)[None, :, None] * loop[:, None, :] + w[None, :, None] * cuff[:, None, :] \
            + bulge[None, :, None] * radial[:, None, :]
        S[:, 0] = loop  # the sewn ring: the armhole's positions exactly
        n_a = loop.shape[0]
        vs.append(S.reshape(-1, 3))
        uvs.append(np.stack(np.broadcast_arrays(np.arange(n_a)[:, None] / n_a, w[None, :]), -1).reshape(-1, 2))
        f = _ring_faces(n_a, n_r, offset, closed=True)
        fs.append(f if sign < 0 else f[:, ::-1])
        panel.append(np.full(f.shape[0], 2 + side))
        offset += S.shape[0] * S.shape[1]
    faces = np.concatenate(fs)
    v = np.concatenate(vs)
    return Mesh(v, faces, None, np.concatenate(uvs), {},
                metadata={"units": "mm", "format": "obj", "panels": np.concatenate(panel)})


def bust_mesh(*, base: str = "closed", n_around: int = 96, n_rows: int = 64, scale: float = 1.0) -> Mesh:
    """A scan-like bust, Y-up: a head on a neck on shoulders, cut flat at the bottom.

    Parameters
    ----------
    base
        ``"closed"`` (a flat cap closes the base, as a watertight scan) or
        ``"open"`` (the base is a hole).
    n_around, n_rows
        Vertices around and from the base to the top.
    scale
        Model units per mm (scans are often unitless); the bust is about
        420 mm wide and 520 mm tall.

    Returns
    -------
    Mesh
        Y-up vertices, outward triangles, no UVs; metadata ``format = "ply"``.
    """
    if base not in ("closed", "open"):
        raise OptionError(f"base: {base!r} is not one of closed, open")
    t = np.linspace(0.0, 1.0, n_rows)  # 0 at the base, 1 at the top of the head
    h = 520.0 * t
    # half widths across (x) and front to back (z), a profile of shoulders, neck and head
    sh = np.clip(1.0 - t / 0.35, 0.0, 1.0)
    neck = np.exp(-(((t - 0.5) / 0.08) ** 2))
    head = np.sqrt(np.clip(1.0 - ((t - 0.78) / 0.22) ** 2, 0.0, 1.0))
    rx = np.maximum.reduce([210.0 * np.sqrt(np.clip(sh, 0, 1)), 55.0 * neck + 40.0, 80.0 * head])
    rz = np.maximum.reduce([110.0 * np.sqrt(np.clip(sh, 0, 1)), 50.0 * neck + 35.0, 95.0 * head])
    top = t > 0.97
    rx = np.where(top, 80.0 * np.sqrt(np.clip(1.0 - ((t - 0.78) / 0.22) ** 2, 0.0, 1.0)) + 1e-3, rx)
    rz = np.where(top, 95.0 * np.sqrt(np.clip(1.0 - ((t - 0.78) / 0.22) ** 2, 0.0, 1.0)) + 1e-3, rz)
    a = np.linspace(0.0, 2 * np.pi, n_around, endpoint=False)
    A, _ = np.meshgrid(a, t, indexing="ij")
    V = np.stack([rx[None, :] * np.cos(A), np.broadcast_to(h[None, :], A.shape), rz[None, :] * np.sin(A)], -1)
    v = V.reshape(-1, 3)
    f = _ring_faces(n_around, n_rows, 0, closed=True)[:, ::-1]
    parts_v, parts_f = [v], [f]
    n = v.shape[0]
    # close the top of the head with a fan, and the base with a flat cap
    parts_v.append(np.array([[0.0, h[-1], 0.0]]))
    ring_top = np.arange(n_around) * n_rows + n_rows - 1
    parts_f.append(np.stack([np.full(n_around, n), np.roll(ring_top, -1), ring_top], -1))
    if base == "closed":
        parts_v.append(np.array([[0.0, 0.0, 0.0]]))
        ring0 = np.arange(n_around) * n_rows
        parts_f.append(np.stack([np.full(n_around, n + 1), ring0, np.roll(ring0, -1)], -1))
    verts = np.concatenate(parts_v) * scale
    return Mesh(verts, np.concatenate(parts_f).astype(np.int64), None, None, {}, metadata={"format": "ply"})


def head_mesh(*, base: str = "open", tilt_deg: float = 25.0, n_around: int = 120, n_rows: int = 90,
              noise_mm: float = 0.3, seed: int = 0) -> Mesh:
    """A scanned head and neck, Y-up, facing +z, about 190 mm wide, 290 mm tall, in mm (see the module).

    Parameters
    ----------
    base
        ``"open"`` (the cut is a hole, as most scans leave it) or ``"closed"``
        (capped flat, as a watertight scan).
    tilt_deg
        How far the cut slants (up towards the front: under the chin), degrees.
    n_around, n_rows
        Vertices around and from the cut to the crown.
    noise_mm
        Gaussian noise on every vertex but the cut's (a scan's), mm.
    seed
        Of the noise.

    Returns
    -------
    Mesh
        Y-up vertices, triangles facing out, no UVs; metadata ``format = "ply"``.
    """
    if base not in ("closed", "open"):
        raise OptionError(f"base: {base!r} is not one of closed, open")
    if not (math.isfinite(tilt_deg) and 0.0 <= tilt_deg < 60.0):
        raise OptionError(f"tilt_deg: must be in [0, 60), got {tilt_deg!r}")
    phi = np.linspace(0.0, 2 * np.pi, n_around, endpoint=False)  # 0 at +x, pi/2 at +z (the face)
    t = np.linspace(0.0, 1.0, n_rows)[None, :]
    # the cut: y = 30 + tan(tilt) z on the neck (radius 55)
    y0 = 30.0 + math.tan(math.radians(tilt_deg)) * 55.0 * np.sin(phi)[:, None]
    y = y0 + (290.0 - y0) * t
    ell = lambda a, b: 1.0 / np.sqrt((np.cos(phi)[:, None] / a) ** 2 + (np.sin(phi)[:, None] / b) ** 2)  # noqa: E731
    head = ell(80.0, 98.0) * np.sqrt(np.clip(1.0 - ((y - 180.0) / 110.0) ** 2, 0.0, 1.0))
    neck = ell(55.0, 58.0) * np.ones_like(y)
    r = np.where(y > 180.0, head, np.log(np.exp(head / 8.0) + np.exp(neck / 8.0)) * 8.0)  # a soft union below
    front = np.exp(-((phi[:, None] - 0.5 * np.pi) / 0.22) ** 2)
    r = r + front * (16.0 * np.exp(-((y - 175.0) / 14.0) ** 2) + 8.0 * np.exp(-((y - 108.0) / 12.0) ** 2))
    r = np.where(t[..., :] >= 1.0, 0.0, r)  # the crown closes in a point
    v = np.stack([r * np.cos(phi)[:, None], y, r * np.sin(phi)[:, None]], -1).reshape(-1, 3)
    f = _ring_faces(n_around, n_rows, 0, closed=True)[:, ::-1]
    parts_v, parts_f = [v], [f]
    if base == "closed":
        ring0 = np.arange(n_around) * n_rows
        parts_v.append(v[ring0].mean(axis=0, keepdims=True))
        parts_f.append(np.stack([np.full(n_around, v.shape[0]), ring0, np.roll(ring0, -1)], -1))
    verts = np.concatenate(parts_v)
    noisy = np.ones(verts.shape[0], bool)
    noisy[np.arange(n_around) * n_rows] = False  # the cut is a software's plane: exact
    noisy[n_around * n_rows:] = False
    verts = verts + noisy[:, None] * np.random.default_rng(seed).normal(0.0, noise_mm, verts.shape)
    faces = np.concatenate(parts_f).astype(np.int64)
    # the crown's ring collapses to one point: drop the faces that collapse with it
    top = np.arange(n_around) * n_rows + n_rows - 1
    verts[top] = verts[top].mean(axis=0)
    return Mesh(verts, faces, None, None, {}, metadata={"format": "ply"})
