"""Fitting models to a flat BRDF (cdbrdf.fit): known answers.

- the baseline's Charlie distribution is normalised (its projected integral
  over the half vectors is 1) and the baseline is reciprocal;
- the analytic derivative of CIELAB matches finite differences;
- a fit recovers the parameters that made the data (the baseline, the pile
  model), and the stated uncertainty matches the spread of fits to noisy
  copies of the data;
- the models' colour channels are independent (what the Jacobian's
  one-evaluation-per-colour rule relies on), for the woven and the pile model;
- bad arguments are refused in one line.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from cdbrdf import fit as F
from cdbrdf.colour import linear_to_lab
from cdbrdf.errors import OptionError
from cdbrdf.fit.core import lab_jacobian


def test_charlie_distribution_is_normalised_and_the_baseline_reciprocal():
    # integral of D(theta_h) cos(theta_h) over the hemisphere of half vectors = 1, for every roughness
    th = (np.arange(20000) + 0.5) * (math.pi / 2) / 20000
    for alpha in (0.05, 0.3, 1.0):
        inv = 1 / alpha
        d = (2 + inv) * np.sin(th) ** inv / (2 * math.pi)
        integral = np.sum(d * np.cos(th) * np.sin(th)) * (math.pi / 2) / 20000 * 2 * math.pi
        assert abs(integral - 1) < 1e-3
    p = F.SheenParams(diffuse_rgb=(0.2, 0.4, 0.6), sheen_rgb=(0.9, 0.5, 0.1), roughness=0.3)
    rng = np.random.default_rng(0)
    tv, tl = rng.uniform(0, 89, 300), rng.uniform(0, 89, 300)
    pv, pl = rng.uniform(0, 360, 300), rng.uniform(0, 360, 300)
    np.testing.assert_allclose(F.sheen_brdf(p, tv, pv, tl, pl), F.sheen_brdf(p, tl, pl, tv, pv), rtol=1e-12)
    # no sheen: Lambert exactly
    lam = F.sheen_brdf(F.SheenParams(diffuse_rgb=(0.5, 0.5, 0.5), sheen_rgb=(0, 0, 0)), tv, pv, tl, pl)
    np.testing.assert_allclose(lam, 0.5 / math.pi)


def test_lab_jacobian_matches_finite_differences():
    rng = np.random.default_rng(1)
    rgb = np.concatenate([rng.uniform(0.0, 1.5, (50, 3)), rng.uniform(0.0, 0.004, (10, 3))])
    j = lab_jacobian(rgb)
    h = 1e-7
    for c in range(3):
        d = np.zeros(3)
        d[c] = h
        fd = (linear_to_lab(rgb + d) - linear_to_lab(rgb - d)) / (2 * h)
        np.testing.assert_allclose(j[:, :, c], fd, rtol=1e-5, atol=1e-4)


def _lab_to_linear(lab):
    """The inverse of cdbrdf.colour.linear_to_lab (CIE 15, D65 white = RGB 1)."""
    from cdbrdf.colour import D65_WHITE_XYZ, RGB_TO_XYZ

    fy = (lab[:, 0] + 16) / 116
    f = np.stack([fy + lab[:, 1] / 500, fy, fy - lab[:, 2] / 200], axis=-1)
    t = np.where(f > 6 / 29, f**3, 3 * (6 / 29) ** 2 * (f - 4 / 29))
    return (t * D65_WHITE_XYZ) @ np.linalg.inv(RGB_TO_XYZ).T


def _sheen_data(values, n=128, seed=0, noise=0.0, rng=None):
    """The baseline at n pairs; with ``noise``, Gaussian noise of that standard deviation added in L*a*b* of pi f."""
    fm = F.fit_model("sheen")
    tv, pv, tl, pl = F.directions(n, seed=seed)
    f = fm.build(values).evaluate(tv, pv, tl, pl)
    if noise:
        lab = linear_to_lab(math.pi * f) + noise * rng.standard_normal(f.shape)
        f = _lab_to_linear(lab) / math.pi
    return F.FitData(tv, pv, tl, pl, f, isotropic=True)


TRUTH = {"diffuse_rgb": (0.3, 0.15, 0.05), "sheen_rgb": (0.6, 0.5, 0.4), "roughness": 0.35}


def test_a_fit_recovers_the_baseline_that_made_the_data():
    data = _sheen_data(TRUTH)
    r = F.fit(data, "sheen", test=_sheen_data(TRUTH, n=256, seed=1))
    np.testing.assert_allclose(r.values["diffuse_rgb"], TRUTH["diffuse_rgb"], atol=2e-3)
    np.testing.assert_allclose(r.values["sheen_rgb"], TRUTH["sheen_rgb"], atol=5e-3)
    assert abs(r.values["roughness"] - TRUTH["roughness"]) < 5e-3
    assert r.errors["test"]["delta_e_median"] < 0.05 and r.errors["test"]["relative_rms"] < 1e-3
    assert r.at_bound == () and all(s is not None for s in r.sigma["diffuse_rgb"])
    rec = r.to_dict()
    assert rec["bounds"]["roughness"]["lower"] == 0.02 and rec["model_params"]["roughness"] == r.values["roughness"]


def test_the_stated_uncertainty_matches_the_spread_of_fits():
    rng = np.random.default_rng(7)
    fits = [F.fit(_sheen_data(TRUTH, noise=1.0, rng=rng), "sheen") for _ in range(24)]
    got = np.array([r.values["diffuse_rgb"] for r in fits])
    stated = np.array([r.sigma["diffuse_rgb"] for r in fits], dtype=float).mean(axis=0)
    spread = got.std(axis=0, ddof=1)
    # independent residuals of one variance in L*a*b* (the assumption of sigma = sqrt(diag((J^T J)^-1) s^2)):
    # the stated sigma is the spread of the fits, within the sampling error of 24 fits (+-30 % at 2 sigma)
    np.testing.assert_allclose(stated, spread, rtol=0.35)
    np.testing.assert_allclose(got.mean(axis=0), TRUTH["diffuse_rgb"], atol=3 * spread.max())


def test_a_parameter_at_its_bound_has_no_sigma():
    truth = dict(TRUTH, sheen_rgb=(0.0, 0.5, 0.4))
    r = F.fit(_sheen_data(truth), "sheen")
    assert "sheen_rgb" in r.at_bound and r.sigma["sheen_rgb"][0] is None and r.values["sheen_rgb"][0] < 1e-3
    assert r.sigma["sheen_rgb"][1] is not None


class _Narrow(F.FitModel):
    """The baseline with its roughness held in a narrow range: variants of one model, as the woven weaves are."""

    def __init__(self, lo=0.02, hi=1.0):
        base = F.fit_model("sheen")
        self.name, self.description = "narrow", base.description
        self.parameters = base.parameters[:2] + (F.Parameter("roughness", lo, hi, log=True),)
        self.lo, self._base = lo, base

    @property
    def label(self):
        return f"{self.parameters[2].lower:g}-{self.parameters[2].upper:g}"

    def variants(self):
        return [_Narrow(0.02, 0.05), _Narrow(0.3, 0.4), _Narrow(0.8, 1.0)] if self.lo == 0.02 and len(
            self.parameters) == 3 and self.parameters[2].upper == 1.0 else [self]

    def initial(self, data):
        return dict(self._base.initial(data), roughness=self.parameters[2].lower)

    def build(self, values, *, quality="full"):
        return self._base.build(values, quality=quality)

    def model_params(self, values):
        return self._base.model_params(values)


def test_a_fit_probes_its_variants_and_fits_the_best():
    r = F.fit(_sheen_data(TRUTH), _Narrow(), max_evaluations=60)
    probes = r.fixed["probes"]  # each variant's median Delta E*ab after its short fit
    assert set(probes) == {"0.02-0.05", "0.3-0.4", "0.8-1"} and min(probes, key=probes.get) == "0.3-0.4"
    assert 0.3 <= r.values["roughness"] <= 0.4 and r.errors["fit"]["delta_e_median"] < 0.05
    assert r.evaluations <= 60


@pytest.mark.slow
def test_a_pile_fit_recovers_its_colours():
    """Fitted to its own values the pile model comes back: 160 evaluations (the default budget of 80 ends at
    Delta E*ab 2.2 on this case since the multiple scattering of model 2.0: measured; about 6 CPU-minutes)."""
    fm = F.fit_model("pile")
    truth = {"fibre_rgb": (0.6, 0.2, 0.1), "ground_rgb": (0.1, 0.3, 0.5), "strands_per_mm2": 120.0,
             "spread_deg": 15.0, "fibre_gloss_deg": 10.0, "fibre_specular": 0.6, "correlation_mm": 0.1}
    tv, pv, tl, pl = F.directions(64, seed=0)
    f = fm.build(truth).evaluate(tv, pv, tl, pl, 0.0)
    data = F.FitData(tv, pv, tl, pl, f, isotropic=False)
    r = F.fit(data, fm, max_evaluations=160)
    assert r.errors["test"]["delta_e_median"] < 1.0
    np.testing.assert_allclose(r.values["fibre_rgb"], truth["fibre_rgb"], atol=0.05)
    assert r.fixed["pile_height_mm"] == 1.5 and "scaled together" in r.fixed["reason"]


@pytest.mark.parametrize("name", ["woven", "pile"])
def test_a_model_that_claims_independent_channels_has_them(name):
    fm = F.fit_model(name, weave="plain")
    tv, pv, tl, pl = F.directions(64, seed=3)
    data = F.FitData(tv, pv, tl, pl, np.full((64, 3), 0.1), isotropic=True)
    base = fm.initial(data)
    colour = next(p.name for p in fm.parameters if p.channels == 3)
    other = dict(base, **{colour: (0.9, base[colour][1], base[colour][2])})
    a = fm.evaluate(base, data)
    b = fm.evaluate(other, data)
    assert np.abs(b[:, 0] - a[:, 0]).max() > 1e-3
    if fm.channels_independent:
        np.testing.assert_array_equal(a[:, 1:], b[:, 1:])
    else:  # a model whose channels mix says so, and the Jacobian steps each channel
        assert not np.array_equal(a[:, 1:], b[:, 1:])


def test_bad_arguments_are_refused():
    data = _sheen_data(TRUTH, n=16)
    with pytest.raises(OptionError, match="'glossy' is not one of woven, pile, sheen"):
        F.fit(data, "glossy")
    with pytest.raises(OptionError, match="max_evaluations"):
        F.fit(data, "sheen", max_evaluations=1)
    with pytest.raises(OptionError, match="theta_max_deg"):
        F.directions(8, theta_max_deg=95.0)
    with pytest.raises(OptionError, match="weave"):
        F.fit_model("woven", weave="knit")
