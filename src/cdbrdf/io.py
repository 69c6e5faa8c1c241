"""The CDBRDF file: HDF5 laid out as NetCDF-4 (see ``docs/format.md``).

``xarray.open_dataset(path, engine="h5netcdf")`` opens a file with named
dimensions ``(kappa, phi_l, theta_l, phi_v, theta_v, channel)``. Files are
written with :mod:`h5netcdf` (so the dimension scales are exactly what NetCDF
readers expect) to a temporary file in the destination folder that is renamed
over the destination only once complete. They are read with :mod:`h5py` and
checked thoroughly; any problem raises :class:`~cdbrdf.errors.FormatError`
naming the file.
"""

from __future__ import annotations

import json
import logging
from os import PathLike
from pathlib import Path
from typing import Any

import numpy as np

from .errors import FormatError, TableError
from .fsutil import atomic_path
from .table import AXES, CDBRDF

__all__ = ["FORMAT_NAME", "FORMAT_VERSION", "save", "load", "atomic_path"]

_LOG = logging.getLogger(__name__)

#: Value of the global attribute ``format``.
FORMAT_NAME = "cdbrdf"
#: ``MAJOR.MINOR``: readers accept any minor version of their major version.
FORMAT_VERSION = "1.0"

_SAMPLE_DIMS = AXES[:-1]
_UNITS = {
    "kappa": "1/mm",
    "phi_l": "degree",
    "theta_l": "degree",
    "phi_v": "degree",
    "theta_v": "degree",
}
_LONG_NAMES = {
    "kappa": "surface curvature (> 0 convex, < 0 concave)",
    "phi_l": "light azimuth from the reference tangent x towards y",
    "theta_l": "light elevation from the surface normal",
    "phi_v": "view azimuth from the reference tangent x towards y",
    "theta_v": "view elevation from the surface normal",
    "channel": "colour channel",
}


def _jsonable(name: str, value: Any) -> str:
    try:
        return json.dumps(value, sort_keys=True, allow_nan=False)
    except (TypeError, ValueError) as exc:
        raise TableError(f"attrs[{name!r}]: cannot be stored in the file ({exc})") from None


def save(table: CDBRDF, path: str | PathLike[str], *, compression: str | None = "gzip") -> None:
    """Write ``table`` to ``path`` (HDF5 / NetCDF-4), atomically.

    Parameters
    ----------
    table
        The table to write.
    path
        Destination; its folder must exist. An existing file is replaced only
        once the new one is complete.
    compression
        ``"gzip"`` (default, with the shuffle filter) or ``None``.

    Raises
    ------
    TableError
        When an attribute cannot be stored (not JSON-serialisable).
    """
    import h5py
    import h5netcdf

    from . import __version__

    if compression not in ("gzip", None):
        raise ValueError(f"compression: {compression!r} is not one of 'gzip', None")
    attrs_json = _jsonable("*", table.attrs)
    for k, v in table.attrs.items():
        _jsonable(k, v)
    comp: dict[str, Any] = {"track_times": False}
    if compression:
        comp.update(compression="gzip", compression_opts=4, shuffle=True)
    k, pl, tl, pv, tv, c = table.shape
    with atomic_path(path) as tmp:
        with h5netcdf.File(tmp, "w") as f:
            f.dimensions = dict(zip(AXES, table.shape))
            for name, axis in table.grid.axes().items():
                var = f.create_variable(name, (name,), "f8", data=axis, track_times=False)
                var.attrs["units"] = _UNITS[name]
                var.attrs["long_name"] = _LONG_NAMES[name]
            ch = f.create_variable(
                "channel",
                ("channel",),
                h5py.string_dtype(),
                data=np.array(table.channels, dtype=object),
                track_times=False,
            )
            ch.attrs["long_name"] = _LONG_NAMES["channel"]
            chunks = (1, 1, tl, pv, tv, c)
            var = f.create_variable(
                "reflectance", AXES, table.values.dtype, data=table.values, chunks=chunks, **comp
            )
            var.attrs["units"] = "1/sr" if table.quantity == "brdf" else "1"
            var.attrs["long_name"] = (
                "BRDF, cosine of the light direction not included"
                if table.quantity == "brdf"
                else "relative reflectance (BRDF up to an unknown scale)"
            )
            m = f.create_variable(
                "measured",
                _SAMPLE_DIMS,
                "u1",
                data=table.measured.astype(np.uint8),
                chunks=chunks[:-1],
                **comp,
            )
            m.attrs["flag_values"] = np.array([0, 1], dtype=np.uint8)
            m.attrs["flag_meanings"] = "filled measured"
            s = f.create_variable(
                "fill_source", _SAMPLE_DIMS, "i8", data=table.fill_source, chunks=chunks[:-1], **comp
            )
            s.attrs["long_name"] = (
                "C-order flat index over (kappa, phi_l, theta_l, phi_v, theta_v) of the "
                "sample a filled value was copied from; -1 measured, -2 source unknown"
            )
            if table.std is not None:
                d = f.create_variable(
                    "reflectance_std", AXES, table.std.dtype, data=table.std, chunks=chunks, **comp
                )
                d.attrs["units"] = var.attrs["units"]
                d.attrs["long_name"] = "per-sample standard deviation of the reflectance"
            f.attrs["format"] = FORMAT_NAME
            f.attrs["format_version"] = FORMAT_VERSION
            f.attrs["software"] = f"cdbrdf {__version__}"
            f.attrs["Conventions"] = "CF-1.10"
            for key, value in table.attrs.items():
                if isinstance(value, (str, bool, int, float)) and key not in f.attrs:
                    f.attrs[key] = value
                elif key not in f.attrs:
                    f.attrs[key] = _jsonable(key, value)
            f.attrs["cdbrdf_attrs"] = attrs_json
    _LOG.debug("wrote %s (%s)", path, table)


