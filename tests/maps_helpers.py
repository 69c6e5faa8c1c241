"""Sine wrinkles as maps and as geometry, and the 100 x 100 mm quad of the issue's test (shared by the map tests).

Known answer: wrinkles ``h = A sin(2 pi x / L)`` across u (crests along v),
``A = 0.4 mm``, ``L = 10 mm``: slope ``A k cos(k x)``, curvature along x
``A k^2 sin(k x)`` (``k = 2 pi / L``), at the crests ``A k^2 = 0.158 / mm``
(convex, > 0), ``-0.158`` in the troughs.
"""

from __future__ import annotations

import math

import numpy as np

from cdbrdf.images import write_png
from cdbrdf.mesh import Mesh

__all__ = ["A", "L", "S", "K", "PEAK", "sine_normals", "sine_heights", "quad", "wrinkled_grid", "write_normal_png",
           "delta_e"]

A, L, S = 0.4, 10.0, 100.0  # mm: amplitude, period, the quad's side (and the map's tile)
K = 2 * math.pi / L
PEAK = A * K * K  # 0.158 / mm


def sine_normals(texels: int = 512, *, size_mm: float = S, period_mm: float = L, amplitude_mm: float = A,
                 along: str = "u") -> np.ndarray:
    """Tangent-space normals (OpenGL, row 0 at v = 1) of the wrinkles over one tile of ``size_mm``."""
    t = (np.arange(texels) + 0.5) / texels * size_mm
    slope = amplitude_mm * 2 * np.pi / period_mm * np.cos(2 * np.pi * t / period_mm)  # dh/dx
    n = np.zeros((texels, texels, 3))
    n[..., 2] = 1.0
    if along == "u":
        n[..., 0] = -slope[None, :]
    else:
        n[..., 1] = -slope[::-1, None]  # rows run down, v up
    return n / np.linalg.norm(n, axis=-1, keepdims=True)


def sine_heights(texels: int = 512, *, size_mm: float = S) -> np.ndarray:
    """The same wrinkles as a height map in [0, 1] (height scale ``2 A`` mm), columns along u."""
    t = (np.arange(texels) + 0.5) / texels * size_mm
    return np.broadcast_to(0.5 + 0.5 * np.sin(K * t)[None, :], (texels, texels)).copy()


def quad(size_mm: float = S, *, uv_scale: float = 1.0) -> Mesh:
    """Two triangles, ``size_mm`` square in z = 0, UVs ``xy / size * uv_scale`` (1: 0 to 1; size: UVs in mm)."""
    v = np.array([[0, 0, 0], [size_mm, 0, 0], [size_mm, size_mm, 0], [0, size_mm, 0]], dtype=float)
    f = np.array([[0, 1, 2], [0, 2, 3]])
    return Mesh(v, f, None, v[:, :2] / size_mm * uv_scale)


def wrinkled_grid(nu: int = 401, nv: int = 41, *, size_mm: float = S) -> Mesh:
    """The wrinkles as geometry: an ``nu x nv`` grid over the quad, UVs 0 to 1."""
    x, y = np.meshgrid(np.linspace(0, size_mm, nu), np.linspace(0, size_mm, nv), indexing="ij")
    z = A * np.sin(K * x)
    q = (np.arange(nu - 1)[:, None] * nv + np.arange(nv - 1)[None, :]).ravel()
    f = np.concatenate([np.c_[q, q + nv, q + nv + 1], np.c_[q, q + nv + 1, q + 1]])
    return Mesh(np.c_[x.ravel(), y.ravel(), z.ravel()], f, None, np.c_[x.ravel(), y.ravel()] / size_mm)


def write_normal_png(path, normals):
    """A 16-bit PNG of tangent-space normals (codes ``(n + 1) / 2``)."""
    write_png(path, np.round((normals + 1.0) / 2.0 * 65535).astype(np.uint16))
    return path


def delta_e(picture_a, mode_a: str, picture_b, mode_b: str) -> np.ndarray:
    """Delta E*ab per pixel seen by both pictures, as shown (sRGB at the first's exposure, display white 1)."""
    from cdbrdf.colour import delta_e_ab, ev_to_factor, linear_to_lab

    f = ev_to_factor(picture_a.exposure_ev)
    la = linear_to_lab(np.clip(np.nan_to_num(picture_a.display(mode_a) * f), 0, 1))
    lb = linear_to_lab(np.clip(np.nan_to_num(picture_b.display(mode_b) * f), 0, 1))
    seen = (picture_a.images[mode_a][..., 3] > 0.99) & (picture_b.images[mode_b][..., 3] > 0.99)
    return delta_e_ab(la, lb)[seen]
