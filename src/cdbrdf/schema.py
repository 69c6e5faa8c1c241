"""The names of the CDBRDF data model, written once (see ``docs/format.md``).

The HDF5 file (:mod:`cdbrdf.io`) and the :mod:`xarray` conversion
(:meth:`cdbrdf.CDBRDF.to_xarray`, :meth:`cdbrdf.CDBRDF.from_xarray`) both lay
a table out the same way, with the names, dimensions, units and long names
defined here:

- dimensions :data:`AXES` ``(kappa, phi_l, theta_l, phi_v, theta_v, channel)``,
  the five sample axes :data:`SAMPLE_AXES` being coordinate variables of the
  same names (units :data:`AXIS_UNITS`) and ``channel`` the channel names
  (default :func:`default_channels`);
- data variables :data:`DATA_VARIABLES` (``reflectance``, ``measured``,
  ``fill_source``, ``reflectance_std`` and, since 1.2, the per-sample fill
  provenance ``fill_method``, ``fill_sources``, ``fill_weights``,
  ``fill_std``) with their dimensions; the fill methods a file can name
  (:data:`FILL_METHOD_CODES`);
- their CF attributes (``units``, ``long_name``, flags) from
  :func:`variable_attrs`, the units of the reflectance depending on the
  table's quantity (:data:`QUANTITIES`, :func:`reflectance_units`);
- the global attributes of a file (:data:`REQUIRED_ATTRS` and the others).

:class:`TableParts` is the plain structure the file reader and writer
exchange with :mod:`cdbrdf.table`, so that the file code never needs the
table class.

This module imports nothing of cdbrdf but :mod:`cdbrdf.errors`.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any

import numpy as np

from .errors import TableError

__all__ = [
    "FORMAT_NAME",
    "FORMAT_VERSION",
    "AXES",
    "SAMPLE_AXES",
    "CHANNEL",
    "AXIS_UNITS",
    "QUANTITIES",
    "REFLECTANCE",
    "MEASURED",
    "FILL_SOURCE",
    "REFLECTANCE_STD",
    "FILL_METHOD",
    "FILL_SOURCES",
    "FILL_WEIGHTS",
    "FILL_STD",
    "FILL_SLOT",
    "FILL_METHOD_CODES",
    "fill_method_code",
    "DATA_VARIABLES",
    "REQUIRED_VARIABLES",
    "CHANNELS_ATTR",
    "REQUIRED_ATTRS",
    "MIRRORED_ATTRS",
    "ATTRS_JSON_ATTR",
    "DIGEST_ATTR",
    "DATA_DIGEST_ATTR",
    "WRITER_ATTRS",
    "UNIT_SPELLINGS",
    "PACKING_ATTRS",
    "MISSING_VALUE_ATTRS",
    "same_units",
    "CONVENTIONS",
    "SYMMETRY_ATTR",
    "SYMMETRIES",
    "check_quantity",
    "check_symmetry",
    "reflectance_units",
    "variable_attrs",
    "default_channels",
    "is_default_channels",
    "channel_names",
    "check_channel_names",
    "with_channel_names",
    "TableParts",
]

#: Value of the global attribute ``format``.
FORMAT_NAME = "cdbrdf"
#: ``MAJOR.MINOR`` of the layout: readers accept any minor version of their major version.
FORMAT_VERSION = "1.5"

# -- dimensions -------------------------------------------------------------------------
#: Dimension names of the reflectance, in storage order (``docs/conventions.md``).
AXES: tuple[str, ...] = ("kappa", "phi_l", "theta_l", "phi_v", "theta_v", "channel")
#: The five sample axes (every dimension but the channel), in storage order.
SAMPLE_AXES: tuple[str, ...] = AXES[:-1]
#: Name of the channel dimension and of its coordinate (the channel names).
CHANNEL = AXES[-1]
#: Units of the sample axes: curvature in mm^-1, angles in degrees.
AXIS_UNITS: Mapping[str, str] = MappingProxyType({
    "kappa": "1/mm",
    "phi_l": "degree",
    "theta_l": "degree",
    "phi_v": "degree",
    "theta_v": "degree",
})

# -- quantities -------------------------------------------------------------------------
#: Valid values of the table attribute ``quantity``.
QUANTITIES: tuple[str, ...] = ("brdf", "relative")
_REFLECTANCE_UNITS: Mapping[str, str] = MappingProxyType({"brdf": "1/sr", "relative": "1"})
_REFLECTANCE_LONG_NAMES: Mapping[str, str] = MappingProxyType({
    "brdf": "BRDF, cosine of the light direction not included",
    "relative": "relative reflectance (BRDF up to an unknown scale)",
})

# -- symmetry ---------------------------------------------------------------------------
#: Table attribute (and global attribute of the file, since 1.2) naming the table's symmetry.
SYMMETRY_ATTR = "symmetry"
#: Valid values of :data:`SYMMETRY_ATTR`. ``"anisotropic"`` (also when the attribute is
#: absent): the five axes as they are. ``"isotropic"``: the value depends on the light and
#: view elevations and the azimuth difference only; ``phi_l`` is the single azimuth 0 and
#: ``phi_v`` holds ``phi_v - phi_l`` (``docs/format.md``).
SYMMETRIES: tuple[str, ...] = ("anisotropic", "isotropic")

# -- data variables ---------------------------------------------------------------------
#: The samples, :data:`AXES`.
REFLECTANCE = "reflectance"
#: 1 (True) where a sample was measured, 0 where it was filled, :data:`SAMPLE_AXES`.
MEASURED = "measured"
#: Flat index of each filled sample's source; -1 measured, -2 unknown, :data:`SAMPLE_AXES`.
FILL_SOURCE = "fill_source"
#: Optional per-sample standard deviation, :data:`AXES`.
REFLECTANCE_STD = "reflectance_std"
#: How each sample was filled (since 1.2): a code of :data:`FILL_METHOD_CODES`, :data:`SAMPLE_AXES`.
FILL_METHOD = "fill_method"
#: Every source of each filled sample (since 1.2): flat indices, -1 unused, :data:`SAMPLE_AXES` + slot.
FILL_SOURCES = "fill_sources"
#: The weight of each source in the filled value (since 1.2), like :data:`FILL_SOURCES`.
FILL_WEIGHTS = "fill_weights"
#: Estimated standard deviation of each filled value's error (since 1.2), :data:`AXES`.
FILL_STD = "fill_std"
#: Dimension of the source slots of :data:`FILL_SOURCES` and :data:`FILL_WEIGHTS`.
FILL_SLOT = "fill_slot"
#: Per-sample fill methods and their codes in :data:`FILL_METHOD` (CF flag values).
#: ``measured``: not filled; ``unknown``: filled, how is not recorded (files
#: before 1.2 whose fill source is unknown); ``nearest``: copied from the
#: nearest measured direction at the same curvature (the paper's rule);
#: ``nearest_stand``: copied from the same direction on the nearest stand that
#: measured it; ``kappa_fit``: a line fitted along the curvature to the same
#: direction on the stands that measured it; ``model`` (since 1.5): a fitted fabric model's change with
#: curvature applied to the same direction measured at other curvatures: on the stands that measured it
#: (the measurement's model fill, ``docs/capture.md``) or the flat measurement alone (``cdbrdf bend``:
#: the direction and its mirror, :mod:`cdbrdf.bend`).
FILL_METHOD_CODES: Mapping[str, int] = MappingProxyType({
    "measured": 0,
    "unknown": 1,
    "nearest": 2,
    "nearest_stand": 3,
    "kappa_fit": 4,
    "model": 5,
})
#: Data variables and their dimensions, in the order they are written.
DATA_VARIABLES: Mapping[str, tuple[str, ...]] = MappingProxyType({
    REFLECTANCE: AXES,
    MEASURED: SAMPLE_AXES,
    FILL_SOURCE: SAMPLE_AXES,
    REFLECTANCE_STD: AXES,
    FILL_METHOD: SAMPLE_AXES,
    FILL_SOURCES: (*SAMPLE_AXES, FILL_SLOT),
    FILL_WEIGHTS: (*SAMPLE_AXES, FILL_SLOT),
    FILL_STD: AXES,
})
#: Data variables a file must hold (the others are optional on read).
REQUIRED_VARIABLES: tuple[str, ...] = (REFLECTANCE, MEASURED)

_LONG_NAMES: Mapping[str, str] = MappingProxyType({
    "kappa": "surface curvature (> 0 convex, < 0 concave)",
    "phi_l": "light azimuth from the reference tangent x towards y",
    "theta_l": "light elevation from the surface normal",
    "phi_v": "view azimuth from the reference tangent x towards y",
    "theta_v": "view elevation from the surface normal",
    CHANNEL: "colour channel",
    FILL_SOURCE: (
        "C-order flat index over (kappa, phi_l, theta_l, phi_v, theta_v) of the "
        "sample a filled value was copied from (of its first source when it was "
        "computed from several); -1 measured, -2 source unknown"
    ),
    REFLECTANCE_STD: "per-sample standard deviation of the reflectance",
    FILL_METHOD: "how the sample was filled",
    FILL_SOURCES: (
        "C-order flat indices over (kappa, phi_l, theta_l, phi_v, theta_v) of every "
        "sample a filled value was computed from, first source first; -1 unused slot"
    ),
    FILL_WEIGHTS: (
        "weight of each source of a filled value: the value is the weighted sum of "
        "the sources (of their logarithms for kappa_fit); 0 in unused slots"
    ),
    FILL_STD: "estimated standard deviation of the error of a filled value; 0 where measured",
    FILL_SLOT: "source slot of a filled sample (0: its first source)",
})

# -- attributes -------------------------------------------------------------------------
#: Table attribute naming the channels when they are not :func:`default_channels`.
CHANNELS_ATTR = "channels"
#: Global attributes every file has, all strings (``docs/format.md``).
REQUIRED_ATTRS: tuple[str, ...] = (
    "format", "format_version", "quantity", "colour_space", "software", "cdbrdf_attrs", "Conventions",
)
#: Required global attributes that are table attributes too (and must equal them).
MIRRORED_ATTRS: tuple[str, ...] = ("quantity", "colour_space")
#: Global attribute holding every table attribute as a JSON object.
ATTRS_JSON_ATTR = "cdbrdf_attrs"
#: Global attribute with the SHA-256 of ``cdbrdf_attrs`` and the channel names (since 1.1).
DIGEST_ATTR = "cdbrdf_sha256"
#: Global attribute with the SHA-256 of the axes and of every data variable as stored (since 1.3).
DATA_DIGEST_ATTR = "cdbrdf_data_sha256"
#: Global attributes the writer sets itself, never mirrors of table attributes.
WRITER_ATTRS: frozenset[str] = frozenset(
    ("format", "format_version", "software", "Conventions", ATTRS_JSON_ATTR, DIGEST_ATTR, DATA_DIGEST_ATTR)
)
#: Spellings of each unit the readers accept in a ``units`` attribute (UDUNITS spellings of the same
#: unit, as other tools write them); any other unit is refused: the values would mean something else.
UNIT_SPELLINGS: Mapping[str, frozenset[str]] = MappingProxyType({
    "1/mm": frozenset({"1/mm", "mm-1", "mm^-1", "1 mm-1", "mm**-1"}),
    "degree": frozenset({"degree", "degrees", "deg"}),
    "1/sr": frozenset({"1/sr", "sr-1", "sr^-1", "1 sr-1", "sr**-1"}),
    "1": frozenset({"1", ""}),
})
#: CF packing attributes (``value = stored * scale_factor + add_offset``): readers refuse a variable
#: that has them (the layout stores unpacked floats; a reader that ignored them would read other values).
PACKING_ATTRS: tuple[str, ...] = ("scale_factor", "add_offset")
#: CF attributes marking missing values: a stored value equal to one of them is missing (xarray reads
#: it as NaN), which a table cannot hold.
MISSING_VALUE_ATTRS: tuple[str, ...] = ("_FillValue", "missing_value")
#: Value of the global attribute ``Conventions``.
CONVENTIONS = "CF-1.10"


def fill_method_code(name: str) -> int:
    """The :data:`FILL_METHOD` code of the per-sample fill method ``name``.

    Raises
    ------
    TableError
        For a name that is not one of :data:`FILL_METHOD_CODES` (the message lists them).
    """
    if not isinstance(name, str) or name not in FILL_METHOD_CODES:
        raise TableError(f"fill method {name!r}: not one of {', '.join(FILL_METHOD_CODES)}")
    return FILL_METHOD_CODES[name]


def check_quantity(quantity: Any) -> str:
    """``quantity`` when it is one of :data:`QUANTITIES`.

    Raises
    ------
    TableError
        Otherwise; the message lists the valid quantities.
    """
    if not isinstance(quantity, str) or quantity not in QUANTITIES:
        raise TableError(f"attrs['quantity']: {quantity!r} is not one of {', '.join(QUANTITIES)}")
    return quantity


def check_symmetry(symmetry: Any) -> str:
    """``symmetry`` when it is one of :data:`SYMMETRIES`.

    Raises
    ------
    TableError
        Otherwise; the message lists the valid symmetries.
    """
    if not isinstance(symmetry, str) or symmetry not in SYMMETRIES:
        raise TableError(f"symmetry: {symmetry!r} is not one of {', '.join(SYMMETRIES)}")
    return symmetry


def reflectance_units(quantity: str) -> str:
    """Units of the reflectance (and its standard deviation) of a table of ``quantity``.

    Parameters
    ----------
    quantity
        One of :data:`QUANTITIES`.

    Returns
    -------
    str
        ``"1/sr"`` for ``"brdf"``, ``"1"`` (unknown scale) for ``"relative"``.

    Raises
    ------
    TableError
        For a quantity that is not one of :data:`QUANTITIES` (the message lists them).
    """
    return _REFLECTANCE_UNITS[check_quantity(quantity)]


def same_units(given: str, expected: str) -> bool:
    """Whether a ``units`` attribute ``given`` names the unit ``expected`` (:data:`UNIT_SPELLINGS`)."""
    g = " ".join(str(given).split())
    return g in UNIT_SPELLINGS.get(expected, frozenset({expected}))


def variable_attrs(name: str, quantity: str) -> dict[str, Any]:
    """The CF attributes of the variable ``name`` of a table of ``quantity``, in writing order.

    Parameters
    ----------
    name
        A dimension of :data:`AXES`, :data:`FILL_SLOT` or a variable of :data:`DATA_VARIABLES`.
    quantity
        The table's quantity, one of :data:`QUANTITIES`.

    Returns
    -------
    dict
        ``units`` and ``long_name`` (axes, reflectance, its standard
        deviation, the fill's standard deviation and weights), ``long_name``
        (channel, fill_source, fill_sources), or ``long_name``,
        ``flag_values`` (uint8) and ``flag_meanings`` (measured, fill_method).

    Raises
    ------
    TableError
        For an unknown variable name or quantity (the message lists the valid ones).
    """
    units = reflectance_units(quantity)
    if name in AXIS_UNITS:
        return {"units": AXIS_UNITS[name], "long_name": _LONG_NAMES[name]}
    if name == REFLECTANCE:
        return {"units": units, "long_name": _REFLECTANCE_LONG_NAMES[quantity]}
    if name in (REFLECTANCE_STD, FILL_STD):
        return {"units": units, "long_name": _LONG_NAMES[name]}
    if name == MEASURED:
        return {"flag_values": np.array([0, 1], dtype=np.uint8), "flag_meanings": "filled measured"}
    if name == FILL_METHOD:
        return {
            "long_name": _LONG_NAMES[name],
            "flag_values": np.array(list(FILL_METHOD_CODES.values()), dtype=np.uint8),
            "flag_meanings": " ".join(FILL_METHOD_CODES),
        }
    if name == FILL_WEIGHTS:
        return {"units": "1", "long_name": _LONG_NAMES[name]}
    if name in (CHANNEL, FILL_SOURCE, FILL_SOURCES, FILL_SLOT):
        return {"long_name": _LONG_NAMES[name]}
    raise TableError(f"variable {name!r}: not one of {', '.join((*AXES, FILL_SLOT, *DATA_VARIABLES))}")


# -- channels ---------------------------------------------------------------------------
def default_channels(n: int) -> list[str]:
    """Names of ``n`` channels when the table names none: R, G, B for 3, else c0, c1, ..."""
    return ["R", "G", "B"] if n == 3 else [f"c{i}" for i in range(n)]


def is_default_channels(names: list[str]) -> bool:
    """Whether ``names`` are the :func:`default_channels` of their number."""
    return list(names) == default_channels(len(names))


def channel_names(attrs: Mapping[str, Any], n: int) -> list[str]:
    """The names of a table's ``n`` channels: ``attrs["channels"]`` when it has ``n`` entries, else the defaults."""
    names = attrs.get(CHANNELS_ATTR)
    if names is not None and len(names) == n:
        return [str(c) for c in names]
    return default_channels(n)


def check_channel_names(attrs: Mapping[str, Any], n: int) -> None:
    """Refuse an ``attrs["channels"]`` entry that is not a list of ``n`` strings (writers store it).

    Raises
    ------
    TableError
        Naming the entry and the number of channels.
    """
    names = attrs.get(CHANNELS_ATTR)
    if names is not None and (
        not isinstance(names, (list, tuple)) or len(names) != n or not all(isinstance(c, str) for c in names)
    ):
        raise TableError(f"attrs[{CHANNELS_ATTR!r}]: {names!r} is not a list of {n} channel name(s)")


def with_channel_names(attrs: Mapping[str, Any], names: list[str]) -> dict[str, Any]:
    """``attrs`` with a ``channels`` entry for ``names`` when they are not the defaults.

    An existing ``channels`` entry is kept as it is (readers that require it to
    agree check that first).
    """
    out = dict(attrs)
    if not is_default_channels(names):
        out.setdefault(CHANNELS_ATTR, list(names))
    return out


# -- the parts of a table ---------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class TableParts:
    """A table as plain arrays: what the file reader returns and the writer takes.

    The arrays are not validated here: :class:`cdbrdf.CDBRDF` does that when a
    table is built from them.

    Parameters
    ----------
    values
        Reflectance, dimensions :data:`AXES`.
    axes
        The sample axes by name (:data:`SAMPLE_AXES`): curvature in mm^-1,
        angles in degrees.
    measured
        Measured mask, dimensions :data:`SAMPLE_AXES`; None: all measured.
    fill_source
        Fill sources, dimensions :data:`SAMPLE_AXES`; None: not recorded.
    std
        Per-sample standard deviation like ``values``, or None.
    attrs
        The table's attributes.
    fill_method, fill_sources, fill_weights, fill_std
        The per-sample fill provenance (since 1.2; :data:`FILL_METHOD`,
        :data:`FILL_SOURCES`, :data:`FILL_WEIGHTS`, :data:`FILL_STD`), or
        None when not recorded.
    file_attrs
        The names of the file's global attributes, when a reader saw them
        (another variable's attributes, a CD-BTF's: :mod:`cdbrdf.sources`); None otherwise.
    """

    values: np.ndarray
    axes: Mapping[str, np.ndarray]
    measured: np.ndarray | None
    fill_source: np.ndarray | None
    std: np.ndarray | None
    attrs: Mapping[str, Any]
    fill_method: np.ndarray | None = None
    fill_sources: np.ndarray | None = None
    fill_weights: np.ndarray | None = None
    fill_std: np.ndarray | None = None
    file_attrs: frozenset[str] | None = None

    @classmethod
    def of(cls, table: Any) -> TableParts:
        """The parts of a table: anything with the attributes of :class:`cdbrdf.CDBRDF` (no copies)."""
        return cls(
            values=table.values,
            axes={name: getattr(table, name) for name in SAMPLE_AXES},
            measured=table.measured,
            fill_source=table.fill_source,
            std=table.std,
            attrs=table.attrs,
            fill_method=getattr(table, "fill_method", None),
            fill_sources=getattr(table, "fill_sources", None),
            fill_weights=getattr(table, "fill_weights", None),
            fill_std=getattr(table, "fill_std", None),
        )

    @property
    def quantity(self) -> str:
        """``attrs["quantity"]``, checked by :func:`check_quantity`."""
        return check_quantity(self.attrs.get("quantity"))

    @property
    def channels(self) -> list[str]:
        """The channel names (:func:`channel_names`)."""
        return channel_names(self.attrs, int(np.shape(self.values)[-1]))

    def variables(self) -> dict[str, np.ndarray]:
        """The data variables that are present, by name, in the order of :data:`DATA_VARIABLES`."""
        arrays = {
            REFLECTANCE: self.values,
            MEASURED: self.measured,
            FILL_SOURCE: self.fill_source,
            REFLECTANCE_STD: self.std,
            FILL_METHOD: self.fill_method,
            FILL_SOURCES: self.fill_sources,
            FILL_WEIGHTS: self.fill_weights,
            FILL_STD: self.fill_std,
        }
        return {name: a for name, a in arrays.items() if a is not None}
