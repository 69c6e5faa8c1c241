"""RGL material database ``.bsdf`` files (Dupuy & Jakob 2018), as Mitsuba 3's ``measured`` plug-in reads them.

The file is a *tensor file*: the 12 bytes ``tensor_file\\0``, the version
(two bytes, 1 0), the number of fields (uint32), then per field its name
(uint16 length + UTF-8), its number of dimensions (uint16), its type (uint8:
1 uint8, 2 int8, 3 uint16, 4 int16, 5 uint32, 6 int32, 7 uint64, 8 int64, 9
float16, 10 float32, 11 float64), the offset of its data (uint64) and its
shape (uint64 each), all little-endian; the data follow. A material holds
``description`` (UTF-8 text), ``theta_i`` and ``phi_i`` (the incident
directions it was measured from, radians), ``ndf``, ``sigma``, ``vndf`` and
``luminance`` (the adaptive parameterisation), the reflectance as ``rgb``
(``phi_i x theta_i x 3 x 32 x 32``) or as ``spectra`` plus ``wavelengths``
(nm), ``jacobian`` and ``valid`` (one bit per reflectance sample: measured or
not, packed most significant bit first).

Values are taken from Mitsuba's own ``measured`` plug-in, evaluated
vectorised in ``llvm_ad_rgb`` at the quadrature points of the resampler, so
the table reproduces exactly what Mitsuba renders. Mitsuba's ``eval`` returns
``f * cos(theta)`` of its ``wo`` with ``si.wi`` the view direction; the BRDF
in sr^-1 is that divided by the cosine of the light direction. Spectral files
are converted first to an RGB file of the same layout (the conversion is
linear, so converting the samples is converting the BRDF): CIE 1931 2-degree
observer and illuminant D65 (Mitsuba's tables), the spectrum interpolated
linearly between the file's wavelengths, XYZ to linear Rec. 709, white
balanced so that a flat spectrum of 1 gives RGB (1, 1, 1). The ``valid`` bits
become the table's measured share: each evaluation's position in the
reflectance grid is found by inverting the VNDF warp exactly as the plug-in
does, and the bits are interpolated there like the reflectance.

Refused, with one line naming the file and the problem: foreign or truncated
files, unknown tensor versions or types, fields that overlap the end of the
file, missing or inconsistent fields, non-finite values, polarised
(Mueller-matrix) files and transmission (BTDF) data.
"""

from __future__ import annotations

import logging
import struct
import tempfile
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from os import PathLike
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..errors import FormatError
from .source import Source, check_plausible, file_sha256, mitsuba, mitsuba_brdf, read_bytes

__all__ = ["MAGIC", "DTYPES", "read_tensor_file", "write_tensor_file", "spectral_to_rgb_weights", "read"]

_LOG = logging.getLogger(__name__)

#: First 12 bytes of a tensor file.
MAGIC = b"tensor_file\0"
#: Tensor file type codes -> NumPy dtypes (Mitsuba's struct types).
DTYPES: Mapping[int, str] = {1: "u1", 2: "i1", 3: "<u2", 4: "<i2", 5: "<u4", 6: "<i4", 7: "<u8", 8: "<i8",
                             9: "<f2", 10: "<f4", 11: "<f8"}
_CODES = {np.dtype(v).str.lstrip("<|"): k for k, v in DTYPES.items()}
_MAX_FIELDS = 4096
#: Largest magnitude a field may hold (float32 sums of the plug-in stay finite).
_MAX_ABS = 1e30
_MAX_NDIM = 16

#: Fields of a polarised (Mueller-matrix) RGL file, read by Mitsuba's ``measured_polarized``.
_POLARISED = ("M", "theta_h", "theta_d", "phi_d", "wvls")
#: Field names that mark transmission data.
_TRANSMISSION = ("btdf", "transmission", "transmittance", "eta")


def _fail(path: Path, problem: str) -> FormatError:
    return FormatError(f"{path}: {problem}")


