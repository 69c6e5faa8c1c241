"""RGB table values as spectra and grey: Mitsuba's sRGB spectral upsampling, vectorised.

Mitsuba's spectral variants turn an RGB reflectance into a smooth spectrum
with the model of Jakob & Hanika (2019, "A Low-Dimensional Function Space for
Efficient Spectral Upsampling"): three coefficients ``c`` per colour, read by
trilinear interpolation from the table ``data/srgb.coeff`` shipped with
Mitsuba, and the spectrum ``s(lambda) = 1/2 + x / (2 sqrt(1 + x^2))`` with
``x = (c0 lambda + c1) lambda + c2`` (lambda in nm). A ``bitmap`` texture or an
RGB mesh attribute stores the coefficients of every sample and blends the
*spectra* of neighbouring samples ("the expansion is nonlinear and therefore
precedes the blend"). The plug-in does the same with the table's samples
(:func:`spectral_records`); :func:`srgb_coefficients` is the coefficient
fetch for whole arrays (Mitsuba's ``mi.srgb_model_fetch`` takes one colour
per call) and agrees with it to float32 rounding (tested).

The model covers colours in [0, 1]. A BRDF value ``f`` (sr^-1) is upsampled
as the reflectance-like colour ``rho = pi f``: where ``max(rho) <= 1`` the
spectrum is the model of ``rho`` divided by pi, exactly what Mitsuba's
``diffuse`` does with an RGB reflectance (so a constant table renders as
``diffuse``); brighter samples (glossy peaks) are divided by their largest
component before the fetch and the spectrum multiplied back. Negative
channels are clamped to 0 (as Mitsuba's model does).

Mono variants use the Rec. 709 luminance of the RGB value (Mitsuba's rule
for RGB inputs in mono variants).
"""

from __future__ import annotations

import functools
import math
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import FormatError

__all__ = ["SRGBModel", "srgb_model", "srgb_coefficients", "spectral_records", "model_path", "LazySpectra",
           "lazy_table"]

#: The coefficient c2 of saturated greys (black: -c2, white: +c2), as in Mitsuba.
_SATURATED = 8192.0


class SRGBModel:
    """The coefficient table of Mitsuba's sRGB upsampling model (``data/srgb.coeff``).

    Attributes
    ----------
    res
        Table resolution per axis (64 in Mitsuba 3).
    scale
        ``(res,)`` the nodes of the brightness axis (the largest component).
    data
        ``(3, res, res, res, 3)`` coefficients by largest component, brightness
        node, and the two other (scaled) components.
    """

    def __init__(self, path: str | Path) -> None:
        raw = Path(path).read_bytes()
        if raw[:4] != b"SPEC":
            raise FormatError(f"{path}: not an RGB-to-spectrum coefficient table (no 'SPEC' header)")
        res = int(np.frombuffer(raw, dtype="<u4", count=1, offset=4)[0])
        n = res**3 * 9
        if res < 2 or len(raw) < 8 + 4 * (res + n):
            raise FormatError(f"{path}: truncated RGB-to-spectrum coefficient table")
        self.res = res
        self.scale = np.frombuffer(raw, dtype="<f4", count=res, offset=8).astype(np.float64)
        self.data = np.frombuffer(raw, dtype="<f4", count=n, offset=8 + 4 * res).reshape(3, res, res, res, 3)


def model_path() -> Path:
    """Where Mitsuba keeps ``data/srgb.coeff`` (next to the ``mitsuba`` package)."""
    import mitsuba

    return Path(mitsuba.__file__).parent / "data" / "srgb.coeff"


@functools.cache
def srgb_model() -> SRGBModel:
    """Mitsuba's coefficient table, read once per process."""
    return SRGBModel(model_path())


