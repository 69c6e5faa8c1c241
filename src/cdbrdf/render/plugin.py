"""The ``cdbrdf`` BSDF plug-in for Mitsuba 3: variants, registration, instances, scene checks.

Importing this module does nothing heavy: it neither imports Mitsuba nor sets
a variant. The plug-in is registered with Mitsuba by :func:`register` (for the
variant that is active), by :func:`set_variant` (an application choosing its
variant: checks libLLVM, sets it, registers) or by :func:`variant` (library
code: the same for a ``with`` block, the caller's variant restored after it);
every helper here that builds or renders a scene calls :func:`register`
itself.

.. code-block:: python

    import cdbrdf.render as cr
    cr.set_variant()                      # llvm_ad_rgb, after checking libLLVM 19
    import mitsuba as mi
    scene = cr.load_dict({
        "type": "scene",
        "sheet": {"type": "ply", "filename": "sheet.ply",
                  "bsdf": {"type": "cdbrdf", "filename": "denim.h5"}},
        ...
    })

Plug-in ``cdbrdf`` parameters
-----------------------------

.. list-table::
   :header-rows: 1
   :widths: 18 12 14 56

   * - Parameter
     - Type
     - Default
     - Description
   * - ``filename``
     - string
     - (required)
     - A CDBRDF or CD-BTF file (``docs/format.md``), found through Mitsuba's file resolver: relative to the
       scene file's folder, as for meshes. From Python a table object can be given instead: ``"table": table``
       in a dict passed to ``cdbrdf.render.load_dict``, or ``cdbrdf.render.make_bsdf(table, ...)``.
   * - ``table``
     - object
     - none
     - From Python, instead of ``filename``: a ``cdbrdf.CDBRDF`` or ``cdbrdf.CDBTF`` (or a file name).
   * - ``mode``
     - string
     - ``cdbrdf``
     - ``cdbrdf``: 5-D lookup with the curvature. ``brdf``: the plain BRDF (the table's kappa = 0 slice); the
       curvature is not read.
   * - ``curvature``
     - string or float
     - by ``curvature_mode``
     - Name of the mesh attribute holding the curvature in mm^-1, or a constant curvature in mm^-1 (e.g. a
       measurement stand; ``"0.13"`` as a string is a constant too).
   * - ``curvature_mode``
     - string
     - ``max``
     - ``max``: attribute ``vertex_curvature``, the principal curvature of larger magnitude with its sign (PLY
       property ``curvature_x``, written by ``cdbrdf curvature``). ``directional``: attribute
       ``vertex_curvature_dir``, the signed normal curvature along the material's x axis
       (``cdbrdf.mesh.CURVATURE_MODES``). Give either this or ``curvature``.
   * - ``curvature_scale``
     - float
     - ``1``
     - Factor on the attribute's values: a shape's ``to_world`` scale and the scene's unit.
       ``cdbrdf.render.load_file`` and ``load_dict`` set it (see "Curvature units"); a constant curvature is
       not scaled.
   * - ``unit``
     - string or float
     - ``mm``
     - The scene's length unit: ``mm``, ``cm``, ``m``, ``in`` or millimetres per scene unit.
       ``cdbrdf.render.load_file``, ``load_dict`` and ``cdbrdf render SCENE.xml`` apply it with each shape's
       ``to_world`` scale (see "Curvature units"); Mitsuba's own loaders give a plug-in no shape, so there it
       is reported as not applied and the attribute is used as it is.
   * - ``scene_scale_applied``
     - boolean
     - ``false``
     - Set by cdbrdf's loaders (``load_file``, ``load_dict``): whether they applied the scene's unit and the
       shape's ``to_world`` scale to ``curvature_scale``. A plug-in made without it (by Mitsuba's own loader)
       warns that the shape checks were not applied.
   * - ``scale``
     - float or texture
     - ``1``
     - Factor on the reflectance, e.g. for ``quantity = "relative"`` tables; any Mitsuba texture (``bitmap``,
       ``checkerboard``, an ``rgb`` colour, ...) multiplies the reflectance per channel, e.g. a printed
       pattern.
   * - ``sampling``
     - string
     - ``table``
     - ``table``: importance sampling of the light direction from the table (see "Sampling"). ``cosine``:
       cosine-weighted hemisphere sampling (a constant table then renders sample for sample as ``diffuse``).
   * - ``cosine_weight``
     - float
     - ``0.1``
     - Share of cosine sampling in the table sampler's mixture, in (0, 1]; it keeps every direction of the
       hemisphere sampled.
   * - ``storage``
     - string
     - ``auto``
     - How the table is held: ``packed`` (RGB as three 21-bit fixed-point channels per 64-bit word; fastest),
       ``float`` (float32 packets of four samples, differentiable). ``auto`` is ``packed``, and ``float`` when
       a gradient with respect to the table is requested, in spectral variants, or when the fixed-point step
       (the table's range / 2,097,151) exceeds 1e-3 of its median absolute value.
   * - ``uv_scale``
     - float or string
     - detected; a CD-BTF's ``1``
     - Mm per UV unit of the shapes (one number; ``"su, sv"`` in a scene file; two numbers from Python, passed
       as numbers): the scale of a map's curvature and of a CD-BTF's texels. A map's default is detected from
       its shape by ``load_file`` / ``check_scene`` (see "Maps").
   * - ``texel_filter``
     - string
     - ``stochastic``
     - A CD-BTF's filter between texels: ``stochastic`` (one of the four nearest texels, chosen with
       probability equal to its bilinear weight), ``bilinear`` (the four blended, exactly ``CDBTF.evaluate``)
       or ``nearest`` (the texel containing the point).
   * - ``normal_map``
     - string
     - none
     - A tangent-space normal map (PNG/TIFF 8/16 bit, float TIFF, OpenEXR), found next to the scene: looked up
       per shading point, its curvature added to the mesh's shape operator (attribute ``vertex_shape``), its
       normals tilting the shading frame (see "Maps").
   * - ``normal_map_convention``
     - string
     - ``opengl``
     - ``opengl`` (green up: Blender, glTF) or ``directx``.
   * - ``height_map``
     - string
     - none
     - A height (bump, displacement) map instead, with ``height_scale``.
   * - ``height_scale``
     - float
     - (required with ``height_map``)
     - Mm per unit of the height map's values (an 8/16-bit image's full code is 1).
   * - ``map_size``
     - float or string
     - one repeat per UV unit
     - Mm one repeat of the map covers on the cloth (one number, or ``"su, sv"``).
   * - ``curvature_map``
     - object
     - none
     - From Python: a ``cdbrdf.mesh.CurvatureMap`` (``prepare_mesh(..., maps=...).metadata["curvature_map"]``,
       any source: normal or height map, a high-resolution mesh).
   * - ``neighbourhood``
     - float
     - the table's measured patch, else ``5``
     - Mm: the map is never resolved finer than a quarter of it.
   * - ``pixel_angle``
     - float
     - ``0``
     - The camera's angle per pixel in radians: the footprint a map's level and a neural CD-BTF's texels are
       filtered over (see "Maps" and "CD-BTF"). ``render_table`` sets it from the camera; for a map,
       ``load_file`` and ``check_scene`` set it from the scene's first perspective sensor. 0: a map's
       neighbourhood level alone, a CD-BTF's texels themselves.
   * - ``map_filter``
     - string
     - ``stochastic``
     - Between the two levels around the footprint's: ``stochastic`` (one of them, chosen with the trilinear
       weights by a hash of the UV, so a render converges to the trilinear one; half the texel reads),
       ``trilinear`` (both blended) or ``none`` (the finest level kept, the neighbourhood's, whatever the
       pixel's footprint: aliases where the map is finer than a pixel; for comparisons).
   * - ``shading_normals``
     - boolean
     - ``true``
     - Whether the map tilts the shading frame; false: only its curvature is used.

The BSDF is diffuse-like (non-delta) and two-sided: seen from the back, the
local frame is turned 180 degrees about x (normal and y flip) and the curvature
changes sign (a crest seen from below is a trough); Mitsuba's ``twosided``
wrapper would not do that, so :func:`check_scene` refuses it and
:func:`load_file` removes it. ``eval`` returns ``f * cos(theta_l)``. With
``sampling="table"``, ``sample`` draws the light direction from the table
times the cosine, conditioned on curvature and view
(:mod:`cdbrdf.render._sampling`), mixed with cosine sampling; ``pdf`` is the
matching density. The view direction is Mitsuba's ``si.wi`` and the light
direction ``wo`` in radiance transport (swapped in importance transport,
where sampling is cosine). The local x axis is ``si.sh_frame.s`` (dP/du):
meshes must have UVs; :func:`check_scene` refuses meshes without them or
without the curvature attribute (Mitsuba's analytic shapes have their own UV
parametrisation and are accepted, with a constant curvature). A map (``normal_map``,
``height_map``, ``curvature_map``; ``docs/rendering.md``, "Maps") is looked up at the
hit's UV (:mod:`cdbrdf.render._maps_jit`): its curvature is added to the mesh's shape
operator and its normal tilts the frame the table is read in, as Mitsuba's ``normalmap``
does. Spectral
variants blend the spectra of the table samples (Mitsuba's sRGB upsampling of
pi f), mono variants use the luminance. ``mi.traverse`` exposes ``values``
(the table) and ``scale``; see ``docs/rendering.md``.
"""

