"""The ``cdbrdf`` plug-in's parameters: the one registry its code reads and its tables are made from.

:data:`PARAMETERS` lists every parameter the plug-in accepts, with its type,
default and meaning. The plug-in reads its parameters only through it (a
name not listed is a programming error), ``load_dict`` refuses a ``cdbrdf``
entry with another key, and the parameter tables of
:mod:`cdbrdf.render.plugin` and ``docs/rendering.md`` are
:func:`parameter_table`'s (``tests/test_render.py`` checks that they agree).
"""

from __future__ import annotations

import textwrap
from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType

__all__ = ["Parameter", "PARAMETERS", "PYTHON_VALUES", "MAP_PARAMETERS", "parameter_table"]


@dataclass(frozen=True)
class Parameter:
    """One parameter of the plug-in.

    Attributes
    ----------
    name
        As a scene file or a dict gives it.
    kind
        Its type, in words (Mitsuba's: ``string``, ``float``, ``boolean``, a texture; ``object`` from Python).
    default
        Its default, in words.
    description
        What it does.
    python
        Given from Python as a value (numbers in pairs, an object), not through Mitsuba's properties.
    """

    name: str
    kind: str
    default: str
    description: str
    python: bool = False


_P = Parameter

#: Every parameter of the ``cdbrdf`` plug-in, in the order of its tables.
PARAMETERS: Mapping[str, Parameter] = MappingProxyType({p.name: p for p in (
    _P("filename", "string", "(required)",
       "A CDBRDF or CD-BTF file (`docs/format.md`), found through Mitsuba's file resolver: relative to the scene "
       "file's folder, as for meshes. From Python a table object can be given instead: `\"table\": table` in a "
       "dict passed to `cdbrdf.render.load_dict`, or `cdbrdf.render.make_bsdf(table, ...)`."),
    _P("table", "object", "none", "From Python, instead of `filename`: a `cdbrdf.CDBRDF` or `cdbrdf.CDBTF` (or a "
       "file name).", python=True),
    _P("mode", "string", "`cdbrdf`",
       "`cdbrdf`: 5-D lookup with the curvature. `brdf`: the plain BRDF (the table's kappa = 0 slice); the "
       "curvature is not read."),
    _P("curvature", "string or float", "by `curvature_mode`",
       "Name of the mesh attribute holding the curvature in mm^-1, or a constant curvature in mm^-1 (e.g. a "
       "measurement stand; `\"0.13\"` as a string is a constant too)."),
    _P("curvature_mode", "string", "`max`",
       "`max`: attribute `vertex_curvature`, the principal curvature of larger magnitude with its sign (PLY "
       "property `curvature_x`, written by `cdbrdf curvature`). `directional`: attribute `vertex_curvature_dir`, "
       "the signed normal curvature along the material's x axis (`cdbrdf.mesh.CURVATURE_MODES`). Give either "
       "this or `curvature`."),
    _P("curvature_scale", "float", "`1`",
       "Factor on the attribute's values: a shape's `to_world` scale and the scene's unit. "
       "`cdbrdf.render.load_file` and `load_dict` set it (see \"Curvature units\"); a constant curvature is not "
       "scaled."),
    _P("unit", "string or float", "`mm`",
       "The scene's length unit: `mm`, `cm`, `m`, `in` or millimetres per scene unit. `cdbrdf.render.load_file`, "
       "`load_dict` and `cdbrdf render SCENE.xml` apply it with each shape's `to_world` scale (see \"Curvature "
       "units\"); Mitsuba's own loaders give a plug-in no shape, so there it is reported as not applied and the "
       "attribute is used as it is."),
    _P("scene_scale_applied", "boolean", "`false`",
       "Set by cdbrdf's loaders (`load_file`, `load_dict`): whether they applied the scene's unit and the "
       "shape's `to_world` scale to `curvature_scale`. A plug-in made without it (by Mitsuba's own loader) "
       "warns that the shape checks were not applied."),
    _P("scale", "float or texture", "`1`",
       "Factor on the reflectance, e.g. for `quantity = \"relative\"` tables; any Mitsuba texture (`bitmap`, "
       "`checkerboard`, an `rgb` colour, ...) multiplies the reflectance per channel, e.g. a printed pattern."),
    _P("sampling", "string", "`table`",
       "`table`: importance sampling of the light direction from the table (see \"Sampling\"). `cosine`: "
       "cosine-weighted hemisphere sampling (a constant table then renders sample for sample as `diffuse`)."),
    _P("cosine_weight", "float", "`0.1`",
       "Share of cosine sampling in the table sampler's mixture, in (0, 1]; it keeps every direction of the "
       "hemisphere sampled."),
    _P("storage", "string", "`auto`",
       "How the table is held: `packed` (RGB as three 21-bit fixed-point channels per 64-bit word; fastest), "
       "`float` (float32 packets of four samples, differentiable). `auto` is `packed`, and `float` when a "
       "gradient with respect to the table is requested, in spectral variants, or when the fixed-point step "
       "(the table's range / 2,097,151) exceeds 1e-3 of its median absolute value."),
    _P("uv_scale", "float or string", "detected; a CD-BTF's `1`",
       "Mm per UV unit of the shapes (one number; `\"su, sv\"` in a scene file; two numbers from Python, passed "
       "as numbers): the scale of a map's curvature and of a CD-BTF's texels. A map's default is detected from "
       "its shape by `load_file` / `check_scene` (see \"Maps\").", python=True),
    _P("texel_filter", "string", "`stochastic`",
       "A CD-BTF's filter between texels: `stochastic` (one of the four nearest texels, chosen with probability "
       "equal to its bilinear weight), `bilinear` (the four blended, exactly `CDBTF.evaluate`) or `nearest` (the "
       "texel containing the point)."),
    _P("normal_map", "string", "none",
       "A tangent-space normal map (PNG/TIFF 8/16 bit, float TIFF, OpenEXR), found next to the scene: looked up "
       "per shading point, its curvature added to the mesh's shape operator (attribute `vertex_shape`), its "
       "normals tilting the shading frame (see \"Maps\")."),
    _P("normal_map_convention", "string", "`opengl`", "`opengl` (green up: Blender, glTF) or `directx`."),
    _P("height_map", "string", "none", "A height (bump, displacement) map instead, with `height_scale`."),
    _P("height_scale", "float", "(required with `height_map`)",
       "Mm per unit of the height map's values (an 8/16-bit image's full code is 1)."),
    _P("map_size", "float or string", "one repeat per UV unit",
       "Mm one repeat of the map covers on the cloth (one number, or `\"su, sv\"`).", python=True),
    _P("curvature_map", "object", "none",
       "From Python: a `cdbrdf.mesh.CurvatureMap` (`prepare_mesh(..., maps=...).metadata[\"curvature_map\"]`, "
       "any source: normal or height map, a high-resolution mesh).", python=True),
    _P("neighbourhood", "float", "the table's measured patch, else `5`",
       "Mm: the map is never resolved finer than a quarter of it."),
    _P("pixel_angle", "float", "`0`",
       "The camera's angle per pixel in radians: the footprint a map's level and a neural CD-BTF's texels are "
       "filtered over (see \"Maps\" and \"CD-BTF\"). `render_table` sets it from the camera; for a map, "
       "`load_file` and `check_scene` set it from the scene's first perspective sensor. 0: a map's "
       "neighbourhood level alone, a CD-BTF's texels themselves."),
    _P("map_filter", "string", "`stochastic`",
       "Between the two levels around the footprint's: `stochastic` (one of them, chosen with the trilinear "
       "weights by a hash of the UV, so a render converges to the trilinear one; half the texel reads), "
       "`trilinear` (both blended) or `none` (the finest level kept, the neighbourhood's, whatever the pixel's "
       "footprint: aliases where the map is finer than a pixel; for comparisons)."),
    _P("shading_normals", "boolean", "`true`",
       "Whether the map tilts the shading frame; false: only its curvature is used."),
)})