def srgb_coefficients(rgb: ArrayLike, model: SRGBModel | None = None) -> NDArray[np.float32]:
    """Coefficients ``(..., 3)`` of Mitsuba's sRGB model for linear RGB ``(..., 3)`` (clamped to [0, 1]).

    The same computation as Mitsuba's ``srgb_model_fetch``: the largest
    component picks the sub-table and (through the node search on ``scale``)
    the brightness cell, the other two components divided by it pick the
    chromaticity cell, and the coefficients are interpolated trilinearly in
    float32; greys get Mitsuba's exact coefficients ``(0, 0, c)`` (black and
    white ``c = -+8192``).
    """
    m = model or srgb_model()
    c = np.clip(np.asarray(rgb, dtype=np.float32), 0.0, 1.0)
    shape = c.shape[:-1]
    c = c.reshape(-1, 3)
    n = c.shape[0]
    rows = np.arange(n)
    # the largest component, the last one on ties
    i = np.where(c[:, 2] >= np.where(c[:, 1] >= c[:, 0], c[:, 1], c[:, 0]), 2, np.where(c[:, 1] >= c[:, 0], 1, 0))
    z = c[rows, i]
    black = z <= 0.0
    zs = np.where(black, np.float32(1.0), z)
    res = m.res
    scale = np.float32(res - 1) / zs
    x = c[rows, (i + 1) % 3] * scale
    y = c[rows, (i + 2) % 3] * scale
    xi = np.minimum(x.astype(np.int64), res - 2)
    yi = np.minimum(y.astype(np.int64), res - 2)
    nodes = m.scale.astype(np.float32)
    zi = np.clip(np.searchsorted(nodes, z, side="right") - 1, 0, res - 2)
    x1 = (x - xi).astype(np.float32)
    y1 = (y - yi).astype(np.float32)
    z1 = ((z - nodes[zi]) / (nodes[zi + 1] - nodes[zi])).astype(np.float32)
    x0, y0, z0 = 1 - x1, 1 - y1, 1 - z1
    d = m.data

    def at(dz: int, dy: int, dx: int) -> NDArray[np.float32]:
        return d[i, zi + dz, yi + dy, xi + dx]

    out = ((at(0, 0, 0) * x0[:, None] + at(0, 0, 1) * x1[:, None]) * y0[:, None]
           + (at(0, 1, 0) * x0[:, None] + at(0, 1, 1) * x1[:, None]) * y1[:, None]) * z0[:, None] \
        + ((at(1, 0, 0) * x0[:, None] + at(1, 0, 1) * x1[:, None]) * y0[:, None]
           + (at(1, 1, 0) * x0[:, None] + at(1, 1, 1) * x1[:, None]) * y1[:, None]) * z1[:, None]
    out = out.astype(np.float32)
    # Greys have exact coefficients (0, 0, c) with s_c = the grey; black and white saturate.
    grey = (c[:, 0] == c[:, 1]) & (c[:, 1] == c[:, 2])
    g = c[:, 0]
    with np.errstate(divide="ignore", invalid="ignore"):
        c2 = (g - np.float32(0.5)) / np.sqrt(g * (np.float32(1.0) - g))
    c2 = np.where(g <= 0.0, np.float32(-_SATURATED), np.where(g >= 1.0, np.float32(_SATURATED), c2))
    out[grey] = 0.0
    out[grey, 2] = c2[grey]
    return out.reshape(shape + (3,))


def spectral_records(values: ArrayLike, model: SRGBModel | None = None) -> NDArray[np.float32]:
    """Per sample ``(c0, c1, c2, scale)`` ``(..., 4)``: its spectrum is ``scale * s_c(lambda)``.

    ``values (..., 3)`` are BRDF values (sr^-1); see the module docstring for
    the reflectance-like colour ``rho = pi f`` and the treatment of values
    brighter than 1 and of black.
    """
    v = np.asarray(values, dtype=np.float64)
    rho = np.clip(v, 0.0, None) * math.pi
    peak = rho.max(axis=-1)
    norm = np.where(peak > 1.0, peak, 1.0)
    coeff = srgb_coefficients(rho / norm[..., None], model)
    scale = np.where(peak > 0.0, norm / math.pi, 0.0)
    out = np.empty(v.shape[:-1] + (4,), dtype=np.float32)
    out[..., :3] = coeff
    out[..., 3] = scale
    return out


class LazySpectra:
    """Spectra of prepared samples at fixed wavelengths, computed for the samples read (scalar variants).

    ``records`` are :func:`cdbrdf.render._lookup_jit.records` (three model
    coefficients and a scale per sample).
    """

    def __init__(self, records: NDArray, wavelengths: NDArray) -> None:
        self.records = records
        self.wavelengths = wavelengths
        self.shape = records.shape[:-1] + (wavelengths.size,)

    def __getitem__(self, idx: tuple[int, ...]) -> NDArray:
        r = self.records[idx].astype(np.float64)
        x = (r[0] * self.wavelengths + r[1]) * self.wavelengths + r[2]
        return r[3] * np.maximum(0.0, 0.5 * x / np.sqrt(x * x + 1.0) + 0.5)


def lazy_table(grid: Any, records: NDArray, wavelengths: NDArray) -> Any:
    """A table whose prepared samples are the spectra of ``records`` at ``wavelengths`` (for ``evaluate_reference``)."""
    from types import SimpleNamespace

    spectra: Any = LazySpectra(records, wavelengths)
    return SimpleNamespace(lookup_grid=lambda: grid._replace(values=spectra))
