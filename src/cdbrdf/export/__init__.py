"""A table out of cdbrdf: a glTF 2.0 asset with the CDBRDF in a vendor extension, and MaterialX (``cdbrdf export``).

- :mod:`cdbrdf.export.gltf`: the asset (the mesh prepared by
  :func:`cdbrdf.mesh.prepare_mesh` in glTF's frame, ``_CURVATURE`` per vertex,
  a curvature map, the material with the ``CDBRDF_materials_curvature_brdf``
  extension whose table :mod:`cdbrdf.gltf_table` encodes);
- :mod:`cdbrdf.export.tangents`: MikkTSpace tangents;
- :mod:`cdbrdf.export.fallback`: the standard material fitted to the flat BRDF;
- :mod:`cdbrdf.export.materialx`: that material as a MaterialX document.

``docs/export.md`` specifies the extension and describes the browser renderer
of the assets (:mod:`cdbrdf.view.gltf_page`).
"""

from __future__ import annotations

__all__ = ["fallback", "gltf", "materialx", "tangents"]
