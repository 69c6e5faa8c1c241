"""The CD-BTF file: a CDBRDF file (format 1.4) holding the tile mean, plus the factorised texels.

The file is a CDBRDF file whose ``reflectance`` is the tile mean, so every
CDBRDF reader (:func:`cdbrdf.load`, xarray) reads it as the CDBRDF of the
fabric; the CD-BTF adds (``docs/format.md``, "The CD-BTF variables"):

- dimensions ``texel_v``, ``texel_u`` and ``component``, with coordinate
  variables (texel centres in mm; component numbers);
- ``btf_weights (texel_v, texel_u, component)`` and ``btf_basis (kappa, phi_l,
  theta_l, phi_v, theta_v, component, channel)``, float32;
- global attributes ``btf_repeat_mm`` (u, v), ``btf_method``, ``btf_rank``,
  ``btf_max_error``, ``btf_relative_rms_error``,
  ``btf_relative_rms_error_per_kappa``, ``btf_compression_ratio``, optionally
  ``btf_truncated_from`` (:meth:`CDBTF.truncated`) and ``btf_sha256`` (the digest of the CD-BTF's variables as stored).

A *neural* CD-BTF (schema 2 of these variables, ``btf_format_version = 2``;
``docs/btf.md``) adds a dimension ``latent_texel`` (the texels of every
pyramid level, level after level, row-major) and ``latent``,
``btf_latents (latent_texel, latent)`` float16, ``decoder_parameter`` and
``btf_decoder (decoder_parameter)`` float32 (each layer's weights, row-major
``(n_in, n_out)``, then its biases), and the attributes
``btf_format_version`` (2), ``btf_latent_levels`` (``n_v, n_u`` of each
level), ``btf_decoder_layers`` (the widths), ``btf_decoder_constants``
(kappa scale, luminance epsilon and offset of the decoder's inputs),
``btf_neural_relative_rms_error`` and ``btf_fit_seconds``; its component count
is ``btf_residual_rank`` (not ``btf_rank``, so that a reader of schema 1
refuses the file instead of reading the residual components as the texels).
Files without ``btf_format_version`` are schema 1 (PCA) and still load.

Everything is written in the one atomic write of the CDBRDF file.
"""

from __future__ import annotations

import math
from os import PathLike
from pathlib import Path
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np

from .._fileattrs import data_digest, get_attr, get_attr_str
from .._hdf5 import check_storage, fail, one_line
from ..limits import check as check_limit
from ..schema import SAMPLE_AXES
from ..table import MAX_ABS_VALUE

if TYPE_CHECKING:
    from ..table import CDBRDF
    from ._neural import Neural

__all__ = ["BTFParts", "write", "read", "is_btf", "TEXEL_U", "TEXEL_V", "COMPONENT", "WEIGHTS", "BASIS",
           "LATENTS", "DECODER", "SCHEMA_VERSION"]

TEXEL_U, TEXEL_V, COMPONENT = "texel_u", "texel_v", "component"
WEIGHTS, BASIS = "btf_weights", "btf_basis"
LATENT_TEXEL, LATENT, DECODER_PARAMETER = "latent_texel", "latent", "decoder_parameter"
LATENTS, DECODER = "btf_latents", "btf_decoder"
_DIGEST = "btf_sha256"
_DIMS = {WEIGHTS: (TEXEL_V, TEXEL_U, COMPONENT), BASIS: (*SAMPLE_AXES, COMPONENT, "channel"),
         LATENTS: (LATENT_TEXEL, LATENT), DECODER: (DECODER_PARAMETER,)}

#: The newest schema of the CD-BTF variables this version reads and writes (1: PCA; 2: neural).
SCHEMA_VERSION = 2


class BTFParts(NamedTuple):
    """A CD-BTF as the file holds it: what :func:`read` returns and :func:`write` takes."""

    mean: CDBRDF
    weights: np.ndarray  # (n_v, n_u, rank) float32
    basis: np.ndarray  # grid shape + (rank, channel) float32
    repeat_mm: tuple[float, float]
    compression: dict[str, Any]
    neural: Neural | None = None

    @property
    def texels(self) -> tuple[int, int]:
        return int(self.weights.shape[1]), int(self.weights.shape[0])

    @property
    def rank(self) -> int:
        return int(self.weights.shape[2])

    def texel_centres_mm(self) -> tuple[np.ndarray, np.ndarray]:
        nu, nv = self.texels
        return ((np.arange(nu) + 0.5) * self.repeat_mm[0] / nu, (np.arange(nv) + 0.5) * self.repeat_mm[1] / nv)


