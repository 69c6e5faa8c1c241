"""Generated test meshes: irregular cylinders and spheres, garments, and files in every layout we read.

Meshes are irregular (jittered points, Delaunay / convex hull), since regular
grids flatter curvature estimators.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy.spatial import ConvexHull, Delaunay

from .shared_data import shared_file

__all__ = [
    "R_CYL",
    "shared_mesh",
    "jittered_uv",
    "cylinder_patch",
    "sphere_mesh",
    "write_obj",
    "write_ascii_ply",
]

R_CYL = 1.0 / 0.22  # mm, the paper's largest curvature



def shared_mesh(name: str) -> Path:
    """A mesh of ``../shared/data/meshes`` (:mod:`tests.shared_data`); the test is skipped when absent."""
    return shared_file(f"meshes/{name}")


def jittered_uv(nu: int, nv: int, seed: int, jitter: float = 0.4) -> np.ndarray:
    rng = np.random.default_rng(seed)
    u, v = np.meshgrid(np.arange(nu, dtype=float), np.arange(nv, dtype=float), indexing="ij")
    u += rng.uniform(-jitter, jitter, u.shape)
    v += rng.uniform(-jitter, jitter, v.shape)
    u[0], u[-1], v[:, 0], v[:, -1] = 0, nu - 1, 0, nv - 1
    return np.c_[u.ravel() / (nu - 1), v.ravel() / (nv - 1)]


def cylinder_patch(radius: float, *, convex: bool = True, n: int = 140, seed: int = 0, angle: float = np.pi,
                   length: float | None = None, n_along: int | None = None):
    """Part of a cylinder (axis y, apex on +z) from jittered Delaunay points.

    ``angle`` is the arc around the axis, ``length`` the extent along it
    (default ``angle * radius``), ``n`` and ``n_along`` (default ``n``) the
    vertices around and along. Faces wind counter-clockwise seen from
    outside (convex) or from the axis (concave). Returns vertices, faces,
    uv (u around, v along the axis), interior mask.
    """
    length = angle * radius if length is None else length
    uv = jittered_uv(n, n if n_along is None else n_along, seed)
    f = Delaunay(uv).simplices.astype(np.int64)
    a = (uv[:, 0] - 0.5) * angle
    v = np.c_[radius * np.sin(a), (uv[:, 1] - 0.5) * length, radius * np.cos(a)]
    e = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    radial = v[f].mean(1) * np.array([1.0, 0.0, 1.0])
    side = np.einsum("ij,ij->i", e, radial)
    wrong = side < 0 if convex else side > 0
    f[wrong] = f[wrong][:, ::-1]
    interior = np.all((uv > 0.1) & (uv < 0.9), axis=1)
    return v, f, uv, interior


def sphere_mesh(radius: float, n: int = 20000, seed: int = 1):
    """Jittered Fibonacci sphere, convex hull, faces wound outward."""
    rng = np.random.default_rng(seed)
    i = np.arange(n) + 0.5
    polar = np.arccos(1 - 2 * i / n)
    azim = np.pi * (1 + 5**0.5) * i
    p = np.c_[np.cos(azim) * np.sin(polar), np.sin(azim) * np.sin(polar), np.cos(polar)]
    p += rng.normal(scale=0.3 * np.sqrt(4 * np.pi / n), size=p.shape)
    p /= np.linalg.norm(p, axis=1, keepdims=True)
    f = ConvexHull(p).simplices.astype(np.int64)
    e = np.cross(p[f[:, 1]] - p[f[:, 0]], p[f[:, 2]] - p[f[:, 0]])
    wrong = np.einsum("ij,ij->i", e, p[f].mean(1)) < 0
    f[wrong] = f[wrong][:, ::-1]
    return p * radius, f


def write_obj(path: Path, v: np.ndarray, f: np.ndarray, uv: np.ndarray | None = None, *, header: str = "") -> Path:
    """A plain OBJ: ``header`` (comment lines, without their ``#``), ``v``, optional ``vt`` with the same
    indices, triangles."""
    lines = [f"# {c}" for c in header.splitlines()]
    lines += [f"v {x:.9g} {y:.9g} {z:.9g}" for x, y, z in v]
    if uv is not None:
        lines += [f"vt {a:.9g} {b:.9g}" for a, b in uv]
        lines += [f"f {a + 1}/{a + 1} {b + 1}/{b + 1} {c + 1}/{c + 1}" for a, b, c in f]
    else:
        lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in f]
    path.write_text("\n".join(lines) + "\n")
    return path


def write_ascii_ply(path: Path, v: np.ndarray, polys: list[list[int]], *, uv: np.ndarray | None = None,
                    extra_header: str = "") -> Path:
    """An ASCII PLY with polygons of any size."""
    head = ["ply", "format ascii 1.0", extra_header, f"element vertex {len(v)}",
            "property float x", "property float y", "property float z"]
    if uv is not None:
        head += ["property float u", "property float v"]
    head += [f"element face {len(polys)}", "property list uchar int vertex_indices", "end_header"]
    rows = [" ".join(f"{x:.9g}" for x in (list(p) + (list(uv[i]) if uv is not None else [])))
            for i, p in enumerate(v)]
    rows += [" ".join(str(x) for x in [len(p), *p]) for p in polys]
    path.write_text("\n".join(h for h in head if h) + "\n" + "\n".join(rows) + "\n")
    return path