from __future__ import annotations

import logging
import math
import re
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from typing import Any

import numpy as np

from ..errors import OptionError, SceneError
from ._bsdf import MODES, PLUGIN_NAME, SAMPLINGS, STORAGES, SUPPORTED_VARIANTS
from ._llvm import INSTALL_HINT, REQUIRED_LLVM_MAJOR, LLVMError, LLVMInfo, check_llvm, find_llvm
from ._params import MAP_PARAMETERS, PARAMETERS, PYTHON_VALUES, Parameter, parameter_table
from ._units import ply_unit_mm, scene_factor, scene_units, uniform_scale

__all__ = [
    "DEFAULT_VARIANT",
    "MODES",
    "PARAMETERS",
    "Parameter",
    "parameter_table",
    "PLUGIN_NAME",
    "SAMPLINGS",
    "STORAGES",
    "SUPPORTED_VARIANTS",
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
    "mitsuba_message",
]

_LOG = logging.getLogger(__name__)

#: The variant for real renders (vectorised; the Python BSDF is traced once).
DEFAULT_VARIANT = "llvm_ad_rgb"

#: Variants :func:`set_variant` accepts (those of :data:`SUPPORTED_VARIANTS`
#: that this project tests; ``scalar_*``: one Python call per ray, debugging only).
VARIANTS: tuple[str, ...] = ("llvm_ad_rgb", "llvm_ad_spectral", "llvm_ad_mono", "cuda_ad_rgb",
                             "cuda_ad_spectral", "cuda_ad_mono", "scalar_rgb", "scalar_spectral", "scalar_mono")

