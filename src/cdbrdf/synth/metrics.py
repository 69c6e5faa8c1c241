"""Summary numbers of a cloth's appearance, used by the presets' targets.

:func:`colour_45_0` is the colour a spectrophotometer of 45/0 geometry
reads: CIE 1976 L*a*b* (D65) of pi times the BRDF with the light at 45
degrees all round (annular, the mean over light azimuths) and the view along
the normal.

All take a reflectance array or a table whose last axis is linear Rec. 709
RGB. ``REC709_Y`` and ``luminance`` are :data:`cdbrdf.colour.LUMINANCE_WEIGHTS`
and :func:`cdbrdf.colour.luminance`, re-exported.

:func:`bend_contrast` is how much a table's colour changes with the bend as
the eye sees it: the median CIE 1976 colour difference Delta E*ab between two
curvatures over random near-normal direction pairs, with the swatch colours
(the mean colour at each curvature) to show side by side.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..colour import LUMINANCE_WEIGHTS as REC709_Y
from ..colour import delta_e_ab, lab_chroma_hue, linear_to_lab, luminance, tonemap_srgb8
from ..errors import OptionError
from ..table import CDBRDF

__all__ = [
    "REC709_Y",
    "luminance",
    "chromaticity",
    "low_elevation_slice",
    "in_plane_luminance",
    "NEAR_NORMAL_MAX_THETA_DEG",
    "NEAR_NORMAL_PAIRS",
    "NEAR_NORMAL_SEED",
    "FLAT_MEDIAN_LUMINANCE",
    "near_normal_pairs",
    "BendContrast",
    "bend_contrast",
    "bend_summary",
    "colour_45_0",
]

#: Largest light and view elevation of the near-normal comparison, degrees.
NEAR_NORMAL_MAX_THETA_DEG = 30.0
#: Number of random direction pairs of the near-normal comparison.
NEAR_NORMAL_PAIRS = 20_000
#: Seed of the random direction pairs (the comparison is reproducible).
NEAR_NORMAL_SEED = 0
#: Median luminance the reference curvature's values are scaled to before
#: CIELAB (white = 1): a mid-grey, L* = 61.7, where Delta E*ab is meaningful.
FLAT_MEDIAN_LUMINANCE = 0.3


def chromaticity(rgb: ArrayLike) -> NDArray[np.float64]:
    """The rgb chromaticity ``(r, g, b) / (r + g + b)`` of the *mean* colour.

    Parameters
    ----------
    rgb
        Linear RGB, ``(..., 3)``.

    Returns
    -------
    numpy.ndarray
        ``(3,)`` chromaticity of the mean of ``rgb``.
    """
    m = np.asarray(rgb, dtype=np.float64).reshape(-1, 3).mean(axis=0)
    return m / m.sum()


def low_elevation_slice(table: CDBRDF, kappa: float, max_theta_deg: float = 30.0) -> NDArray[np.float64]:
    """Samples at one curvature with view and light elevations <= ``max_theta_deg``.

    Parameters
    ----------
    table
        The table.
    kappa
        One of its curvatures, mm^-1.
    max_theta_deg
        Largest elevation, degrees.

    Returns
    -------
    numpy.ndarray
        The samples, ``(n_phi_l, n_theta_l, n_phi_v, n_theta_v, channel)`` over the
        kept elevations.
    """
    i = int(np.flatnonzero(np.isclose(table.kappa, kappa))[0])
    tl = table.theta_l <= max_theta_deg + 1e-9
    tv = table.theta_v <= max_theta_deg + 1e-9
    return np.asarray(table.values[i][:, tl][:, :, :, tv], dtype=np.float64)


def in_plane_luminance(table: CDBRDF, kappa: float, plane_phi_deg: float) -> float:
    """Mean luminance of the samples whose view and light lie in one plane.

    Parameters
    ----------
    table
        The table.
    kappa
        One of its curvatures, mm^-1.
    plane_phi_deg
        The plane's azimuth, degrees: the samples at azimuths ``phi`` and
        ``phi + 180``, all elevations.

    Returns
    -------
    float
        The mean luminance.
    """
    i = int(np.flatnonzero(np.isclose(table.kappa, kappa))[0])
    az = [plane_phi_deg % 360.0, (plane_phi_deg + 180.0) % 360.0]
    il = [int(np.flatnonzero(np.isclose(table.phi_l, a))[0]) for a in az]
    iv = [int(np.flatnonzero(np.isclose(table.phi_v, a))[0]) for a in az]
    v = np.asarray(table.values[i], dtype=np.float64)[il][:, :, iv]
    return float(luminance(v).mean())


def near_normal_pairs(
    n: int = NEAR_NORMAL_PAIRS,
    *,
    max_theta_deg: float = NEAR_NORMAL_MAX_THETA_DEG,
    seed: int = NEAR_NORMAL_SEED,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Random view and light directions near the normal, degrees.

    Elevations uniform in ``[0, max_theta_deg]`` and azimuths uniform in
    ``[0, 360)``, independently for the view and the light.

    Parameters
    ----------
    n
        Number of pairs.
    max_theta_deg
        Largest elevation, degrees.
    seed
        Seed of the random generator.

    Returns
    -------
    tuple of numpy.ndarray
        ``(theta_v, phi_v, theta_l, phi_l)``, each ``(n,)``.
    """
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
        raise OptionError(f"n: must be a positive integer, got {n!r}")
    if not 0.0 < float(max_theta_deg) <= 90.0:
        raise OptionError(f"max_theta_deg: must lie in (0, 90] degrees, got {max_theta_deg!r}")
    rng = np.random.default_rng(seed)
    t = rng.uniform(0.0, float(max_theta_deg), (2, int(n)))
    p = rng.uniform(0.0, 360.0, (2, int(n)))
    return t[0], p[0], t[1], p[1]


