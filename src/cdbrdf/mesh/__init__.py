"""Meshes: files in and out, repair, units, up axis, the material frame, curvature, analytic surfaces.

Everything the package does with triangle meshes lives here, below the
renderer and the viewer, which use it:

- :class:`Mesh` (:mod:`~cdbrdf.mesh.core`), read and written by
  :func:`read_mesh` / :func:`write_ply` (:mod:`~cdbrdf.mesh.io`: PLY by
  cdbrdf's reader, OBJ, glTF/GLB, STL and OFF through trimesh);
- :func:`repair` (:mod:`~cdbrdf.mesh.repair`; seams closed for the fit:
  :func:`weld_seams`), units, the unit a garment's size makes plausible and
  the check against a table's kappa range (:mod:`~cdbrdf.mesh.units`), what
  a file states of its unit and up axis (:mod:`~cdbrdf.mesh.statements`) and
  what its geometry says (:mod:`~cdbrdf.mesh.shape`), the material's x axis
  (:mod:`~cdbrdf.mesh.frames`);
- the curvature in mm^-1 (:mod:`~cdbrdf.mesh.curvature`, the fit in
  :mod:`~cdbrdf.mesh.estimate`): as in the paper, the principal curvature of
  larger magnitude with its sign (> 0 convex, bending away from the normal;
  ``docs/conventions.md``), and the directional mode, the normal curvature
  along the material's x axis (:data:`CURVATURE_MODES`; every attribute's
  name in a mesh, a PLY file and Mitsuba: :mod:`~cdbrdf.mesh.attributes`);
- :func:`prepare_mesh` (:mod:`~cdbrdf.mesh.prepare`): a user's mesh made
  ready to render, and its up axis (:func:`detect_up`, :func:`z_up_mesh`);
- the analytic surfaces with their sizes (:mod:`~cdbrdf.mesh.surfaces`): the
  paper's sine sheet, a swatch laid in folds of known radii, a draped cloth,
  a skirt; garments as their makers export them (:mod:`~cdbrdf.mesh.garments`:
  sewn panels, a scanned bust and head);
- the detail maps laid by a mesh's UVs (:mod:`~cdbrdf.mesh.maps`:
  :class:`SurfaceMaps`, the UV scale): normal maps read as data
  (:mod:`~cdbrdf.mesh.normalmap`), height maps and high-resolution meshes
  baked (:mod:`~cdbrdf.mesh.bake`) into prefiltered curvature maps
  (:mod:`~cdbrdf.mesh.curvature_map`) that the renderer looks up per
  shading point.
"""

from __future__ import annotations

from .attributes import (
    CURVATURE_MODES,
    SHAPE_ATTRIBUTES,
    CurvatureMode,
    attribute_of_ply,
    curvature_mode,
    mitsuba_attribute,
    ply_property,
)
from .bake import HeightMap, bake_height_map, bake_mesh, bake_normal_map, height_map_from_values, read_height_map
from .core import Mesh
from .curvature import (
    SurfaceCurvature,
    check_neighbourhood,
    dihedral_curvature,
    max_curvature,
    neighbourhood_from_table,
    principal_curvatures,
    surface_curvature,
)
from .curvature_map import CurvatureMap
from .estimate import DEFAULT_NEIGHBOURHOOD_MM, NEIGHBOURHOOD_RANGE_MM, PrincipalCurvatures
from .frames import FRAMES
from .garments import Garment, bust_mesh, garment_mesh, head_mesh
from .io import MESH_FORMATS, ply_metadata, read_mesh, read_obj, read_ply, write_ply
from .maps import BAKES, SurfaceMaps, UVScale, apply_maps, as_uv_scale, detect_uv_scale, mesh_uv_scale
from .normalmap import NORMAL_MAP_CONVENTIONS, NormalMap, normal_map_from_normals, read_normal_map
from .prepare import UP_AXES, MeshSurface, check_up, detect_up, has_own_uv, prepare_mesh, to_z_up, z_up_mesh
from .references import Reference, check_references, referenced_files
from .repair import RepairedMesh, repair
from .surfaces import (
    DrapedCloth,
    SineSheet,
    Skirt,
    Swatch,
    draped_cloth_height,
    draped_cloth_mesh,
    sine_sheet_curvature,
    sine_sheet_height,
    sine_sheet_mesh,
    skirt_mesh,
    swatch_curvature,
    swatch_mesh,
)
from .units import (
    MAX_SIZE_MM,
    UNITS_MM,
    KappaRangeCheck,
    Units,
    check_garment_size,
    check_kappa_range,
    check_size,
    infer_units,
    parse_units,
)
from .weld import SEAM_TOLERANCE, WELD_TOLERANCE, weld, weld_seams

__all__ = [
    "Mesh",
    "MESH_FORMATS",
    "read_mesh",
    "read_ply",
    "ply_metadata",
    "read_obj",
    "write_ply",
    "Reference",
    "referenced_files",
    "check_references",
    "CURVATURE_MODES",
    "CurvatureMode",
    "curvature_mode",
    "ply_property",
    "mitsuba_attribute",
    "attribute_of_ply",
    "FRAMES",
    "UNITS_MM",
    "UP_AXES",
    "DEFAULT_NEIGHBOURHOOD_MM",
    "NEIGHBOURHOOD_RANGE_MM",
    "WELD_TOLERANCE",
    "SEAM_TOLERANCE",
    "MAX_SIZE_MM",
    "Units",
    "parse_units",
    "KappaRangeCheck",
    "check_kappa_range",
    "check_size",
    "infer_units",
    "check_garment_size",
    "PrincipalCurvatures",
    "SurfaceCurvature",
    "RepairedMesh",
    "surface_curvature",
    "principal_curvatures",
    "max_curvature",
    "dihedral_curvature",
    "repair",
    "weld",
    "weld_seams",
    "check_neighbourhood",
    "neighbourhood_from_table",
    "prepare_mesh",
    "MeshSurface",
    "has_own_uv",
    "detect_up",
    "to_z_up",
    "z_up_mesh",
    "check_up",
    "SineSheet",
    "sine_sheet_mesh",
    "sine_sheet_height",
    "sine_sheet_curvature",
    "DrapedCloth",
    "draped_cloth_height",
    "draped_cloth_mesh",
    "Skirt",
    "skirt_mesh",
    "Swatch",
    "swatch_mesh",
    "swatch_curvature",
    "Garment",
    "garment_mesh",
    "bust_mesh",
    "head_mesh",
    "NORMAL_MAP_CONVENTIONS",
    "NormalMap",
    "read_normal_map",
    "normal_map_from_normals",
    "HeightMap",
    "read_height_map",
    "height_map_from_values",
    "CurvatureMap",
    "SHAPE_ATTRIBUTES",
    "bake_normal_map",
    "bake_height_map",
    "bake_mesh",
    "BAKES",
    "SurfaceMaps",
    "UVScale",
    "detect_uv_scale",
    "mesh_uv_scale",
    "as_uv_scale",
    "apply_maps",
]