#: The property cdbrdf's loaders set on a BSDF whose curvature factor they applied.
_APPLIED = "scene_scale_applied"

#: Keys of a ``{"type": "cdbrdf", "table": ...}`` dict entry: the parameters (:data:`PARAMETERS`), the type and id.
_DICT_KEYS = frozenset({"type", "id", *PARAMETERS} - {"filename"})


def available_variants() -> tuple[str, ...]:
    """The variants of :data:`VARIANTS` that the installed Mitsuba provides.

    Returns
    -------
    tuple of str
        The variants, in the order of :data:`VARIANTS`.
    """
    import mitsuba as mi

    have = set(mi.variants())
    return tuple(v for v in VARIANTS if v in have)


def set_variant(variant: str = DEFAULT_VARIANT) -> str:
    """Check libLLVM (for llvm variants), set the Mitsuba variant, register the plug-in.

    Parameters
    ----------
    variant
        One of :data:`VARIANTS` that the installed Mitsuba has
        (:func:`available_variants`); default ``"llvm_ad_rgb"``.

    Returns
    -------
    str
        The variant set.

    Raises
    ------
    LLVMError
        For an llvm variant when Dr.Jit would not load libLLVM 19.
    ValueError
        For another variant.
    """
    if variant not in VARIANTS:
        raise OptionError(f"variant: {variant!r} is not one of {', '.join(VARIANTS)}")
    import mitsuba as mi

    if variant not in mi.variants():
        raise OptionError(f"variant: {variant!r} is not built into the installed Mitsuba; it has "
                         f"{', '.join(available_variants())}")
    if variant.startswith("llvm") and mi.variant() != variant:
        check_llvm()
    try:
        mi.set_variant(variant)
    except (ImportError, RuntimeError) as exc:  # e.g. a cuda variant without a GPU
        why = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise OptionError(f"variant: {variant!r} cannot be used on this machine ({why})") from None
    register()
    return variant


