"""The names of a mesh's per-vertex attributes, in a :class:`~cdbrdf.mesh.Mesh`, in a PLY file and in Mitsuba.

One rule names every attribute in the three places it lives: the array
``NAME`` of :attr:`cdbrdf.mesh.Mesh.attributes` is written as the PLY
vertex property ``NAME_x`` (:func:`ply_property`), which Mitsuba's PLY
loader keeps (it keeps an unknown property only when its name ends in a
channel suffix, and strips it) as the mesh attribute ``vertex_NAME``
(:func:`mitsuba_attribute`); the renderer sets the same attribute in memory.
The one exception is the shape operator: its three arrays
(:data:`SHAPE_ATTRIBUTES`) are the consecutive properties
:data:`SHAPE_PLY_PROPERTIES`, which Mitsuba groups into the one
three-channel attribute :data:`SHAPE_MESH_ATTRIBUTE`.

The curvature the CDBRDF is looked up with is a :class:`CurvatureMode`
(:data:`CURVATURE_MODES`): ``max``, the paper's (the signed principal
curvature of larger magnitude), and ``directional`` (the normal curvature
along the material's x axis), each with its attribute.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType

from ..errors import OptionError

__all__ = [
    "CurvatureMode",
    "CURVATURE_MODES",
    "curvature_mode",
    "SHAPE_ATTRIBUTES",
    "SHAPE_PLY_PROPERTIES",
    "SHAPE_MESH_ATTRIBUTE",
    "ply_property",
    "mitsuba_attribute",
    "attribute_of_ply",
]

#: Per-vertex attributes of a prepared mesh holding its own shape operator (1/mm) in the frame
#: x = dP/du, y = n x x: what the plug-in adds a map's to.
SHAPE_ATTRIBUTES: tuple[str, str, str] = ("shape_xx", "shape_xy", "shape_yy")

#: The PLY vertex properties of :data:`SHAPE_ATTRIBUTES`: consecutive, so that Mitsuba's PLY loader groups
#: them into the one three-channel mesh attribute :data:`SHAPE_MESH_ATTRIBUTE` (one read per shading point).
SHAPE_PLY_PROPERTIES: tuple[str, str, str] = ("shape_x", "shape_y", "shape_z")

#: The three-channel Mitsuba mesh attribute ``(sxx, sxy, syy)`` the plug-in reads.
SHAPE_MESH_ATTRIBUTE = "vertex_shape"

_PLY_SUFFIX = "_x"
_MITSUBA_PREFIX = "vertex_"


def ply_property(name: str, *, shape: bool = True) -> str:
    """The PLY vertex property of the mesh attribute ``name`` (``curvature`` -> ``curvature_x``).

    Parameters
    ----------
    name
        The array's name in :attr:`cdbrdf.mesh.Mesh.attributes`.
    shape
        The mesh has the whole shape operator (:data:`SHAPE_ATTRIBUTES`),
        written as its three properties; a lone one of them is named by the
        general rule.

    Returns
    -------
    str
        The property's name.
    """
    if shape and name in SHAPE_ATTRIBUTES:
        return SHAPE_PLY_PROPERTIES[SHAPE_ATTRIBUTES.index(name)]
    return name + _PLY_SUFFIX


def mitsuba_attribute(name: str) -> str:
    """The Mitsuba mesh attribute of the mesh attribute ``name`` (``curvature`` -> ``vertex_curvature``).

    Parameters
    ----------
    name
        The array's name in :attr:`cdbrdf.mesh.Mesh.attributes`.

    Returns
    -------
    str
        Mitsuba's name (:data:`SHAPE_MESH_ATTRIBUTE` for the shape operator's three).
    """
    if name in SHAPE_ATTRIBUTES:
        return SHAPE_MESH_ATTRIBUTE
    return _MITSUBA_PREFIX + name


def attribute_of_ply(prop: str, *, shape: bool = True) -> str | None:
    """The mesh attribute a PLY vertex property holds (``curvature_x`` -> ``curvature``).

    Parameters
    ----------
    prop
        The vertex property's name.
    shape
        The file has all three of :data:`SHAPE_PLY_PROPERTIES` (the shape
        operator); a lone one of them is named by the general rule.

    Returns
    -------
    str or None
        The attribute's name, or None for a property that holds none (no ``_x`` suffix).
    """
    if shape and prop in SHAPE_PLY_PROPERTIES:
        return SHAPE_ATTRIBUTES[SHAPE_PLY_PROPERTIES.index(prop)]
    if prop.endswith(_PLY_SUFFIX) and len(prop) > len(_PLY_SUFFIX):
        return prop[: -len(_PLY_SUFFIX)]
    return None


@dataclass(frozen=True)
class CurvatureMode:
    """A curvature the CDBRDF can be looked up with, and where a mesh holds it.

    Attributes
    ----------
    name
        ``"max"`` or ``"directional"`` (the key of :data:`CURVATURE_MODES`).
    attribute
        The array of :attr:`cdbrdf.mesh.Mesh.attributes` (mm^-1).
    description
        What it is, in words.
    """

    name: str
    attribute: str
    description: str

    @property
    def ply_property(self) -> str:
        """The PLY vertex property (``curvature_x``)."""
        return ply_property(self.attribute)

    @property
    def mitsuba_attribute(self) -> str:
        """The Mitsuba mesh attribute the ``cdbrdf`` BSDF reads (``vertex_curvature``)."""
        return mitsuba_attribute(self.attribute)


#: The curvature modes, by name: the paper's, and the normal curvature along the material's x.
CURVATURE_MODES: Mapping[str, CurvatureMode] = MappingProxyType({
    "max": CurvatureMode("max", "curvature", "the principal curvature of larger magnitude, signed (the paper's)"),
    "directional": CurvatureMode("directional", "curvature_dir",
                                 "the normal curvature along the material's x axis, signed"),
})


def curvature_mode(value: object, *, what: str = "curvature mode") -> CurvatureMode:
    """The :class:`CurvatureMode` named ``value``.

    Parameters
    ----------
    value
        A name of :data:`CURVATURE_MODES` (or a :class:`CurvatureMode`).
    what
        How the message names it.

    Returns
    -------
    CurvatureMode
        The mode.

    Raises
    ------
    OptionError
        For another value (the message lists the valid ones).
    """
    if isinstance(value, CurvatureMode):
        return value
    if not isinstance(value, str) or value not in CURVATURE_MODES:
        raise OptionError(f"{what}: {value!r:.40} is not one of {', '.join(CURVATURE_MODES)}")
    return CURVATURE_MODES[value]