@dataclass(frozen=True)
class BendContrast:
    """How a table's colour near the normal differs between two curvatures.

    All colours are the table's linear RGB times :attr:`scale`, which brings
    the median luminance at the reference curvature to
    :data:`FLAT_MEDIAN_LUMINANCE` (white = 1).

    Attributes
    ----------
    kappa, reference_kappa
        The two curvatures, mm^-1.
    median_delta_e
        Median over the direction pairs of Delta E*ab between the two
        curvatures, pair by pair.
    scale
        The factor applied to both.
    rgb, reference_rgb
        The swatch colours: mean linear RGB over the pairs at each curvature.
    lab, reference_lab
        Their CIE 1976 L*a*b*.
    """

    kappa: float
    reference_kappa: float
    median_delta_e: float
    scale: float
    rgb: NDArray[np.float64]
    reference_rgb: NDArray[np.float64]
    lab: NDArray[np.float64]
    reference_lab: NDArray[np.float64]

    @property
    def swatch_delta_e(self) -> float:
        """Delta E*ab between the two swatch colours."""
        return float(delta_e_ab(self.lab, self.reference_lab))

    @property
    def lightness_change(self) -> float:
        """L* of the swatch at :attr:`kappa` minus that at :attr:`reference_kappa`."""
        return float(self.lab[0] - self.reference_lab[0])

    def chroma_hue(self) -> tuple[tuple[float, float], tuple[float, float]]:
        """Chroma and hue of the two swatches.

        Returns
        -------
        at_kappa : tuple of float
            ``(C*ab, h_ab)`` at :attr:`kappa`, the hue angle in degrees.
        at_reference : tuple of float
            The same at :attr:`reference_kappa`.
        """
        c, h = lab_chroma_hue(np.stack([self.lab, self.reference_lab]))
        return (float(c[0]), float(h[0])), (float(c[1]), float(h[1]))

    def swatches_srgb8(self) -> tuple[NDArray[np.uint8], NDArray[np.uint8]]:
        """The two swatch colours as 8-bit sRGB.

        Returns
        -------
        at_kappa : numpy.ndarray
            ``(3,)`` uint8 at :attr:`kappa`.
        at_reference : numpy.ndarray
            ``(3,)`` uint8 at :attr:`reference_kappa`.
        """
        return tonemap_srgb8(self.rgb), tonemap_srgb8(self.reference_rgb)