def read_tensor_file(path: Path, data: bytes) -> dict[str, NDArray[Any]]:
    """The fields of a tensor file's bytes, checked against the file's size.

    Raises
    ------
    FormatError
        For a foreign or truncated file, an unknown version or type, a name
        that is not UTF-8, a field whose data leave the file.
    """
    if len(data) < 18:
        raise _fail(path, f"not an RGL .bsdf tensor file (only {len(data)} bytes)")
    if data[:12] != MAGIC:
        raise _fail(path, f"not an RGL .bsdf tensor file (its first bytes are {data[:12]!r}, "
                          f"expected {MAGIC!r})")
    if data[12:14] != b"\x01\x00":
        raise _fail(path, f"unknown tensor file version {data[12]}.{data[13]} (this reader knows 1.0)")
    (n_fields,) = struct.unpack_from("<I", data, 14)
    if n_fields > _MAX_FIELDS:
        raise _fail(path, f"declares {n_fields} fields: damaged or not a material file")
    pos = 18
    fields: dict[str, NDArray[Any]] = {}
    try:
        for _ in range(n_fields):
            (nlen,) = struct.unpack_from("<H", data, pos)
            pos += 2
            raw = data[pos:pos + nlen]
            if len(raw) != nlen:
                raise _fail(path, "truncated in the field table")
            try:
                name = raw.decode("utf-8")
            except UnicodeDecodeError:
                raise _fail(path, "a field name is not UTF-8 text: damaged file") from None
            pos += nlen
            ndim, code, offset = struct.unpack_from("<HBQ", data, pos)
            pos += 11
            if ndim > _MAX_NDIM:
                raise _fail(path, f"field {name!r} declares {ndim} dimensions: damaged file")
            shape = struct.unpack_from(f"<{ndim}Q", data, pos)
            pos += 8 * ndim
            if any(s > len(data) for s in shape):
                raise _fail(path, f"field {name!r} declares a dimension of {max(shape)}, more than the file's "
                                  f"{len(data)} bytes: damaged file")
            if code not in DTYPES:
                raise _fail(path, f"field {name!r} has the unknown type code {code}")
            dt = np.dtype(DTYPES[code])
            count = 1
            for s in shape:
                count *= int(s)
            nbytes = count * dt.itemsize
            if offset > len(data) or nbytes > len(data) - offset:
                raise _fail(path, f"field {name!r} ({'x'.join(map(str, shape)) or 'scalar'} {dt.name}) "
                                  f"runs past the end of the file ({len(data)} bytes): truncated")
            fields[name] = np.frombuffer(data, dtype=dt, count=count, offset=offset).reshape(shape)
    except struct.error:
        raise _fail(path, "truncated in the field table") from None
    return fields


def write_tensor_file(path: str | PathLike[str], fields: Mapping[str, Any], *, align: int = 8) -> None:
    """Write ``fields`` (name -> array or str) as a tensor file (as Mitsuba's ``tensor_io.write`` does)."""
    arrays = {}
    for k, v in fields.items():
        a = np.frombuffer(v.encode("utf-8"), dtype=np.uint8) if isinstance(v, str) else np.ascontiguousarray(v)
        key = a.dtype.str.lstrip("<|")
        if key not in _CODES:
            raise ValueError(f"field {k!r}: dtype {a.dtype} has no tensor file type")
        arrays[k] = a
    head = bytearray(MAGIC + b"\x01\x00" + struct.pack("<I", len(arrays)))
    for k, a in arrays.items():
        code = _CODES[a.dtype.str.lstrip("<|")]
        head += struct.pack("<H", len(k.encode())) + k.encode() + struct.pack("<HB", a.ndim, code)
        head += b"\0" * 8 + struct.pack(f"<{a.ndim}Q", *a.shape)
    body = bytearray()
    offsets = []
    base = len(head)
    for a in arrays.values():
        pad = (-(base + len(body))) % align
        body += b"\0" * pad
        offsets.append(base + len(body))
        body += a.astype(a.dtype.newbyteorder("<"), copy=False).tobytes()
    pos = 18
    for (k, a), off in zip(arrays.items(), offsets):
        pos += 2 + len(k.encode()) + 3
        head[pos:pos + 8] = struct.pack("<Q", off)
        pos += 8 + 8 * a.ndim
    Path(path).write_bytes(bytes(head + body))


# -- the material ----------------------------------------------------------------------------
def _check_kind(path: Path, f: Mapping[str, NDArray[Any]]) -> None:
    if "M" in f or sum(k in f for k in _POLARISED) >= 3:
        raise _fail(path, "a polarised (Mueller-matrix) RGL file, for Mitsuba's measured_polarized: "
                          "not supported (use the RGB or spectral file of the material)")
    bad = [k for k in f if k.lower() in _TRANSMISSION]
    if bad:
        raise _fail(path, f"holds transmission data (field {bad[0]!r}): BTDFs are not supported, "
                          "only reflection (BRDF) files")


