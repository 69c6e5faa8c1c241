"""Render a CDBRDF with Mitsuba 3: the ``cdbrdf`` BSDF plug-in, scenes, checks.

Importing this package does nothing heavy: it neither imports Mitsuba nor sets
a variant. The plug-in is registered with Mitsuba by :func:`register` (for the
variant that is active) or by :func:`set_variant` (checks libLLVM, sets the
variant, registers); every helper here that builds or renders a scene calls
:func:`register` itself.

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

=============  ===============  ==================================================
Parameter      Type             Description
=============  ===============  ==================================================
``filename``   string           A CDBRDF file (HDF5). Instead, a table object can
                                be given: ``"table": table`` in a dict passed to
                                :func:`cdbrdf.render.load_dict`, or
                                :func:`make_bsdf` (Mitsuba's own properties cannot
                                hold Python objects).
``mode``       string           ``"cdbrdf"`` (default): 5-D lookup with the
                                curvature; ``"brdf"``: the plain BRDF (the table's
                                kappa = 0 slice), curvature ignored.
``curvature``  string or float  Name of the mesh attribute holding the curvature
                                in mm^-1 (default ``"vertex_curvature"``, i.e. a
                                PLY vertex property ``curvature_x`` as written by
                                ``cdbrdf curvature``), or a constant in mm^-1.
``scale``      float            Factor on the reflectance (default 1).
=============  ===============  ==================================================

The BSDF is diffuse-like (non-delta) and two-sided: seen from the back, the
local frame is turned 180 degrees about x (normal and y flip) and the curvature
changes sign (a crest seen from below is a trough). ``eval`` returns
``f * cos(theta_l)``, ``sample`` draws cosine-weighted directions and ``pdf``
is the matching density. The view direction is Mitsuba's ``si.wi`` and the
light direction ``wo`` in radiance transport (swapped in importance
transport, so light tracers see the same reflectance). The local x axis is
``si.sh_frame.s`` (dP/du): meshes must have UVs; :func:`check_scene` refuses
meshes without them (Mitsuba's analytic shapes have their own UV
parametrisation and are accepted, with a constant curvature).
"""

from __future__ import annotations

from typing import Any

from ._bsdf import MODES, PLUGIN_NAME
from ._llvm import INSTALL_HINT, LLVMError, LLVMInfo, REQUIRED_LLVM_MAJOR, check_llvm, find_llvm

__all__ = [
    "DEFAULT_VARIANT",
    "MODES",
    "PLUGIN_NAME",
    "VARIANTS",
    "INSTALL_HINT",
    "LLVMError",
    "LLVMInfo",
    "REQUIRED_LLVM_MAJOR",
    "check_llvm",
    "find_llvm",
    "set_variant",
    "register",
    "make_bsdf",
    "load_dict",
    "check_scene",
    "render",
]

#: The variant for real renders (vectorised; the Python BSDF is traced once).
DEFAULT_VARIANT = "llvm_ad_rgb"

#: Variants the plug-in supports (scalar_rgb: one Python call per ray, debugging only).
VARIANTS: tuple[str, ...] = ("llvm_ad_rgb", "scalar_rgb")


def set_variant(variant: str = DEFAULT_VARIANT) -> str:
    """Check libLLVM (for llvm variants), set the Mitsuba variant, register the plug-in.

    Parameters
    ----------
    variant
        ``"llvm_ad_rgb"`` (default) or ``"scalar_rgb"``.

    Raises
    ------
    LLVMError
        For an llvm variant when Dr.Jit would not load libLLVM 19.
    ValueError
        For another variant.
    """
    if variant not in VARIANTS:
        raise ValueError(f"variant: {variant!r} is not one of {', '.join(VARIANTS)}")
    import mitsuba as mi

    if variant.startswith("llvm") and mi.variant() != variant:
        check_llvm()
    mi.set_variant(variant)
    register()
    return variant