def _flat_latents(net: Neural) -> np.ndarray:
    return np.concatenate([z.reshape(-1, z.shape[-1]) for z in net.latents]).astype("<f2")


def _flat_decoder(net: Neural) -> np.ndarray:
    parts = [a.reshape(-1) for w, b in zip(net.weights, net.biases) for a in (w, b)]
    return np.concatenate(parts).astype("<f4")


def _stored(btf: BTFParts) -> list[tuple[str, np.ndarray]]:
    cu, cv = btf.texel_centres_mm()
    out = [(TEXEL_U, cu), (TEXEL_V, cv), (WEIGHTS, np.asarray(btf.weights, "<f4")),
           (BASIS, np.asarray(btf.basis, "<f4"))]
    if btf.neural is not None:
        out += [(LATENTS, _flat_latents(btf.neural)), (DECODER, _flat_decoder(btf.neural))]
    return out


def _write_neural(f: Any, net: Neural, storage: dict[str, Any]) -> None:
    lat, dec = _flat_latents(net), _flat_decoder(net)
    f.dimensions[LATENT_TEXEL], f.dimensions[LATENT] = lat.shape
    f.dimensions[DECODER_PARAMETER] = dec.size
    var = f.create_variable(LATENTS, _DIMS[LATENTS], "f2", data=lat, chunks=lat.shape, **storage)
    var.attrs["long_name"] = "latent code of each texel of each pyramid level"
    var = f.create_variable(DECODER, _DIMS[DECODER], "f4", data=dec, chunks=dec.shape, **storage)
    var.attrs["long_name"] = "the decoder's weights and biases, layer after layer"
    f.attrs["btf_format_version"] = np.int64(SCHEMA_VERSION)
    f.attrs["btf_latent_levels"] = np.array([n for z in net.latents for n in z.shape[:2]], dtype=np.int64)
    f.attrs["btf_decoder_layers"] = np.array(net.layers, dtype=np.int64)
    f.attrs["btf_decoder_constants"] = np.array(net.constants, dtype=np.float64)


def write(btf: BTFParts, path: str | PathLike[str], *, compression: str | None = "gzip") -> None:
    """Write ``btf`` to ``path`` atomically: the tile mean as a CDBRDF file plus the CD-BTF variables.

    Raises
    ------
    TableError, OSError
        As :func:`cdbrdf.io.write`.
    """
    from ..io import write as write_table
    from ..schema import TableParts

    comp = btf.compression
    nu, nv = btf.texels

    def extra(f: Any, storage: dict[str, Any]) -> None:
        for dim, size in ((TEXEL_U, nu), (TEXEL_V, nv), (COMPONENT, btf.rank)):
            f.dimensions[dim] = size
        cu, cv = btf.texel_centres_mm()
        for name, axis in ((TEXEL_U, cu), (TEXEL_V, cv)):
            var = f.create_variable(name, (name,), "f8", data=axis, chunks=(axis.size,), fletcher32=True,
                                    track_times=False)
            var.attrs.update({"units": "mm", "long_name": f"texel centre along {name[-1]} in the flat repeat"})
        var = f.create_variable(COMPONENT, (COMPONENT,), "i4", data=np.arange(btf.rank, dtype=np.int32),
                                track_times=False)
        var.attrs["long_name"] = "component of the factorised texel deviations"
        if btf.rank:
            w = f.create_variable(WEIGHTS, _DIMS[WEIGHTS], "f4", data=btf.weights, chunks=btf.weights.shape,
                                  **storage)
            w.attrs["long_name"] = "weight of each component per texel"
            chunks = (1, 1, *btf.basis.shape[2:])
            b = f.create_variable(BASIS, _DIMS[BASIS], "f4", data=btf.basis, chunks=chunks, **storage)
            b.attrs["long_name"] = "components of the texels' deviation from the tile mean"
        f.attrs["btf_repeat_mm"] = np.array(btf.repeat_mm, dtype=np.float64)
        f.attrs["btf_method"] = "pca" if btf.neural is None else "neural"
        if btf.neural is None:
            f.attrs["btf_rank"] = np.int64(btf.rank)
        else:
            f.attrs["btf_residual_rank"] = np.int64(btf.rank)
            _write_neural(f, btf.neural, storage)
        for key in ("max_error", "relative_rms_error", "compression_ratio", "neural_relative_rms_error",
                    "fit_seconds"):
            if key in comp:
                f.attrs[f"btf_{key}"] = float(comp[key])
        if "relative_rms_error_per_kappa" in comp:
            f.attrs["btf_relative_rms_error_per_kappa"] = np.array(comp["relative_rms_error_per_kappa"], float)
        if "truncated_from" in comp:
            f.attrs["btf_truncated_from"] = np.int64(comp["truncated_from"])
        f.attrs[_DIGEST] = data_digest(_stored(btf))

    write_table(TableParts.of(btf.mean), path, compression=compression, extra=extra)


