"""The attributes of a CDBRDF file: its global attributes and digests, and the CF attributes of its variables.

Owned with :mod:`cdbrdf.io` (the file): the global attributes a file and
:meth:`cdbrdf.CDBRDF.to_xarray` carry (:func:`global_attrs`,
:func:`attrs_from_globals`), the SHA-256 digests of the attributes and of the
data (Fletcher-32, HDF5's chunk checksum, cannot see every change), and the
rules for CF attributes on read (packing and another unit refused, missing
values refused). ``docs/format.md`` describes them.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path
from typing import Any

import numpy as np

from ._hdf5 import fail, one_line
from .errors import TableError
from .schema import (
    ATTRS_JSON_ATTR,
    CONVENTIONS,
    DIGEST_ATTR,
    FORMAT_NAME,
    FORMAT_VERSION,
    MISSING_VALUE_ATTRS,
    PACKING_ATTRS,
    QUANTITIES,
    WRITER_ATTRS,
    TableParts,
    same_units,
    variable_attrs,
)

__all__ = ["global_attrs", "attrs_from_globals", "jsonable", "attrs_digest", "data_digest", "native_mirror",
           "get_attr", "get_attr_str", "as_str", "check_cf", "check_missing", "check_mirrors"]


def jsonable(name: str, value: Any) -> str:
    try:
        return json.dumps(value, sort_keys=True, allow_nan=False)
    except (TypeError, ValueError) as exc:
        raise TableError(f"attrs[{name!r}]: cannot be stored in the file ({exc})") from None


def attrs_digest(attrs_json: str, channels: list[str]) -> np.ndarray:
    """SHA-256 over ``cdbrdf_attrs`` and the channel names, as 32 uint8."""
    h = hashlib.sha256(b"cdbrdf-1.1\0")
    h.update(attrs_json.encode("utf-8"))
    for c in channels:
        h.update(b"\0" + c.encode("utf-8"))
    return np.frombuffer(h.digest(), dtype=np.uint8).copy()


def data_digest(arrays: list[tuple[str, np.ndarray]]) -> np.ndarray:
    """SHA-256 over the axes and data variables as stored (name, little-endian dtype, shape, bytes), as 32 uint8.

    Fletcher-32, the chunk checksum HDF5 offers, cannot see every change: a
    16-bit word turned from 0x0000 to 0xFFFF (or back) keeps its sums (a
    theta_l of 15 degrees read as 15.49999 in a checksummed 1.2 file). This
    digest sees any change of any value.
    """
    h = hashlib.sha256(b"cdbrdf-data-1.3\0")
    for name, a in arrays:
        le = np.ascontiguousarray(a, dtype=np.asarray(a).dtype.newbyteorder("<"))
        h.update(f"{name}\0{le.dtype.str}\0{le.shape}\0".encode())
        h.update(le.reshape(-1).view(np.uint8).data)
    return np.frombuffer(h.digest(), dtype=np.uint8).copy()


def global_attrs(parts: TableParts) -> dict[str, Any]:
    """The global attributes of a file of ``parts``, all netCDF-legal (strings, numbers, uint8 digests).

    The format's own (``format``, ``format_version``, ``software``,
    ``Conventions``), every table attribute mirrored (scalars as themselves,
    the rest as JSON text), ``cdbrdf_attrs`` (all of them as one JSON object)
    and ``cdbrdf_sha256`` (the digest of that text and the channel names).
    The writer writes them, and :meth:`cdbrdf.CDBRDF.to_xarray` gives them
    to its dataset, so that ``to_xarray().to_netcdf(f)`` writes a file
    :func:`read` reads. The data digest (``cdbrdf_data_sha256``) is the
    writer's alone: data edited in xarray are not damaged data.

    Parameters
    ----------
    parts
        The table's arrays and attributes.

    Returns
    -------
    dict
        The global attributes by name.

    Raises
    ------
    TableError
        When an attribute cannot be stored (not JSON-serialisable).
    """
    from ._version import __version__

    attrs = parts.attrs
    attrs_json = jsonable("*", attrs)
    out: dict[str, Any] = {"format": FORMAT_NAME, "format_version": FORMAT_VERSION,
                           "software": f"cdbrdf {__version__}", "Conventions": CONVENTIONS}
    for key, value in attrs.items():
        if key not in out:
            out[key] = value if native_mirror(value) else jsonable(key, value)
    out[ATTRS_JSON_ATTR] = attrs_json
    out[DIGEST_ATTR] = attrs_digest(attrs_json, parts.channels)
    return out


def attrs_from_globals(globals_: Any) -> dict[str, Any]:
    """The table attributes of global attributes made by :func:`global_attrs` (an xarray dataset's ``attrs``).

    ``cdbrdf_attrs`` is the source of truth when present; every global
    attribute that mirrors one of its entries must agree with it, as in a
    file. Without it the global attributes are taken as they are, but for
    the format's own.

    Parameters
    ----------
    globals_
        The global attributes (a mapping).

    Returns
    -------
    dict
        The table's attributes.

    Raises
    ------
    TableError
        When ``cdbrdf_attrs`` is not a JSON object or a mirror disagrees with it.
    """
    g = dict(globals_)
    if ATTRS_JSON_ATTR not in g:
        return {k: v for k, v in g.items() if k not in WRITER_ATTRS}
    try:
        attrs = json.loads(str(g[ATTRS_JSON_ATTR]))
    except (ValueError, RecursionError) as exc:
        raise TableError(f"attrs[{ATTRS_JSON_ATTR!r}]: not valid JSON ({one_line(exc)})") from None
    if not isinstance(attrs, dict):
        raise TableError(f"attrs[{ATTRS_JSON_ATTR!r}]: not a JSON object")
    for key, value in attrs.items():
        if key in WRITER_ATTRS or key not in g:
            continue
        stored = g[key]
        if isinstance(stored, np.ndarray) and stored.size == 1:
            stored = stored.reshape(()).item()
        if isinstance(stored, np.generic):
            stored = stored.item()
        want = value if native_mirror(value) else jsonable(key, value)
        if not (stored == want and type(stored) is type(want)):
            raise TableError(f"attrs[{key!r}]: {stored!r:.60} disagrees with its entry in {ATTRS_JSON_ATTR!r} "
                             f"({want!r:.60}); change both, or drop {ATTRS_JSON_ATTR!r}")
    return attrs


def native_mirror(value: Any) -> bool:
    """Whether a global attribute mirrors ``value`` as itself (else as its JSON text).

    NetCDF-4 has no boolean attribute type and HDF5 no integer beyond 64 bits:
    booleans and such integers are mirrored as JSON text (``true``, ``2**70``
    in digits), like lists and mappings. ``cdbrdf_attrs`` keeps the value.
    """
    if isinstance(value, bool):
        return False
    if isinstance(value, int):
        return -(2**63) <= value < 2**63
    return isinstance(value, (str, float))


def as_str(path: Path, what: str, v: Any) -> str:
    """``v`` (str, UTF-8 bytes or a one-element array of them) as str; FormatError otherwise."""
    if isinstance(v, np.ndarray) and v.size == 1 and v.dtype.kind in "OSU":
        v = v.reshape(()).item()
    if isinstance(v, (bytes, np.bytes_)):
        try:
            v = bytes(v).decode("utf-8")
        except UnicodeDecodeError:
            raise fail(path, f"{what} is not valid UTF-8 text") from None
    if not isinstance(v, str):
        raise fail(path, f"{what} is not a string (got {type(v).__name__})")
    return v


def get_attr(path: Path, attrs: Any, name: str) -> Any:
    try:
        return attrs[name]
    except UnicodeDecodeError:
        raise fail(path, f"global attribute {name!r} is not valid UTF-8 text") from None
    except (OSError, RuntimeError, KeyError, ValueError, TypeError) as exc:
        raise fail(path, f"global attribute {name!r} cannot be read ({one_line(exc)}): the file is damaged") from None


def get_attr_str(path: Path, attrs: Any, name: str) -> str:
    if name not in attrs:
        raise fail(path, f"missing the global attribute {name!r}")
    return as_str(path, f"global attribute {name!r}", get_attr(path, attrs, name))


def check_cf(path: Path, ds: Any, name: str, quantity: str) -> None:
    """Refuse CF packing (``scale_factor``, ``add_offset``) and a ``units`` attribute naming another unit.

    A reader that ignored them would read other values than xarray (half of
    them with ``scale_factor = 2``, a negative reflectance with ``add_offset
    = 1``), or values in another unit than the axis is (``1/m``): neither is
    ever read as the table.
    """
    for attr in PACKING_ATTRS:
        if attr in ds.attrs:
            value = np.asarray(get_attr(path, ds.attrs, attr)).reshape(-1)[:1].tolist()
            raise fail(path, f"{name!r} is packed ({attr} = {value[0] if value else '?'!r:.40}); the format "
                             "stores the values unpacked: unpack it (xarray's decoding) and save it again")
    if "units" not in ds.attrs or quantity not in QUANTITIES:
        return
    expected = variable_attrs(name, quantity).get("units")
    if expected is None:
        return
    given = as_str(path, f"the units of {name!r}", get_attr(path, ds.attrs, "units"))
    if not same_units(given, expected):
        raise fail(path, f"{name!r} is in {given!r:.40}, expected {expected!r}: values in another unit are not "
                         "read as the table")


def check_missing(path: Path, ds: Any, name: str, a: np.ndarray) -> None:
    """Refuse values a CF missing-value attribute marks missing (xarray reads them as NaN): a table has none."""
    for attr in MISSING_VALUE_ATTRS:
        if attr not in ds.attrs:
            continue
        marks = np.asarray(get_attr(path, ds.attrs, attr)).reshape(-1)
        if marks.dtype.kind not in "fiub":
            raise fail(path, f"{name!r} has a {attr} that is not a number")
        with np.errstate(invalid="ignore"):
            hit = int(np.count_nonzero(np.isin(a, marks)))
        if hit:
            raise fail(path, f"{name!r} holds {hit} value(s) equal to its {attr} ({marks[0]!r}): missing values, "
                             "which a table cannot have")


def check_mirrors(path: Path, f: Any, attrs: dict[str, Any]) -> None:
    """The global attributes that mirror ``cdbrdf_attrs`` entries must agree with them."""
    for key, value in attrs.items():
        if key in WRITER_ATTRS or key not in f.attrs:
            continue
        stored = get_attr(path, f.attrs, key)
        if isinstance(value, str):
            ok = as_str(path, f"global attribute {key!r}", stored) == value
        elif native_mirror(value):
            s = stored.reshape(()).item() if isinstance(stored, np.ndarray) and stored.size == 1 else stored
            if isinstance(s, np.generic):
                s = s.item()
            ok = isinstance(s, (bool, int, float)) and type(s) is type(value) and s == value
        else:
            ok = as_str(path, f"global attribute {key!r}", stored) == jsonable(key, value)
        if not ok:
            raise fail(path, f"global attribute {key!r} disagrees with its entry in 'cdbrdf_attrs'")
