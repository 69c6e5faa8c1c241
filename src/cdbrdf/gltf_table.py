"""A table in a glTF 2.0 asset: the ``CDBRDF_materials_curvature_brdf`` extension's lookup texture, both ways.

A CDBRDF goes into a glTF asset (``cdbrdf export``, :mod:`cdbrdf.export`)
as a material extension holding the table's lookup grid as one 16-bit PNG
texture and the axes as JSON, so that a renderer reproduces
:meth:`cdbrdf.CDBRDF.evaluate` with the lookup rule of :mod:`cdbrdf.interp`
(``docs/export.md`` has the specification, ``docs/schema/`` its JSON schema).
This module owns that encoding: :func:`encode_table` (a table -> the texture,
the measured mask and the extension's JSON), :func:`decode_table` (back) and
:func:`read_gltf` (a ``.glb`` or ``.gltf`` file -> :class:`~cdbrdf.schema.TableParts`,
which :func:`cdbrdf.load` builds the table from).

**The texture.** The values of the table's :class:`~cdbrdf.interp.LookupGrid`
(pole rule applied: node 0 of both elevation axes is theta = 0 and holds the
ring mean, a virtual node when the table starts above 0), as a layer per
curvature: a layer is the Fig. 7 image (rows: light directions ``phi_l``
then ``theta_l``; columns: view directions ``phi_v`` then ``theta_v``) read
row by row, texel ``i`` at ``(i % width, i // width)`` with ``width =
min(n, 2048)`` (WebGL2's guaranteed texture size), the layers stacked from
the top of the image, ``rows_per_layer`` image rows each. Every channel is
normalised 16-bit (``unorm16``): ``value = offset + scale * q / 65535`` with
a per-channel ``offset`` (0 unless the channel has negative values) and
``scale``; the largest error is half a step, ``scale / 131070`` (7.6e-6 of
the channel's range), recorded with the relative errors in the extension.

**Reading back** gives the table on its own grid: every sample with both
elevations above 0 as stored, within the quantisation; the samples at an
elevation of 0 as the ring mean the lookup uses (the pole rule: the lookups
of the read table and of the source agree everywhere); the measured mask
from its 8-bit PNG; the fill provenance as not recorded.
"""

from __future__ import annotations

import base64
import json
import os
import re
import stat
import warnings
from collections.abc import Mapping
from dataclasses import dataclass
from os import PathLike
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .errors import FormatError
from .schema import SAMPLE_AXES, TableParts

__all__ = [
    "EXTENSION",
    "EXTENSION_VERSION",
    "ENCODINGS",
    "MAX_TEXTURE_WIDTH",
    "MAX_GLTF_BYTES",
    "LookupTexture",
    "CurvatureMapTexture",
    "MAP_CHANNELS",
    "encode_table",
    "encode_curvature_map",
    "decode_table",
    "is_gltf",
    "read_gltf",
    "gltf_document",
]

#: The vendor extension's name (a material extension).
EXTENSION = "CDBRDF_materials_curvature_brdf"

#: Its version: a reader refuses a newer major version.
EXTENSION_VERSION = "1.0"

#: Texel encodings of the lookup texture (``docs/export.md``).
ENCODINGS: tuple[str, ...] = ("unorm16",)

#: Widest texture row (WebGL2's guaranteed MAX_TEXTURE_SIZE).
MAX_TEXTURE_WIDTH = 2048

#: Largest glTF file read back, bytes.
MAX_GLTF_BYTES = 2 * 1024**3

_UNORM16 = 65535.0
_GLB_MAGIC = b"glTF"


@dataclass(frozen=True)
class LookupTexture:
    """A table encoded for the extension (:func:`encode_table`).

    Attributes
    ----------
    png
        The lookup texture: 16-bit grey or RGB PNG.
    measured_png
        The measured mask on the table's own grid (8-bit grey, 255 measured,
        0 filled; rows ``kappa, phi_l, theta_l``, columns ``phi_v, theta_v``).
    spec
        The extension's JSON without the texture and image indices (``lookup``,
        ``axes``, ``symmetry``, ``quantity``, ``channels``, ``material``, ``attrs``).
    """

    png: bytes
    measured_png: bytes
    spec: dict[str, Any]