def _fail(path: Path, msg: str) -> FormatError:
    return FormatError(f"{path}: {msg}")


def _attr_str(path: Path, attrs: Any, name: str) -> str:
    if name not in attrs:
        raise _fail(path, f"missing the global attribute {name!r}")
    v = attrs[name]
    if isinstance(v, bytes):
        v = v.decode("utf-8", "replace")
    if isinstance(v, np.ndarray) and v.size == 1:
        v = v.reshape(()).item()
        if isinstance(v, bytes):
            v = v.decode("utf-8", "replace")
    if not isinstance(v, str):
        raise _fail(path, f"global attribute {name!r} is not a string")
    return v


def _dims_of(ds: Any) -> tuple[str, ...]:
    names = []
    for dim in ds.dims:
        if len(dim) == 0:
            names.append("")
        else:
            names.append(dim[0].name.rsplit("/", 1)[-1])
    return tuple(names)


def load(path: str | PathLike[str]) -> CDBRDF:
    """Read a CDBRDF file written by :func:`save` (any 1.x version).

    Raises
    ------
    FileNotFoundError
        When ``path`` does not exist.
    FormatError
        When the file is not HDF5, not a CDBRDF file, of a newer major version,
        or has missing variables, inconsistent shapes, non-monotonic axes or
        non-finite values. The message names the file and the problem.
    """
    import h5py

    p = Path(path)
    if not p.exists():
        raise FileNotFoundError(f"{p}: no such file")
    if p.is_dir():
        raise _fail(p, "is a folder, not a CDBRDF file")
    if not h5py.is_hdf5(p):
        raise _fail(p, "not an HDF5 file (a CDBRDF file is HDF5 / NetCDF-4)")
    try:
        f = h5py.File(p, "r")
    except OSError as exc:
        raise _fail(p, f"cannot be opened as HDF5 ({exc})") from None
    with f:
        fmt = _attr_str(p, f.attrs, "format") if "format" in f.attrs else None
        if fmt != FORMAT_NAME:
            raise _fail(
                p,
                "not a CDBRDF file (global attribute 'format' is "
                f"{fmt!r}, expected {FORMAT_NAME!r})",
            )
        version = _attr_str(p, f.attrs, "format_version")
        try:
            major, minor = (int(x) for x in version.split(".")[:2])
        except ValueError:
            raise _fail(p, f"unreadable format_version {version!r}") from None
        own_major = int(FORMAT_VERSION.split(".")[0])
        if major > own_major:
            raise _fail(
                p,
                f"format version {version} is newer than this cdbrdf reads "
                f"({own_major}.x); upgrade cdbrdf",
            )
        if major < 1:
            raise _fail(p, f"unsupported format version {version}")
        for name in (*AXES, "reflectance", "measured"):
            if name not in f or not isinstance(f[name], h5py.Dataset):
                raise _fail(p, f"missing the variable {name!r}")
        axes = {}
        for name in _SAMPLE_DIMS:
            a = f[name][()]
            if a.ndim != 1:
                raise _fail(p, f"axis {name!r} is not 1-D (shape {a.shape})")
            axes[name] = a
        grid_shape = tuple(axes[n].size for n in _SAMPLE_DIMS)
        refl = f["reflectance"]
        if refl.ndim != 6:
            raise _fail(p, f"'reflectance' has {refl.ndim} dimensions, expected 6 {AXES}")
        dims = _dims_of(refl)
        if dims != AXES:
            raise _fail(p, f"'reflectance' has dimensions {dims}, expected {AXES}")
        if refl.shape[:5] != grid_shape:
            raise _fail(
                p, f"'reflectance' has shape {refl.shape} but the axes give {grid_shape} + (channel,)"
            )
        if f["channel"].shape != (refl.shape[5],):
            raise _fail(p, f"'channel' has {f['channel'].shape} entries, 'reflectance' {refl.shape[5]}")
        if refl.dtype not in (np.float32, np.float64):
            raise _fail(p, f"'reflectance' has dtype {refl.dtype}, expected float32 or float64")
        values = refl[()]
        if not np.all(np.isfinite(values)):
            bad = int(np.count_nonzero(~np.isfinite(values)))
            raise _fail(p, f"'reflectance' holds {bad} NaN or infinite value(s)")
        measured = f["measured"]
        if measured.shape != grid_shape:
            raise _fail(p, f"'measured' has shape {measured.shape}, expected {grid_shape}")
        mvals = measured[()]
        if not np.isin(mvals, (0, 1)).all():
            raise _fail(p, "'measured' holds values other than 0 and 1")
        fill = None
        if "fill_source" in f:
            if f["fill_source"].shape != grid_shape:
                raise _fail(p, f"'fill_source' has shape {f['fill_source'].shape}, expected {grid_shape}")
            fill = f["fill_source"][()]
        std = None
        if "reflectance_std" in f:
            if f["reflectance_std"].shape != refl.shape:
                raise _fail(p, f"'reflectance_std' has shape {f['reflectance_std'].shape}, expected {refl.shape}")
            std = f["reflectance_std"][()]
        if "cdbrdf_attrs" in f.attrs:
            try:
                attrs = json.loads(_attr_str(p, f.attrs, "cdbrdf_attrs"))
            except json.JSONDecodeError as exc:
                raise _fail(p, f"attribute 'cdbrdf_attrs' is not valid JSON ({exc})") from None
            if not isinstance(attrs, dict):
                raise _fail(p, "attribute 'cdbrdf_attrs' is not a JSON object")
        else:
            attrs = {}
            for key in ("quantity", "colour_space", "material"):
                if key in f.attrs:
                    attrs[key] = _attr_str(p, f.attrs, key)
        channels = [c.decode() if isinstance(c, bytes) else str(c) for c in f["channel"][()]]
    n = len(channels)
    default = ["R", "G", "B"] if n == 3 else [f"c{i}" for i in range(n)]
    if channels != default:
        attrs.setdefault("channels", channels)
    try:
        return CDBRDF(
            values,
            **axes,
            measured=mvals.astype(bool),
            fill_source=fill,
            std=std,
            attrs=attrs,
        )
    except TableError as exc:
        raise _fail(p, str(exc)) from None
