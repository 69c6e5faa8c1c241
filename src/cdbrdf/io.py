"""The CDBRDF file: HDF5 laid out as NetCDF-4 (see ``docs/format.md``).

``xarray.open_dataset(path, engine="h5netcdf")`` opens a file with named
dimensions ``(kappa, phi_l, theta_l, phi_v, theta_v, channel)``. Files are
written with :mod:`h5netcdf` (so the dimension scales are exactly what NetCDF
readers expect) to a temporary file in the destination folder that is renamed
over the destination only once complete, with HDF5's checksummed metadata
(superblock v3, v2 object headers) and the Fletcher-32 checksum on every
chunked dataset. They are read with :mod:`h5py` and checked thoroughly before
anything big is read; any problem raises :class:`~cdbrdf.errors.FormatError`
naming the file (or :class:`~cdbrdf.errors.LimitError` for a file that asks for
more memory than :mod:`cdbrdf.limits` allows).

The names, dimensions, units and attributes come from :mod:`cdbrdf.schema`.
This module exchanges a table as :class:`~cdbrdf.schema.TableParts` and does
not know the table class: :func:`cdbrdf.load` (in :mod:`cdbrdf.table`) calls
:func:`read` and builds the table; :meth:`cdbrdf.CDBRDF.save` calls :func:`save`.

Files without metadata checksums (format 1.0, or HDF5 written by other tools
with the old superblock) can hold damaged structures that make the HDF5
library loop forever with the interpreter lock held, where Ctrl-C does not
help. Those are read in a child process under a time limit. The checks of
HDF5 structures that the library would trust (global heaps, string
references, chunk addresses) are in :mod:`cdbrdf._hdf5`.
"""

from __future__ import annotations

import hashlib
import io as _bytes_io
import json
import logging
import math
import re
import subprocess
import sys
from os import PathLike
from pathlib import Path
from typing import Any

import numpy as np

from . import limits
from ._hdf5 import (
    Heaps,
    UnsureError,
    check_global_heaps,
    check_storage,
    check_vlen_refs,
    fail,
    one_line,
    superblock_version,
)
from .errors import FormatError, LimitError, OptionError, TableError
from .fsutil import atomic_path, check_regular
from .schema import (
    ATTRS_JSON_ATTR,
    AXES,
    CHANNEL,
    CHANNELS_ATTR,
    CONVENTIONS,
    DATA_DIGEST_ATTR,
    DATA_VARIABLES,
    DIGEST_ATTR,
    FILL_METHOD,
    FILL_SLOT,
    FILL_SOURCE,
    FILL_SOURCES,
    FILL_STD,
    FILL_WEIGHTS,
    FORMAT_NAME,
    FORMAT_VERSION,
    MEASURED,
    MIRRORED_ATTRS,
    MISSING_VALUE_ATTRS,
    PACKING_ATTRS,
    QUANTITIES,
    REFLECTANCE,
    REFLECTANCE_STD,
    REQUIRED_ATTRS,
    REQUIRED_VARIABLES,
    SAMPLE_AXES,
    WRITER_ATTRS,
    TableParts,
    check_channel_names,
    same_units,
    variable_attrs,
    with_channel_names,
)

__all__ = [
    "FORMAT_NAME",
    "FORMAT_VERSION",
    "LEGACY_READ_TIMEOUT_S",
    "LEGACY_START_TIMEOUT_S",
    "write",
    "save",
    "read",
    "global_attrs",
    "attrs_from_globals",
    "superblock_version",
    "atomic_path",
]

_LOG = logging.getLogger(__name__)

#: HDF5 file-format bounds of written files: "v110" gives superblock v3 and
#: v2 object headers, whose Jenkins checksums make damaged metadata an error
#: instead of an endless loop; HDF5 >= 1.10 (and NetCDF-C built on it) reads it.
_LIBVER = ("v110", "v110")
#: Seconds a file without metadata checksums may take to read, once the reader has started (plus 1 s
#: per 10 MB): a damaged one is refused within about this time.
LEGACY_READ_TIMEOUT_S = 3.0
#: Seconds the reader of such a file may take to start (import its libraries) before it reads.
LEGACY_START_TIMEOUT_S = 60.0

#: dtypes the file stores variables in when not the array's own (docs/format.md).
_FILE_DTYPES = {MEASURED: "u1", FILL_SOURCE: "i8", FILL_METHOD: "u1", FILL_SOURCES: "i8", FILL_WEIGHTS: "f8"}
#: dtype kinds the reader accepts for each data variable.
_FILE_KINDS = {
    REFLECTANCE: "f", MEASURED: "uib", FILL_SOURCE: "iu", REFLECTANCE_STD: "f",
    FILL_METHOD: "ui", FILL_SOURCES: "iu", FILL_WEIGHTS: "f", FILL_STD: "f",
}
#: Most source slots per filled sample a file may declare (one per curvature is the most cdbrdf writes).
MAX_FILL_SLOTS = 4096


def _jsonable(name: str, value: Any) -> str:
    try:
        return json.dumps(value, sort_keys=True, allow_nan=False)
    except (TypeError, ValueError) as exc:
        raise TableError(f"attrs[{name!r}]: cannot be stored in the file ({exc})") from None