@contextmanager
def variant(name: str = DEFAULT_VARIANT) -> Iterator[str]:
    """Use a Mitsuba variant for a ``with`` block; the variant active before is restored after it.

    What library code uses (:func:`cdbrdf.render.render_table`, the simulated
    rig, the importers' checks against Mitsuba): it never leaves the caller's
    variant changed. Checks and registers as :func:`set_variant` does.

    Parameters
    ----------
    name
        One of :data:`VARIANTS`.

    Yields
    ------
    str
        The variant in use inside the block.
    """
    import mitsuba as mi

    before = mi.variant()
    if before == name:
        register()
        yield name
        return
    set_variant(name)
    try:
        yield name
    finally:
        if before is not None and mi.variant() != before:
            mi.set_variant(before)
            register()


def register() -> None:
    """Register the ``cdbrdf`` BSDF with Mitsuba for the active variant.

    Raises
    ------
    RuntimeError
        When no Mitsuba variant is set (use :func:`set_variant`).
    ValueError
        For a variant the plug-in does not support (polarised ones).
    LLVMError
        For an llvm variant whose libLLVM is not version 19.
    """
    import mitsuba as mi

    from ._bsdf import bsdf_class

    cls = bsdf_class()
    if str(mi.variant()).startswith("llvm"):
        # The variant may have been set without set_variant(): check the
        # libLLVM Dr.Jit loaded before anything is compiled with it.
        check_llvm()
    mi.register_bsdf(PLUGIN_NAME, _factory(cls))


def _factory(cls: type) -> Callable[[Any], Any]:
    """The plug-in's constructor for Mitsuba, raising its own errors without the frames inside it.

    Mitsuba (nanobind) prefixes the error of a Python plug-in with the Python
    frames of the call; :func:`load_dict` and :func:`load_file` give the
    one-line message alone (:class:`~cdbrdf.errors.SceneError`).
    """

    def make(props: Any) -> Any:
        try:
            bsdf = cls(props)
        except (ValueError, OSError) as exc:  # cdbrdf's errors (ValueError) and a missing file
            raise exc.with_traceback(None) from None
        if _APPLIED not in props:
            unit = f" and its unit ({bsdf.units})" if "unit" in props else ""
            _LOG.warning(
                "cdbrdf BSDF%s: made by Mitsuba's own loader, which gives the plug-in no shape: the checks of the "
                "shapes that use it (UV coordinates, the curvature attribute, no twosided wrapper)%s are not "
                "applied and the curvature attribute is used as it is; load the scene with "
                "cdbrdf.render.load_file or load_dict, or call cdbrdf.render.check_scene(scene)",
                f" {props.id()!r}" if props.id() else "", unit)
        return bsdf

    return make


def make_bsdf(
    table: Any,
    *,
    mode: str = "cdbrdf",
    curvature: str | float | None = None,
    curvature_mode: str | None = None,
    curvature_scale: float = 1.0,
    scale: float | Any = 1.0,
    sampling: str = "table",
    cosine_weight: float | None = None,
    storage: str = "auto",
    uv_scale: float | str | tuple[float, float] | None = None,
    texel_filter: str | None = None,
    unit: str | float | None = None,
    pixel_angle: float | None = None,
    curvature_map: Any = None,
    map_settings: Mapping[str, Any] | None = None,
) -> Any:
    """A ``cdbrdf`` BSDF instance from a table object (or file name).

    The instance can be put into a scene dict in place of a BSDF dict
    (``"bsdf": make_bsdf(table)``).

    Parameters
    ----------
    table
        A :class:`~cdbrdf.table.CDBRDF`, a :class:`cdbrdf.CDBTF` or a file name.
    mode, curvature, curvature_mode, curvature_scale
        The plug-in's parameters (module docstring, ``docs/rendering.md``);
        ``curvature=None`` with ``curvature_mode=None`` reads ``vertex_curvature``.
    scale
        A float or a Mitsuba texture (an object or a dict).
    sampling, cosine_weight, storage
        The plug-in's parameters.
    uv_scale, texel_filter
        For a CD-BTF: mm per UV unit (one number or ``(u, v)``; default 1: UVs
        in mm) and ``"stochastic"`` (default: one of the four nearest texels
        with probability its bilinear weight), ``"bilinear"`` (the four
        blended, as :meth:`cdbrdf.CDBTF.evaluate`) or ``"nearest"``.
    unit
        The scene's unit (applied by :func:`load_dict` with the shape's
        ``to_world``; ``docs/rendering.md``, "Curvature units").
    pixel_angle
        The angle one pixel of the camera subtends, radians: a neural
        CD-BTF's texels and a map's levels are filtered over the pixel's
        footprint at the hit (``docs/btf.md``, "Filtering"; ``docs/rendering.md``,
        "Maps"). Default: a map takes the scene's camera's
        (:func:`check_scene`), a CD-BTF 0 (the texels themselves).
    curvature_map
        A :class:`cdbrdf.mesh.CurvatureMap` (``prepare_mesh(...).metadata["curvature_map"]``):
        looked up per shading point, added to the mesh's curvature, tilting the shading normal.
    map_settings
        The other map parameters of the table above (``normal_map``,
        ``height_map``, ``height_scale``, ``map_size``, ``neighbourhood``,
        ``map_filter``, ``shading_normals``, ...).

    Returns
    -------
    mitsuba.BSDF
        The plug-in instance, in the active variant.
    """
    extra = dict(map_settings or {})
    unknown = set(extra) - set(MAP_PARAMETERS)
    if unknown:
        raise OptionError(f"map_settings: unknown parameter(s) {sorted(unknown)}; valid: {', '.join(MAP_PARAMETERS)}")
    if curvature_map is not None:
        extra["curvature_map"] = curvature_map
    if pixel_angle is not None:
        extra["pixel_angle"] = pixel_angle
    return _make_bsdf(table, mode=mode, curvature=curvature, curvature_mode=curvature_mode,
                      curvature_scale=curvature_scale, scale=scale, sampling=sampling, cosine_weight=cosine_weight,
                      storage=storage, uv_scale=uv_scale, texel_filter=texel_filter, unit=unit, **extra)