def _field(path: Path, f: Mapping[str, NDArray[Any]], name: str, ndim: int, kinds: str) -> NDArray[Any]:
    if name not in f:
        raise _fail(path, f"not an RGL material file: no field {name!r} (fields: {', '.join(sorted(f)) or 'none'})")
    a = f[name]
    if a.ndim != ndim or a.dtype.kind not in kinds:
        raise _fail(path, f"field {name!r} is {a.dtype.name} of shape {a.shape}, expected {ndim} dimension(s)")
    return a


def _check_values(path: Path, out: Mapping[str, Any]) -> None:
    """Finite, bounded values; incident elevations from 0 within [0, 90]; distributions that can be sampled."""
    th, ph = out["theta_i"], out["phi_i"]
    n_ph = ph.size
    for name, a in out.items():
        if isinstance(a, np.ndarray) and a.dtype.kind == "f" and not np.all(np.isfinite(a)):
            raise _fail(path, f"field {name!r} holds {int(np.count_nonzero(~np.isfinite(a)))} NaN or infinite "
                              "value(s)")
    if abs(float(th[0])) > 1e-6:
        raise _fail(path, f"'theta_i' starts at {np.degrees(th[0]):.4g} degrees; the material's incident "
                          "elevations must start at 0")
    if np.any(np.diff(th) <= 0) or th[0] < 0 or th[-1] > np.pi / 2 + 1e-4:
        if th[-1] > np.pi / 2 + 1e-4:
            raise _fail(path, f"incident elevations up to {np.degrees(th[-1]):.1f} degrees: transmission (BTDF) "
                              "data are not supported, only reflection")
        raise _fail(path, "'theta_i' is not increasing within [0, 90] degrees")
    if np.any(np.diff(ph) <= 0) or np.any(np.abs(ph) > 2 * np.pi + 1e-4):
        raise _fail(path, "'phi_i' is not increasing within one turn")
    if n_ph > 2 and ph[-1] - ph[0] <= 0:
        raise _fail(path, "'phi_i' spans no angle")
    for name in ("vndf", "luminance", "ndf", "sigma"):
        if np.any(out[name] < 0) or not np.any(out[name] > 0):
            raise _fail(path, f"field {name!r} holds negative values or only zeros: not a distribution")
    for name in ("vndf", "luminance"):
        sums = out[name].astype(np.float64).sum(axis=(2, 3))
        if np.any(sums <= 0):
            i = np.argwhere(sums <= 0)[0]
            raise _fail(path, f"field {name!r} is all zeros at incident direction {tuple(int(x) for x in i)}: "
                              "not a distribution")
    for name, a in out.items():
        if isinstance(a, np.ndarray) and a.dtype.kind == "f" and a.size and float(np.abs(a).max()) > _MAX_ABS:
            raise _fail(path, f"field {name!r} holds values up to {float(np.abs(a).max()):.3g}, beyond "
                              f"+-{_MAX_ABS:g}: damaged")