#: The parameters of a map (``docs/rendering.md``, "Maps"; :mod:`cdbrdf.render._maps_jit`), in the table's order.
MAP_PARAMETERS: tuple[str, ...] = ("curvature_map", "normal_map", "normal_map_convention", "height_map",
                                   "height_scale", "map_size", "neighbourhood", "pixel_angle", "map_filter",
                                   "shading_normals")

#: Parameters given as Python values (numbers in pairs, objects), not through Mitsuba's properties.
PYTHON_VALUES: tuple[str, ...] = tuple(n for n, p in PARAMETERS.items() if p.python and n != "table")


def parameter_table(fmt: str = "markdown") -> str:
    """The plug-in's parameter table, from :data:`PARAMETERS`.

    Parameters
    ----------
    fmt
        ``"markdown"`` (``docs/rendering.md``) or ``"rst"`` (a ``list-table``,
        the docstring of :mod:`cdbrdf.render.plugin`).

    Returns
    -------
    str
        The table, one line per row (markdown) or per cell (rst).
    """
    if fmt == "markdown":
        rows = ["| Parameter | Type | Default | Description |", "|---|---|---|---|"]
        rows += [f"| `{p.name}` | {p.kind} | {p.default} | {p.description} |" for p in PARAMETERS.values()]
        return "\n".join(rows)
    if fmt != "rst":
        raise ValueError(f"fmt: {fmt!r} is not one of markdown, rst")
    out = [".. list-table::", "   :header-rows: 1", "   :widths: 18 12 14 56", "",
           "   * - Parameter", "     - Type", "     - Default", "     - Description"]
    for p in PARAMETERS.values():
        out += [f"   * - ``{p.name}``", f"     - {p.kind}", f"     - {_rst(p.default)}",
                textwrap.fill(_rst(p.description), width=110, initial_indent="     - ", subsequent_indent=" " * 7,
                              break_on_hyphens=False, break_long_words=False)]
    return "\n".join(out)


def _rst(text: str) -> str:
    """Markdown's inline code as reStructuredText's."""
    parts = text.split("`")
    return "".join(f"``{x}``" if i % 2 else x for i, x in enumerate(parts))
