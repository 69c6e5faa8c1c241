"""Pile-fabric presets: ``velvet`` and ``towel`` (:class:`~cdbrdf.synth.pile.PileParams` values).

Registered with the woven ones in :mod:`cdbrdf.synth.presets`.

- ``velvet``: a cut warp-pile velvet, crimson viscose pile on a gold cotton
  ground (a two-colour, "voided" velvet). Pile height 2.0 mm (velvet's pile is
  under 1/8 in, 3.2 mm: Fairchild's Dictionary of Textiles); each strand is
  one leg of a cut pile tuft, a 150 dtex viscose yarn (1.5 g/cm^3, packing
  0.6: 0.15 mm across); 45 pile ends/cm x 40 picks/cm with a V-tuft every two
  picks and two legs per tuft: 18 strands/mm^2; standing within a few
  degrees of the normal (spread 6 degrees), the nap leaning 5 degrees
  along y (the warp). Viscose's refractive index 1.53; fibre gloss 8
  degrees (Marschner et al. 2003's longitudinal width for smooth fibres).
  Gaps between tufts about one tuft across (0.15 mm).
- ``towel``: a white terry towel, bleached cotton loops on a bleached cotton
  ground: loop
  height 3.5 mm and base 0.6 mm (three-pick terry), 20 pile ends/cm x
  17 picks/cm / 3 picks per loop: 1.1 loops/mm^2; the loop yarn Ne 16/2
  cotton (74 tex, 1.52 g/cm^3, packing 0.5: 0.35 mm across); loop planes
  at random azimuths, tilted by 30 degrees (standard deviation); cotton's
  rough, matte fibres (specular weight 0.3, width 15 degrees); gaps between
  loops about 0.5 mm.

Colours (:mod:`cdbrdf.synth.colorants` has the dye and fibre data and
their sources): the ground is a woven surface and takes its material's
reflectance ``R_inf`` as its albedo; a strand is one scatterer among many,
and takes the albedo for which a thick layer of the pile's strands reflects
its material's ``R_inf`` in the model's own multiple scattering
(:func:`cdbrdf.synth.pile.strand_albedo`; ``python scripts/preset_colours.py``
recomputes them). The velvet's ground differs from its pile, so that the
ground's share, which grows on a convex bend as the pile fans open, is seen
as a colour change; the towel is white through and through, and bending
changes it little.
"""

from __future__ import annotations

from collections.abc import Mapping
from types import MappingProxyType
from typing import Any

__all__ = ["PILE_PRESETS"]

PILE_PRESETS: Mapping[str, Mapping[str, Any]] = MappingProxyType(
    {
        "velvet": MappingProxyType(
            {
                "name": "velvet",
                "kind": "cut",
                "pile_height_mm": 2.0,
                "strand_diameter_mm": 0.15,
                "strands_per_mm2": 18.0,
                "lean_deg": 5.0,
                "brush_deg": 90.0,
                "spread_deg": 6.0,
                # Crimson viscose (a direct red shaded orange and yellow), R_inf =
                # colorants.linear_rgb("crimson_viscose") = (0.171, 0.0176, 0.0454), L* 27, a* 37, b* 4:
                # the strand albedo of that R_inf.
                "fibre_rgb": (0.4714, 0.0337, 0.1257),
                # An old-gold cotton ground (C.I. Direct Yellow 12, shaded): colorants.linear_rgb(
                # "gold_cotton"), L* 53, a* 11.5, b* 34.
                "ground_rgb": (0.3597, 0.1797, 0.056),
                "fibre_specular": 1.0,
                "fibre_gloss_deg": 8.0,
                "ior": 1.53,
                "correlation_mm": 0.15,
            }
        ),
        "towel": MappingProxyType(
            {
                "name": "towel",
                "kind": "loop",
                "pile_height_mm": 3.5,
                "loop_width_mm": 0.6,
                "strand_diameter_mm": 0.35,
                "strands_per_mm2": 1.1,
                "lean_deg": 0.0,
                "spread_deg": 30.0,
                # Bleached cotton, R_inf = colorants.linear_rgb("bleached_cotton") = (0.8888, 0.8912,
                # 0.8712), L* 95.5, b* 1.1: the strand albedo of that R_inf.
                "fibre_rgb": (0.9979, 0.998, 0.9971),
                # The ground weave, bleached cotton too: its R_inf.
                "ground_rgb": (0.8888, 0.8912, 0.8712),
                "fibre_specular": 0.3,
                "fibre_gloss_deg": 15.0,
                "ior": 1.53,
                "correlation_mm": 0.5,
            }
        ),
    }
)