def _validate(path: Path, f: Mapping[str, NDArray[Any]]) -> dict[str, Any]:
    """The checked fields (float32 copies) of an RGL material, and whether it is spectral."""
    _check_kind(path, f)
    desc = _field(path, f, "description", 1, "u")
    try:
        description = bytes(desc).decode("utf-8").strip()
    except UnicodeDecodeError:
        description = bytes(desc).decode("utf-8", "replace").strip()
    out: dict[str, Any] = {"description": description}
    for name, ndim in (("theta_i", 1), ("phi_i", 1), ("ndf", 2), ("sigma", 2), ("vndf", 4), ("luminance", 4)):
        a = _field(path, f, name, ndim, "f")
        if a.dtype != np.float32:
            raise _fail(path, f"field {name!r} is {a.dtype.name}, Mitsuba's measured plug-in needs float32")
        out[name] = np.array(a, dtype=np.float32)
    spectral = "wavelengths" in f or "spectra" in f
    if spectral:
        wl = _field(path, f, "wavelengths", 1, "f")
        sp = _field(path, f, "spectra", 5, "f")
        out["wavelengths"] = np.array(wl, dtype=np.float32)
        out["spectra"] = np.array(sp, dtype=np.float32)
        refl = out["spectra"]
        if refl.shape[2] != wl.size:
            raise _fail(path, f"'spectra' has {refl.shape[2]} wavelengths but 'wavelengths' {wl.size}")
        w64 = out["wavelengths"].astype(np.float64)
        if wl.size < 2 or not np.all(np.diff(w64) > 0):  # descending: other colours; repeated: no spectrum
            raise _fail(path, "'wavelengths' must be at least 2, strictly increasing (got "
                              f"{', '.join(f'{x:g}' for x in w64[:6])}{' ...' if w64.size > 6 else ''} nm)")
    else:
        refl = out["rgb"] = np.array(_field(path, f, "rgb", 5, "f"), dtype=np.float32)
        if refl.shape[2] != 3:
            raise _fail(path, f"'rgb' has {refl.shape[2]} channels, expected 3")
    jac = _field(path, f, "jacobian", 1, "u")
    if jac.size != 1:
        raise _fail(path, f"'jacobian' has {jac.size} entries, expected 1")
    out["jacobian"] = np.array(jac, dtype=np.uint8)
    th, ph = out["theta_i"], out["phi_i"]
    n_ph, n_th = ph.size, th.size
    if n_th < 2 or n_ph < 1:
        raise _fail(path, f"needs at least 2 incident elevations and 1 azimuth, got {n_th} and {n_ph}")
    shapes = {"vndf": (n_ph, n_th), "luminance": (n_ph, n_th), "rgb" if not spectral else "spectra": (n_ph, n_th)}
    for name, lead in shapes.items():
        if out[name].shape[:2] != lead:
            raise _fail(path, f"{name!r} has shape {out[name].shape}, expected ({n_ph}, {n_th}, ...) "
                              "as theta_i and phi_i give")
    ny, nx = refl.shape[3:]
    if out["luminance"].shape[2:] != (ny, nx) or ny != nx or ny < 2:
        raise _fail(path, f"'luminance' {out['luminance'].shape} and the reflectance {refl.shape} do not match")
    for name in ("ndf", "sigma"):
        if min(out[name].shape) < 2:
            raise _fail(path, f"{name!r} has shape {out[name].shape}, too small")
    _check_values(path, out)
    n_valid = n_ph * n_th * ny * nx
    if "valid" in f:
        v = f["valid"]
        if v.dtype != np.uint8 or v.size * 8 < n_valid:
            raise _fail(path, f"'valid' holds {v.size} bytes, {(n_valid + 7) // 8} are needed for its bits")
        bits = np.unpackbits(np.asarray(v).reshape(-1))[:n_valid]  # most significant bit first
        if not bits.any():
            raise _fail(path, "holds no measured sample (every 'valid' bit is 0)")
        out["valid"] = bits.reshape(n_ph, n_th, ny, nx).astype(np.float32)
    out["spectral"] = spectral
    return out


def spectral_to_rgb_weights(wavelengths_nm: NDArray[np.floating]) -> NDArray[np.float64]:
    """``(3, n)`` weights turning samples at ``wavelengths_nm`` into linear Rec. 709 RGB.

    The spectrum is linear between the samples (constant beyond them),
    integrated against the CIE 1931 2-degree observer under D65 (Mitsuba's
    tables, 1 nm steps over 360-830 nm), converted XYZ -> linear Rec. 709 and
    white balanced so that a flat spectrum of 1 gives exactly (1, 1, 1).
    """
    mi, _ = mitsuba()
    wl = np.asarray(wavelengths_nm, dtype=np.float64)
    fine = np.arange(360.0, 831.0, 1.0)
    eye = np.eye(wl.size)
    hat = np.stack([np.interp(fine, wl, eye[i]) for i in range(wl.size)], axis=1)  # (n_fine, n)
    with rgb_variant():
        xyz = np.array(mi.cie1931_xyz(mi.Float(fine.astype(np.float32))), dtype=np.float64)  # (3, n_fine)
        d65 = np.array(mi.cie_d65(mi.Float(fine.astype(np.float32))), dtype=np.float64)
    w_xyz = (xyz * d65) @ hat / float(np.sum(xyz[1] * d65))
    m = np.array([[3.2404542, -1.5371385, -0.4985314],
                  [-0.9692660, 1.8760108, 0.0415560],
                  [0.0556434, -0.2040259, 1.0572252]])
    w = m @ w_xyz
    return w / w.sum(axis=1, keepdims=True)