def is_btf(path: str | PathLike[str]) -> bool:
    """Whether ``path`` is a CD-BTF file (a CDBRDF file with the CD-BTF attributes); False for other files."""
    import h5py

    try:
        with h5py.File(path, "r") as f:
            return "btf_repeat_mm" in f.attrs
    except (OSError, ValueError):
        return False


def _array(path: Path, f: Any, name: str, shape: tuple[int, ...]) -> np.ndarray:
    if name not in f:
        raise fail(path, f"missing variable {name!r} of a CD-BTF file")
    ds = f[name]
    if not isinstance(getattr(ds, "shape", None), tuple):
        raise fail(path, f"{name!r} is not a variable (an HDF5 group?)")
    if tuple(ds.shape) != shape:
        raise fail(path, f"{name!r} has shape {tuple(ds.shape)}, expected {shape}")
    if ds.dtype.kind != "f":
        raise fail(path, f"{name!r} has dtype {ds.dtype}, expected float")
    check_storage(path, ds, name, path.stat().st_size)
    try:
        a = np.asarray(ds[()])
    except (OSError, ValueError) as exc:
        raise fail(path, f"{name!r} cannot be read ({one_line(exc)})") from None
    if not np.all(np.isfinite(a)):
        raise fail(path, f"{name!r} holds NaN or infinite values")
    if a.size and float(np.max(np.abs(a))) > float(np.finfo(np.float32).max):
        raise fail(path, f"{name!r} holds values beyond float32 (up to {float(np.max(np.abs(a))):.3g})")
    return a


#: The sizes of a repeat ``btf_repeat_mm`` may have, mm: a tenth of a fibre's width to ten metres (a smaller or
#: larger repeat is a unit error, and its reciprocal overflows the renderer's float32 texel coordinates).
REPEAT_MM_RANGE = (0.01, 1e4)

#: The bounds of the compression record's numbers: ``(low, high, integer)``. Relative errors are fractions (a
#: few hundred percent at most for any representation; 1e3 leaves room), the ratio a positive number.
_RECORD = {"max_error": (0.0, 1e3, False), "relative_rms_error": (0.0, 1e3, False),
           "neural_relative_rms_error": (0.0, 1e3, False), "compression_ratio": (1e-12, 1e15, False),
           "fit_seconds": (0.0, 1e9, False), "truncated_from": (1, 4096, True)}


def _numbers(path: Path, attrs: Any, name: str, *, low: float = -math.inf, high: float = math.inf,
             integer: bool = False) -> np.ndarray:
    """A global attribute of numbers (float64, flat): one-line FormatError for text, an empty attribute,
    NaN or a value outside ``[low, high]`` (or not whole, ``integer``)."""
    a = np.asarray(get_attr(path, attrs, name))
    kind = "integers" if integer else "numbers"
    if a.dtype.kind not in "iuf" or a.size == 0:
        raise fail(path, f"global attribute {name!r} is not {kind} (got {a.dtype} of {a.size} value(s))")
    with np.errstate(all="ignore"):
        x = a.astype(np.float64).reshape(-1)
        bad = ~np.isfinite(x) | (x < low) | (x > high)
        if integer:
            bad |= x != np.round(x)
    if np.any(bad):
        top = x[bad][0]
        raise fail(path, f"global attribute {name!r} holds {top!r}: expected finite {kind} in [{low:g}, {high:g}]")
    return x


