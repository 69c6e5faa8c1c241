"""Generated test meshes beyond the sine sheet, with UVs, in millimetres.

:func:`draped_cloth_mesh` is a square cloth draped over a round object: a
smooth convex dome in the middle and radial folds, alternately convex ridges
and concave valleys, growing towards the hem. It exercises both signs of
curvature over the range of the paper's stands (|kappa| up to about
0.2 mm^-1) on one surface, with a planar UV map (u along x, v along y), so
the material's reference tangent x is the same everywhere seen from above.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .meshio import Mesh

__all__ = ["DrapedCloth", "draped_cloth_height", "draped_cloth_mesh"]


@dataclass(frozen=True)
class DrapedCloth:
    """Parameters of :func:`draped_cloth_mesh` (lengths in mm).

    Attributes
    ----------
    size_mm
        Side of the square cloth seen from above.
    height_mm
        Height of the dome under the cloth.
    sigma_mm
        Radius (Gaussian sigma) of the dome.
    folds
        Number of radial folds around the dome.
    fold_amplitude_mm
        Amplitude of the folds far from the dome.
    resolution
        Vertices along each side.
    """

    size_mm: float = 100.0
    height_mm: float = 22.0
    sigma_mm: float = 17.0
    folds: int = 8
    fold_amplitude_mm: float = 5.0
    resolution: int = 161

    def __post_init__(self) -> None:
        for name in ("size_mm", "height_mm", "sigma_mm", "fold_amplitude_mm"):
            v = getattr(self, name)
            if not (np.isfinite(v) and v > 0):
                raise ValueError(f"{name}: must be a positive length in mm, got {v!r}")
        if int(self.folds) != self.folds or self.folds < 1:
            raise ValueError(f"folds: must be a positive integer, got {self.folds!r}")
        if int(self.resolution) != self.resolution or self.resolution < 8:
            raise ValueError(f"resolution: must be an integer >= 8, got {self.resolution!r}")


def draped_cloth_height(x_mm, y_mm, cloth: DrapedCloth = DrapedCloth()):
    """Height (mm) of the draped cloth at ``(x, y)`` (mm)."""
    x = np.asarray(x_mm, dtype=np.float64)
    y = np.asarray(y_mm, dtype=np.float64)
    r2 = x * x + y * y
    g = np.exp(-r2 / (2.0 * cloth.sigma_mm**2))
    theta = np.arctan2(y, x)
    # the folds grow from nothing on the dome to full amplitude at the hem
    grow = (1.0 - g) ** 2
    return cloth.height_mm * g + cloth.fold_amplitude_mm * grow * np.sin(cloth.folds * theta)


def draped_cloth_mesh(cloth: DrapedCloth = DrapedCloth()) -> Mesh:
    """The draped cloth as a triangle mesh with UVs and vertex normals.

    Faces wind counter-clockwise seen from above (+z): the outward normal
    points up, so the dome is convex (kappa > 0) and the fold valleys are
    concave (kappa < 0). Curvature is not stored: the renderer computes it
    from the mesh (:func:`cdbrdf.curvature.max_curvature`), as for a user's
    mesh.
    """
    n = int(cloth.resolution)
    s = cloth.size_mm
    x = np.linspace(-s / 2, s / 2, n)
    X, Y = np.meshgrid(x, x, indexing="ij")
    Z = draped_cloth_height(X, Y, cloth)
    h = x[1] - x[0]
    dzdx, dzdy = np.gradient(Z, h, h)
    N = np.stack([-dzdx, -dzdy, np.ones_like(Z)], axis=-1)
    N /= np.linalg.norm(N, axis=-1, keepdims=True)
    V = np.stack([X, Y, Z], axis=-1).reshape(-1, 3)
    U = np.stack([(X + s / 2) / s, (Y + s / 2) / s], axis=-1).reshape(-1, 2)
    i, j = np.meshgrid(np.arange(n - 1), np.arange(n - 1), indexing="ij")
    a = (i * n + j).ravel()
    b = a + n  # +x
    c = b + 1  # +x +y
    d = a + 1  # +y
    F = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)]).astype(np.int64)
    return Mesh(V, F, N.reshape(-1, 3), U, {})