def _make_bsdf(table: Any, *, mode: str = "cdbrdf", curvature: str | float | None = None,
               curvature_mode: str | None = None, curvature_scale: float = 1.0, scale: float | Any = 1.0,
               sampling: str = "table", cosine_weight: float | None = None, storage: str = "auto",
               uv_scale: float | str | tuple[float, float] | None = None, texel_filter: str | None = None,
               unit: str | float | None = None, scene_scale_applied: bool = False, **maps: Any) -> Any:
    import mitsuba as mi

    from ._bsdf import bsdf_class

    register()
    props = mi.Properties(PLUGIN_NAME)
    if unit is not None:
        props["unit"] = unit if isinstance(unit, str) else float(unit)
    if scene_scale_applied:
        props[_APPLIED] = True
    props["mode"] = str(mode)
    if curvature is not None:
        props["curvature"] = curvature if isinstance(curvature, str) else float(curvature)
    if curvature_mode is not None:
        props["curvature_mode"] = str(curvature_mode)
    props["curvature_scale"] = float(curvature_scale)
    if isinstance(scale, (int, float)):
        props["scale"] = float(scale)
    else:
        props["scale"] = mi.load_dict(scale) if isinstance(scale, dict) else scale
    props["sampling"] = str(sampling)
    if cosine_weight is not None:
        props["cosine_weight"] = float(cosine_weight)
    props["storage"] = str(storage)
    if texel_filter is not None:
        props["texel_filter"] = str(texel_filter)
    extras: dict[str, Any] = {} if uv_scale is None else {"uv_scale": uv_scale}  # numbers as they are
    for key, value in maps.items():
        if value is None:
            continue
        if key in PYTHON_VALUES or not isinstance(value, (str, bool, int, float)):
            extras[key] = value
        else:
            props[key] = value if isinstance(value, (str, bool)) else float(value)
    return bsdf_class()(props, table=table, extras=extras)


def _replace_tables(d: Any) -> Any:
    if isinstance(d, dict):
        if d.get("type") == PLUGIN_NAME and "table" in d:
            unknown = set(d) - _DICT_KEYS
            if unknown:
                raise OptionError(f"cdbrdf BSDF: unknown parameter(s) {sorted(unknown)}")
            kw = {k: v for k, v in d.items() if k not in ("type", "table", "id")}
            return _make_bsdf(d["table"], **kw)
        return {k: _replace_tables(v) for k, v in d.items()}
    return d


