"""Render a CDBRDF with Mitsuba 3: the ``cdbrdf`` BSDF plug-in, scenes, pictures.

Importing this package does nothing heavy: it neither imports Mitsuba nor sets
a variant. One function makes a picture of a table, on a built-in scene (the
paper's sine sheet, a swatch laid in folds of known radii) or on any mesh,
seen by a :class:`Camera` and lit by a :class:`Light`, all in one
:class:`RenderSpec` (:func:`render_table`); the pieces it is made of are
public too:

- :mod:`~cdbrdf.render.plugin`: the ``cdbrdf`` BSDF plug-in (its parameter
  table and examples), variants (:func:`set_variant` for an application,
  :func:`variant` for a ``with`` block), :func:`load_dict`;
  :mod:`~cdbrdf.render.checks`: :func:`check_scene`;
- :mod:`~cdbrdf.render.scenefile`: Mitsuba XML scenes using the plug-in
  (:func:`load_file`: curvature units, the scene checks);
- :mod:`~cdbrdf.render.spec`: the :class:`RenderSpec` record (surface,
  camera, light, maps, exposure, film, modes), the built-in scenes'
  names (:data:`SCENES`) and every range of a picture's options;
- :mod:`~cdbrdf.render.scenes`: the scenes of a spec (built-in and mesh
  scenes), meshes given to Mitsuba in memory
  (:func:`~cdbrdf.render.scenes.mitsuba_mesh`);
- :mod:`~cdbrdf.render.camera`, :mod:`~cdbrdf.render.lighting`: the camera
  (framing, zoom, field of view, look-at) and lights; :mod:`~cdbrdf.render.picture`: renders in passes, exposure,
  :func:`render_table`; :mod:`~cdbrdf.render.output`: image files;
- :mod:`~cdbrdf.render.contrast`: the curvature seen in each pixel and the
  colour difference of two renders at the crests and where the surface is
  flat (:func:`crest_contrast`).

.. code-block:: python

    import cdbrdf, cdbrdf.render as cr
    pic = cr.render_table(cdbrdf.materials.load("denim"), cr.RenderSpec(modes=("brdf", "cdbrdf"), spp=16))
    pic.display("cdbrdf")                 # linear RGB, shown at pic.exposure_ev
"""

from __future__ import annotations

from ..mesh import CURVATURE_MODES
from ._bsdf import MODES, PLUGIN_NAME, SAMPLINGS, STORAGES, SUPPORTED_VARIANTS
from ._btf_jit import DEFAULT_TEXEL_FILTER, TEXEL_FILTERS
from ._llvm import INSTALL_HINT, REQUIRED_LLVM_MAJOR, LLVMError, LLVMInfo, check_llvm, find_llvm
from .camera import LOOK_AT_ANCHORS, Camera
from .checks import cdbrdf_shapes, check_scene
from .contrast import CrestContrast, crest_contrast, curvature_image
from .lighting import Light
from .picture import (
    Picture,
    composite,
    exposure_from_render,
    render,
    render_scene,
    render_table,
)
from .plugin import (
    DEFAULT_VARIANT,
    VARIANTS,
    available_variants,
    load_dict,
    make_bsdf,
    register,
    set_variant,
    variant,
)
from .scenefile import load_file
from .scenes import mesh_scene, mitsuba_mesh, sine_scene, swatch_scene, table_scene
from .spec import RENDER_MODES, SCENES, RenderSpec

__all__ = [
    "CURVATURE_MODES",
    "DEFAULT_TEXEL_FILTER",
    "DEFAULT_VARIANT",
    "MODES",
    "PLUGIN_NAME",
    "RENDER_MODES",
    "SAMPLINGS",
    "STORAGES",
    "SUPPORTED_VARIANTS",
    "TEXEL_FILTERS",
    "VARIANTS",
    "INSTALL_HINT",
    "LLVMError",
    "LLVMInfo",
    "REQUIRED_LLVM_MAJOR",
    "available_variants",
    "check_llvm",
    "find_llvm",
    "set_variant",
    "variant",
    "register",
    "make_bsdf",
    "load_dict",
    "load_file",
    "check_scene",
    "cdbrdf_shapes",
    "render",
    "render_scene",
    "render_table",
    "RenderSpec",
    "Picture",
    "Camera",
    "Light",
    "LOOK_AT_ANCHORS",
    "SCENES",
    "table_scene",
    "sine_scene",
    "swatch_scene",
    "mesh_scene",
    "mitsuba_mesh",
    "exposure_from_render",
    "composite",
    "CrestContrast",
    "crest_contrast",
    "curvature_image",
]
