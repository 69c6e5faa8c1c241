"""The triangle mesh object every stage of the package passes around.

A :class:`Mesh` holds positions in the mesh's own unit, triangles, optional
normals, UVs and tangents, per-vertex attributes (the curvatures in mm^-1)
and what is known about it (unit, up axis, how its curvature was computed).
Read and written by :mod:`cdbrdf.mesh.io`, prepared for rendering by
:func:`cdbrdf.mesh.prepare_mesh`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["Mesh"]


@dataclass
class Mesh:
    """A triangle mesh with what the renderer needs.

    Attributes
    ----------
    vertices
        ``(n, 3)`` float64 positions, in the mesh's unit.
    faces
        ``(m, 3)`` int64 vertex indices (counter-clockwise = front).
    normals, uv, tangents
        Optional ``(n, 3)`` vertex normals, ``(n, 2)`` texture coordinates and
        ``(n, 3)`` tangents.
    attributes
        Per-vertex scalar arrays by name (``"curvature"``, ``"curvature_dir"``
        in mm^-1).
    metadata
        What is known about the mesh: ``"format"``, ``"units"`` (as given to
        :func:`cdbrdf.mesh.parse_units`), ``"up"`` (``"y"`` or ``"z"``),
        ``"curvature_units"`` (``"1/mm"`` when the curvature is in mm^-1),
        ``"neighbourhood_mm"``, ``"frame"``, and after
        :func:`cdbrdf.mesh.prepare_mesh` ``"repairs"`` and ``"notes"``.
    """

    vertices: NDArray[np.float64]
    faces: NDArray[np.int64]
    normals: NDArray[np.float64] | None = None
    uv: NDArray[np.float64] | None = None
    attributes: dict[str, NDArray[np.float64]] = field(default_factory=dict)
    tangents: NDArray[np.float64] | None = None
    metadata: dict[str, Any] = field(default_factory=dict)

    @property
    def n_vertices(self) -> int:
        """Number of vertices."""
        return int(self.vertices.shape[0])

    def copy(self) -> Mesh:
        """A copy whose arrays and dicts can be replaced without touching this mesh.

        Returns
        -------
        Mesh
            The copy.
        """
        return Mesh(self.vertices, self.faces, self.normals, self.uv, dict(self.attributes), self.tangents,
                    dict(self.metadata))
