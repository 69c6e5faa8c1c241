"""Named cloth presets: ``denim`` and ``shot`` (tamamushi-ori).

Each preset is a set of :class:`~cdbrdf.synth.cloth.ClothParams` values, every
one a physical quantity with its source or the reason for it next to it
(``docs/fabric-model.md`` derives them and shows what bending does to each
cloth); :func:`params` returns them with user overrides applied (validated,
unknown names rejected). The pile presets ``velvet`` and ``towel`` are
:class:`~cdbrdf.synth.pile.PileParams` values (:mod:`cdbrdf.synth.pile_presets`).

Yarn diameters follow Peirce (1937): a yarn of ``tex`` g/km packed at
specific volume ``v`` cm^3/g has ``d = sqrt(4 tex v / (1000 pi))`` mm
(cotton, ``v = 1.1``: ``d = 1 / (28 sqrt(Ne))`` inch); in the cloth the
cross-section is an ellipse of the same area, flattened to the width the
neighbours leave or to the flattening of the yarn type.

- ``denim``: a 12-13 oz/yd^2 3/1 right-hand twill: indigo-dyed Ne 6 open-end
  cotton warp over an undyed Ne 8 weft, 25 ends and 18 picks per cm. The
  warp runs along y (the axis of the bending cylinder), so a convex bend
  spreads the warp yarns and shows the white weft (lighter), a concave one
  closes them (darker).
- ``shot``: a shot silk taffeta (tamamushi-ori) of the heavy kind: a fine
  red-orange filament warp, 80 ends per cm, woven plain with a thick yellow
  dupion weft, 30 picks per cm. The two mix to an ochre yellow; a convex bend
  spreads the warp and shows more of the weft (lighter, yellower).

The yarn colours are the colours of the dyed (or undyed) fibres'
reflectance spectra, from the dyes' and fibres' published data
(:mod:`cdbrdf.synth.colorants`, which cites them; ``python
scripts/preset_colours.py`` recomputes every preset colour from them).

References
----------
F. T. Peirce, "The geometry of cloth structure", Journal of the Textile
Institute Transactions 28(3), T45-T96, 1937.
"""

from __future__ import annotations

from collections.abc import Mapping
from types import MappingProxyType
from typing import Any

from ..errors import OptionError
from .cloth import ClothModel, ClothParams
from .pile import PileModel, PileParams
from .pile_presets import PILE_PRESETS

__all__ = ["PRESETS", "names", "params", "params_class", "model"]

