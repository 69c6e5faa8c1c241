"""Reflectance spectra to colour: CIE 1931 2-degree XYZ under D65 and linear Rec. 709 RGB.

The presets' colours come from dye and fibre spectra (:mod:`cdbrdf.synth.colorants`);
this module turns a reflectance spectrum into the numbers a fabric model takes. The
colour-matching functions and the illuminant are the CIE's tables as the
``colour-science`` package holds them (imported inside the functions), at 1 nm over
360-830 nm; the sum is CIE 15:2004's, section 7.1.

References
----------
CIE 15:2004, Colorimetry, 3rd edition, sections 7.1 (tristimulus values) and 8.2.1.

Examples
--------
>>> import numpy as np
>>> wl = np.array([400.0, 700.0])
>>> reflectance_to_linear(wl, np.full(2, 0.5)).round(6).tolist()
[0.5, 0.5, 0.5]
"""

from __future__ import annotations

from functools import cache

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .colour import RGB_TO_XYZ
from .errors import OptionError

__all__ = ["CIE_WAVELENGTHS_NM", "reflectance_to_xyz", "reflectance_to_linear"]

#: Wavelengths (nm) the sums run over: the CIE tables' 360-830 nm in 1 nm steps.
CIE_WAVELENGTHS_NM: NDArray[np.float64] = np.arange(360.0, 831.0, 1.0)


@cache
def _cie_d65_tables() -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """CIE 1931 2-degree colour-matching functions ``(n, 3)`` and D65 ``(n,)`` at :data:`CIE_WAVELENGTHS_NM`."""
    import colour as colour_science

    shape = colour_science.SpectralShape(360, 830, 1)
    cmf = colour_science.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"].copy().align(shape).values
    d65 = colour_science.SDS_ILLUMINANTS["D65"].copy().align(shape).values
    cmf.setflags(write=False)
    d65.setflags(write=False)
    return cmf, d65


def reflectance_to_xyz(wavelengths_nm: ArrayLike, reflectance: ArrayLike) -> NDArray[np.float64]:
    """CIE XYZ of a reflectance spectrum under D65, CIE 1931 2-degree observer (CIE 15:2004, 7.1).

    ``X = sum R S x / sum S y`` over 360-830 nm in 1 nm steps, the spectrum
    interpolated linearly between its samples and held constant beyond
    them; the perfect reflecting diffuser has ``Y = 1``.

    Parameters
    ----------
    wavelengths_nm
        Increasing wavelengths of the samples, nm.
    reflectance
        ``(..., n)`` reflectance factors at them.

    Returns
    -------
    numpy.ndarray
        ``(..., 3)`` X, Y, Z.
    """
    wl = np.asarray(wavelengths_nm, dtype=np.float64)
    r = np.asarray(reflectance, dtype=np.float64)
    if wl.ndim != 1 or wl.size < 2 or not np.all(np.diff(wl) > 0) or r.shape[-1:] != wl.shape:
        raise OptionError(f"reflectance: expected (..., {wl.size}) samples at increasing wavelengths, "
                          f"got {r.shape} at {wl.shape}")
    if not np.all(np.isfinite(r)):
        raise OptionError("reflectance: values must be finite")
    cmf, d65 = _cie_d65_tables()
    flat = r.reshape(-1, wl.size)
    dense = np.stack([np.interp(CIE_WAVELENGTHS_NM, wl, row) for row in flat])
    xyz = (dense * d65) @ cmf / float(d65 @ cmf[:, 1])
    return xyz.reshape(r.shape[:-1] + (3,))


def reflectance_to_linear(wavelengths_nm: ArrayLike, reflectance: ArrayLike) -> NDArray[np.float64]:
    """Linear Rec. 709 RGB of a reflectance spectrum under D65 (:func:`reflectance_to_xyz`).

    Scaled channel by channel so that the perfect reflecting diffuser is
    exactly (1, 1, 1) (the tabulated D65 and Rec. 709's white differ by
    about 0.1 %): the result is the albedo a model takes.

    Parameters
    ----------
    wavelengths_nm, reflectance
        As :func:`reflectance_to_xyz`.

    Returns
    -------
    numpy.ndarray
        ``(..., 3)`` linear RGB (may leave [0, 1] for colours outside the gamut).
    """
    to_rgb = np.linalg.inv(RGB_TO_XYZ)
    xyz = reflectance_to_xyz(wavelengths_nm, reflectance)
    wl = np.asarray(wavelengths_nm, dtype=np.float64)
    white = reflectance_to_xyz(wl, np.ones(wl.size)) @ to_rgb.T
    return (xyz @ to_rgb.T) / white