def _apply_units(scene: dict, unit_mm: float | None) -> dict:
    """The scene dict with each shape's inline ``cdbrdf`` BSDF given its curvature factor (:mod:`._units`)."""
    import mitsuba

    mi: Any = mitsuba
    out = dict(scene)
    for key, shape in scene.items():
        if not isinstance(shape, dict):
            continue
        bsdf = shape.get("bsdf")
        if not (isinstance(bsdf, dict) and bsdf.get("type") == PLUGIN_NAME):
            continue
        unit = scene_units(bsdf["unit"]) if "unit" in bsdf else None
        u_mm = unit_mm if unit_mm is not None else unit.mm_per_unit if unit is not None else 1.0
        s = 1.0
        if "to_world" in shape:
            tw = shape["to_world"]
            s = uniform_scale(np.array(tw.matrix if hasattr(tw, "matrix") else tw), what=f"shape {key!r} to_world")
        m_file = None
        if shape.get("type") == "ply" and "filename" in shape:
            m_file = ply_unit_mm(str(mi.file_resolver().resolve(str(shape["filename"]))))
        factor = scene_factor(m_file=m_file, scale=s, unit_mm=u_mm)
        b = dict(bsdf)
        b["curvature_scale"] = float(b.get("curvature_scale", 1.0)) * factor
        b["unit"] = float(u_mm)
        b[_APPLIED] = True
        out[key] = {**shape, "bsdf": b}
    return out


def _mark_loaded(d: Any) -> Any:
    """Every ``cdbrdf`` BSDF dict marked as loaded by cdbrdf (its scale applied or not needed)."""
    if isinstance(d, dict):
        out = {k: _mark_loaded(v) for k, v in d.items()}
        if d.get("type") == PLUGIN_NAME and _APPLIED not in d:
            out[_APPLIED] = False
        return out
    return d


def load_dict(scene: dict, *, check: bool = True, unit_mm: float | None = None) -> Any:
    """:func:`mitsuba.load_dict` that accepts ``"table": CDBRDF``, applies the scene's unit and checks the result.

    ``{"type": "cdbrdf", "table": t, ...}`` entries become plug-in instances.
    A shape's own ``cdbrdf`` BSDF dict gets the curvature factor of its
    ``to_world`` scale and the scene's unit (``unit_mm``, mm per scene unit;
    default: the BSDF's ``unit``, else mm; ``docs/rendering.md``, "Curvature
    units"). With ``check`` the loaded scene goes through
    :func:`check_scene`. An object that cannot be made (a missing table, a
    damaged environment map) is one :class:`~cdbrdf.errors.SceneError` line.

    Parameters
    ----------
    scene
        A Mitsuba scene dictionary.
    check
        Check the loaded scene.
    unit_mm
        Millimetres per scene unit (default: each BSDF's ``unit``, else mm).

    Returns
    -------
    mitsuba.Object
        The loaded scene or object.
    """
    import mitsuba as mi

    register()
    if unit_mm is not None and not (math.isfinite(unit_mm) and unit_mm > 0):
        raise SceneError(f"unit_mm: must be a positive number of millimetres per scene unit, got {unit_mm}")
    if isinstance(scene, dict) and scene.get("type") == "scene":
        scene = _apply_units(scene, unit_mm)
    spec = _replace_tables(_mark_loaded(scene))
    if not isinstance(spec, dict):  # {"type": "cdbrdf", "table": ...} alone: the instance itself
        return spec
    try:
        obj = mi.load_dict(spec)
    except RuntimeError as exc:  # a plug-in's error, Mitsuba's: one line, without Mitsuba's traceback
        raise SceneError(mitsuba_message(exc)) from None
    if check and isinstance(obj, mi.Scene):
        from .checks import check_scene

        check_scene(obj)
    return obj


def mitsuba_message(exc: BaseException) -> str:
    """Mitsuba's message on one line, without its source-file prefixes (``[parser.cpp:111]``)."""
    text = re.sub(r"\[[A-Za-z0-9_]+\.(?:cpp|h):\d+\]\s*", "", str(exc))
    if "Traceback (most recent call last)" in text:
        # a Python plug-in's exception as Mitsuba reports it: keep where, and the exception's own line
        head, _, tail = text.partition("Traceback (most recent call last)")
        last = [ln.strip() for ln in tail.splitlines() if ln.strip()][-1:]
        text = head.rstrip(" :\n") + ": " + " ".join(last)
    lines = [ln.strip() for ln in text.splitlines() if ln.strip()]
    return " ".join(lines) if lines else type(exc).__name__