def bend_contrast(
    table: CDBRDF,
    kappa: float,
    *,
    reference_kappa: float = 0.0,
    n_pairs: int = NEAR_NORMAL_PAIRS,
    max_theta_deg: float = NEAR_NORMAL_MAX_THETA_DEG,
    seed: int = NEAR_NORMAL_SEED,
    reference_luminance: float = FLAT_MEDIAN_LUMINANCE,
) -> BendContrast:
    """The colour difference near the normal between curvature ``kappa`` and ``reference_kappa``.

    The table is evaluated (:meth:`cdbrdf.CDBRDF.evaluate`, curvature clamped
    to its range) at :func:`near_normal_pairs` at both curvatures; both are
    scaled by one factor that brings the median luminance at the reference
    to ``reference_luminance``; each pair's values are converted to CIE 1976
    L*a*b* (:func:`cdbrdf.colour.linear_to_lab`) and compared
    (:func:`cdbrdf.colour.delta_e_ab`).

    Parameters
    ----------
    table
        Any table (a bundled material, a measured or imported one).
    kappa, reference_kappa
        Curvatures compared, mm^-1.
    n_pairs, max_theta_deg, seed
        The direction pairs (:func:`near_normal_pairs`).
    reference_luminance
        Median luminance at the reference curvature after scaling.

    Returns
    -------
    BendContrast
        The median Delta E*ab, the scale and the swatch colours.

    Raises
    ------
    OptionError
        For an invalid option, or a table whose reference values are all black.

    Examples
    --------
    >>> import cdbrdf.materials
    >>> from cdbrdf.synth.metrics import bend_contrast
    >>> c = bend_contrast(cdbrdf.materials.load("shot"), 0.13)   # doctest: +SKIP
    >>> c.median_delta_e, c.swatches_srgb8()                      # doctest: +SKIP
    """
    if not np.isfinite(reference_luminance) or reference_luminance <= 0:
        raise OptionError(f"reference_luminance: must be a positive number, got {reference_luminance!r}")
    tv, pv, tl, pl = near_normal_pairs(n_pairs, max_theta_deg=max_theta_deg, seed=seed)
    bent = table.evaluate(tv, pv, tl, pl, float(kappa))
    ref = table.evaluate(tv, pv, tl, pl, float(reference_kappa))
    median_y = float(np.median(luminance(ref)))
    if not median_y > 0:
        raise OptionError(f"table {table.attrs.get('material', '')!r}: black at kappa = {reference_kappa:g}; "
                          "no colour to compare")
    scale = reference_luminance / median_y
    d = delta_e_ab(linear_to_lab(bent * scale), linear_to_lab(ref * scale))
    rgb = bent.mean(axis=0) * scale
    rgb_ref = ref.mean(axis=0) * scale
    return BendContrast(
        kappa=float(kappa),
        reference_kappa=float(reference_kappa),
        median_delta_e=float(np.median(d)),
        scale=scale,
        rgb=rgb,
        reference_rgb=rgb_ref,
        lab=linear_to_lab(rgb),
        reference_lab=linear_to_lab(rgb_ref),
    )


def bend_summary(table: CDBRDF, **options: Any) -> list[dict[str, Any]]:
    """What bending does near the normal: :func:`bend_contrast` of every bent curvature against the flat one.

    Parameters
    ----------
    table
        A table with ``kappa = 0`` among its curvatures (else the list is empty).
    **options
        Passed to :func:`bend_contrast`.

    Returns
    -------
    list of dict
        One per curvature ``!= 0``, JSON-friendly: ``kappa`` (mm^-1),
        ``median_delta_e``, ``lightness_change``, ``chroma_change`` (of the
        swatch colours), ``hue_change_deg`` (in [-180, 180)), ``srgb8`` and
        ``flat_srgb8`` (the swatches, 8-bit sRGB).
    """
    if not np.any(table.kappa == 0.0):
        return []
    rows = []
    for k in (float(x) for x in table.kappa if x != 0.0):
        c = bend_contrast(table, k, **options)
        (ch, h), (ch0, h0) = c.chroma_hue()
        bent, flat = c.swatches_srgb8()
        rows.append({"kappa": k, "median_delta_e": c.median_delta_e, "lightness_change": c.lightness_change,
                     "chroma_change": ch - ch0, "hue_change_deg": (h - h0 + 180.0) % 360.0 - 180.0,
                     "srgb8": bent.tolist(), "flat_srgb8": flat.tolist()})
    return rows


def colour_45_0(source: CDBRDF | Any, kappa: float = 0.0) -> tuple[float, float, float, float, float]:
    """The 45/0 colour of a table or a fabric model: ``(L*, a*, b*, C*ab, h_ab)``.

    A reflectance factor as a 45 deg annular / 0 deg colorimeter reads it
    (CIE 15:2004, 45 deg a : 0 deg): pi times the BRDF with the view along the
    normal and the light at 45 degrees elevation, averaged over the light
    azimuths 0, 30, ..., 330 degrees, as linear Rec. 709 to CIE 1976
    L*a*b* (D65, white = 1).

    Parameters
    ----------
    source
        A :class:`cdbrdf.CDBRDF` or a model with ``evaluate(theta_v, phi_v,
        theta_l, phi_l, kappa)`` (:mod:`cdbrdf.synth`).
    kappa
        Curvature, mm^-1.

    Returns
    -------
    tuple of float
        L*, a*, b*, chroma C*ab and hue angle h_ab (degrees).
    """
    azimuths = np.arange(0.0, 360.0, 30.0)
    rgb = np.asarray(source.evaluate(0.0, 0.0, 45.0, azimuths, kappa), dtype=np.float64).mean(axis=0)
    lab = linear_to_lab(np.pi * rgb)
    c, h = lab_chroma_hue(lab)
    return float(lab[0]), float(lab[1]), float(lab[2]), float(c), float(h)