def _layout(shape: tuple[int, ...], max_width: int) -> tuple[int, int]:
    """``(width, rows_per_layer)`` of a layer of ``shape[1:5]`` texels folded into rows of at most ``max_width``."""
    n = int(np.prod(shape[1:5]))
    width = max(1, min(n, int(max_width)))
    return width, -(-n // width)


def _json_attrs(attrs: Mapping[str, Any]) -> dict[str, Any]:
    """The table's attributes that JSON holds as they are (others as their text)."""
    out: dict[str, Any] = {}
    for k, v in attrs.items():
        if isinstance(v, np.ndarray):
            v = v.tolist()
        elif isinstance(v, np.generic):
            v = v.item()
        try:
            json.dumps(v, allow_nan=False)
        except (TypeError, ValueError):
            v = str(v)
        out[str(k)] = v
    return out


def _quantise(v: NDArray[np.float64]) -> tuple[NDArray[np.uint16], NDArray[np.float64], NDArray[np.float64]]:
    """``(q, offset, scale)`` per channel (last axis) of the unorm16 encoding."""
    flat = v.reshape(-1, v.shape[-1])
    lo = np.minimum(flat.min(axis=0), 0.0)
    hi = flat.max(axis=0)
    scale = np.where(hi > lo, hi - lo, 1.0)
    q = np.rint((v - lo) / scale * _UNORM16)
    return np.clip(q, 0, _UNORM16).astype(np.uint16), lo, scale


def _errors(v: NDArray[np.float64], back: NDArray[np.float64], scale: NDArray[np.float64]) -> dict[str, float]:
    """The quantisation's errors: largest absolute over the channel's range, relative percentiles."""
    d = np.abs(back - v)
    pos = np.abs(v) > 0
    rel = d[pos] / np.abs(v[pos]) if pos.any() else np.zeros(1)
    return {
        "maxAbsoluteOverRange": float(np.max(d.reshape(-1, v.shape[-1]) / scale)),
        "medianRelative": float(np.median(rel)),
        "p99Relative": float(np.percentile(rel, 99)),
        "maxRelative": float(rel.max()),
    }


def encode_table(table: Any, *, max_width: int = MAX_TEXTURE_WIDTH) -> LookupTexture:
    """Encode a table as the extension's lookup texture (see the module's description).

    Parameters
    ----------
    table
        A :class:`~cdbrdf.CDBRDF` with 1 (grey) or 3 (RGB) channels.
    max_width
        The widest texture row, texels.

    Returns
    -------
    LookupTexture
        The texture, the measured mask and the extension's JSON.

    Raises
    ------
    FormatError
        For a table of another channel count, or one with more curvatures or
        directions than a texture holds (at most ``max_width ** 2`` light x
        view directions and 256 curvatures: WebGL2's guaranteed limits).
    """
    import imagecodecs

    nc = int(table.n_channels)
    if nc not in (1, 3):
        raise FormatError(f"table: glTF export takes RGB or grey tables; this one has {nc} channels "
                          f"({', '.join(table.channels)})")
    lg = table.lookup_grid()
    shape = tuple(int(s) for s in lg.values.shape)
    width, rows = _layout(shape, max_width)
    if rows > max_width or shape[0] > 256:
        raise FormatError(f"table: {int(np.prod(shape[1:5])):,} light x view directions and {shape[0]} curvatures "
                          f"exceed a texture of {max_width} x {max_width} texels and 256 layers; resample it "
                          "first (cdbrdf view --grid's resampling: cdbrdf.view.asset.resample)")
    v = np.asarray(lg.values, dtype=np.float64)
    q, offset, scale = _quantise(v)
    back = offset + scale * (q.astype(np.float64) / _UNORM16)
    k = shape[0]
    atlas = np.zeros((k, rows * width, nc), dtype=np.uint16)
    atlas[:, : int(np.prod(shape[1:5]))] = q.reshape(k, -1, nc)
    image = atlas.reshape(k * rows, width, nc)
    png = imagecodecs.png_encode(np.ascontiguousarray(image[..., 0] if nc == 1 else image), level=9)
    g = table.grid
    meas = np.asarray(table.measured, dtype=np.uint8).reshape(g.kappa.size * g.phi_l.size * g.theta_l.size, -1)
    measured_png = imagecodecs.png_encode(np.ascontiguousarray(meas * 255), level=9)
    attrs = _json_attrs(table.attrs)
    spec: dict[str, Any] = {
        "version": EXTENSION_VERSION,
        "quantity": table.quantity,
        "symmetry": table.symmetry,
        "channels": list(table.channels),
        "material": str(table.attrs.get("material", "")),
        "axes": {name: np.asarray(getattr(g, name), dtype=np.float64).tolist() for name in SAMPLE_AXES},
        "lookup": {
            "shape": list(shape[:5]),
            "kappa": lg.kappa.tolist(),
            "theta_l": lg.theta_l.tolist(),
            "theta_v": lg.theta_v.tolist(),
            "phi_l": {"first": float(lg.phi_l0), "step": float(lg.phi_l_step), "count": shape[1]},
            "phi_v": {"first": float(lg.phi_v0), "step": float(lg.phi_v_step), "count": shape[3]},
            "isotropic": bool(lg.isotropic),
            "snapTolerance": 1e-6,
            "width": width,
            "rowsPerLayer": rows,
            "layers": k,
            "encoding": {"type": "unorm16", "offset": offset.tolist(), "scale": scale.tolist(),
                         "error": _errors(v, back, scale)},
        },
        "attrs": attrs,
    }
    return LookupTexture(png=bytes(png), measured_png=bytes(measured_png), spec=spec)


@dataclass(frozen=True)
class CurvatureMapTexture:
    """A curvature map encoded for the extension (:func:`encode_curvature_map`).

    Attributes
    ----------
    pngs
        Two 16-bit RGB PNGs: the channels ``p, q, dp_du`` and ``dp_dv, dq_du, dq_dv``.
    spec
        The extension's ``curvature.map`` JSON without the texture indices.
    """

    pngs: tuple[bytes, bytes]
    spec: dict[str, Any]


#: The channels of a curvature map's texel, in order (:data:`cdbrdf.mesh.curvature_map.CHANNELS`).
MAP_CHANNELS: tuple[str, ...] = ("p", "q", "dp_du", "dp_dv", "dq_du", "dq_dv")


def encode_curvature_map(levels: Any, *, transform: tuple[float, float, float, float],
                         uv_scale: tuple[float, float], min_level: float) -> CurvatureMapTexture:
    """A curvature map's levels as two 16-bit PNG atlases and the extension's JSON (``docs/export.md``).

    The levels (:class:`cdbrdf.mesh.CurvatureMap`: level 0 first, each the 2 x 2
    means of the one before, the last 1 x 1) are stacked from the top of the
    image, level ``l`` at rows ``levels[l][0]`` to ``levels[l][0] + h_l - 1``,
    columns 0 to ``w_l - 1``; each channel unorm16 with its own offset and scale.

    Parameters
    ----------
    levels
        ``(H_l, W_l, 6)`` arrays of :data:`MAP_CHANNELS`.
    transform
        ``(ru, rv, ou, ov)``: texture coordinate ``(ru u + ou, rv v + ov)`` of the mesh's UVs (v up), row 0 at
        the top.
    uv_scale
        Mm per UV unit the map is read at.
    min_level
        The finest level a lookup reads (the curvature's neighbourhood).

    Returns
    -------
    CurvatureMapTexture
        The images and the JSON.
    """
    import imagecodecs

    lv = [np.asarray(a, dtype=np.float64) for a in levels]
    width = max(a.shape[1] for a in lv)
    rows, y = [], 0
    for a in lv:
        rows.append([y, int(a.shape[1]), int(a.shape[0])])
        y += int(a.shape[0])
    allv = np.concatenate([a.reshape(-1, len(MAP_CHANNELS)) for a in lv])
    lo, hi = allv.min(axis=0), allv.max(axis=0)
    scale = np.where(hi > lo, hi - lo, 1.0)
    atlas = np.zeros((y, width, len(MAP_CHANNELS)), dtype=np.uint16)
    err = 0.0
    for (y0, w, h), a in zip(rows, lv, strict=True):
        q = np.clip(np.rint((a - lo) / scale * _UNORM16), 0, _UNORM16)
        atlas[y0:y0 + h, :w] = q.astype(np.uint16)
        err = max(err, float(np.max(np.abs(lo + scale * q / _UNORM16 - a) / scale)))
    pngs = tuple(bytes(imagecodecs.png_encode(np.ascontiguousarray(atlas[..., 3 * j:3 * j + 3]), level=9))
                 for j in (0, 1))
    spec = {"channels": list(MAP_CHANNELS), "levels": rows,
            "encoding": {"type": "unorm16", "offset": lo.tolist(), "scale": scale.tolist(),
                         "error": {"maxAbsoluteOverRange": err}},
            "transform": [float(x) for x in transform], "uvScale": [float(x) for x in uv_scale],
            "minLevel": float(min_level)}
    return CurvatureMapTexture(pngs=(pngs[0], pngs[1]), spec=spec)


# -- reading back ---------------------------------------------------------------------------------
def _need(cond: bool, name: str, problem: str) -> None:
    if not cond:
        raise FormatError(f"{name}: {problem}")


def _axis(spec: Mapping[str, Any], key: str, name: str) -> NDArray[np.float64]:
    try:
        a = np.asarray(spec[key], dtype=np.float64)
    except (KeyError, TypeError, ValueError):
        raise FormatError(f"{name}: the extension's {key!r} is missing or not a list of numbers") from None
    _need(a.ndim == 1 and a.size >= 1 and bool(np.all(np.isfinite(a))), name,
          f"the extension's {key!r} is not a non-empty list of finite numbers")
    return a


def _lookup_to_table(v: NDArray[np.float64], tl_lookup: NDArray[np.float64], tv_lookup: NDArray[np.float64],
                     tl: NDArray[np.float64], tv: NDArray[np.float64], name: str) -> NDArray[np.float64]:
    """The table's own samples from the lookup grid's values: the virtual pole nodes dropped."""
    def keep(lookup_axis: NDArray[np.float64], axis: NDArray[np.float64], which: str) -> slice:
        virtual = axis[0] > 0.0
        want = np.r_[0.0, axis] if virtual else axis
        _need(lookup_axis.shape == want.shape and bool(np.allclose(lookup_axis, want, rtol=0, atol=1e-9)), name,
              f"the lookup's {which} nodes do not follow from the table's axis (the pole rule)")
        return slice(1, None) if virtual else slice(None)

    return v[:, :, keep(tl_lookup, tl, "theta_l"), :, keep(tv_lookup, tv, "theta_v")]


def decode_table(spec: Mapping[str, Any], png: bytes, measured_png: bytes | None = None, *,
                 name: str = "glTF") -> TableParts:
    """A table's parts from the extension's JSON and its textures (see the module's description).

    Parameters
    ----------
    spec
        The extension's JSON (:attr:`LookupTexture.spec`, or as read from a file).
    png
        The lookup texture's PNG bytes.
    measured_png
        The measured mask's PNG bytes, or None (all measured).
    name
        The file, for messages.

    Returns
    -------
    TableParts
        The values (float32, or float64 when the texture needs more than
        float32 keeps), the axes, the measured mask and the attributes.

    Raises
    ------
    FormatError
        For a newer major version, an unknown encoding, a texture or JSON
        that does not match (one line naming ``name``).
    """
    from .images import _png_decode
    from .limits import check

    try:
        ver = str(spec.get("version", ""))
        major = int(ver.split(".")[0])
    except (ValueError, AttributeError):
        raise FormatError(f"{name}: {EXTENSION} has no valid version") from None
    _need(major <= int(EXTENSION_VERSION.split(".")[0]), name,
          f"{EXTENSION} version {ver} is newer than this cdbrdf reads ({EXTENSION_VERSION})")
    lk = spec.get("lookup")
    axes_spec = spec.get("axes")
    _need(isinstance(lk, Mapping) and isinstance(axes_spec, Mapping), name, f"{EXTENSION} lacks 'lookup' or 'axes'")
    assert isinstance(lk, Mapping) and isinstance(axes_spec, Mapping)
    axes = {a: _axis(axes_spec, a, name) for a in SAMPLE_AXES}
    enc = lk.get("encoding")
    _need(isinstance(enc, Mapping) and enc.get("type") in ENCODINGS, name,
          f"the lookup texture's encoding is not one of {', '.join(ENCODINGS)}")
    assert isinstance(enc, Mapping)
    try:
        shape = tuple(int(s) for s in lk["shape"])
        width, rows, layers = int(lk["width"]), int(lk["rowsPerLayer"]), int(lk["layers"])
        offset = np.asarray(enc["offset"], dtype=np.float64)
        scale = np.asarray(enc["scale"], dtype=np.float64)
    except (KeyError, TypeError, ValueError):
        raise FormatError(f"{name}: the lookup's shape, layout or encoding is missing or not numbers") from None
    _need(len(shape) == 5 and all(s >= 1 for s in shape), name, f"the lookup's shape {list(shape)} is not 5 sizes")
    check("table_samples", float(np.prod(shape)) * max(offset.size, 1), what=f"{name}: a lookup of shape {shape}")
    _need(layers == shape[0] and (width, rows) == _layout(shape, width) and width <= MAX_TEXTURE_WIDTH * 8, name,
          f"the texture layout {width} x {rows} x {layers} does not hold a lookup of shape {list(shape)}")
    try:
        img = np.asarray(_png_decode(png))
    except ValueError as exc:
        raise FormatError(f"{name}: the lookup texture is not a readable PNG ({exc})") from None
    nc = offset.size
    img = img[..., None] if img.ndim == 2 else img
    _need(img.dtype == np.uint16 and img.shape == (layers * rows, width, nc), name,
          f"the lookup texture is {img.shape} {img.dtype}, expected ({layers * rows}, {width}, {nc}) uint16")
    _need(scale.shape == (nc,) and bool(np.all(np.isfinite(scale) & (scale > 0)) and np.all(np.isfinite(offset))),
          name, "the encoding's scale and offset are not one finite number per channel (scale > 0)")
    n = int(np.prod(shape[1:5]))
    q = img.reshape(layers, rows * width, nc)[:, :n].reshape(*shape, nc)
    v = offset + scale * (q.astype(np.float64) / _UNORM16)
    tl_lookup, tv_lookup = _axis(lk, "theta_l", name), _axis(lk, "theta_v", name)
    g_shape = tuple(axes[a].size for a in SAMPLE_AXES)
    _need(shape[0] == g_shape[0] and shape[1] == g_shape[1] and shape[3] == g_shape[3], name,
          f"the lookup's shape {list(shape)} does not match the axes {list(g_shape)}")
    values = _lookup_to_table(v, tl_lookup, tv_lookup, axes["theta_l"], axes["theta_v"], name)
    _need(values.shape[:5] == g_shape, name,
          f"the lookup's shape {list(shape)} does not match the axes {list(g_shape)}")
    measured = None
    if measured_png is not None:
        try:
            m = np.asarray(_png_decode(measured_png))
        except ValueError as exc:
            raise FormatError(f"{name}: the measured mask is not a readable PNG ({exc})") from None
        _need(m.ndim == 2 and m.size == int(np.prod(g_shape)), name,
              f"the measured mask has {m.size} pixels, expected {int(np.prod(g_shape))}")
        measured = (m.reshape(g_shape) >= 128)
    attrs = dict(spec.get("attrs") or {}) if isinstance(spec.get("attrs"), Mapping) else {}
    attrs["quantity"] = spec.get("quantity", attrs.get("quantity", "relative"))
    if spec.get("symmetry") == "isotropic":
        attrs["symmetry"] = "isotropic"
    fill_source = None if measured is None else np.where(measured, -1, -2).astype(np.int64)
    # float32 keeps the 16-bit values' every step (24 bits of mantissa)
    return TableParts(values=values.astype(np.float32), axes=axes, measured=measured, fill_source=fill_source,
                      std=None, attrs=attrs)


def is_gltf(path: str | PathLike[str]) -> bool:
    """Whether ``path`` names a glTF asset: suffix ``.glb``/``.gltf``, or a file starting with the GLB magic.

    Parameters
    ----------
    path
        The file.

    Returns
    -------
    bool
        True for a glTF asset.
    """
    if not isinstance(path, str | PathLike):
        return False
    p = Path(path)
    if p.suffix.lower() in (".glb", ".gltf"):
        return True
    try:  # the magic of a regular file only (never blocks on a FIFO or a device)
        fd = os.open(p, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_NOCTTY", 0))
    except (OSError, ValueError):
        return False
    try:
        return stat.S_ISREG(os.fstat(fd).st_mode) and os.read(fd, 4) == _GLB_MAGIC
    except OSError:
        return False
    finally:
        os.close(fd)


_DATA_URI = re.compile(r"^data:[^;,]*(;base64)?,", re.IGNORECASE)


def gltf_document(path: str | PathLike[str]) -> tuple[Any, Any]:
    """A glTF file read by pygltflib: ``(gltf, buffer_bytes)`` where ``buffer_bytes(i)`` gives buffer ``i``.

    A GLB's first buffer is its binary chunk; a ``.gltf``'s buffers are data
    URIs or files beside it (a plain relative name, read as a regular file).

    Parameters
    ----------
    path
        A ``.glb`` or ``.gltf`` file.

    Returns
    -------
    gltf : pygltflib.GLTF2
        The document.
    buffer_bytes : callable
        ``buffer_bytes(i)``: the bytes of buffer ``i``.

    Raises
    ------
    FormatError
        For a file that is not glTF 2.0, or a buffer that cannot be had.
    """
    from pygltflib import GLTF2

    from .fsutil import check_regular, read_regular

    p = Path(path)
    data = read_regular(p, max_bytes=MAX_GLTF_BYTES)
    if len(data) > MAX_GLTF_BYTES:
        raise FormatError(f"{p}: larger than {MAX_GLTF_BYTES:,} bytes")
    if data[:4] == _GLB_MAGIC and (len(data) < 12 or int.from_bytes(data[8:12], "little") != len(data)):
        declared = int.from_bytes(data[8:12], "little") if len(data) >= 12 else 0
        raise FormatError(f"{p}: not a readable glTF file (the GLB header declares {declared:,} bytes, the file has "
                          f"{len(data):,}: truncated or damaged)")
    try:
        with warnings.catch_warnings():  # dataclasses_json warns of the fields glTF leaves out (an image's uri)
            warnings.simplefilter("ignore")
            doc = GLTF2.load_from_bytes(data) if data[:4] == _GLB_MAGIC else GLTF2.from_json(data.decode("utf-8"))
    except Exception as exc:  # noqa: BLE001 - pygltflib raises anything on a malformed file
        raise FormatError(f"{p}: not a readable glTF file ({type(exc).__name__}: {str(exc)[:120]})") from None
    if doc is None or str(getattr(doc.asset, "version", "")).split(".")[0] != "2":
        raise FormatError(f"{p}: not a glTF 2.0 asset")

    def buffer_bytes(i: int) -> bytes:
        bufs = doc.buffers or []
        _need(0 <= i < len(bufs), str(p), f"buffer {i} does not exist")
        uri = bufs[i].uri
        if uri is None:
            blob = doc.binary_blob()
            _need(blob is not None, str(p), f"buffer {i} has no data (no GLB binary chunk)")
            return bytes(blob)
        m = _DATA_URI.match(uri)
        if m:
            _need(m.group(1) is not None, str(p), f"buffer {i}: only base64 data URIs are read")
            try:
                return base64.b64decode(uri[m.end():], validate=True)
            except ValueError:
                raise FormatError(f"{p}: buffer {i}'s data URI is not valid base64") from None
        _need("/" not in uri and "\\" not in uri and ":" not in uri and uri not in (".", ".."), str(p),
              f"buffer {i}'s URI {uri[:60]!r} is not a file beside the asset")
        q = check_regular(p.parent / uri)
        raw = read_regular(q, max_bytes=MAX_GLTF_BYTES)
        _need(len(raw) <= MAX_GLTF_BYTES, str(p), f"buffer {i} is too large")
        return raw

    return doc, buffer_bytes


def _image_bytes(doc: Any, buffer_bytes: Any, index: Any, name: str, what: str) -> bytes:
    images = doc.images or []
    _need(isinstance(index, int) and 0 <= index < len(images), name, f"{what}: image {index!r} does not exist")
    im = images[index]
    _need(im.bufferView is not None, name, f"{what}: image {index} is not in a buffer view")
    views = doc.bufferViews or []
    _need(0 <= im.bufferView < len(views), name, f"{what}: buffer view {im.bufferView} does not exist")
    bv = views[im.bufferView]
    buf = buffer_bytes(bv.buffer)
    start, size = int(bv.byteOffset or 0), int(bv.byteLength)
    _need(0 <= start and start + size <= len(buf), name, f"{what}: buffer view {im.bufferView} lies outside its buffer")
    return bytes(buf[start:start + size])


def read_gltf(path: str | PathLike[str]) -> TableParts:
    """The table of a glTF asset written by ``cdbrdf export`` (the first material with the extension).

    Parameters
    ----------
    path
        A ``.glb`` or ``.gltf`` file.

    Returns
    -------
    TableParts
        The table's parts (:func:`decode_table`); ``attrs["gltf_export"]``
        records the extension's quantisation and fallback-fit errors.

    Raises
    ------
    FileNotFoundError
        When ``path`` does not exist.
    FormatError
        For a file without the extension or a damaged one (one line naming the file).
    """
    p = Path(path)
    doc, buffer_bytes = gltf_document(p)
    for mat in doc.materials or []:
        ext = (mat.extensions or {}).get(EXTENSION)
        if ext is None:
            continue
        _need(isinstance(ext, Mapping), str(p), f"{EXTENSION} is not a JSON object")
        lk = ext.get("lookup")
        _need(isinstance(lk, Mapping), str(p), f"{EXTENSION} has no 'lookup'")
        tex = lk.get("texture") if isinstance(lk, Mapping) else None
        ti = tex.get("index") if isinstance(tex, Mapping) else None
        textures = doc.textures or []
        if not (isinstance(ti, int) and 0 <= ti < len(textures)):
            raise FormatError(f"{p}: the lookup texture does not exist")
        png = _image_bytes(doc, buffer_bytes, textures[ti].source, str(p), "the lookup texture")
        mi = ext.get("measuredImage")
        measured = None if mi is None else _image_bytes(doc, buffer_bytes, mi, str(p), "the measured mask")
        parts = decode_table(ext, png, measured, name=str(p))
        attrs = dict(parts.attrs)
        attrs["gltf_export"] = {"extension": EXTENSION, "version": str(ext.get("version")),
                                "encoding": dict(lk.get("encoding", {})).get("error"),
                                "fallback": ext.get("fallback")}
        return TableParts(values=parts.values, axes=parts.axes, measured=parts.measured,
                          fill_source=parts.fill_source, std=None, attrs=attrs)
    raise FormatError(f"{p}: no material with the {EXTENSION} extension (not a cdbrdf export, or its table "
                      "was stripped)")