def _scalar(path: Path, attrs: Any, name: str, *, low: float = -math.inf, high: float = math.inf,
            integer: bool = False) -> float:
    x = _numbers(path, attrs, name, low=low, high=high, integer=integer)
    if x.size != 1:
        raise fail(path, f"global attribute {name!r} is not one number (got {x.size})")
    return float(x[0])


def _ints(path: Path, f: Any, name: str) -> list[int]:
    x = _numbers(path, f.attrs, name, low=1, high=1 << 20, integer=True)
    if x.size > 64:
        raise fail(path, f"global attribute {name!r} is not a short list of positive integers ({x.size} values)")
    return [int(v) for v in x]


def _texel_axis(path: Path, f: Any, name: str) -> int:
    """The length of a texel axis: a 1-D variable of 1 to 2^20 texel centres."""
    ds = f.get(name) if name in f else None
    shape = getattr(ds, "shape", None)
    if ds is None or not isinstance(shape, tuple) or len(shape) != 1 or not 1 <= shape[0] <= 1 << 20:
        what = "missing" if ds is None else (f"of shape {shape}" if isinstance(shape, tuple) else "not a variable")
        raise fail(path, f"the texel axis {name!r} is {what}: expected 1 to {1 << 20} texel centres")
    return int(shape[0])


def _read_neural(path: Path, f: Any, nu: int, nv: int, n_channels: int) -> Neural:
    """The neural part of a schema-2 file: the latent pyramid and the decoder, shapes checked."""
    from ._neural import N_FEATURES, Neural, level_shapes

    levels = _ints(path, f, "btf_latent_levels")
    layers = _ints(path, f, "btf_decoder_layers")
    shapes = [(levels[i], levels[i + 1]) for i in range(0, len(levels) - 1, 2)]
    if len(levels) % 2 or shapes != level_shapes(nu, nv):
        raise fail(path, f"'btf_latent_levels' {levels} do not match {nu} x {nv} texels")
    if len(layers) < 2 or layers[-1] != n_channels or layers[0] <= N_FEATURES:
        raise fail(path, f"'btf_decoder_layers' {layers} do not end in {n_channels} channels or take too few inputs")
    dims = layers[0] - N_FEATURES
    n_lat = sum(a * b for a, b in shapes)
    n_par = sum(a * b + b for a, b in zip(layers[:-1], layers[1:]))
    lat = _array(path, f, LATENTS, (n_lat, dims)).astype(np.float32)
    dec = _array(path, f, DECODER, (n_par,)).astype(np.float32)
    const = _numbers(path, f.attrs, "btf_decoder_constants")
    if const.size != 3 or const[0] <= 0 or const[1] <= 0:
        raise fail(path, "global attribute 'btf_decoder_constants' is not (kappa scale > 0, epsilon > 0, offset)")
    latents, start = [], 0
    for a, b in shapes:
        latents.append(lat[start : start + a * b].reshape(a, b, dims))
        start += a * b
    ws, bs, start = [], [], 0
    for a, b in zip(layers[:-1], layers[1:]):
        ws.append(dec[start : start + a * b].reshape(a, b))
        bs.append(dec[start + a * b : start + a * b + b])
        start += a * b + b
    return Neural(tuple(latents), tuple(ws), tuple(bs), (float(const[0]), float(const[1]), float(const[2])))


