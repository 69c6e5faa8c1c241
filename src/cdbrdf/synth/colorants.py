"""The presets' colours from dye and fibre data: reflectance spectra, then CIE 1931 / D65, then linear Rec. 709.

Each yarn colour of the presets (:mod:`cdbrdf.synth.presets`,
:mod:`cdbrdf.synth.pile_presets`) is the colour of a *reflectance spectrum*
of the dyed (or undyed) fibre, made by the Kubelka-Munk rule of colour
matching (Kubelka & Munk 1931; the textile dyer's single-constant form,
e.g. Nobbs 1985):

    K/S(lambda) = K/S_fibre(lambda) + sum_dyes c_d k_d(lambda),
    R(lambda) = 1 + K/S - sqrt((K/S)^2 + 2 K/S),

with ``K/S_fibre`` from the undyed fibre's reflectance (its own, measured
plateau and yellowness), each dye's absorption band ``k_d`` a Gaussian in
wavenumber at the dye's absorption maximum, and ``c_d k_d(lambda_max)`` the
depth of shade as ``K/S`` at the maximum. The spectrum's colour is its CIE
1931 2-degree XYZ under D65, as linear Rec. 709 RGB with the perfect white
at (1, 1, 1) (:func:`cdbrdf.spectral.reflectance_to_linear`). Every
colorant's entry in :data:`COLORANTS` says where its numbers come from;
:func:`linear_rgb` gives the colour a woven yarn takes (its surface reflects
like the bulk material, ``R_inf``), and the pile presets' strand albedos
are derived from it in the pile's own multiple scattering
(``scripts/preset_colours.py``, ``docs/fabric-model.md``).

What is measured and what is modelled: the dyes' absorption maxima and
the fibres' reflectance levels are published values (the sources below);
the bands' widths are those typical of the dye class, and the depths of
shade are chosen for the named shade (a dark indigo, a full crimson); the
spectra are therefore models of real dyeings, not measurements of one.

References
----------
P. Kubelka, F. Munk, "Ein Beitrag zur Optik der Farbanstriche",
Zeitschrift fuer technische Physik 12, 1931.
J. H. Nobbs, "Kubelka-Munk theory and the prediction of reflectance",
Review of Progress in Coloration 15, 1985.
CIE 15:2004, Colorimetry (CIE 1931 observer, D65).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType

import numpy as np
from numpy.typing import NDArray

from ..errors import OptionError

__all__ = ["Band", "Fibre", "Colorant", "FIBRES", "COLORANTS", "PRESET_COLOURS", "WAVELENGTHS_NM", "reflectance",
           "linear_rgb", "preset_colour", "ks_to_reflectance", "reflectance_to_ks"]

#: The wavelengths the spectra are made on, nm.
WAVELENGTHS_NM: NDArray[np.float64] = np.arange(380.0, 781.0, 5.0)
WAVELENGTHS_NM.setflags(write=False)


@dataclass(frozen=True)
class Band:
    """An absorption band: a Gaussian in wavenumber.

    Attributes
    ----------
    peak_nm
        The absorption maximum, nm.
    fwhm_per_cm
        Full width at half maximum, cm^-1.
    ks
        ``K/S`` the band adds at its maximum (the depth of shade).
    """

    peak_nm: float
    fwhm_per_cm: float
    ks: float

    def __call__(self, nm: NDArray[np.float64]) -> NDArray[np.float64]:
        nu, nu0 = 1e7 / nm, 1e7 / self.peak_nm
        sigma = self.fwhm_per_cm / (2.0 * math.sqrt(2.0 * math.log(2.0)))
        return self.ks * np.exp(-0.5 * ((nu - nu0) / sigma) ** 2)


@dataclass(frozen=True)
class Fibre:
    """An undyed fibre: the plateau of its reflectance and its own yellowing absorption.

    Attributes
    ----------
    plateau
        Reflectance ``R_inf`` where nothing absorbs (the long-wave end).
    yellowing
        Its own absorption in the near ultraviolet and blue (natural
        pigments, residual yellowness), as bands.
    source
        Where the numbers come from.
    """

    plateau: float
    yellowing: tuple[Band, ...]
    source: str


@dataclass(frozen=True)
class Colorant:
    """A dyed (or undyed) fibre: the fibre and the dyes' bands.

    Attributes
    ----------
    fibre
        A key of :data:`FIBRES`.
    dyes
        The dyes' absorption bands (empty: undyed).
    source
        Where the numbers come from.
    """

    fibre: str
    dyes: tuple[Band, ...]
    source: str


def ks_to_reflectance(ks: NDArray[np.float64]) -> NDArray[np.float64]:
    """Kubelka-Munk ``R_inf = 1 + K/S - sqrt((K/S)^2 + 2 K/S)`` (an opaque layer)."""
    x = np.asarray(ks, dtype=np.float64)
    return 1.0 + x - np.sqrt(x * x + 2.0 * x)


def reflectance_to_ks(r: NDArray[np.float64]) -> NDArray[np.float64]:
    """Kubelka-Munk ``K/S = (1 - R_inf)^2 / (2 R_inf)``."""
    r = np.asarray(r, dtype=np.float64)
    return (1.0 - r) ** 2 / (2.0 * r)


#: Undyed fibres.
FIBRES: Mapping[str, Fibre] = MappingProxyType({
    "bleached_cotton": Fibre(
        plateau=0.89, yellowing=(Band(340.0, 7000.0, 0.040),),
        source="fully bleached cotton without optical brightener: reflectance 85-90 % across the visible "
               "(the bleaching house's target, e.g. Trotman, Dyeing and Chemical Technology of Textile "
               "Fibres, 6th ed., 1984), slightly yellow (CIE whiteness 50-70 without brightener)",
    ),
    "ecru_cotton": Fibre(
        plateau=0.66, yellowing=(Band(360.0, 7500.0, 0.30),),
        source="greige (undyed, unbleached) cotton of the grades open-end denim yarns are spun from: "
               "reflectance Rd 65 % and Hunter yellowness +b 6, in the lower, greyer part of the upland "
               "cotton colour chart (Nickerson-Hunter diagram, Rd 40-85 %, +b 4-18; USDA AMS, The "
               "Classification of Cotton, Agricultural Handbook 566)",
    ),
    "degummed_silk": Fibre(
        plateau=0.84, yellowing=(Band(330.0, 7000.0, 0.12),),
        source="degummed silk: a white fibre with a faint yellow (fibroin's tyrosine and tryptophan "
               "absorb below 320 nm, their tail reaches the violet)",
    ),
    "viscose": Fibre(
        plateau=0.90, yellowing=(Band(330.0, 7000.0, 0.03),),
        source="bright viscose rayon: regenerated cellulose, as white as bleached cotton",
    ),
})

#: The presets' yarns.
COLORANTS: Mapping[str, Colorant] = MappingProxyType({
    "indigo_cotton_dark": Colorant(
        fibre="ecru_cotton",
        dyes=(Band(660.0, 2400.0, 30.0), Band(610.0, 2800.0, 20.0), Band(560.0, 3000.0, 8.0), Band(380.0, 8000.0, 5.0)),
        source="indigo (C.I. Vat Blue 1) on cotton: absorption maximum 660 nm in the fibre, where the "
               "denim mills measure its depth of shade as K/S (e.g. Etters, Textile Chemist and Colorist "
               "27(2), 1995; Ratnapandian, RMIT PhD thesis 2013), with the vibronic shoulder near 605 nm "
               "and indigo's near-ultraviolet band; a dark rope-dyed shade on the "
               "greige warp yarn (K/S 30, 20, 8 and 5 in the four bands)",
    ),
    "ecru_cotton": Colorant(fibre="ecru_cotton", dyes=(), source="the undyed denim weft"),
    "bleached_cotton": Colorant(fibre="bleached_cotton", dyes=(), source="a white terry towel's yarn"),
    "red_orange_silk": Colorant(
        fibre="degummed_silk", dyes=(Band(485.0, 5500.0, 8.0), Band(427.0, 5500.0, 6.0)),
        source="a red-orange on silk: C.I. Acid Orange 7 (absorption maximum 485 nm; the monoazo acid "
               "dyes' bands are about 5,000-6,000 cm^-1 wide) shaded with C.I. Acid Yellow 23 (427 nm), "
               "K/S 8 and 6 at their maxima",
    ),
    "golden_yellow_silk": Colorant(
        fibre="degummed_silk", dyes=(Band(427.0, 5000.0, 3.0),),
        source="tartrazine on silk, C.I. Acid Yellow 23 (absorption maximum 427 nm), K/S 3 at its maximum",
    ),
    "crimson_viscose": Colorant(
        fibre="viscose", dyes=(Band(545.0, 2800.0, 15.0), Band(490.0, 3500.0, 10.0), Band(430.0, 5000.0, 6.0)),
        source="a crimson direct dyeing on viscose: a red of the class of C.I. Direct Red 80 (absorption "
               "maximum about 530-545 nm on cellulose; K/S 15) shaded with an orange (490 nm, K/S 10) and a "
               "yellow (430 nm, K/S 6) that take out the green and the blue",
    ),
    "gold_cotton": Colorant(
        fibre="bleached_cotton", dyes=(Band(405.0, 6000.0, 8.0), Band(485.0, 5500.0, 1.5), Band(560.0, 9000.0, 0.5)),
        source="an old gold on a cotton ground: C.I. Direct Yellow 12 (absorption maximum 405 nm, K/S 8) "
               "shaded with an orange absorbing at 485 nm (K/S 1.5) and a little of a broad-band black "
               "(K/S 0.5) that dulls it",
    ),
})


def _check(name: str) -> Colorant:
    if name not in COLORANTS:
        raise OptionError(f"colorant {name!r}: unknown; valid names: {', '.join(COLORANTS)}")
    return COLORANTS[name]


def reflectance(name: str, wavelengths_nm: NDArray[np.float64] | None = None) -> NDArray[np.float64]:
    """The reflectance spectrum ``R_inf(lambda)`` of a colorant (:data:`COLORANTS`).

    Parameters
    ----------
    name
        The colorant.
    wavelengths_nm
        Where; default :data:`WAVELENGTHS_NM`.

    Returns
    -------
    numpy.ndarray
        Reflectance factors in (0, 1).
    """
    c = _check(name)
    nm = WAVELENGTHS_NM if wavelengths_nm is None else np.asarray(wavelengths_nm, dtype=np.float64)
    fibre = FIBRES[c.fibre]
    ks = np.full(nm.shape, float(reflectance_to_ks(np.array(fibre.plateau))))
    for band in fibre.yellowing + c.dyes:
        ks = ks + band(nm)
    return ks_to_reflectance(ks)


def linear_rgb(name: str) -> NDArray[np.float64]:
    """The colorant's reflectance as linear Rec. 709 RGB under D65 (CIE 1931 2-degree), ``(3,)``."""
    from ..spectral import reflectance_to_linear

    return np.clip(reflectance_to_linear(WAVELENGTHS_NM, reflectance(name)), 0.0, 1.0)


