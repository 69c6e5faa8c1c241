"""The fallback material as a MaterialX document (``cdbrdf export --materialx OUT.mtlx``).

:func:`materialx_document` writes the standard material fitted to the flat
BRDF (:mod:`cdbrdf.export.fallback`) as a ``standard_surface`` shader (base
colour at weight 1, metalness 0, specular of index 1.5 and the fitted
roughness and anisotropy, the sheen layer with the fitted colour and
roughness) in a ``surfacematerial``, through the ``materialx`` package, and
checks it with MaterialX's own validation (``Document.validate`` against the
standard data libraries). The mapping is glTF's to ``standard_surface`` as
MaterialX's ``gltf_pbr`` documents it (both use the Charlie sheen and GGX);
``specular_rotation`` is the anisotropy's rotation in turns.

The curvature dependence cannot be expressed in MaterialX: it has no node
that reads a mesh's curvature, nor a tabulated BRDF looked up by direction.
The document says so in a comment and records the table it stands for; the
CDBRDF itself travels in the glTF asset's extension.
"""

from __future__ import annotations

import math
from os import PathLike
from pathlib import Path
from typing import Any

from ..errors import FormatError
from .fallback import FallbackFit

__all__ = ["CURVATURE_NOTE", "materialx_document", "write_materialx"]

#: What the document says about the curvature dependence.
CURVATURE_NOTE = ("The curvature dependence of this fabric (its CDBRDF, a table over curvature and light and view "
                  "directions) is not expressible in MaterialX, which has no node for a mesh's curvature nor a "
                  "tabulated BRDF: this is the flat fabric's fit everywhere. The CDBRDF travels in the glTF asset's "
                  "CDBRDF_materials_curvature_brdf extension.")


def _name(text: str) -> str:
    """A valid MaterialX element name from ``text``."""
    out = "".join(c if c.isalnum() or c == "_" else "_" for c in text) or "fabric"
    return out if not out[0].isdigit() else f"m_{out}"


def materialx_document(fit: FallbackFit, *, material: str = "fabric", source: str = "") -> Any:
    """The fallback as a validated MaterialX document (see the module's description).

    Parameters
    ----------
    fit
        The standard material's fit.
    material
        The material's name.
    source
        What it was fitted to (the table's file), recorded in the document.

    Returns
    -------
    MaterialX.Document
        The document, with the standard libraries imported for validation.

    Raises
    ------
    FormatError
        When MaterialX's validation refuses it (with MaterialX's message).
    """
    import MaterialX as mx

    doc = mx.createDocument()
    lib = mx.createDocument()
    mx.loadLibraries(mx.getDefaultDataLibraryFolders(), mx.getDefaultDataSearchPath(), lib)
    name = _name(material)
    doc.addChildOfCategory("comment").setDocString(CURVATURE_NOTE)
    shader = doc.addNode("standard_surface", f"{name}_fallback", "surfaceshader")
    shader.setDocString(f"cdbrdf fallback of {material}" + (f" ({source})" if source else "")
                        + f": fitted to the flat BRDF, relative RMS error {fit.relative_rms_error:.3f}, "
                        f"median relative error {fit.median_relative_error:.3f} over {fit.samples} directions")

    def put(inp: str, kind: str, value: Any) -> None:
        shader.setInputValue(inp, value, kind)

    put("base", "float", 1.0)
    put("base_color", "color3", mx.Color3(*(float(c) for c in fit.base_color)))
    put("metalness", "float", 0.0)
    put("specular", "float", 1.0)
    put("specular_color", "color3", mx.Color3(1.0, 1.0, 1.0))
    put("specular_IOR", "float", 1.5)
    put("specular_roughness", "float", float(fit.roughness))
    put("specular_anisotropy", "float", float(fit.anisotropy_strength))
    put("specular_rotation", "float", float((fit.anisotropy_rotation / (2.0 * math.pi)) % 1.0))
    sheen = max(fit.sheen_color)
    put("sheen", "float", 1.0 if sheen > 0 else 0.0)
    put("sheen_color", "color3", mx.Color3(*(float(c) for c in fit.sheen_color)))
    put("sheen_roughness", "float", float(fit.sheen_roughness))
    mat = doc.addMaterialNode(name, shader)
    mat.setDocString(CURVATURE_NOTE)
    doc.importLibrary(lib)
    ok, message = doc.validate()
    if not ok:
        raise FormatError(f"MaterialX refuses the fallback of {material}: {' '.join(message.split())[:300]}")
    return doc


def write_materialx(fit: FallbackFit, path: str | PathLike[str], *, material: str = "fabric",
                    source: str = "") -> Path:
    """Write the fallback's MaterialX document atomically (the libraries it was validated against left out).

    Parameters
    ----------
    fit
        The fit.
    path
        The ``.mtlx`` file.
    material, source
        As :func:`materialx_document` takes them.

    Returns
    -------
    pathlib.Path
        The file.
    """
    import MaterialX as mx

    from ..fsutil import atomic_path

    doc = materialx_document(fit, material=material, source=source)
    opts = mx.XmlWriteOptions()
    opts.writeXIncludeEnable = False
    opts.elementPredicate = lambda elem: not elem.hasSourceUri()  # not the standard libraries
    text = mx.writeToXmlString(doc, opts)
    p = Path(path)
    with atomic_path(p, suffix=".mtlx") as tmp:
        tmp.write_text(text, encoding="utf-8")
    return p
