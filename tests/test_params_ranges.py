"""The fabric models' parameters within physical ranges (issue 38, item 9): a value outside is refused naming the
parameter; at the ends of every range the models give finite reflectance (``fibre_gloss_deg=1e-300`` gave NaN
naming no parameter)."""

from __future__ import annotations

import numpy as np
import pytest

from cdbrdf import Grid
from cdbrdf.errors import OptionError
from cdbrdf.synth.cloth import CLOTH_RANGES
from cdbrdf.synth.pile import PILE_RANGES
from cdbrdf.synth.presets import model

GRID = Grid.regular(theta_step_deg=45, phi_step_deg=180, kappa=[0.2])
_CASES = [("velvet", p) for p in PILE_RANGES] + [("towel", "loop_width_mm")] + [("denim", p) for p in CLOTH_RANGES]


@pytest.mark.parametrize(("preset", "name"), _CASES)
def test_values_outside_the_range_are_refused_naming_the_parameter(preset, name):
    lo, hi = (PILE_RANGES if name in PILE_RANGES else CLOTH_RANGES)[name]
    for bad in (lo * 0.5 if lo > 0 else -1.0, hi * 2.0, 1e-300, 5e-324, 0.0, float("nan"), float("inf")):
        if lo <= bad <= hi:
            continue
        with pytest.raises(OptionError, match=f"^{name}: must be a number in"):
            model(preset, **{name: bad})


def test_the_presets_lie_within_the_ranges():
    from cdbrdf.synth.cloth import ClothParams
    from cdbrdf.synth.pile import PileParams
    from cdbrdf.synth.presets import PRESETS

    for preset, values in PRESETS.items():
        ranges, params = (PILE_RANGES, PileParams) if "kind" in values else (CLOTH_RANGES, ClothParams)
        p = params(**values)
        assert all(lo <= getattr(p, k) <= hi for k, (lo, hi) in ranges.items()), preset


def test_the_command_line_names_the_parameter(tmp_path):
    from .test_fuzz_hostile3 import _run_cli

    status, err = _run_cli(["synth", "velvet", "--set", "fibre_gloss_deg=1e-300", "--grid", "regular:45,180",
                            "--kappa", "0", "-o", str(tmp_path / "v.h5")])
    assert status == 2 and err.count("\n") == 1 and "fibre_gloss_deg" in err and "[0.1, 90]" in err, err
    assert not (tmp_path / "v.h5").exists()


@pytest.mark.parametrize(("preset", "name", "end"), [("velvet", "fibre_gloss_deg", 0)]
                         + [pytest.param(pr, n, e, marks=pytest.mark.slow) for pr, n in _CASES for e in (0, 1)])
def test_the_ends_of_each_range_give_finite_reflectance(preset, name, end):
    value = (PILE_RANGES if name in PILE_RANGES else CLOTH_RANGES)[name][end]
    t = model(preset, **{name: value}).tabulate(GRID)
    assert np.all(np.isfinite(t.values)) and np.all(t.values >= 0)
