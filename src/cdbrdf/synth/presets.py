"""Named cloth presets: ``denim`` and ``shot`` (tamamushi-ori).

Each preset is a set of :class:`~cdbrdf.synth.cloth.ClothParams` values;
:func:`params` returns them with user overrides applied (validated, unknown
names rejected). The pile presets ``velvet`` and ``towel`` are
:class:`~cdbrdf.synth.pile.PileParams` values (:mod:`cdbrdf.synth.pile_presets`).

- ``denim``: indigo-dyed cotton warp over a white (ecru) weft, 3/1
  warp-faced twill, coarse twisted cotton yarns: matte with a faint sheen.
  The warp runs along y (the axis of the bending cylinder), so bending along
  x opens the gaps between the indigo warp yarns and shows the white weft
  (the lightening the paper reports for convex bends).
- ``shot``: tamamushi-ori silk taffeta: crimson warp, green weft, plain
  weave, nearly untwisted filament yarns with a narrow, coloured sheen. Red
  and green mix to the ochre/yellow the paper describes; the balance
  between the two shifts with the bend and with the viewing direction.
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
                "weave": "twill_3_1",
                "warp_along": "y",
                "warp_rgb": (0.015, 0.030, 0.140),
                "weft_rgb": (0.60, 0.57, 0.50),
                "backing_rgb": (0.30, 0.29, 0.26),
                "warp_pitch_mm": 0.42,
                "weft_pitch_mm": 0.60,
                "warp_width_mm": 0.41,
                "weft_width_mm": 0.28,
                "warp_height_mm": 0.30,
                "weft_height_mm": 0.12,
                "crimp_share_warp": 0.85,
                "warp_twist_deg": 25.0,
                "weft_twist_deg": 20.0,
                "thickness_mm": 1.0,
                "footprint_mm": 1.0,
                "ior": 1.53,
                "warp_specular": 0.4,
                "weft_specular": 0.4,
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
                "weave": "plain",
                "warp_along": "y",
                "warp_rgb": (0.50, 0.02, 0.05),
                "weft_rgb": (0.12, 0.60, 0.08),
                "backing_rgb": (0.15, 0.12, 0.05),
                "warp_pitch_mm": 0.20,
                "weft_pitch_mm": 0.26,
                "warp_width_mm": 0.20,
                "weft_width_mm": 0.26,
                "warp_height_mm": 0.08,
                "weft_height_mm": 0.10,
                "crimp_share_warp": 0.5,
                "warp_twist_deg": 3.0,
                "weft_twist_deg": 3.0,
                "thickness_mm": 0.6,
                "footprint_mm": 0.3,
                "ior": 1.55,
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


def params(name: str, **overrides: Any) -> ClothParams | PileParams:
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


def model(name: str, **overrides: Any) -> ClothModel | PileModel:
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