@contextmanager
def rgb_variant() -> Iterator[None]:
    """Mitsuba in an RGB variant for a ``with`` block: the active one if it is, else llvm_ad_rgb (then restored)."""
    mi, _ = mitsuba()
    if mi.variant() in ("llvm_ad_rgb", "cuda_ad_rgb"):
        yield
        return
    from ..render import variant

    with variant("llvm_ad_rgb"):
        yield


def _rgb_file(path: Path, fields: Mapping[str, Any], folder: Path) -> tuple[Path, dict[str, Any]]:
    """An RGB tensor file for Mitsuba: the original when it is RGB, else the spectra converted."""
    if not fields["spectral"]:
        return path, {}
    w = spectral_to_rgb_weights(fields["wavelengths"])
    rgb = np.einsum("cw,ptwyx->ptcyx", w, fields["spectra"].astype(np.float64)).astype(np.float32)
    out = {k: fields[k] for k in ("theta_i", "phi_i", "sigma", "ndf", "vndf", "luminance")}
    out.update(description=fields["description"], rgb=rgb, jacobian=fields["jacobian"],
               version=np.array([1, 0], np.uint32))
    p = folder / "rgb.bsdf"
    write_tensor_file(p, out)
    wl = fields["wavelengths"]
    return p, {"spectral": {"wavelengths_nm": [float(wl[0]), float(wl[-1])], "n_wavelengths": int(wl.size),
                            "conversion": "CIE 1931 2-degree observer, D65, XYZ -> linear Rec.709, "
                                          "white-balanced (flat spectrum of 1 -> RGB 1, 1, 1)"}}