_WOVEN: Mapping[str, Mapping[str, Any]] = MappingProxyType(
    {
        "denim": MappingProxyType(
            {
                "name": "denim",
                # 3/1 warp-faced twill: the denim weave.
                "weave": "twill_3_1",
                # Warp along the stand's axis: bending across the warp opens it.
                "warp_along": "y",
                # Indigo on greige cotton, a dark rope-dyed shade (K/S 30 at indigo's 660 nm maximum):
                # L* 26, a* 1.5, b* -32 (colorants.linear_rgb("indigo_cotton_dark"); the dye and fibre
                # data and their sources in cdbrdf.synth.colorants).
                "warp_rgb": (0.0, 0.0502, 0.1539),
                # Undyed greige cotton, Rd 65 %, +b 6 (USDA colour chart): L* 85, b* 6.4
                # (colorants.linear_rgb("ecru_cotton")).
                "weft_rgb": (0.6592, 0.6577, 0.5714),
                # Seen through holes: the stand under the cloth (white, as the
                # paper's stands' walls in its Fig. 7b).
                "backing_rgb": (0.80, 0.80, 0.80),
                # 25 ends per cm.
                "warp_pitch_mm": 0.400,
                # 18 picks per cm.
                "weft_pitch_mm": 0.556,
                # Ne 6 (98 tex) warp, d = 0.371 mm (cover d/p = 0.93); in the cloth
                # 0.39 mm wide (a 0.01 mm gap) by 0.353 mm high (same area).
                "warp_width_mm": 0.390,
                "warp_height_mm": 0.353,
                # Ne 8 (74 tex) weft, d = 0.321 mm, flattened 1.3 : 1.
                "weft_width_mm": 0.366,
                "weft_height_mm": 0.281,
                # Crimp: warp 14 %, weft 8.5 % (the warp does most of the crimping
                # in a warp-faced twill).
                "crimp_share_warp": 0.65,
                # Surface helix angle atan(pi d T) of Z-twisted open-end yarns at
                # twist multipliers 4.5 (warp) and 4.0 (weft): 27 and 24 deg.
                "warp_twist_deg": 27.0,
                "weft_twist_deg": 24.0,
                # 0.85 mm: the yarn envelope (crowns of the face to crowns of the
                # back) is 0.76 mm, surface hair adds the rest; heavy denims gauge
                # about 0.8-1 mm. Areal mass from the counts, tex and crimps:
                # 280 + 144 = 425 g/m^2 = 12.5 oz/yd^2.
                "thickness_mm": 0.85,
                # Bonded to the stand: the back keeps its length.
                "neutral_fraction": 0.0,
                # The paper's 7 x 7 pixels of 980 over a field of about 140 mm.
                "footprint_mm": 1.0,
                # Cellulose.
                "ior": 1.53,
                # Matte cotton: a weak surface reflection, broad lobes, mostly
                # isotropic volume scattering.
                "warp_specular": 0.2,
                "weft_specular": 0.2,
                "warp_gloss_deg": 12.0,
                "weft_gloss_deg": 12.0,
                "warp_sheen_deg": 25.0,
                "weft_sheen_deg": 25.0,
                "warp_isotropic": 0.85,
                "weft_isotropic": 0.85,
            }
        ),
        "shot": MappingProxyType(
            {
                "name": "shot",
                # Plain weave, as every shot silk: the taffeta construction (a
                # fine, dense warp over a thicker weft, a faint weft-way rib).
                "weave": "plain",
                # Warp along the stand's axis: bending across the warp opens it.
                "warp_along": "y",
                # Red-orange silk: C.I. Acid Orange 7 (485 nm) shaded with C.I. Acid Yellow 23 (427 nm)
                # on degummed silk, L* 40, a* 25, b* 26 (colorants.linear_rgb("red_orange_silk")).
                "warp_rgb": (0.2625, 0.0715, 0.0343),
                # Golden-yellow silk: tartrazine (C.I. Acid Yellow 23, 427 nm) on degummed silk,
                # L* 81, a* 9, b* 56, hue angle 81 deg (colorants.linear_rgb("golden_yellow_silk")).
                "weft_rgb": (0.919, 0.524, 0.1093),
                # The white stand under the cloth (as for denim).
                "backing_rgb": (0.80, 0.80, 0.80),
                # 80 ends per cm.
                "warp_pitch_mm": 0.125,
                # 2 x 21 den (4.7 tex) twisted silk filament, d = 0.086 mm at a
                # packing of 0.6 (fibroin 1.33 g/cm^3); flattened 1.6 : 1 to
                # 0.110 x 0.067 mm (0.88 of the spacing; cover d/p = 0.69).
                "warp_width_mm": 0.110,
                "warp_height_mm": 0.067,
                # 30 picks per cm.
                "weft_pitch_mm": 0.333,
                # 300 den (33 tex) dupion silk, d = 0.231 mm, flattened 1.5 : 1.
                "weft_width_mm": 0.283,
                "weft_height_mm": 0.189,
                # The fine warp wraps the thick weft: warp crimp 23 %, weft 6 %.
                "crimp_share_warp": 0.85,
                # Surface helix angle of the warp at 600 turns/m (9 deg) and of
                # the weft at 200 turns/m (8 deg).
                "warp_twist_deg": 9.0,
                "weft_twist_deg": 8.0,
                # 0.30 mm: the yarn envelope (0.29 mm). Areal mass from the counts,
                # tex and crimps: 46 + 106 = 152 g/m^2 (35 momme, a heavy shot
                # silk: the dupion weft of shot dupioni).
                "thickness_mm": 0.30,
                # Bonded to the stand: the back keeps its length.
                "neutral_fraction": 0.0,
                # The same rig as for denim.
                "footprint_mm": 1.0,
                # Silk fibroin.
                "ior": 1.55,
                # Silk lustre: strong, narrow surface reflection and a narrow,
                # mostly forward coloured sheen.
                "warp_specular": 0.6,
                "weft_specular": 0.6,
                "warp_gloss_deg": 6.0,
                "weft_gloss_deg": 6.0,
                "warp_sheen_deg": 10.0,
                "weft_sheen_deg": 10.0,
                "warp_isotropic": 0.15,
                "weft_isotropic": 0.15,
            }
        ),
    }
)

#: Every preset: the woven ones above and the pile ones.
PRESETS: Mapping[str, Mapping[str, Any]] = MappingProxyType({**_WOVEN, **PILE_PRESETS})


def names() -> list[str]:
    """Names of the presets.

    Returns
    -------
    list of str
        The names.
    """
    return sorted(PRESETS)


def params_class(name: str) -> type[ClothParams] | type[PileParams]:
    """The parameter class of a preset: :class:`ClothParams` (woven) or :class:`PileParams` (pile).

    Raises
    ------
    OptionError
        For an unknown preset (listing the valid ones).
    """
    if name not in PRESETS:
        raise OptionError(f"unknown preset {name!r}; valid presets: {', '.join(names())}")
    return PileParams if name in PILE_PRESETS else ClothParams


def params(name: str, /, **overrides: Any) -> ClothParams | PileParams:
    """The parameters of a preset with ``overrides`` applied.

    Parameters
    ----------
    name
        One of :func:`names`.
    **overrides
        Parameters changed, by name.

    Returns
    -------
    ClothParams
        The parameters.

    Raises
    ------
    OptionError
        For an unknown preset or parameter name (listing the valid ones) or
        an invalid value.
    """
    return params_class(name)().replace(**dict(PRESETS[name])).replace(**overrides)


def model(name: str, /, **overrides: Any) -> ClothModel | PileModel:
    """The model of a preset.

    Parameters
    ----------
    name
        One of :func:`names`.
    **overrides
        Parameters changed (:func:`params`).

    Returns
    -------
    ClothModel or PileModel
        The model (:class:`PileModel` for a pile preset).
    """
    p = params(name, **overrides)
    return PileModel(p) if isinstance(p, PileParams) else ClothModel(p)