def register() -> None:
    """Register the ``cdbrdf`` BSDF with Mitsuba for the active variant.

    Raises
    ------
    RuntimeError
        When no Mitsuba variant is set (use :func:`set_variant`).
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
    mi.register_bsdf(PLUGIN_NAME, lambda props: cls(props))


def make_bsdf(
    table: Any,
    *,
    mode: str = "cdbrdf",
    curvature: str | float = "vertex_curvature",
    scale: float = 1.0,
):
    """A ``cdbrdf`` BSDF instance from a table object (or file name).

    The instance can be put into a scene dict in place of a BSDF dict
    (``"bsdf": make_bsdf(table)``). Parameters as in the plug-in table above.
    """
    import mitsuba as mi

    from ._bsdf import bsdf_class

    register()
    props = mi.Properties(PLUGIN_NAME)
    props["mode"] = str(mode)
    if isinstance(curvature, str):
        props["curvature"] = curvature
    else:
        props["curvature"] = float(curvature)
    props["scale"] = float(scale)
    return bsdf_class()(props, table=table)



def _replace_tables(d: Any) -> Any:
    if isinstance(d, dict):
        if d.get("type") == PLUGIN_NAME and "table" in d:
            unknown = set(d) - {"type", "table", "mode", "curvature", "scale", "id"}
            if unknown:
                raise ValueError(f"cdbrdf BSDF: unknown parameter(s) {sorted(unknown)}")
            return make_bsdf(
                d["table"],
                mode=d.get("mode", "cdbrdf"),
                curvature=d.get("curvature", "vertex_curvature"),
                scale=d.get("scale", 1.0),
            )
        return {k: _replace_tables(v) for k, v in d.items()}
    return d


def load_dict(scene: dict, *, check: bool = True):
    """:func:`mitsuba.load_dict` that accepts ``"table": CDBRDF`` and checks the result.

    ``{"type": "cdbrdf", "table": t, ...}`` entries become plug-in instances;
    with ``check`` the loaded scene goes through :func:`check_scene`.
    """
    import mitsuba as mi

    register()
    obj = mi.load_dict(_replace_tables(scene))
    if check and isinstance(obj, mi.Scene):
        check_scene(obj)
    return obj


def check_scene(scene) -> None:
    """Refuse shapes with a ``cdbrdf`` BSDF that cannot define its frame or curvature.

    Raises
    ------
    ValueError
        When such a shape is a mesh without UVs (no anisotropy frame), or when
        the BSDF reads a curvature attribute the shape does not have.
    """
    import mitsuba as mi

    from ._bsdf import bsdf_class

    cls = bsdf_class()
    for shape in scene.shapes():
        bsdf = shape.bsdf()
        if not isinstance(bsdf, cls):
            continue
        name = shape.id() or type(shape).__name__
        # Analytic shapes (sphere, disk, ...) have a UV parametrisation; meshes need UVs.
        if isinstance(shape, mi.Mesh) and not shape.has_vertex_texcoords():
            raise ValueError(
                f"shape {name!r}: the cdbrdf BSDF needs a mesh with UV coordinates, whose dP/du "
                "is the material's reference direction x; this shape has none, so it has no "
                "anisotropy frame (add UVs, e.g. along the bending direction)"
            )
        attr = bsdf.curvature_attribute
        if attr is not None and not shape.has_attribute(attr):
            raise ValueError(
                f"shape {name!r}: the cdbrdf BSDF reads the curvature from mesh attribute "
                f"{attr!r}, which the mesh does not have (write it with `cdbrdf curvature`, "
                "or give the BSDF a constant curvature)"
            )


def render(scene, *, spp: int | None = None, seed: int = 0, progress=None):
    """Render a scene after :func:`check_scene`; returns a float32 (H, W, 3) NumPy image.

    ``progress`` is an optional callable ``progress(done, total)`` called per pass.
    """
    from .scenes import render_scene

    check_scene(scene)
    return render_scene(scene, spp=spp, seed=seed, progress=progress)
