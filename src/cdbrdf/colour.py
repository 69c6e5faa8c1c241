"""Colour rules shared by the whole package: sRGB, luminance, exposure, 8-bit display.

Tables, photographs decoded for measuring and renders all hold linear,
scene-referred RGB with Rec. 709 primaries. This module owns the few rules
that turn such values into something to look at, so that the figures
(:mod:`cdbrdf.plot`), the simulated rig, the measurement and the demo apply
exactly the same numbers:

- the sRGB transfer function and its inverse (IEC 61966-2-1):
  :func:`linear_to_srgb`, :func:`srgb_to_linear`, and :func:`srgb_encode`
  (the transfer function of values clipped to [0, 1], for display);
- the Rec. 709 luminance ``Y = 0.2126 R + 0.7152 G + 0.0722 B``
  (:data:`LUMINANCE_WEIGHTS`, :func:`luminance`);
- exposure: a linear factor applied before encoding, either chosen from the
  data (:func:`auto_exposure` maps a percentile of the luminance to a target;
  :func:`auto_exposure_ev` is the same rule in stops, clipped, for renders),
  named (:data:`EXPOSURE_MODES`, resolved by :func:`resolve_exposure`) or in
  stops (:func:`ev_to_factor`, :func:`factor_to_ev`);
- 8-bit display encoding of linear radiance (:func:`tonemap_srgb8`);
- colour differences: linear RGB to CIE XYZ (:data:`RGB_TO_XYZ`, D65) and
  CIE 1976 L*a*b* (:func:`linear_to_lab`, :func:`xyz_to_lab`), display
  sRGB (8-bit codes or encoded values) to L*a*b* (:func:`srgb_to_lab`),
  chroma and hue angle (:func:`lab_chroma_hue`), the CIE 1976 colour
  difference Delta E*ab (:func:`delta_e_ab`) and the metrics of
  :data:`DELTA_E_METRICS` (:func:`delta_e`): CIEDE2000, the textile trade's
  tolerance metric, and Delta E*ab.

The L*a*b* formula and CIEDE2000 are those of the ``colour-science``
package (imported as ``colour_science`` inside the functions that use it,
so that importing this module imports only numpy and does nothing).
Reflectance spectra to colour: :mod:`cdbrdf.spectral`.

References
----------
IEC 61966-2-1:1999, Multimedia systems and equipment - Colour measurement and
management - Default RGB colour space - sRGB.
ITU-R BT.709-6, Parameter values for the HDTV standards, item 3.3 (luminance).
CIE 15:2004, Colorimetry, 3rd edition, section 8.2.1 (CIE 1976 L*a*b*) and
8.2.1.3 (Delta E*ab).
CIE 142-2001, Improvement to industrial colour-difference evaluation (CIEDE2000).
G. Sharma, W. Wu, E. N. Dalal, "The CIEDE2000 color-difference formula:
implementation notes, supplementary test data, and mathematical
observations", Color Research & Application 30(1), 21-30, 2005.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .errors import OptionError

__all__ = [
    "LUMINANCE_WEIGHTS",
    "luminance",
    "linear_to_srgb",
    "srgb_to_linear",
    "srgb_encode",
    "EXPOSURE_PERCENTILE",
    "EXPOSURE_MODES",
    "WHITE_EXPOSURE",
    "RENDER_EXPOSURE_PERCENTILE",
    "RENDER_EXPOSURE_TARGET",
    "RENDER_EV_RANGE",
    "GREY_CARD",
    "card_exposure_ev",
    "auto_exposure",
    "auto_exposure_ev",
    "resolve_exposure",
    "ev_to_factor",
    "factor_to_ev",
    "tonemap_srgb8",
    "RGB_TO_XYZ",
    "D65_WHITE_XYZ",
    "linear_to_xyz",
    "xyz_to_lab",
    "linear_to_lab",
    "lab_chroma_hue",
    "delta_e_ab",
    "srgb_to_lab",
    "DELTA_E_METRICS",
    "delta_e",
]

#: Rec. 709 / sRGB luminance weights of linear R, G, B (read-only).
LUMINANCE_WEIGHTS: NDArray[np.float64] = np.array([0.2126, 0.7152, 0.0722])
LUMINANCE_WEIGHTS.setflags(write=False)

#: Linear value at which the sRGB curve changes from the line to the power law.
_SRGB_LINEAR_KNEE = 0.0031308
#: The same point on the encoded side.
_SRGB_ENCODED_KNEE = 0.04045

#: Percentile of the luminance over all shown panels that the automatic
#: exposure of a table's figure maps to display white.
EXPOSURE_PERCENTILE = 99.5

#: Named exposures of table figures: ``"auto"`` maps the
#: :data:`EXPOSURE_PERCENTILE`-th percentile of the shown luminance to 1;
#: ``"white"`` (``quantity="brdf"`` only) multiplies by :data:`WHITE_EXPOSURE`,
#: so that a perfect white Lambertian reflector (f = 1/pi sr^-1) is display
#: white, as next to a white card in a photograph.
EXPOSURE_MODES: tuple[str, ...] = ("auto", "white")

#: The factor of the ``"white"`` exposure: pi (a white Lambertian BRDF is 1/pi sr^-1).
WHITE_EXPOSURE = math.pi

#: Percentile of a render's luminance that :func:`auto_exposure_ev` maps to
#: :data:`RENDER_EXPOSURE_TARGET`.
RENDER_EXPOSURE_PERCENTILE = 99.0

#: Display value (before encoding) that the automatic render exposure aims at.
RENDER_EXPOSURE_TARGET = 0.85

#: Reflectance of a photographer's grey card, which an exposure "from the grey card" shows at the same
#: linear value (display mid-grey, sRGB 0.46): every colour then shows at its own reflectance.
GREY_CARD = 0.18

#: Default range of :func:`auto_exposure_ev`, in stops (EV).
RENDER_EV_RANGE: tuple[float, float] = (-8.0, 12.0)


# -- luminance -------------------------------------------------------------------------
def luminance(rgb: ArrayLike) -> NDArray[np.float64]:
    """Rec. 709 relative luminance ``Y`` of linear RGB.

    Parameters
    ----------
    rgb
        Linear values ``(..., 3)``; the last axis holds R, G, B.

    Returns
    -------
    numpy.ndarray
        ``rgb.shape[:-1]``, float64. NaN propagates; an infinite channel gives
        an infinite ``Y`` (NaN when infinities of both signs meet).

    Raises
    ------
    ValueError
        When the last axis does not hold 3 channels.
    """
    v = np.asarray(rgb, dtype=np.float64)
    if v.ndim == 0 or v.shape[-1] != 3:
        raise OptionError(f"rgb: expected linear RGB values (..., 3), got shape {v.shape}")
    return v @ LUMINANCE_WEIGHTS


# -- sRGB ------------------------------------------------------------------------------
def linear_to_srgb(x: ArrayLike) -> NDArray[np.float64]:
    """Encode linear values to sRGB (IEC 61966-2-1), without clipping.

    Values in [0, 1] map to [0, 1]; below the knee (0.0031308) the curve is the
    line ``12.92 x`` (so negative values stay negative), above it the power law
    ``1.055 x^(1/2.4) - 0.055`` (values above 1 exceed 1). NaN stays NaN.

    Parameters
    ----------
    x
        Linear values (any shape).

    Returns
    -------
    numpy.ndarray
        The encoded values.
    """
    x = np.asarray(x, dtype=np.float64)
    return np.where(
        x <= _SRGB_LINEAR_KNEE,
        12.92 * x,
        1.055 * np.maximum(x, _SRGB_LINEAR_KNEE) ** (1.0 / 2.4) - 0.055,
    )


def srgb_to_linear(x: ArrayLike) -> NDArray[np.float64]:
    """Decode sRGB-encoded values to linear (IEC 61966-2-1), without clipping.

    The inverse of :func:`linear_to_srgb`: ``x / 12.92`` up to the knee
    (0.04045), ``((x + 0.055) / 1.055)^2.4`` above. NaN stays NaN.

    Parameters
    ----------
    x
        sRGB-encoded values (any shape).

    Returns
    -------
    numpy.ndarray
        The linear values.
    """
    x = np.asarray(x, dtype=np.float64)
    return np.where(
        x <= _SRGB_ENCODED_KNEE,
        x / 12.92,
        ((np.maximum(x, _SRGB_ENCODED_KNEE) + 0.055) / 1.055) ** 2.4,
    )


def srgb_encode(linear: ArrayLike) -> NDArray[np.float64]:
    """The sRGB transfer function of values clipped to [0, 1], for display.

    ``linear_to_srgb(clip(linear, 0, 1))``: negative values and -inf show as
    0, values above 1 and +inf as 1; NaN stays NaN (see :func:`tonemap_srgb8`
    for an encoding that maps NaN to black).

    Parameters
    ----------
    linear
        Linear values (any shape).

    Returns
    -------
    numpy.ndarray
        Encoded values in [0, 1].
    """
    return linear_to_srgb(np.clip(np.asarray(linear, dtype=np.float64), 0.0, 1.0))


# -- exposure --------------------------------------------------------------------------
def ev_to_factor(ev: float) -> float:
    """The linear factor of an exposure in stops: ``2**ev``.

    Parameters
    ----------
    ev
        Exposure, stops.

    Returns
    -------
    float
        The factor.
    """
    return float(2.0**ev)


def factor_to_ev(factor: float) -> float:
    """The exposure in stops of a positive linear factor: ``log2(factor)``.

    Parameters
    ----------
    factor
        Linear factor, > 0.

    Returns
    -------
    float
        Exposure, stops.
    """
    return math.log2(factor)


def _finite_percentile(values: ArrayLike, percentile: float) -> float | None:
    """The ``percentile``-th percentile of the finite values; None when there are none."""
    y = np.asarray(values, dtype=np.float64)
    y = y[np.isfinite(y)]
    if y.size == 0:
        return None
    return float(np.percentile(y, percentile))


def auto_exposure(lum: ArrayLike, *, percentile: float = EXPOSURE_PERCENTILE, target: float = 1.0) -> float:
    """Exposure factor mapping the ``percentile``-th percentile of ``lum`` to ``target``.

    Non-finite values are ignored.

    Parameters
    ----------
    lum
        Luminances (any shape).
    percentile
        The percentile of ``lum`` that maps to ``target``, in [0, 100].
    target
        Its display value.

    Returns
    -------
    float
        The factor; 1 (no change) when that percentile is not positive or no
        value is finite (an all-black table).
    """
    p = _finite_percentile(lum, percentile)
    return target / p if p is not None and p > 0 else 1.0


def auto_exposure_ev(
    image: ArrayLike,
    *,
    target: float = RENDER_EXPOSURE_TARGET,
    percentile: float = RENDER_EXPOSURE_PERCENTILE,
    min_ev: float = RENDER_EV_RANGE[0],
    max_ev: float = RENDER_EV_RANGE[1],
) -> float:
    """Exposure in stops mapping a percentile of an image's luminance to ``target``.

    Parameters
    ----------
    image
        Linear image ``(..., >= 3)``: the first three channels are R, G, B
        (an alpha channel is ignored).
    target
        Display value (before sRGB encoding) that the percentile maps to.
    percentile
        Percentile of the luminance of the finite pixels.
    min_ev, max_ev
        The result is clipped to this range (stops).

    Returns
    -------
    float
        ``clip(log2(target / p), min_ev, max_ev)``; 0 when ``p`` is not
        positive (a black image).
    """
    y = luminance(np.asarray(image, dtype=np.float64)[..., :3])
    p = _finite_percentile(y, percentile)
    if p is None or not p > 0:
        return 0.0
    return float(np.clip(factor_to_ev(target / p), min_ev, max_ev))


def resolve_exposure(exposure: float | str | None, lum: ArrayLike, quantity: str) -> tuple[float, str]:
    """The exposure factor of a table figure and a note saying how it was chosen.

    Parameters
    ----------
    exposure
        None or ``"auto"`` (:func:`auto_exposure` of ``lum``), ``"white"``
        (:data:`WHITE_EXPOSURE`, absolute tables only) or a positive number
        (the factor itself).
    lum
        The luminance shown, for the automatic exposure.
    quantity
        The table's quantity: ``"brdf"`` (sr^-1) or ``"relative"``.

    Returns
    -------
    tuple of (float, str)
        The linear factor and a short note for the figure.

    Raises
    ------
    ValueError
        For an unknown mode, ``"white"`` on a relative table, or a number that
        is not positive and finite.
    """
    if exposure is None or (isinstance(exposure, str) and exposure == "auto"):
        return auto_exposure(lum), f"auto: {EXPOSURE_PERCENTILE:g}th percentile → 1"
    if isinstance(exposure, str):
        if exposure != "white":
            raise OptionError(
                f"exposure: {exposure!r} is not a number nor one of {', '.join(EXPOSURE_MODES)}"
            )
        if quantity != "brdf":
            raise OptionError(
                "exposure: 'white' needs an absolute table (quantity 'brdf'); "
                "this one is 'relative': give a number or 'auto'"
            )
        return float(WHITE_EXPOSURE), "white: f = 1/π sr⁻¹ → 1"
    try:
        x = float(exposure)
    except (TypeError, ValueError):
        raise OptionError(
            f"exposure: expected a positive number or one of {', '.join(EXPOSURE_MODES)}, got {exposure!r}"
        ) from None
    if not (np.isfinite(x) and x > 0):
        raise OptionError(f"exposure: must be a positive number, got {exposure!r}")
    return x, "given"


# -- 8-bit display ---------------------------------------------------------------------
def card_exposure_ev(card_irradiance: float) -> float:
    """The exposure (EV) at which a grey card lit by ``card_irradiance`` shows as mid-grey.

    A Lambertian card of reflectance :data:`GREY_CARD` under irradiance
    ``E`` has radiance ``GREY_CARD E / pi``; shown at ``GREY_CARD`` it needs
    the factor ``pi / E``: ``log2(pi / E)`` stops, whatever the scene's
    contents. A surface of reflectance ``rho`` under the same light then
    shows at ``rho`` (a dark indigo denim stays dark, white is just white).

    Parameters
    ----------
    card_irradiance
        Irradiance on the card, W m^-2.

    Returns
    -------
    float
        The exposure, stops.

    Raises
    ------
    ValueError
        For an irradiance that is not a positive finite number.
    """
    e = float(card_irradiance)
    if not (math.isfinite(e) and e > 0):
        raise ValueError(f"card irradiance: must be a positive finite number, got {card_irradiance!r}")
    return math.log2(math.pi / e)


def tonemap_srgb8(image: ArrayLike, *, exposure_ev: float = 0.0) -> NDArray[np.uint8]:
    """Linear radiance -> 8-bit sRGB: ``srgb(clip(image * 2**exposure_ev, 0, 1))``.

    NaN and negative values show as black, +inf as white.

    Parameters
    ----------
    image
        Linear radiance (any shape; RGB last for a picture).
    exposure_ev
        Exposure, stops.

    Returns
    -------
    numpy.ndarray
        ``uint8`` codes, the shape of ``image``.
    """
    x = np.asarray(image, dtype=np.float64) * ev_to_factor(exposure_ev)
    x = np.clip(np.nan_to_num(x, nan=0.0, posinf=1.0, neginf=0.0), 0.0, 1.0)
    return np.rint(srgb_encode(x) * 255.0).astype(np.uint8)


# -- CIELAB and colour differences -------------------------------------------------------
#: Linear Rec. 709 / sRGB RGB -> CIE 1931 XYZ, D65 white (IEC 61966-2-1), read-only. Its
#: second row is :data:`LUMINANCE_WEIGHTS` to four digits.
RGB_TO_XYZ: NDArray[np.float64] = np.array(
    [
        [0.4124, 0.3576, 0.1805],
        [0.2126, 0.7152, 0.0722],
        [0.0193, 0.1192, 0.9505],
    ]
)
RGB_TO_XYZ.setflags(write=False)

#: XYZ of the reference white: linear RGB (1, 1, 1), i.e. D65 with Y = 1 (read-only).
D65_WHITE_XYZ: NDArray[np.float64] = RGB_TO_XYZ.sum(axis=1)
D65_WHITE_XYZ.setflags(write=False)

def linear_to_xyz(rgb: ArrayLike) -> NDArray[np.float64]:
    """CIE XYZ of linear Rec. 709 RGB (:data:`RGB_TO_XYZ`); white (1, 1, 1) has Y = 1.

    Parameters
    ----------
    rgb
        Linear Rec. 709 RGB, ``(..., 3)``.

    Returns
    -------
    numpy.ndarray
        X, Y, Z, ``(..., 3)``.
    """
    v = np.asarray(rgb, dtype=np.float64)
    if v.ndim == 0 or v.shape[-1] != 3:
        raise OptionError(f"rgb: expected linear RGB values (..., 3), got shape {v.shape}")
    return v @ RGB_TO_XYZ.T


def xyz_to_lab(xyz: ArrayLike, *, white: ArrayLike = D65_WHITE_XYZ) -> NDArray[np.float64]:
    """CIE 1976 L*a*b* of XYZ ``(..., 3)`` relative to the reference ``white`` (CIE 15:2004).

    ``L* = 116 f(Y/Yn) - 16``, ``a* = 500 (f(X/Xn) - f(Y/Yn))``,
    ``b* = 200 (f(Y/Yn) - f(Z/Zn))`` with ``f(t) = t^(1/3)`` above
    ``(6/29)^3`` and the CIE's linear segment below it (so negative values
    give finite, negative L*).

    Parameters
    ----------
    xyz
        CIE XYZ, ``(..., 3)``.
    white
        XYZ of the reference white (default D65 with Y = 1).

    Returns
    -------
    numpy.ndarray
        L*, a*, b*, ``(..., 3)``.
    """
    import colour as colour_science  # the colour-science package (this module is cdbrdf.colour)

    v = np.asarray(xyz, dtype=np.float64)
    if v.ndim == 0 or v.shape[-1] != 3:
        raise OptionError(f"xyz: expected XYZ values (..., 3), got shape {v.shape}")
    w = np.asarray(white, dtype=np.float64)
    if w.shape != (3,) or not (np.all(np.isfinite(w)) and np.all(w > 0)):
        raise OptionError(f"white: expected the XYZ of a white (3 positive numbers), got {w!r:.60}")
    # colour-science takes the white as chromaticity xyY: its Y scales the white (here Y/Yn, as CIE 15 says)
    with colour_science.domain_range_scale("reference"):  # whatever scale the caller set for the library
        lab = colour_science.XYZ_to_Lab(v, illuminant=colour_science.XYZ_to_xyY(w))
    return np.asarray(lab, dtype=np.float64)


def linear_to_lab(rgb: ArrayLike) -> NDArray[np.float64]:
    """CIE 1976 L*a*b* of linear Rec. 709 RGB ``(..., 3)``, white = RGB (1, 1, 1) (L* = 100).

    Scale the values first so that 1 is the white they are seen against
    (e.g. a BRDF times pi, or a render's display white).

    Parameters
    ----------
    rgb
        Linear Rec. 709 RGB, ``(..., 3)``.

    Returns
    -------
    numpy.ndarray
        L*, a*, b*, ``(..., 3)``.
    """
    return xyz_to_lab(linear_to_xyz(rgb))


def lab_chroma_hue(lab: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Chroma ``C*ab = hypot(a*, b*)`` and hue angle ``h_ab`` of L*a*b* colours.

    Parameters
    ----------
    lab
        CIE L*a*b*, ``(..., 3)``.

    Returns
    -------
    chroma : numpy.ndarray
        ``C*ab``, shape ``(...)``.
    hue : numpy.ndarray
        ``h_ab`` in degrees, [0, 360).
    """
    v = np.asarray(lab, dtype=np.float64)
    if v.ndim == 0 or v.shape[-1] != 3:
        raise OptionError(f"lab: expected L*a*b* values (..., 3), got shape {v.shape}")
    return np.hypot(v[..., 1], v[..., 2]), np.mod(np.degrees(np.arctan2(v[..., 2], v[..., 1])), 360.0)


def delta_e_ab(lab1: ArrayLike, lab2: ArrayLike) -> NDArray[np.float64]:
    """CIE 1976 colour difference Delta E*ab: the Euclidean distance of L*a*b* ``(..., 3)`` (broadcast).

    About 1 is a just-noticeable difference between patches side by side,
    about 2 the threshold of noticing in practice.

    Parameters
    ----------
    lab1, lab2
        CIE L*a*b* colours, ``(..., 3)``.

    Returns
    -------
    numpy.ndarray
        Delta E*ab, the broadcast shape without the last axis.
    """
    a = np.asarray(lab1, dtype=np.float64)
    b = np.asarray(lab2, dtype=np.float64)
    if a.ndim == 0 or b.ndim == 0 or a.shape[-1] != 3 or b.shape[-1] != 3:
        raise OptionError(f"lab: expected L*a*b* values (..., 3), got shapes {a.shape} and {b.shape}")
    return np.sqrt(np.sum((a - b) ** 2, axis=-1))


def srgb_to_lab(srgb: ArrayLike) -> NDArray[np.float64]:
    """CIE 1976 L*a*b* (D65, white = display white) of display sRGB: 8-bit codes or encoded values.

    The colours as a picture shows them: the sRGB decoding
    (:func:`srgb_to_linear`), the sRGB primaries to XYZ (:data:`RGB_TO_XYZ`)
    and L*a*b* relative to the display's white (:func:`linear_to_lab`).

    Parameters
    ----------
    srgb
        ``(..., 3)``: ``uint8`` codes 0-255 (as :func:`tonemap_srgb8` makes
        them), or encoded values in [0, 1] as floats.

    Returns
    -------
    numpy.ndarray
        L*, a*, b*, ``(..., 3)``.
    """
    v = np.asarray(srgb)
    if v.ndim == 0 or v.shape[-1] != 3:
        raise OptionError(f"srgb: expected sRGB colours (..., 3), got shape {v.shape}")
    enc = v.astype(np.float64) / 255.0 if v.dtype == np.uint8 else np.asarray(v, dtype=np.float64)
    return linear_to_lab(srgb_to_linear(enc))


#: Colour-difference metrics of :func:`delta_e` (``cdbrdf render --compare --delta-e``).
DELTA_E_METRICS: Mapping[str, str] = {
    "2000": "CIEDE2000 (CIE 142-2001; kL = kC = kH = 1): the textile trade's tolerance metric",
    "2000-textiles": "CIEDE2000 with the textile industry's lightness weight kL = 2 (CIEDE2000 (2:1:1))",
    "ab": "CIE 1976 Delta E*ab: the distance in L*a*b*",
}

def delta_e(lab1: ArrayLike, lab2: ArrayLike, *, metric: str = "2000") -> NDArray[np.float64]:
    """Colour difference of L*a*b* colours ``(..., 3)`` (broadcast) by a metric of :data:`DELTA_E_METRICS`.

    ``"2000"`` is CIEDE2000 (``colour-science``'s ``delta_E_CIE2000``,
    checked against the test pairs of Sharma, Wu and Dalal, 2005, in the
    tests): about 1 is a just-noticeable difference, and textile colour
    tolerances are commonly set at 1 (tight) to 2. ``"2000-textiles"``
    weighs lightness differences half (kL = 2), as textile colour matching
    does. ``"ab"`` is :func:`delta_e_ab`.

    Parameters
    ----------
    lab1, lab2
        CIE L*a*b* colours, ``(..., 3)``.
    metric
        A key of :data:`DELTA_E_METRICS`.

    Returns
    -------
    numpy.ndarray
        The difference, the broadcast shape without the last axis.

    Raises
    ------
    OptionError
        For another metric (the message lists the valid ones) or colours not ``(..., 3)``.
    """
    if metric not in DELTA_E_METRICS:
        raise OptionError(f"delta E metric: {metric!r:.40} is not one of {', '.join(DELTA_E_METRICS)}")
    if metric == "ab":
        return delta_e_ab(lab1, lab2)
    import colour as colour_science  # the colour-science package (this module is cdbrdf.colour)

    a = np.asarray(lab1, dtype=np.float64)
    b = np.asarray(lab2, dtype=np.float64)
    if a.ndim == 0 or b.ndim == 0 or a.shape[-1] != 3 or b.shape[-1] != 3:
        raise OptionError(f"lab: expected L*a*b* values (..., 3), got shapes {a.shape} and {b.shape}")
    a, b = np.broadcast_arrays(a, b)
    with colour_science.domain_range_scale("reference"):
        d = colour_science.difference.delta_E_CIE2000(a, b, textiles=metric == "2000-textiles")
    return np.asarray(d, dtype=np.float64)