def read(path: str | PathLike[str], *, mean: CDBRDF | None = None) -> BTFParts:
    """Read a CD-BTF file written by :meth:`cdbrdf.btf.CDBTF.save` (:func:`cdbrdf.btf.load` builds the object).

    The tile mean is read and checked by :func:`cdbrdf.load` (every rule of
    the CDBRDF file), then the CD-BTF variables: shapes against the mean and
    each other, finite values within float32, every number attribute in its
    range (``docs/format.md``), the digest ``btf_sha256``, and the decoded
    values within the table's bound (:data:`cdbrdf.table.MAX_ABS_VALUE`).

    Raises
    ------
    FileNotFoundError
        When ``path`` does not exist.
    FormatError
        For a file that is not a CD-BTF file or is inconsistent or damaged
        (the message starts with the path).
    """
    import h5py

    from ..table import load as load_table

    p = Path(path)
    mean = load_table(p) if mean is None else mean  # given: read already, by cdbrdf.sources.open_source
    try:
        f = h5py.File(p, "r")
    except OSError as exc:
        raise fail(p, f"cannot be opened as HDF5 ({one_line(exc)})") from None
    with f:
        if "btf_repeat_mm" not in f.attrs:
            raise fail(p, "a CDBRDF file without the CD-BTF variables (no 'btf_repeat_mm'): read it with "
                          "cdbrdf.load")
        repeat = _numbers(p, f.attrs, "btf_repeat_mm", low=REPEAT_MM_RANGE[0], high=REPEAT_MM_RANGE[1])
        if repeat.size != 2:
            raise fail(p, f"global attribute 'btf_repeat_mm' is not two sizes (u, v) in mm: {repeat.size} value(s)")
        method = get_attr_str(p, f.attrs, "btf_method")
        version = int(_scalar(p, f.attrs, "btf_format_version", low=1, high=1 << 20, integer=True)) \
            if "btf_format_version" in f.attrs else 1
        if version not in (1, SCHEMA_VERSION):
            raise fail(p, f"CD-BTF variables of schema {version}: this cdbrdf reads schemas 1 and {SCHEMA_VERSION} "
                          "(a newer cdbrdf wrote it)")
        if (method == "neural") != (version == 2):
            raise fail(p, f"'btf_method' {method[:40]!r} does not match the CD-BTF schema {version}")
        rank = int(_scalar(p, f.attrs, "btf_rank" if version == 1 else "btf_residual_rank", low=0, high=4096,
                           integer=True))
        nu, nv = _texel_axis(p, f, TEXEL_U), _texel_axis(p, f, TEXEL_V)
        check_limit("table_samples", float(math.prod(mean.shape)) * (rank + 1) + nu * nv * max(rank, 1),
                     what=f"{p}: CD-BTF of {nu} x {nv} texels and rank {rank}")
        if rank:
            weights = _array(p, f, WEIGHTS, (nv, nu, rank))
            basis = _array(p, f, BASIS, mean.shape[:-1] + (rank, mean.n_channels))
        else:
            weights = np.zeros((nv, nu, 0), np.float32)
            basis = np.zeros(mean.shape[:-1] + (0, mean.n_channels), np.float32)
        net = _read_neural(p, f, nu, nv, mean.n_channels) if version == 2 else None
        comp = _record(p, f.attrs, method, rank, mean.shape[0])
        stored = np.asarray(get_attr(p, f.attrs, _DIGEST)) if _DIGEST in f.attrs else None
    btf = BTFParts(mean, weights, basis, (float(repeat[0]), float(repeat[1])), comp, net)
    if stored is None or stored.dtype != np.uint8 or stored.shape != (32,):
        raise fail(p, f"global attribute {_DIGEST!r} is missing or not 32 bytes")
    if not np.array_equal(stored, data_digest(_stored(btf))):
        raise fail(p, f"checksum mismatch in the CD-BTF variables ({_DIGEST!r}): the file is damaged")
    from ._neural import decoded_bound

    bound = decoded_bound(mean.values, weights, basis, net, mean.grid.kappa)
    if not bound <= MAX_ABS_VALUE:
        names = "'btf_weights' and 'btf_basis'" if net is None else "'btf_latents', 'btf_decoder' and 'btf_basis'"
        raise fail(p, f"{names} could decode to values up to {bound:.3g}, beyond the table's bound "
                      f"+-{MAX_ABS_VALUE:g}: not a reflectance")
    return btf


def _record(p: Path, attrs: Any, method: str, rank: int, n_kappa: int) -> dict[str, Any]:
    """The compression record of the file's attributes, each number checked against its range."""
    comp: dict[str, Any] = {"method": method, "rank": rank}
    for key, (low, high, integer) in _RECORD.items():
        if f"btf_{key}" in attrs:
            x = _scalar(p, attrs, f"btf_{key}", low=low, high=high, integer=integer)
            comp[key] = int(x) if integer else x
    if comp.get("truncated_from", rank) < rank:
        raise fail(p, f"global attribute 'btf_truncated_from' ({comp['truncated_from']}) is below the rank {rank}")
    name = "btf_relative_rms_error_per_kappa"
    if name in attrs:
        per = _numbers(p, attrs, name, low=0.0, high=1e3)
        if per.size != n_kappa:
            raise fail(p, f"global attribute {name!r} has {per.size} value(s), expected one per curvature "
                          f"({n_kappa})")
        comp["relative_rms_error_per_kappa"] = [float(v) for v in per]
    return comp