def _digest(attrs_json: str, channels: list[str]) -> np.ndarray:
    """SHA-256 over ``cdbrdf_attrs`` and the channel names, as 32 uint8."""
    h = hashlib.sha256(b"cdbrdf-1.1\0")
    h.update(attrs_json.encode("utf-8"))
    for c in channels:
        h.update(b"\0" + c.encode("utf-8"))
    return np.frombuffer(h.digest(), dtype=np.uint8).copy()


def _data_digest(arrays: list[tuple[str, np.ndarray]]) -> np.ndarray:
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


def _stored_arrays(parts: TableParts) -> list[tuple[str, np.ndarray]]:
    """The axes and data variables of ``parts`` as the file stores them (dtypes of :data:`_FILE_DTYPES`)."""
    out = [(name, np.asarray(parts.axes[name], dtype=np.float64)) for name in SAMPLE_AXES]
    for name, data in parts.variables().items():
        out.append((name, np.asarray(data, dtype=_FILE_DTYPES.get(name))))
    return out


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

    Raises
    ------
    TableError
        When an attribute cannot be stored (not JSON-serialisable).
    """
    from ._version import __version__

    attrs = parts.attrs
    attrs_json = _jsonable("*", attrs)
    out: dict[str, Any] = {"format": FORMAT_NAME, "format_version": FORMAT_VERSION,
                           "software": f"cdbrdf {__version__}", "Conventions": CONVENTIONS}
    for key, value in attrs.items():
        if key not in out:
            out[key] = value if _native_mirror(value) else _jsonable(key, value)
    out[ATTRS_JSON_ATTR] = attrs_json
    out[DIGEST_ATTR] = _digest(attrs_json, parts.channels)
    return out


def attrs_from_globals(globals_: Any) -> dict[str, Any]:
    """The table attributes of global attributes made by :func:`global_attrs` (an xarray dataset's ``attrs``).

    ``cdbrdf_attrs`` is the source of truth when present; every global
    attribute that mirrors one of its entries must agree with it, as in a
    file. Without it the global attributes are taken as they are, but for
    the format's own.

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
        want = value if _native_mirror(value) else _jsonable(key, value)
        if not (stored == want and type(stored) is type(want)):
            raise TableError(f"attrs[{key!r}]: {stored!r:.60} disagrees with its entry in {ATTRS_JSON_ATTR!r} "
                             f"({want!r:.60}); change both, or drop {ATTRS_JSON_ATTR!r}")
    return attrs


def save(table: Any, path: str | PathLike[str], *, compression: str | None = "gzip") -> None:
    """Write ``table`` (a :class:`cdbrdf.CDBRDF`, or anything with its attributes) to ``path``.

    :meth:`cdbrdf.CDBRDF.save` is the usual way to call it; see :func:`write`
    for the parameters and errors.
    """
    write(TableParts.of(table), path, compression=compression)


def write(parts: TableParts, path: str | PathLike[str], *, compression: str | None = "gzip") -> None:
    """Write a table given as parts to ``path`` (HDF5 / NetCDF-4), atomically.

    Parameters
    ----------
    parts
        The table's arrays and attributes (:meth:`TableParts.of` a table),
        with every variable the file requires.
    path
        Destination; its folder must exist. An existing file is replaced only
        once the new one is complete.
    compression
        ``"gzip"`` (default, with the shuffle filter) or ``None``. Every
        variable but ``channel`` is chunked and carries the Fletcher-32
        checksum either way.

    Raises
    ------
    TableError
        When an attribute cannot be stored (not JSON-serialisable),
        ``attrs["channels"]`` does not name every channel, ``attrs["quantity"]``
        is not a valid quantity or a required variable is missing.
    OSError
        When the file cannot be written, one line naming it (a full disk
        included: the file is built in memory and written as plain bytes by
        :func:`cdbrdf.fsutil.atomic_path`, which keeps the old file).
    """
    import h5netcdf
    import h5py

    if compression not in ("gzip", None):
        raise OptionError(f"compression: {compression!r:.40} is not one of 'gzip', None")
    shape = tuple(np.shape(parts.values))
    check_channel_names(parts.attrs, shape[-1])
    gattrs = global_attrs(parts)
    quantity = parts.quantity
    variables = parts.variables()
    for name in REQUIRED_VARIABLES:
        if name not in variables:
            raise TableError(f"{name}: a CDBRDF file needs this variable")
    comp: dict[str, Any] = {"track_times": False, "fletcher32": True}
    if compression:
        comp.update(compression="gzip", compression_opts=4, shuffle=True)
    dims_sizes = dict(zip(AXES, shape, strict=True))
    for name in (FILL_SOURCES, FILL_WEIGHTS):
        if name in variables:
            n_slot = int(np.shape(variables[name])[-1])
            if dims_sizes.setdefault(FILL_SLOT, n_slot) != n_slot:
                raise TableError(
                    f"{name}: {n_slot} source slots, but the other fill variable has {dims_sizes[FILL_SLOT]}"
                )
    # built in memory, then written as plain bytes: a full disk or a file-size limit is then one OSError
    # of the write (atomic_path names the file), never an HDF5 error in the middle of its close
    image = _bytes_io.BytesIO()
    with h5netcdf.File(image, "w", libver=_LIBVER) as f:
        f.dimensions = dims_sizes
        for name in SAMPLE_AXES:
            axis = np.asarray(parts.axes[name])
            var = f.create_variable(
                name, (name,), "f8", data=axis, chunks=(axis.size,), fletcher32=True, track_times=False
            )
            _set_attrs(var, variable_attrs(name, quantity))
        ch = f.create_variable(
            CHANNEL,
            (CHANNEL,),
            h5py.string_dtype(),
            data=np.array(parts.channels, dtype=object),
            track_times=False,
        )
        _set_attrs(ch, variable_attrs(CHANNEL, quantity))
        if FILL_SLOT in dims_sizes:
            slots = np.arange(dims_sizes[FILL_SLOT], dtype=np.int32)
            var = f.create_variable(FILL_SLOT, (FILL_SLOT,), "i4", data=slots, chunks=(slots.size,),
                                    fletcher32=True, track_times=False)
            _set_attrs(var, variable_attrs(FILL_SLOT, quantity))
        for name, data in variables.items():
            dims = DATA_VARIABLES[name]
            data = np.asarray(data, dtype=_FILE_DTYPES.get(name))
            chunks = (1, 1, *data.shape[2:])  # one (kappa, phi_l) pair at a time
            var = f.create_variable(
                name, dims, _FILE_DTYPES.get(name, data.dtype), data=data, chunks=chunks, **comp
            )
            _set_attrs(var, variable_attrs(name, quantity))
        for key, value in gattrs.items():
            f.attrs[key] = value
        f.attrs[DATA_DIGEST_ATTR] = _data_digest(_stored_arrays(parts))
    with atomic_path(path) as tmp, open(tmp, "wb") as fh:
        fh.write(image.getbuffer())
    _LOG.debug("wrote %s (%s values)", path, "x".join(str(n) for n in shape))


def _native_mirror(value: Any) -> bool:
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


def _set_attrs(var: Any, attrs: dict[str, Any]) -> None:
    for key, value in attrs.items():
        var.attrs[key] = value


def _as_str(path: Path, what: str, v: Any) -> str:
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


def _attr(path: Path, attrs: Any, name: str) -> Any:
    try:
        return attrs[name]
    except UnicodeDecodeError:
        raise fail(path, f"global attribute {name!r} is not valid UTF-8 text") from None
    except (OSError, RuntimeError, KeyError, ValueError, TypeError) as exc:
        raise fail(path, f"global attribute {name!r} cannot be read ({one_line(exc)}): the file is damaged") from None


def _attr_str(path: Path, attrs: Any, name: str) -> str:
    if name not in attrs:
        raise fail(path, f"missing the global attribute {name!r}")
    return _as_str(path, f"global attribute {name!r}", _attr(path, attrs, name))


def _dims_of(ds: Any) -> tuple[str, ...]:
    names = []
    for dim in ds.dims:
        if len(dim) == 0:
            names.append("")
        else:
            names.append(dim[0].name.rsplit("/", 1)[-1])
    return tuple(names)


def _check_storage(path: Path, ds: Any, name: str) -> None:
    """Refuse a variable whose stored data do not cover it (nothing is read but the chunk index).

    HDF5 reads a chunk (or a contiguous block) that is not allocated as its
    fill value, silently: in a file without metadata checksums a damaged
    chunk index (a zeroed B-tree record) makes whole chunks read as zeros.
    Every chunk of a CDBRDF variable is written, so the index must list
    each chunk of the grid once, at an address inside the file, with a
    non-zero size, and with no mandatory filter (Fletcher-32, shuffle)
    marked as skipped.
    """
    if ds.size == 0:
        return
    dsid = ds.id
    if ds.chunks is None:
        if dsid.get_storage_size() < ds.size * ds.dtype.itemsize:
            raise fail(path, f"{name!r} has no (or too little) stored data: the file is damaged or incomplete")
        return
    counts = [-(-n // c) for n, c in zip(ds.shape, ds.chunks, strict=True)]
    expected = math.prod(counts)
    n = dsid.get_num_chunks()
    if n != expected:
        raise fail(path, f"{name!r}: {expected - n} of its {expected} chunks are missing: the file is damaged "
                         "or incomplete")
    plist = dsid.get_create_plist()
    mandatory = 0
    for i in range(plist.get_nfilters()):
        if not plist.get_filter(i)[1] & 1:  # H5Z_FLAG_OPTIONAL unset: HDF5 never skips it when writing
            mandatory |= 1 << i
    size = path.stat().st_size
    seen: set[tuple[int, ...]] = set()
    for i in range(n):
        ci = dsid.get_chunk_info(i)
        off = tuple(ci.chunk_offset)
        ok = (
            len(off) == len(ds.chunks) and off not in seen
            and all(o % c == 0 and 0 <= o < s for o, c, s in zip(off, ds.chunks, ds.shape, strict=False))
            and ci.byte_offset is not None and 0 < ci.byte_offset and 0 < ci.size
            and ci.byte_offset + ci.size <= size and not ci.filter_mask & mandatory
        )
        if not ok:
            raise fail(path, f"{name!r}: the index of its chunks is damaged (chunk {i})")
        seen.add(off)


def _read_ds(path: Path, ds: Any, name: str) -> np.ndarray:
    try:
        _check_storage(path, ds, name)
    except FormatError:
        raise
    except (OSError, RuntimeError, ValueError, TypeError, AttributeError, KeyError) as exc:
        raise fail(path, f"{name!r}: the index of its data cannot be read ({one_line(exc)}): the file is "
                         "damaged") from None
    try:
        return np.asarray(ds[()])
    except UnicodeDecodeError:
        raise fail(path, f"{name!r} holds text that is not valid UTF-8") from None
    except (OSError, RuntimeError, ValueError, TypeError) as exc:
        if "filter" in str(exc) and getattr(ds, "fletcher32", False):
            raise fail(path, f"checksum mismatch in {name!r}: the file is damaged") from None
        raise fail(path, f"{name!r} cannot be read ({one_line(exc)}): the file is damaged") from None


def _dataset(path: Path, f: Any, name: str, *, required: bool) -> Any:
    import h5py

    if name not in f:
        if required:
            raise fail(path, f"missing the variable {name!r}")
        return None
    obj = f[name]
    if not isinstance(obj, h5py.Dataset):
        raise fail(path, f"{name!r} is not a variable (HDF5 dataset)")
    return obj


def _expect(path: Path, ds: Any, name: str, shape: tuple[int, ...], dims: tuple[str, ...], kinds: str) -> None:
    """Check a variable's declared shape, dimension names and dtype kind (nothing is read)."""
    if ds.shape != shape:
        raise fail(path, f"{name!r} has shape {ds.shape}, but the axes give {shape}")
    got = _dims_of(ds)
    if got != dims:
        raise fail(path, f"{name!r} has dimensions {got}, expected {dims}")
    if ds.dtype.kind not in kinds or ds.dtype.itemsize > 8:
        raise fail(path, f"{name!r} has dtype {ds.dtype}, which the format does not allow")


def _check_cf(path: Path, ds: Any, name: str, quantity: str) -> None:
    """Refuse CF packing (``scale_factor``, ``add_offset``) and a ``units`` attribute naming another unit.

    A reader that ignored them would read other values than xarray (half of
    them with ``scale_factor = 2``, a negative reflectance with ``add_offset
    = 1``), or values in another unit than the axis is (``1/m``): neither is
    ever read as the table.
    """
    for attr in PACKING_ATTRS:
        if attr in ds.attrs:
            value = np.asarray(_attr(path, ds.attrs, attr)).reshape(-1)[:1].tolist()
            raise fail(path, f"{name!r} is packed ({attr} = {value[0] if value else '?'!r:.40}); the format "
                             "stores the values unpacked: unpack it (xarray's decoding) and save it again")
    if "units" not in ds.attrs or quantity not in QUANTITIES:
        return
    expected = variable_attrs(name, quantity).get("units")
    if expected is None:
        return
    given = _as_str(path, f"the units of {name!r}", _attr(path, ds.attrs, "units"))
    if not same_units(given, expected):
        raise fail(path, f"{name!r} is in {given!r:.40}, expected {expected!r}: values in another unit are not "
                         "read as the table")


def _check_missing(path: Path, ds: Any, name: str, a: np.ndarray) -> None:
    """Refuse values a CF missing-value attribute marks missing (xarray reads them as NaN): a table has none."""
    for attr in MISSING_VALUE_ATTRS:
        if attr not in ds.attrs:
            continue
        marks = np.asarray(_attr(path, ds.attrs, attr)).reshape(-1)
        if marks.dtype.kind not in "fiub":
            raise fail(path, f"{name!r} has a {attr} that is not a number")
        with np.errstate(invalid="ignore"):
            hit = int(np.count_nonzero(np.isin(a, marks)))
        if hit:
            raise fail(path, f"{name!r} holds {hit} value(s) equal to its {attr} ({marks[0]!r}): missing values, "
                             "which a table cannot have")


def _check_mirrors(path: Path, f: Any, attrs: dict[str, Any]) -> None:
    """The global attributes that mirror ``cdbrdf_attrs`` entries must agree with them."""
    for key, value in attrs.items():
        if key in WRITER_ATTRS or key not in f.attrs:
            continue
        stored = _attr(path, f.attrs, key)
        if isinstance(value, str):
            ok = _as_str(path, f"global attribute {key!r}", stored) == value
        elif _native_mirror(value):
            s = stored.reshape(()).item() if isinstance(stored, np.ndarray) and stored.size == 1 else stored
            if isinstance(s, np.generic):
                s = s.item()
            ok = isinstance(s, (bool, int, float)) and type(s) is type(value) and s == value
        else:
            ok = _as_str(path, f"global attribute {key!r}", stored) == _jsonable(key, value)
        if not ok:
            raise fail(path, f"global attribute {key!r} disagrees with its entry in 'cdbrdf_attrs'")


def _slot_shape(path: Path, ds: Any, name: str, grid_shape: tuple[int, ...]) -> tuple[int, ...]:
    """The shape a fill variable with source slots may have: the sample axes and 1 to MAX_FILL_SLOTS slots."""
    n_slot = ds.shape[-1] if ds.ndim == len(grid_shape) + 1 else 0
    if not 1 <= n_slot <= MAX_FILL_SLOTS:
        raise fail(path, f"{name!r} has shape {ds.shape}: expected the sample axes and 1 to "
                         f"{MAX_FILL_SLOTS} source slots")
    limits.check("table_samples", math.prod(grid_shape) * n_slot, what=f"{path}: {name!r}")
    return (*grid_shape, n_slot)


def _check_format(path: Path, f: Any) -> None:
    """The file says it is a CDBRDF file of a major version this reader reads."""
    fmt = _attr_str(path, f.attrs, "format") if "format" in f.attrs else None
    if fmt != FORMAT_NAME:
        raise fail(
            path, f"not a CDBRDF file (global attribute 'format' is {fmt!r}, expected {FORMAT_NAME!r})"
        )
    version = _attr_str(path, f.attrs, "format_version")
    m = re.fullmatch(r"(\d{1,6})\.(\d{1,6})", version)
    if m is None:
        raise fail(path, f"unreadable format_version {version!r} (expected MAJOR.MINOR)")
    major = int(m[1])
    own_major = int(FORMAT_VERSION.split(".")[0])
    if major > own_major:
        raise fail(
            path, f"format version {version} is newer than this cdbrdf reads ({own_major}.x); upgrade cdbrdf"
        )
    if major < 1:
        raise fail(path, f"unsupported format version {version}")


def _read_parts(path: Path, heaps: Heaps | None = None) -> TableParts:
    """Read and check everything of a CDBRDF file, as the parts of a table.

    ``heaps``: the checked global heaps, when reading in this process.
    """
    import h5py

    try:
        f = h5py.File(path, "r")
    except OSError as exc:
        raise fail(path, f"cannot be opened as HDF5 ({one_line(exc)})") from None
    with f:
        file_size = path.stat().st_size
        _check_format(path, f)
        gattrs = {name: _attr_str(path, f.attrs, name) for name in REQUIRED_ATTRS}

        # -- declared shapes, dims and dtypes of every variable, before reading any data
        axis_ds = {name: _dataset(path, f, name, required=True) for name in AXES}
        for name, ds in axis_ds.items():
            if ds.ndim != 1:
                raise fail(path, f"axis {name!r} is not 1-D (shape {ds.shape})")
            limits.check("table_samples", ds.size, what=f"{path}: axis {name!r}")
            if name != CHANNEL and (ds.dtype.kind != "f" or ds.dtype.itemsize not in (4, 8)):
                raise fail(path, f"axis {name!r} has dtype {ds.dtype}, expected float64")
        if h5py.check_string_dtype(axis_ds[CHANNEL].dtype) is None:
            raise fail(path, f"{CHANNEL!r} has dtype {axis_ds[CHANNEL].dtype}, expected strings")
        grid_shape = tuple(axis_ds[n].size for n in SAMPLE_AXES)
        shape = (*grid_shape, axis_ds[CHANNEL].size)
        limits.check("table_samples", math.prod(shape), what=f"{path}: {REFLECTANCE!r} of shape {shape}")
        shapes = {AXES: shape, SAMPLE_AXES: grid_shape}
        datasets = dict(axis_ds)
        for name, dims in DATA_VARIABLES.items():
            ds = _dataset(path, f, name, required=name in REQUIRED_VARIABLES)
            if ds is None:
                continue
            if dims not in shapes:  # the fill variables with their source slots (since 1.2)
                shapes[dims] = _slot_shape(path, ds, name, grid_shape)
            if name == REFLECTANCE and ds.ndim != len(AXES):
                raise fail(path, f"{name!r} has {ds.ndim} dimensions, expected {len(AXES)} {AXES}")
            _expect(path, ds, name, shapes[dims], dims, _FILE_KINDS[name])
            datasets[name] = ds
        for name, ds in datasets.items():
            check_storage(path, ds, name, file_size)
        quantity = gattrs["quantity"]
        for name in (*SAMPLE_AXES, *(n for n in DATA_VARIABLES if n in datasets)):
            _check_cf(path, datasets[name], name, quantity)

        # -- metadata
        raw = {name: _read_ds(path, axis_ds[name], name) for name in SAMPLE_AXES}
        axes = {name: raw[name].astype(np.float64) for name in SAMPLE_AXES}
        if heaps is not None:
            check_vlen_refs(path, axis_ds[CHANNEL], CHANNEL, heaps)
        channels = [_as_str(path, f"a {CHANNEL!r} name", c) for c in _read_ds(path, axis_ds[CHANNEL], CHANNEL)]
        text = gattrs[ATTRS_JSON_ATTR]
        limits.check("json_bytes", len(text.encode("utf-8")), what=f"{path}: attribute {ATTRS_JSON_ATTR!r}")
        if DIGEST_ATTR in f.attrs:
            stored = np.asarray(_attr(path, f.attrs, DIGEST_ATTR))
            if stored.dtype != np.uint8 or stored.shape != (32,):
                raise fail(path, f"global attribute {DIGEST_ATTR!r} is not 32 bytes")
            if not np.array_equal(stored, _digest(text, channels)):
                raise fail(path, f"checksum mismatch in {ATTRS_JSON_ATTR!r} or {CHANNEL!r}: the file is damaged")
        try:
            attrs = json.loads(text)
        except (ValueError, RecursionError) as exc:
            raise fail(path, f"attribute {ATTRS_JSON_ATTR!r} is not valid JSON ({one_line(exc)})") from None
        if not isinstance(attrs, dict):
            raise fail(path, f"attribute {ATTRS_JSON_ATTR!r} is not a JSON object")
        for key in MIRRORED_ATTRS:
            if attrs.get(key) != gattrs[key]:
                raise fail(path, f"global attribute {key!r} disagrees with its entry in {ATTRS_JSON_ATTR!r}")
        _check_mirrors(path, f, attrs)
        if CHANNELS_ATTR in attrs and attrs[CHANNELS_ATTR] != channels:
            raise fail(
                path,
                f"{ATTRS_JSON_ATTR!r} names the channels {attrs[CHANNELS_ATTR]!r} but the {CHANNEL!r} variable "
                f"holds {channels!r}",
            )
        attrs = with_channel_names(attrs, channels)

        # -- data: everything read, then the data digest (since 1.3), then the values' checks
        data = _read_data(path, f, datasets, raw)
    return TableParts(axes=axes, attrs=attrs, **data)


def _read_data(path: Path, f: Any, datasets: dict[str, Any], raw: dict[str, np.ndarray]) -> dict[str, Any]:
    """Read every data variable into ``raw`` (which holds the axes), check the data digest, then the values.

    Returns the keyword arguments of :class:`TableParts` but the axes and attributes.
    """
    for name in DATA_VARIABLES:
        if name in datasets:
            raw[name] = _read_ds(path, datasets[name], name)
    if DATA_DIGEST_ATTR in f.attrs:
        stored = np.asarray(_attr(path, f.attrs, DATA_DIGEST_ATTR))
        if stored.dtype != np.uint8 or stored.shape != (32,):
            raise fail(path, f"global attribute {DATA_DIGEST_ATTR!r} is not 32 bytes")
        if not np.array_equal(stored, _data_digest(list(raw.items()))):
            raise fail(path, "checksum mismatch in the data (the axes or a variable): the file is damaged")
    for name, a in raw.items():
        _check_missing(path, datasets[name], name, a)
    values = raw[REFLECTANCE]
    if not np.all(np.isfinite(values)):
        bad = int(np.count_nonzero(~np.isfinite(values)))
        raise fail(path, f"{REFLECTANCE!r} holds {bad} NaN or infinite value(s)")
    mvals = raw[MEASURED]
    if not np.isin(mvals, (0, 1)).all():
        raise fail(path, f"{MEASURED!r} holds values other than 0 and 1")
    fill = None
    if FILL_SOURCE in datasets:
        fill = raw[FILL_SOURCE]
        if fill.size and (fill.min() < -2 or fill.max() >= fill.size):
            raise fail(path, f"{FILL_SOURCE!r} holds indices outside [-2, {fill.size})")
        fill = fill.astype(np.int64)
    std = None
    if REFLECTANCE_STD in datasets:
        std = raw[REFLECTANCE_STD]
    fill_parts = _read_fill_parts(path, raw)
    return dict(values=values, measured=mvals.astype(bool), fill_source=fill, std=std, **fill_parts)


def _read_fill_parts(path: Path, raw: dict[str, np.ndarray]) -> dict[str, np.ndarray | None]:
    """The per-sample fill provenance of a 1.2 file (None for each variable a file lacks), from the arrays read."""
    out: dict[str, np.ndarray | None] = {}
    for name, key in ((FILL_METHOD, "fill_method"), (FILL_SOURCES, "fill_sources"),
                      (FILL_WEIGHTS, "fill_weights"), (FILL_STD, "fill_std")):
        a = None
        if name in raw:
            a = raw[name]
            if a.dtype.kind == "f" and not np.all(np.isfinite(a)):
                raise fail(path, f"{name!r} holds NaN or infinite value(s)")
            if name == FILL_SOURCES:
                if a.size and (a.min() < -1 or a.max() >= a[..., 0].size):
                    raise fail(path, f"{FILL_SOURCES!r} holds indices outside [-1, {a[..., 0].size})")
                a = a.astype(np.int64)
        out[key] = a
    return out


def _read_guarded(path: Path, heaps: Heaps | None = None) -> TableParts:
    """:func:`_read_parts`, with every unexpected exception turned into FormatError."""
    try:
        return _read_parts(path, heaps)
    except (FormatError, LimitError, UnsureError):
        raise
    except MemoryError:
        raise fail(path, "not enough memory to read it") from None
    except (OSError, RuntimeError, KeyError, ValueError, TypeError, AttributeError, IndexError, RecursionError,
            OverflowError, UnicodeError) as exc:
        if "checksum" in str(exc):
            raise fail(path, "metadata checksum mismatch: the file is damaged") from None
        raise fail(path, f"damaged or not a valid CDBRDF file ({one_line(exc)})") from None


#: The child's program. It runs as ``python -I -S -c`` (no environment variables of Python, no user or
#: site folder, no script folder or current folder on ``sys.path``), in a fresh private folder as its
#: current folder, with a clean environment: only the standard library is importable until it puts
#: the parent's own package folders on ``sys.path`` (argv[2]), so no file beside the table (a
#: ``pickle.py`` in a downloaded dataset) can ever be imported. It dies with the parent: the kernel
#: kills it when the parent dies (Linux, PR_SET_PDEATHSIG), a thread ends it when its stdin pipe closes
#: (the parent gone, elsewhere) and a CPU-time limit ends it in any case. It answers on stdout:
#: ``ready``, then ``ok`` and the parts as an .npz (no pickle), or ``error`` and one JSON line.
_CHILD = r"""
import sys


def _die_with_parent(parent, cpu_s):
    import os, resource, signal, threading
    try:
        import ctypes
        ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
    except (OSError, AttributeError, ImportError):
        pass
    if os.getppid() != parent:  # the parent died before that
        os._exit(3)
    try:
        resource.setrlimit(resource.RLIMIT_CPU, (cpu_s, cpu_s + 1))
    except (ValueError, OSError):
        pass

    def watch():
        try:
            while os.read(0, 4096):
                pass
        finally:
            os._exit(4)

    threading.Thread(target=watch, daemon=True).start()


def main():
    import json
    parent, cpu_s, path_json, file = int(sys.argv[1]), int(sys.argv[2]), sys.argv[3], sys.argv[4]
    _die_with_parent(parent, cpu_s)
    sys.path[:0] = json.loads(path_json)
    import io
    from pathlib import Path

    import h5py
    import numpy as np
    try:
        h5py.h5pl.set_loading_state(0)  # no filter plug-in is loaded from anywhere
    except (AttributeError, RuntimeError):
        pass
    from cdbrdf import io as cio
    from cdbrdf.errors import FormatError, LimitError

    out = sys.stdout.buffer
    out.write(b"ready\n")
    out.flush()
    try:
        parts = cio._read_guarded(Path(file))
    except (FormatError, LimitError) as exc:
        out.write(b"error\n" + json.dumps([type(exc).__name__, str(exc)]).encode() + b"\n")
        out.flush()
        return
    arrays = {"values": parts.values, "attrs": np.array(json.dumps(parts.attrs))}
    for name, a in parts.axes.items():
        arrays["axis_" + name] = a
    for name in ("measured", "fill_source", "std", "fill_method", "fill_sources", "fill_weights", "fill_std"):
        a = getattr(parts, name)
        if a is not None:
            arrays[name] = a
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    out.write(b"ok\n" + buf.getvalue())
    out.flush()


main()
sys.stdout.flush()
import os
os._exit(0)  # not a normal shutdown: the watching thread may be in a read
"""


def _child_path() -> list[str]:
    """The folders the child imports from: this package's, then the parent's absolute ``sys.path``.

    The parent's current folder (and relative entries, which name it) are
    left out: only installed code is imported.
    """
    import os

    cwd = os.path.realpath(os.getcwd())
    out = [str(Path(__file__).resolve().parent.parent)]
    for entry in sys.path:
        if entry and os.path.isabs(entry) and os.path.realpath(entry) != cwd and entry not in out:
            out.append(entry)
    return out


def _child_env() -> dict[str, str]:
    """A clean environment for the child: the limits, HDF5's file locking and what starts Python, nothing else."""
    import os

    keep = {"PATH", "LD_LIBRARY_PATH", "DYLD_LIBRARY_PATH", "SYSTEMROOT", "HDF5_USE_FILE_LOCKING"}
    return {k: v for k, v in os.environ.items() if k in keep or k.startswith("CDBRDF_MAX_")}


def _parts_from_npz(path: Path, data: bytes) -> TableParts:
    """The child's answer (an .npz, loaded without pickle) as parts."""
    try:
        with np.load(_bytes_io.BytesIO(data), allow_pickle=False) as z:
            arrays = {k: z[k] for k in z.files}
        attrs = json.loads(str(arrays.pop("attrs")))
        axes = {name: arrays.pop("axis_" + name) for name in SAMPLE_AXES}
    except (ValueError, KeyError, OSError, EOFError) as exc:  # pragma: no cover - the child writes it
        raise fail(path, f"the reader's answer cannot be read ({one_line(exc)})") from None
    return TableParts(values=arrays.pop("values"), axes=axes, attrs=attrs,
                      **{k: arrays.get(k) for k in ("measured", "fill_source", "std", "fill_method",
                                                    "fill_sources", "fill_weights", "fill_std")})


def _read_in_child(path: Path) -> TableParts:
    """:func:`_read_guarded` in an isolated child process stopped after a time limit.

    For files without metadata checksums, where a damaged structure can make
    the HDF5 library loop forever with the interpreter lock held. See
    :data:`_CHILD` for the isolation; the limit (:data:`LEGACY_READ_TIMEOUT_S`
    plus one second per 10 MB) counts from the moment the child has imported
    its libraries. Ctrl-C in the parent stops the child too.
    """
    import os
    import selectors
    import shutil
    import signal
    import tempfile
    import time

    timeout = LEGACY_READ_TIMEOUT_S + path.stat().st_size / 10e6
    start_s = LEGACY_START_TIMEOUT_S
    folder = tempfile.mkdtemp(prefix="cdbrdf-read-")
    cpu_s = int(start_s + timeout) + 5
    cmd = [sys.executable, "-I", "-S", "-c", _CHILD, str(os.getpid()), str(cpu_s), json.dumps(_child_path()),
           str(path.absolute())]
    chunks: dict[str, list[bytes]] = {"out": [], "err": []}
    proc = None
    try:
        proc = subprocess.Popen(cmd, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                cwd=folder, env=_child_env(), start_new_session=False)
        assert proc.stdout is not None and proc.stderr is not None
        sel = selectors.DefaultSelector()
        sel.register(proc.stdout, selectors.EVENT_READ, "out")
        sel.register(proc.stderr, selectors.EVENT_READ, "err")
        deadline = time.monotonic() + start_s
        ready = False
        open_streams = 2
        while open_streams:
            left = deadline - time.monotonic()
            if left <= 0:
                if not ready:
                    raise fail(path, f"the reader did not start within {start_s:.0f} s")
                raise fail(path, f"reading it took longer than {timeout:.0f} s and was stopped: its HDF5 "
                                 "structure is damaged")
            for key, _ in sel.select(min(left, 0.5)):
                data = os.read(key.fd, 1 << 20)
                if not data:
                    sel.unregister(key.fileobj)
                    open_streams -= 1
                    continue
                chunks[key.data].append(data)
                if not ready and b"\n" in b"".join(chunks["out"]):
                    ready = True
                    deadline = time.monotonic() + timeout
        sel.close()
        proc.wait(timeout=5)
    finally:
        if proc is not None:
            if proc.poll() is None:
                proc.kill()
                proc.wait()
            for stream in (proc.stdin, proc.stdout, proc.stderr):
                if stream is not None:
                    stream.close()
        shutil.rmtree(folder, ignore_errors=True)
    out = b"".join(chunks["out"])
    head, _, rest = out.partition(b"\n")
    kind, _, payload = rest.partition(b"\n")
    if head != b"ready" or kind not in (b"ok", b"error") or proc.returncode != 0:
        err = b"".join(chunks["err"]).decode("utf-8", "replace").strip().splitlines()[-1:]
        code = proc.returncode
        why = err[0][:200] if err else (f"killed by signal {-code}" if code < 0 and -code in signal.valid_signals()
                                         else f"exit status {code}")
        raise fail(path, f"the reader stopped on it ({why}): the file is damaged")
    if kind == b"error":
        name, message = json.loads(payload.decode("utf-8"))
        raise (LimitError if name == "LimitError" else FormatError)(message)
    return _parts_from_npz(path, payload)


def read(path: str | PathLike[str]) -> TableParts:
    """Read and check a CDBRDF file written by :func:`write` (any 1.x version), as parts.

    :func:`cdbrdf.load` (which builds the table from the parts) is the usual
    way to call it.

    Files with HDF5 metadata checksums (superblock v2/v3, as written by format
    1.1) whose global heaps (unchecksummed) parse are read in this process.
    Others (format 1.0, other writers, damaged heaps) are read in a child
    process that is stopped after :data:`LEGACY_READ_TIMEOUT_S` seconds (plus
    one per 20 MB), because damaged unchecksummed metadata can
    make the HDF5 library loop forever; re-saving such a file makes it fast.

    Parameters
    ----------
    path
        The file.

    Returns
    -------
    TableParts
        The arrays and attributes of the table that was saved; the sample
        axes and the relations between mask and fill sources are checked
        when the table is built from them (:class:`cdbrdf.CDBRDF`).

    Raises
    ------
    FileNotFoundError
        When ``path`` does not exist.
    FormatError
        For any problem with an existing file: not HDF5, not a CDBRDF file, a
        newer major version, missing variables or attributes, inconsistent
        shapes, attributes or dtypes, non-finite values,
        checksum mismatches, damaged HDF5 structures, unreadable permissions.
        The message starts with the file's path. (:func:`cdbrdf.load` adds
        non-monotonic or out-of-range axes and inconsistent fill sources.)
    LimitError
        When the file declares more samples than the ``table_samples`` limit.
    """
    if not isinstance(path, (str, PathLike)):
        raise OptionError(f"path: expected a file name (str or os.PathLike), got {type(path).__name__}")
    p = Path(path)
    if not p.exists():
        raise FileNotFoundError(f"{p}: no such file")
    if p.is_dir():
        raise fail(p, "is a folder, not a CDBRDF file")
    try:
        check_regular(p)  # a FIFO would block the read, a device never end it
    except OSError as exc:
        raise fail(p, f"{str(exc).removeprefix(f'{p}: ')}; not a CDBRDF file") from None
    try:
        version = superblock_version(p)
    except OSError as exc:
        raise fail(p, f"cannot be read ({exc.strerror or one_line(exc)})") from None
    if version is None:
        raise fail(p, "not an HDF5 file (a CDBRDF file is HDF5 / NetCDF-4); a BRDF file of another format (RGL "
                      ".bsdf, MERL .binary, UTIA .bin) is converted with `cdbrdf import FILE -o OUT.h5`")
    heaps = Heaps("unsure")
    if version >= 2:
        try:
            heaps = check_global_heaps(p)
        except OSError as exc:
            raise fail(p, f"cannot be read ({exc.strerror or one_line(exc)})") from None
        if heaps.status not in ("ok", "unsure"):
            raise fail(p, f"{heaps.status}: the file is truncated or damaged")
    parts = None
    if heaps.status == "ok":
        try:
            parts = _read_guarded(p, heaps)
        except UnsureError:
            pass
    if parts is None:
        parts = _read_in_child(p)
    return parts
