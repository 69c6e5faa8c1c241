"""Recompute every preset colour from the dye and fibre data of :mod:`cdbrdf.synth.colorants`.

Run: ``.venv/bin/python scripts/preset_colours.py [--fast]``

For each colour of :data:`cdbrdf.synth.colorants.PRESET_COLOURS`: the
colorant's reflectance spectrum (Kubelka-Munk from the dye's absorption band
and the fibre's reflectance), its CIE 1976 L*a*b* (D65, CIE 1931 observer),
the linear Rec. 709 albedo a woven yarn or a pile's ground takes, and for a
pile strand the albedo whose thick layer reflects that in the pile's own
multiple scattering (:func:`cdbrdf.synth.pile.strand_albedo`, about a minute
each on 2 cores; ``--fast`` skips them); then whether the preset holds it.
Exits 1 when a preset differs from its derivation by more than 5e-4.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

import numpy as np


def main(argv: Sequence[str] | None = None) -> int:
    """Print the derivation of every preset colour; 1 if a preset disagrees."""
    from cdbrdf.colour import lab_chroma_hue, linear_to_lab
    from cdbrdf.synth import colorants, presets

    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--fast", action="store_true", help="skip the pile strands' albedo (slow)")
    args = parser.parse_args(argv)
    bad = 0
    for (preset, param), (name, how) in colorants.PRESET_COLOURS.items():
        r_inf = colorants.linear_rgb(name)
        lab = linear_to_lab(r_inf)
        c, h = lab_chroma_hue(lab)
        held = np.array(getattr(presets.params(preset), param))
        line = (f"{preset}.{param:10s} {name:20s} R_inf {np.round(r_inf, 4)} L* {lab[0]:5.1f} a* {lab[1]:6.1f} "
                f"b* {lab[2]:6.1f} C* {c:5.1f} h {h:4.0f}")
        if how == "strand" and args.fast:
            print(f"{line}  (strand: skipped) preset {held}")
            continue
        derived = np.array(colorants.preset_colour(preset, param))
        ok = bool(np.all(np.abs(derived - held) <= 5e-4))
        bad += not ok
        print(f"{line}  -> {how} {derived}  preset {held} {'ok' if ok else 'DIFFERS'}")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