class _Evaluator:
    """Mitsuba's ``measured`` plug-in at arrays of directions, plus the measured share from the ``valid`` bits."""

    def __init__(self, path: Path, fields: Mapping[str, Any]) -> None:
        with rgb_variant():
            self._load(path, fields)

    def _load(self, path: Path, fields: Mapping[str, Any]) -> None:
        mi, _ = mitsuba()
        self._tmp = tempfile.TemporaryDirectory(prefix="cdbrdf-rgl-")
        rgb_path, self.conversion = _rgb_file(path, fields, Path(self._tmp.name))
        try:
            self.bsdf = mi.load_dict({"type": "measured", "filename": str(rgb_path)})
        except RuntimeError as exc:
            raise _fail(path, f"Mitsuba's measured plug-in refuses it ({str(exc).splitlines()[-1][:200]})") from None
        finally:
            self._tmp.cleanup()
        self.path = path
        ph = fields["phi_i"].astype(np.float64)
        th = fields["theta_i"].astype(np.float64)
        self.isotropic = ph.size <= 2
        self.reduction = 0 if self.isotropic else int(np.rint(2 * np.pi / (ph[-1] - ph[0])))
        self.params = [list(map(float, ph)), list(map(float, th))]
        self.vndf: Any = None
        self.valid: Any = None
        if "valid" in fields:
            self.vndf = mi.MarginalContinuous2D2(np.array(fields["vndf"], dtype=np.float32), self.params, True, True)
            self.valid = mi.MarginalContinuous2D2(np.array(fields["valid"], dtype=np.float32), self.params, False,
                                                  False)
        self._probe(path)

    def _probe(self, path: Path) -> None:
        """Evaluate at a spread of directions: a file whose distributions the plug-in cannot use gives NaN."""
        rng = np.random.default_rng(0)
        n = 512
        q = [rng.uniform(0, 89.9, n), rng.uniform(-180, 180, n), rng.uniform(0, 89.9, n), rng.uniform(-180, 180, n)]
        for a in (q[0], q[2]):  # along the normal and grazing too
            a[:64] = 0.0
            a[64:96] = 89.9
        self(*q)

    def _check(self, f: NDArray[np.float64], m: NDArray[np.float64] | None) -> None:
        bad = int(np.count_nonzero(~np.isfinite(f).all(axis=1)))
        if m is not None:
            bad += int(np.count_nonzero(~np.isfinite(m)))
        if bad:
            raise _fail(self.path, f"Mitsuba's measured plug-in gives NaN or infinite values at {bad} of {f.shape[0]} "
                                   "directions: the file's distributions are damaged")
        check_plausible(self.path, f, what="BRDF values (Mitsuba's measured plug-in)")

    def __call__(self, theta_v: NDArray[np.float64], phi_v: NDArray[np.float64], theta_l: NDArray[np.float64],
                 phi_l: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64] | None]:
        with rgb_variant():  # the variant the plug-in was loaded in
            return self._evaluate(theta_v, phi_v, theta_l, phi_l)

    def _evaluate(self, theta_v: NDArray[np.float64], phi_v: NDArray[np.float64], theta_l: NDArray[np.float64],
                  phi_l: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64] | None]:
        _, dr = mitsuba()
        f, wi, wo = mitsuba_brdf(self.bsdf, theta_v, phi_v, theta_l, phi_l)
        if self.valid is None:
            out = np.array(f, dtype=np.float64).T
            self._check(out, None)
            return out, None
        val = self._measured(wi, wo)
        dr.eval(f, val)
        out, share = np.array(f, dtype=np.float64).T, np.array(val, dtype=np.float64)
        self._check(out, share)
        return out, np.clip(share, 0.0, 1.0)

    def _measured(self, wi: Any, wo: Any) -> Any:
        """The ``valid`` bits interpolated at each evaluation's position in the reflectance grid.

        The position is found as in the plug-in's ``eval``: the half vector's
        elevation and azimuth (relative to the view's for isotropic data, after
        the mirror reduction of anisotropic ones) mapped through the inverse
        of the VNDF warp.
        """
        mi, dr = mitsuba()
        if self.reduction >= 2:
            sy = wi.y
            sx = wi.x if self.reduction == 4 else sy
            wi = mi.Vector3f(dr.mulsign_neg(wi.x, sx), dr.mulsign_neg(wi.y, sy), wi.z)
            wo = mi.Vector3f(dr.mulsign_neg(wo.x, sx), dr.mulsign_neg(wo.y, sy), wo.z)
        m = dr.normalize(wi + wo)

        def elevation(d: Any) -> Any:
            return 2.0 * dr.safe_asin(0.5 * dr.sqrt(dr.square(d.x) + dr.square(d.y) + dr.square(d.z - 1.0)))

        theta_i, phi_i = elevation(wi), dr.atan2(wi.y, wi.x)
        theta_m, phi_m = elevation(m), dr.atan2(m.y, m.x)
        if self.isotropic:
            phi_m = phi_m - phi_i
        u = (phi_m + dr.pi) * (0.5 / dr.pi)
        um = mi.Point2f(dr.sqrt(theta_m * (2.0 / dr.pi)), u - dr.floor(u))
        params = mi.Point2f(phi_i, theta_i)
        sample, _ = self.vndf.invert(um, params)
        return self.valid.eval(sample, params)


def read(path: str | PathLike[str], *, material: str | None = None) -> Source:
    """An RGL ``.bsdf`` file as a :class:`~cdbrdf.importers.source.Source`.

    Parameters
    ----------
    path
        The file (RGB or spectral; isotropic or anisotropic).
    material
        Name for the table (default: the file's description).

    Raises
    ------
    FormatError
        For anything but a valid RGL reflection file (see the module docstring).
    """
    p, data = read_bytes(path, what="an RGL .bsdf file")
    fields = _validate(p, read_tensor_file(p, data))
    ev = _Evaluator(p, fields)
    th = np.degrees(fields["theta_i"].astype(np.float64))
    details: dict[str, Any] = {
        "reader": "Mitsuba 3 'measured' plug-in (llvm_ad_rgb), divided by cos(theta_l)",
        "incident_elevations_deg": [round(float(x), 4) for x in th],
        "incident_azimuths": int(fields["phi_i"].size),
        "resolution": list(map(int, fields["vndf"].shape)),
        "samples_measured": (None if "valid" not in fields else
                             f"{int(fields['valid'].sum())} of {fields['valid'].size}"),
        "channels": "spectral" if fields["spectral"] else "rgb",
    }
    details.update(ev.conversion)
    return Source(
        path=p,
        format="rgl",
        symmetry="isotropic" if ev.isotropic else "anisotropic",
        quantity="brdf",
        colour_space="linear Rec.709 (sRGB primaries)",
        material=material or fields["description"] or p.stem,
        description=fields["description"],
        details=details,
        evaluate=ev,
        sha256=file_sha256(data),
    )
