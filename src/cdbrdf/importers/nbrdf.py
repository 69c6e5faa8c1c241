"""Neural-BRDF networks (Sztrajman, Rainer, Ritschel & Weyrich, CGF 40(6), 2021): a Keras MLP per material.

A material is a pair of files with one stem: ``NAME.json``, the Keras
architecture (a ``Sequential`` model: ``Dense`` 6 -> 21 ``relu``, 21 -> 21
``relu``, 21 -> 3 ``linear``, then a ``Lambda`` layer computing
``exp(x) - 1``), and ``NAME.h5``, the weights as Keras' ``save_weights``
writes them (root attribute ``layer_names``; per layer a group with the
attribute ``weight_names`` naming its kernel ``(n_in, n_out)`` and bias
datasets). The weights are read with h5py in the isolated child process of
:mod:`cdbrdf._isolated_read` (a Keras file has no HDF5 metadata checksums; a
damaged one cannot hang the import) and the network is evaluated here with
NumPy; no TensorFlow is needed. The ``Lambda`` layer's code (a marshalled
Python function) is never run: it is recognised as the published transform
by the name ``exp`` it calls.

The input encoding is that of the authors' Mitsuba plug-in
(``mitsuba/bsdfs/nbrdf_npy.cpp`` and ``dj_brdf.h`` of the ``asztr/Neural-BRDF``
repository), the half/difference vectors of Rusinkiewicz (1998) with the
light as the "in" direction: ``h = normalize(l + v)``, ``theta_h``,
``phi_h`` its angles (both 0 when ``h_z > 0.99999``); the difference vector
``d`` is ``l`` turned by ``-phi_h`` about the normal and by ``-theta_h``
about the binormal; the network's input is ``(sin theta_h, 0, cos theta_h,
d_x, d_y, d_z)`` (``phi_h`` dropped: the material is isotropic). Its output
goes through ``max(exp(y) - 1, 0)`` (the plug-in's decode) and is the BRDF in
sr^-1 *without* the cosine (the plug-in multiplies by ``cos theta_l``; the
training loss applied the cosine to both sides, the targets were MERL's
values with its channel scales), linear RGB.

Reciprocity: the measurements the networks learned from are reciprocal by
construction (MERL's tables store ``phi_d`` over half a turn, folding
``phi_d`` and ``phi_d + 180`` degrees together, which is the swap of light
and view), but a network is not exactly: the shared networks differ between
``(l, v)`` and ``(v, l)`` by a median 0.4 % (pink felt) to 15 % (RGL's blue
silk). The reader evaluates the mean of both orders, the projection onto
what the data obey, and records the network's own asymmetry in the details
(a warning above 5 %).
"""

from __future__ import annotations

import base64
import json
import logging
from dataclasses import dataclass
from os import PathLike
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..errors import FormatError
from .source import MAX_PLAUSIBLE_BRDF, Source, check_plausible, file_sha256

__all__ = ["Network", "ACTIVATIONS", "MAX_FILE_BYTES", "MAX_LAYERS", "MAX_UNITS", "encode", "pair", "looks_like",
           "read_network", "read", "write"]

log = logging.getLogger(__name__)

#: Activations of ``Dense`` layers the reader evaluates.
ACTIVATIONS: tuple[str, ...] = ("relu", "linear")
#: Largest file of either kind (bytes): the published networks are 18.7 kB (weights) and 1.8 kB (architecture).
MAX_FILE_BYTES = 1 << 20
#: Most ``Dense`` layers, and most units in one.
MAX_LAYERS = 16
MAX_UNITS = 1024
#: Median relative difference between the network's two orders of light and view above which a warning is logged.
ASYMMETRY_WARNING = 0.05
#: The published decode of the output layer, as recorded in the details.
OUTPUT_DECODE = "max(exp(y) - 1, 0)"
_CHUNK = 1 << 14
_HDF5_MAGIC = b"\x89HDF\r\n\x1a\n"
#: A Keras weights file's own attribute names (``save_weights`` writes both at the root).
_KERAS_MARKS = (b"layer_names", b"weight_names")
#: Above this the exponent of the output decode is cut (exp(60) is far beyond any plausible BRDF).
_MAX_EXPONENT = 60.0