#: Which colorant each preset colour comes from, and how: ``"surface"`` (a woven yarn's
#: surface or a pile's ground: the material's ``R_inf``) or ``"strand"`` (a pile strand:
#: the albedo whose thick layer reflects ``R_inf``, :func:`cdbrdf.synth.pile.strand_albedo`).
PRESET_COLOURS: Mapping[tuple[str, str], tuple[str, str]] = MappingProxyType({
    ("denim", "warp_rgb"): ("indigo_cotton_dark", "surface"),
    ("denim", "weft_rgb"): ("ecru_cotton", "surface"),
    ("shot", "warp_rgb"): ("red_orange_silk", "surface"),
    ("shot", "weft_rgb"): ("golden_yellow_silk", "surface"),
    ("velvet", "fibre_rgb"): ("crimson_viscose", "strand"),
    ("velvet", "ground_rgb"): ("gold_cotton", "surface"),
    ("towel", "fibre_rgb"): ("bleached_cotton", "strand"),
    ("towel", "ground_rgb"): ("bleached_cotton", "surface"),
})


def preset_colour(preset: str, parameter: str) -> tuple[float, float, float]:
    """A preset colour recomputed from its colorant (:data:`PRESET_COLOURS`), rounded to 4 decimals.

    Parameters
    ----------
    preset, parameter
        A key of :data:`PRESET_COLOURS`.

    Returns
    -------
    tuple of float
        The linear Rec. 709 albedo the preset holds.
    """
    key = (preset, parameter)
    if key not in PRESET_COLOURS:
        valid = ", ".join(f"{a}.{b}" for a, b in PRESET_COLOURS)
        raise OptionError(f"preset colour {preset}.{parameter}: unknown; valid: {valid}")
    name, how = PRESET_COLOURS[key]
    rgb = linear_rgb(name)
    if how == "strand":
        from .pile import PileParams, strand_albedo
        from .presets import params

        p = params(preset)
        assert isinstance(p, PileParams)
        rgb = np.asarray(strand_albedo(p, rgb))
    return (round(float(rgb[0]), 4), round(float(rgb[1]), 4), round(float(rgb[2]), 4))