@dataclass(frozen=True)
class Network:
    """A Neural-BRDF MLP: ``Dense`` layers then the output decode ``max(exp(y) - 1, 0)``.

    Attributes
    ----------
    kernels
        Per layer ``(n_in, n_out)`` float64.
    biases
        Per layer ``(n_out,)`` float64.
    activations
        Per layer, one of :data:`ACTIVATIONS`.
    layer_names
        The layers' names in the files.
    """

    kernels: tuple[NDArray[np.float64], ...]
    biases: tuple[NDArray[np.float64], ...]
    activations: tuple[str, ...]
    layer_names: tuple[str, ...]

    @property
    def sizes(self) -> tuple[int, ...]:
        """Units per layer, input first (``(6, 21, 21, 3)`` for the published networks)."""
        return (self.kernels[0].shape[0], *(k.shape[1] for k in self.kernels))

    def forward(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        """The decoded output ``(n, 3)`` for encoded inputs ``x`` ``(n, 6)`` (:func:`encode`).

        Computed in float32 as the authors' plug-in computes it (``nn.h``), returned as float64.
        """
        ks = [k.astype(np.float32) for k in self.kernels]
        bs = [b.astype(np.float32) for b in self.biases]
        out = np.empty((x.shape[0], self.sizes[-1]))
        for c0 in range(0, x.shape[0], _CHUNK):
            a = np.asarray(x[c0:c0 + _CHUNK], dtype=np.float32)
            for k, b, act in zip(ks, bs, self.activations):
                a = a @ k
                a += b
                if act == "relu":
                    np.maximum(a, 0.0, out=a)
            np.minimum(a, _MAX_EXPONENT, out=a)
            out[c0:c0 + _CHUNK] = np.maximum(np.expm1(a), 0.0)
        return out

    def brdf(self, theta_v: NDArray[np.float64], phi_v: NDArray[np.float64], theta_l: NDArray[np.float64],
             phi_l: NDArray[np.float64], *, reciprocal: bool = True) -> NDArray[np.float64]:
        """The BRDF ``(n, 3)``, sr^-1, at directions in degrees; with ``reciprocal`` the mean of both orders."""
        f = self.forward(encode(theta_v, phi_v, theta_l, phi_l))
        if reciprocal:
            f = 0.5 * (f + self.forward(encode(theta_l, phi_l, theta_v, phi_v)))
        return f


def encode(theta_v: NDArray[np.float64], phi_v: NDArray[np.float64], theta_l: NDArray[np.float64],
           phi_l: NDArray[np.float64]) -> NDArray[np.float64]:
    """The network's input ``(n, 6)``: ``(sin theta_h, 0, cos theta_h, d)`` of direction pairs in degrees.

    The light is the "in" direction of the half/difference construction (the
    module's description); directions point away from the surface.
    """
    tl, pl = np.radians(np.asarray(theta_l, dtype=np.float64)), np.radians(np.asarray(phi_l, dtype=np.float64))
    tv, pv = np.radians(np.asarray(theta_v, dtype=np.float64)), np.radians(np.asarray(phi_v, dtype=np.float64))
    stl, stv = np.sin(tl), np.sin(tv)
    lx, ly, lz = stl * np.cos(pl), stl * np.sin(pl), np.cos(tl)
    hx, hy, hz = lx + stv * np.cos(pv), ly + stv * np.sin(pv), lz + np.cos(tv)
    norm = np.sqrt(hx * hx + hy * hy + hz * hz)
    norm[norm == 0] = 1.0
    hz = hz / norm
    pole = hz > 0.99999
    theta_h = np.where(pole, 0.0, np.arccos(np.clip(hz, -1.0, 1.0)))
    phi_h = np.where(pole, 0.0, np.arctan2(hy, hx))
    c, s = np.cos(phi_h), np.sin(phi_h)  # turn l by -phi_h about z
    x, y = c * lx + s * ly, -s * lx + c * ly
    out = np.empty(np.shape(theta_h) + (6,))
    ct, st = np.cos(theta_h), np.sin(theta_h)  # then by -theta_h about y
    out[..., 0], out[..., 1], out[..., 2] = st, 0.0, ct
    out[..., 3], out[..., 4], out[..., 5] = ct * x - st * lz, y, st * x + ct * lz
    out[..., 3:] /= np.linalg.norm(out[..., 3:], axis=-1, keepdims=True)
    return out


def pair(path: str | PathLike[str]) -> tuple[Path, Path]:
    """``(architecture .json, weights .h5)`` of a network given either file (same folder, same stem).

    Raises
    ------
    FileNotFoundError
        When ``path`` does not exist.
    FormatError
        When its suffix is neither ``.json`` nor ``.h5``.
    """
    p = Path(path)
    if not p.exists():
        raise FileNotFoundError(f"{p}: no such file")
    suffix = p.suffix.lower()
    if suffix == ".json":
        return p, p.with_suffix(".h5")
    if suffix in (".h5", ".hdf5", ".keras"):
        return p.with_suffix(".json"), p
    raise FormatError(f"{p}: a Neural-BRDF network is a pair NAME.json (architecture) + NAME.h5 (weights); "
                      f"the suffix {suffix or '(none)'!r} is neither")


def looks_like(head: bytes, path: Path) -> bool:
    """Whether a file whose first bytes are ``head`` is one of a Keras network's pair (cheap, no parsing)."""
    if head.startswith(_HDF5_MAGIC):
        from ..fsutil import read_regular

        try:
            data = read_regular(path, max_bytes=MAX_FILE_BYTES)
        except OSError:
            return False
        return all(m in data for m in _KERAS_MARKS)
    return head.lstrip()[:1] == b"{" and path.suffix.lower() == ".json"


def _read_small(path: Path, what: str) -> bytes:
    from ..fsutil import check_regular, read_regular

    try:
        check_regular(path)
    except FileNotFoundError:
        raise FormatError(f"{path}: missing; a Neural-BRDF network needs both NAME.json and NAME.h5") from None
    except IsADirectoryError:
        raise FormatError(f"{path}: is a folder, not {what}") from None
    except OSError as exc:
        raise FormatError(f"{exc}; not {what}") from None
    try:
        size = path.stat().st_size
        if size > MAX_FILE_BYTES:
            raise FormatError(f"{path}: {size} bytes, more than {MAX_FILE_BYTES} for {what} (the published "
                              "networks' files are under 20 kB)")
        return read_regular(path, max_bytes=MAX_FILE_BYTES)
    except OSError as exc:
        raise FormatError(f"{path}: cannot be read ({exc.strerror or exc})") from None


def _architecture(path: Path, data: bytes) -> tuple[list[tuple[str, str]], bool]:
    """``([(layer name, activation)] of the Dense layers, whether the published exp(x) - 1 decode follows)``."""
    try:
        model = json.loads(data.decode("utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError, RecursionError) as exc:
        raise FormatError(f"{path}: not a Keras architecture file (JSON: {str(exc).splitlines()[0][:120]})") from None
    kind = model.get("class_name") if isinstance(model, dict) else None
    if kind != "Sequential":
        raise FormatError(f"{path}: not a Keras Sequential model (class_name {str(kind)[:40]!r}); a Neural-BRDF "
                          "network is one")
    config = model.get("config")
    layers = config.get("layers") if isinstance(config, dict) else config
    if not isinstance(layers, list) or not layers:
        raise FormatError(f"{path}: the Keras model lists no layers")
    dense: list[tuple[str, str]] = []
    decode = False
    for i, layer in enumerate(layers):
        if not isinstance(layer, dict) or not isinstance(layer.get("config"), dict):
            raise FormatError(f"{path}: layer {i} is not a Keras layer description")
        kind, cfg = layer.get("class_name"), layer["config"]
        name = str(cfg.get("name", f"layer {i}"))[:64]
        if decode:
            raise FormatError(f"{path}: layer {name!r} follows the output transform; not a Neural-BRDF network")
        if kind == "Dense":
            act = cfg.get("activation", "linear")
            if act not in ACTIVATIONS:
                raise FormatError(f"{path}: layer {name!r} has the activation {str(act)[:40]!r}; this reader "
                                  f"evaluates {', '.join(ACTIVATIONS)}")
            if cfg.get("use_bias", True) is not True:
                raise FormatError(f"{path}: layer {name!r} has no bias; the Neural-BRDF networks all have one")
            dense.append((name, str(act)))
        elif kind == "Lambda":
            if not _is_exp_minus_one(cfg.get("function")):
                raise FormatError(f"{path}: layer {name!r} is a Lambda layer that is not the published output "
                                  "transform exp(x) - 1 (its Python code is never run)")
            decode = True
        else:
            raise FormatError(f"{path}: layer {name!r} is a {str(kind)[:40]!r} layer; a Neural-BRDF network has "
                              "Dense layers and the exp(x) - 1 output transform")
    if not dense or len(dense) > MAX_LAYERS:
        raise FormatError(f"{path}: {len(dense)} Dense layers (expected 1 to {MAX_LAYERS})")
    return dense, decode


def _is_exp_minus_one(function: Any) -> bool:
    """Whether a Keras Lambda's marshalled function is the published ``lambda x: K.exp(x) - 1`` (by its names)."""
    code = function[0] if isinstance(function, list) and function else function
    if not isinstance(code, str):
        return False
    try:
        raw = base64.b64decode(code.encode("ascii"), validate=False)
    except (ValueError, UnicodeEncodeError):
        return False
    return b"exp" in raw and len(raw) < 4096


def read_weights(file: str) -> dict[str, NDArray[Any]]:
    """The weights of a Keras ``save_weights`` (or whole-model) file: ``layer_names`` and ``L/i`` arrays.

    Runs in the isolated child process (:func:`cdbrdf._isolated_read.arrays_in_child`).
    """
    import h5py

    p = Path(file)
    try:
        f = h5py.File(p, "r")
    except OSError as exc:
        raise FormatError(f"{p}: not a readable HDF5 file ({str(exc).splitlines()[0][:120]})") from None
    out: dict[str, NDArray[Any]] = {}
    try:
        root: Any = f
        if "layer_names" not in f.attrs and "model_weights" in f:
            root = f["model_weights"]
        names = [n.decode("utf-8", "replace") if isinstance(n, bytes) else str(n)
                 for n in np.asarray(root.attrs.get("layer_names", [])).reshape(-1)]
        if not names:
            raise FormatError(f"{p}: no Keras layer_names attribute; not the weights of a Keras network")
        if len(names) > 4 * MAX_LAYERS:
            raise FormatError(f"{p}: {len(names)} layers; not a Neural-BRDF network")
        out["layer_names"] = np.array(names, dtype="U64")
        for i, name in enumerate(names):
            if name not in root:
                raise FormatError(f"{p}: layer {name[:64]!r} is listed but has no group")
            g = root[name]
            wnames = [n.decode("utf-8", "replace") if isinstance(n, bytes) else str(n)
                      for n in np.asarray(g.attrs.get("weight_names", [])).reshape(-1)]
            for j, w in enumerate(wnames[:4]):
                ds = g.get(w)
                if not isinstance(ds, h5py.Dataset) or ds.ndim not in (1, 2) or ds.size > MAX_UNITS * MAX_UNITS:
                    raise FormatError(f"{p}: weight {w[:64]!r} of layer {name[:64]!r} is not a 1-D or 2-D array "
                                      f"of at most {MAX_UNITS * MAX_UNITS} numbers")
                if ds.dtype.kind != "f":
                    raise FormatError(f"{p}: weight {w[:64]!r} holds {ds.dtype}, not floating-point numbers")
                out[f"{i}/{j}"] = np.asarray(ds[()], dtype=np.float64)
    except (OSError, RuntimeError, KeyError, ValueError, TypeError) as exc:
        raise FormatError(f"{p}: its HDF5 structure cannot be read ({str(exc).splitlines()[0][:120]})") from None
    finally:
        f.close()
    return out


def _weights(path: Path) -> dict[str, NDArray[Any]]:
    from .._isolated_read import arrays_in_child
    from ..io import LEGACY_READ_TIMEOUT_S, LEGACY_START_TIMEOUT_S

    _read_small(path, "a Keras weights file")  # size, kind of file
    return arrays_in_child(path.absolute(), "cdbrdf.importers.nbrdf:read_weights", timeout_s=LEGACY_READ_TIMEOUT_S,
                           start_timeout_s=LEGACY_START_TIMEOUT_S)


def read_network(path: str | PathLike[str]) -> tuple[Network, dict[str, Any], bytes]:
    """The network of a Neural-BRDF pair, given either file.

    Returns
    -------
    tuple
        ``(network, details for the provenance, the bytes both files hash)``.

    Raises
    ------
    FileNotFoundError
        When ``path`` does not exist.
    FormatError
        One line naming the file and the problem: a partner file missing, an
        architecture this reader does not evaluate, weights that do not fit it.
    """
    arch_path, h5_path = pair(path)
    arch_bytes = _read_small(arch_path, "a Keras architecture (.json) file")
    h5_bytes = _read_small(h5_path, "a Keras weights (.h5) file")
    if not h5_bytes.startswith(_HDF5_MAGIC):
        raise FormatError(f"{h5_path}: not an HDF5 file; a Neural-BRDF network's weights are Keras' HDF5 file")
    dense, decode = _architecture(arch_path, arch_bytes)
    if not decode:
        raise FormatError(f"{arch_path}: no exp(x) - 1 output transform after the Dense layers; not a "
                          "Neural-BRDF network")
    w = _weights(h5_path)
    names = [str(n) for n in w["layer_names"]]
    kernels: list[NDArray[np.float64]] = []
    biases: list[NDArray[np.float64]] = []
    for name, _ in dense:
        if name not in names:
            raise FormatError(f"{h5_path}: has no weights for the layer {name!r} of {arch_path.name}")
        i = names.index(name)
        k, b = w.get(f"{i}/0"), w.get(f"{i}/1")
        if k is None or b is None or k.ndim != 2 or b.shape != (k.shape[1],):
            raise FormatError(f"{h5_path}: layer {name!r} needs a kernel (n_in, n_out) and a bias (n_out,)")
        if max(k.shape) > MAX_UNITS:
            raise FormatError(f"{h5_path}: layer {name!r} has {max(k.shape)} units, more than {MAX_UNITS}")
        if kernels and k.shape[0] != kernels[-1].shape[1]:
            raise FormatError(f"{h5_path}: layer {name!r} takes {k.shape[0]} inputs but the layer before gives "
                              f"{kernels[-1].shape[1]}")
        if not (np.all(np.isfinite(k)) and np.all(np.isfinite(b))):
            raise FormatError(f"{h5_path}: layer {name!r} holds NaN or infinite weights")
        kernels.append(k)
        biases.append(b)
    if kernels[0].shape[0] != 6 or kernels[-1].shape[1] != 3:
        raise FormatError(f"{h5_path}: the network maps {kernels[0].shape[0]} inputs to {kernels[-1].shape[1]} "
                          "outputs; a Neural-BRDF network maps the 6 half/difference coordinates to RGB (3)")
    net = Network(kernels=tuple(kernels), biases=tuple(biases), activations=tuple(a for _, a in dense),
                  layer_names=tuple(n for n, _ in dense))
    details: dict[str, Any] = {
        "architecture_file": arch_path.name,
        "weights_file": h5_path.name,
        "architecture_sha256": file_sha256(arch_bytes),
        "weights_sha256": file_sha256(h5_bytes),
        "layers": list(net.sizes),
        "activations": list(net.activations),
        "output_decode": OUTPUT_DECODE,
        "encoding": "Rusinkiewicz half/difference vectors, light = in: (sin theta_h, 0, cos theta_h, d_x, d_y, d_z) "
                    "(asztr/Neural-BRDF, mitsuba/bsdfs/nbrdf_npy.cpp)",
        "values": "BRDF in sr^-1 without the cosine, linear RGB (MERL channel scales in the training targets)",
        "keras_version": _keras_version(arch_bytes),
    }
    return net, details, arch_bytes + h5_bytes


def _keras_version(arch: bytes) -> str:
    try:
        v = json.loads(arch.decode("utf-8")).get("keras_version", "")
    except (ValueError, AttributeError):
        return ""
    return str(v)[:32]


def _asymmetry(net: Network) -> float:
    """Median relative difference of the raw network between (l, v) and (v, l) (cosine-distributed pairs)."""
    rng = np.random.default_rng(0)
    n = 4096
    t = np.degrees(np.arcsin(np.sqrt(rng.random((2, n)))))
    p = 360.0 * rng.random((2, n))
    a = net.forward(encode(t[0], p[0], t[1], p[1]))
    b = net.forward(encode(t[1], p[1], t[0], p[0]))
    m = 0.5 * (a + b)
    ok = m > 1e-6 * max(float(m.max()), 1e-30)
    return float(np.median(np.abs(a - b)[ok] / m[ok])) if np.any(ok) else 0.0


def read(path: str | PathLike[str], *, material: str | None = None) -> Source:
    """A Neural-BRDF network (``NAME.json`` + ``NAME.h5``, either given) as a :class:`~cdbrdf.importers.source.Source`.

    Isotropic, absolute (``quantity = "brdf"``), every value "measured" (the
    network covers the hemisphere; its error against the measurement it
    learned is the paper's, not known here), evaluated reciprocally (the
    module's description).

    Raises
    ------
    FileNotFoundError, FormatError
        As :func:`read_network`; also for values beyond the plausible bound.
    """
    net, details, data = read_network(path)
    arch_path, h5_path = pair(path)
    asym = _asymmetry(net)
    details["reciprocity"] = ("evaluated as the mean of the network at (l, v) and (v, l); the network's own "
                              "median relative difference between the two")
    details["network_asymmetry_median"] = round(asym, 6)
    if asym > ASYMMETRY_WARNING:
        log.warning("%s: the network differs between light and view swapped by a median %.1f %%; the mean of "
                    "both orders is used", h5_path, 100 * asym)

    def evaluate(theta_v: Any, phi_v: Any, theta_l: Any, phi_l: Any) -> tuple[NDArray[np.float64], None]:
        f = net.brdf(theta_v, phi_v, theta_l, phi_l)
        if f.size and float(f.max()) > MAX_PLAUSIBLE_BRDF:
            check_plausible(h5_path, f, what="the network's values")
        return f, None

    probe = np.linspace(0.0, 85.0, 18)
    check_plausible(h5_path, evaluate(probe, probe * 4.0, probe[::-1], -probe * 3.0)[0], what="the network's values")
    return Source(
        path=h5_path, format="nbrdf", symmetry="isotropic", quantity="brdf",
        colour_space="linear Rec.709 (sRGB primaries)", material=material or h5_path.stem, description="",
        details=details, evaluate=evaluate, sha256=file_sha256(data),
    )


def write(path: str | PathLike[str], kernels: list[NDArray[np.floating]], biases: list[NDArray[np.floating]],
          *, activations: list[str] | None = None) -> tuple[Path, Path]:
    """Write a network as Keras 2.2 does (``NAME.json`` + ``NAME.h5``, ``path`` either): for tests.

    ``activations`` default to ``relu`` for all but the last ``Dense`` layer
    (``linear``); the ``exp(x) - 1`` transform follows as a ``Lambda`` layer.
    """
    import h5py

    arch_path, h5_path = Path(path).with_suffix(".json"), Path(path).with_suffix(".h5")
    n = len(kernels)
    acts = activations or ["relu"] * (n - 1) + ["linear"]
    names = [f"dense_{i + 1}" for i in range(n)]
    lam = base64.b64encode(b"\xe3" + b"\x00" * 16 + b"exp" + b"\x00" * 8).decode("ascii") + "\n"
    layers: list[dict[str, Any]] = [
        {"class_name": "Dense", "config": {"name": nm, "units": int(np.shape(k)[1]), "activation": a,
                                           "use_bias": True}}
        for nm, k, a in zip(names, kernels, acts)]
    layers[0]["config"]["batch_input_shape"] = [None, int(np.shape(kernels[0])[0])]
    layers.append({"class_name": "Lambda", "config": {"name": "lambda_1", "function": [lam, None, None],
                                                      "function_type": "lambda"}})
    arch = {"class_name": "Sequential", "config": {"name": "sequential_1", "layers": layers},
            "keras_version": "2.2.4", "backend": "tensorflow"}
    arch_path.write_text(json.dumps(arch))
    with h5py.File(h5_path, "w", libver="earliest") as f:
        f.attrs["layer_names"] = np.array([nm.encode() for nm in names + ["lambda_1"]])
        f.attrs["keras_version"] = b"2.2.4"
        f.attrs["backend"] = b"tensorflow"
        for nm, k, b in zip(names, kernels, biases):
            g = f.create_group(nm)
            g.attrs["weight_names"] = np.array([f"{nm}/kernel:0".encode(), f"{nm}/bias:0".encode()])
            sub = g.create_group(nm)
            sub["kernel:0"] = np.asarray(k, dtype=np.float32)
            sub["bias:0"] = np.asarray(b, dtype=np.float32)
        f.create_group("lambda_1").attrs["weight_names"] = np.array([], dtype="S1")
    return arch_path, h5_path
