"""Filling invalid samples: the paper's rule (nearest direction, same curvature) and the fill registry."""

from __future__ import annotations

import numpy as np
import pytest

from cdbrdf import CDBRDF, Grid, TableError
from cdbrdf.frames import direction_from_angles
from cdbrdf.measure.fill import (
    DEFAULT_FILL,
    FILL_METHODS,
    MIN_CHECK_SAMPLES,
    check_fill_method,
    fill,
    fill_nearest,
    kappa_fit_weights,
    refill,
)
from cdbrdf.schema import FILL_METHOD_CODES


def angular_distance_deg(t1, p1, t2, p2):
    """Independent reference: the half-chord formula 2 asin(|a - b| / 2)."""
    a, b = direction_from_angles(t1, p1), direction_from_angles(t2, p2)
    return np.degrees(2 * np.arcsin(np.clip(np.linalg.norm(a - b, axis=-1) / 2, 0, 1)))


@pytest.fixture
def grid():
    return Grid(kappa=[-0.2, 0.0], theta_l=[0, 30, 60], phi_l=[0, 90, 180, 270],
                theta_v=[0, 30, 60], phi_v=[0, 120, 240])


def test_nothing_to_fill(grid):
    v = np.random.default_rng(0).random(grid.shape + (3,))
    out, src, _ = fill_nearest(v, np.ones(grid.shape, bool), grid)
    np.testing.assert_array_equal(out, v)
    assert (src == -1).all()


def test_fill_is_nearest_by_view_plus_light_angle(grid):
    rng = np.random.default_rng(1)
    v = rng.random(grid.shape + (3,))
    valid = rng.random(grid.shape) > 0.4
    out, src, _ = fill_nearest(np.where(valid[..., None], v, np.nan), valid, grid)
    m = grid.mesh()
    flat = {n: a.ravel() for n, a in m.items()}
    for i in np.flatnonzero(~valid.ravel()):
        j = src.ravel()[i]
        assert valid.ravel()[j]
        # same curvature
        assert flat["kappa"][j] == flat["kappa"][i]
        # brute force: no measured sample at this kappa is strictly nearer
        same = (flat["kappa"] == flat["kappa"][i]) & valid.ravel()
        d = angular_distance_deg(flat["theta_v"][i], flat["phi_v"][i], flat["theta_v"], flat["phi_v"]) + \
            angular_distance_deg(flat["theta_l"][i], flat["phi_l"][i], flat["theta_l"], flat["phi_l"])
        assert d[j] <= d[same].min() + 1e-9
        # tie-break: the lowest flat index among the nearest
        assert j == np.flatnonzero(same & (d <= d[same].min() + 1e-9))[0]
        np.testing.assert_array_equal(out.reshape(-1, 3)[i], v.reshape(-1, 3)[j])
    # the result is a valid table
    t = CDBRDF(out, grid, measured=valid, fill_source=src)
    assert t.measured.sum() == valid.sum()


def test_pole_fills_from_same_direction(grid):
    """At theta_v = 0 every phi is one direction: a missing phi copies phi = 0 exactly (distance 0)."""
    v = np.random.default_rng(2).random(grid.shape + (1,))
    valid = np.ones(grid.shape, bool)
    valid[:, :, :, 1:, 0] = False  # theta_v = 0 only photographed at phi_v = 0
    out, src, _ = fill_nearest(v, valid, grid)
    # (at theta_l = 0 the light's azimuths are one direction too: the lowest phi_l wins the tie)
    np.testing.assert_array_equal(out[:, :, 1:, 1, 0], v[:, :, 1:, 0, 0])
    np.testing.assert_array_equal(out[:, :, 1:, 2, 0], v[:, :, 1:, 0, 0])
    np.testing.assert_array_equal(out[:, :, 0, 1, 0], v[:, :1, 0, 0, 0].repeat(4, axis=1))


def test_tie_break_lowest_index():
    g = Grid(kappa=[0.0], theta_l=[45.0], phi_l=[0, 90, 180, 270], theta_v=[0.0], phi_v=[0.0])
    v = np.arange(4, dtype=float).reshape(g.shape + (1,))
    valid = np.array([True, False, True, True]).reshape(g.shape)
    # phi_l = 90 is equally far from 0 and 180: the lower index (phi_l = 0) wins
    out, src, _ = fill_nearest(v, valid, g)
    assert src.ravel()[1] == 0 and out.ravel()[1] == 0.0


def test_std_filled_too(grid):
    v = np.ones(grid.shape + (3,))
    s = np.random.default_rng(3).random(grid.shape + (3,))
    valid = np.ones(grid.shape, bool)
    valid[0, 0, 0, 0, 0] = False
    _, src, s2 = fill_nearest(v, valid, grid, std=s)
    np.testing.assert_array_equal(s2.reshape(-1, 3)[0], s.reshape(-1, 3)[src.ravel()[0]])


def test_curvature_without_measurement_raises(grid):
    valid = np.ones(grid.shape, bool)
    valid[1] = False
    with pytest.raises(TableError, match="kappa = 0 1/mm: no sample was measured"):
        fill_nearest(np.ones(grid.shape + (3,)), valid, grid)


# -- the registry --------------------------------------------------------------------------
KGRID = Grid(kappa=[-0.22, -0.13, 0.0, 0.13, 0.22], theta_l=[0, 30, 60], phi_l=[0, 90, 180, 270],
             theta_v=[0, 30, 60], phi_v=[0, 120, 240])


def test_registry_lists_the_methods():
    assert list(FILL_METHODS) == ["kappa-fit", "nearest-stand", "nearest", "model", "auto"]
    assert DEFAULT_FILL == "auto"
    for name in FILL_METHODS:
        assert check_fill_method(name) == name
    for bad in ("Nearest", "", None, 3, "kappa"):
        with pytest.raises(ValueError, match=r"fill: .* is not one of kappa-fit, nearest-stand, nearest, model, auto$"):
            check_fill_method(bad)
    with pytest.raises(ValueError, match="is not one of kappa-fit"):
        fill(np.ones(KGRID.shape + (1,)), np.ones(KGRID.shape, bool), KGRID, method="linear")


def test_kappa_fit_weights_reproduce_lines():
    ks = np.array([0.0, 0.13, 0.22])
    w = kappa_fit_weights(ks, -0.22)
    assert w.sum() == pytest.approx(1.0, abs=1e-12)
    assert w @ ks == pytest.approx(-0.22, abs=1e-12)  # a line is reproduced at the target
    # nearer stands weigh more: the weighted least-squares line, checked against numpy's polyfit
    a = np.polyfit(ks + 0.22, np.array([1.0, 2.0, 5.0]), 1, w=np.sqrt(1 / np.abs(ks + 0.22)))
    assert w @ np.array([1.0, 2.0, 5.0]) == pytest.approx(a[1], rel=1e-12)
    np.testing.assert_array_equal(kappa_fit_weights(np.array([0.13]), -0.22), [1.0])


def _smooth_table(grid, quadratic=0.0):
    """log f = A(direction) + B(direction) kappa + C kappa^2: a known curvature dependence."""
    m = grid.mesh()
    a = -1.5 + 0.6 * np.cos(np.radians(m["theta_v"])) + 0.2 * np.sin(np.radians(m["phi_l"] + m["theta_l"]))
    b = 1.2 * np.cos(np.radians(m["phi_v"] - m["phi_l"])) - 0.004 * m["theta_l"]
    logf = a + b * m["kappa"] + quadratic * m["kappa"] ** 2
    return np.exp(logf[..., None] + np.array([0.0, 0.1, -0.2]))


def _hidden(grid):
    """Grazing directions hidden on the two concave stands (more on the tighter one), as a stand does."""
    valid = np.ones(grid.shape, bool)
    valid[0, :, :, :, 2] = False  # theta_v = 60 hidden at -0.22
    valid[0, :, 2] = False  # theta_l = 60 hidden at -0.22
    valid[1, 0, 2, :, :] = False  # theta_l = 60, phi_l = 0 hidden at -0.13 too
    return valid


def test_kappa_fit_is_exact_for_a_log_linear_curvature_dependence():
    truth = _smooth_table(KGRID)
    valid = _hidden(KGRID)
    r = fill(np.where(valid[..., None], truth, np.nan), valid, KGRID, method="kappa-fit")
    np.testing.assert_allclose(r.values, truth, rtol=1e-12)
    # measured samples are kept bit for bit
    np.testing.assert_array_equal(r.values[valid], truth[valid])
    assert r.summary["samples"] == {"measured": int(valid.sum()), "nearest": 0, "nearest_stand": 0,
                                    "kappa_fit": int((~valid).sum()), "model": 0}


def test_kappa_fit_error_is_the_second_order_term():
    """For log f = A + B kappa + C kappa^2 the fill's log error is C (sum_s w_s kappa_s^2 - kappa_0^2)."""
    c = 3.0
    truth = _smooth_table(KGRID, quadratic=c)
    valid = _hidden(KGRID)
    r = fill(np.where(valid[..., None], truth, np.nan), valid, KGRID, method="kappa-fit")
    ks = KGRID.kappa
    for k, stands in ((0, [2, 3, 4]), (0, [1, 2, 3, 4]), (1, [2, 3, 4])):
        rest = [s for s in range(5) if s not in stands and s != k]
        sel = ~valid[k] & valid[stands].all(axis=0) & ~valid[rest].any(axis=0)
        w = kappa_fit_weights(ks[stands], ks[k])
        expected = c * (w @ ks[stands] ** 2 - ks[k] ** 2)
        assert sel.any()
        np.testing.assert_allclose(np.log(r.values[k][sel] / truth[k][sel]), expected, atol=1e-12)
        assert abs(expected) > 0.01  # a real, visible second-order error


def test_nearest_stand_copies_the_same_direction_of_the_nearest_stand():
    truth = _smooth_table(KGRID)
    valid = _hidden(KGRID)
    r = fill(np.where(valid[..., None], truth, np.nan), valid, KGRID, method="nearest-stand")
    idx = np.arange(valid.size).reshape(valid.shape)
    # hidden at -0.22 but measured at -0.13: from -0.13; hidden at both: from the flat stand (0)
    for k in (0, 1):
        for i in zip(*np.nonzero(~valid[k]), strict=True):
            src = 1 if (k == 0 and valid[(1, *i)]) else 2
            assert r.fill_source[(k, *i)] == idx[(src, *i)]
            np.testing.assert_array_equal(r.values[(k, *i)], truth[(src, *i)])
    assert set(np.unique(r.fill_method[~valid])) == {FILL_METHOD_CODES["nearest_stand"]}


def test_provenance_reproduces_every_filled_value():
    rng = np.random.default_rng(5)
    truth = _smooth_table(KGRID) * (1 + 0.01 * rng.standard_normal(KGRID.shape + (3,)))
    valid = _hidden(KGRID)
    valid[2, 3, 1, 1, 1] = False  # a saturated sample on the flat stand: measured on every other stand
    truth[2, 1, 2, 0, 0, 0] = -1e-4  # a dark-subtracted source below zero: that channel is combined linearly
    t = CDBRDF(np.where(valid[..., None], truth, 0.0), KGRID, measured=valid)
    r = refill(t, method="kappa-fit")
    flat = r.values.reshape(-1, 3)
    src = r.fill_sources.reshape(-1, r.fill_sources.shape[-1])
    w = r.fill_weights.reshape(src.shape)
    n_linear = 0
    for i in np.flatnonzero(~valid.ravel()):
        used = src[i] >= 0
        v = flat[src[i][used]]
        assert r.measured.ravel()[src[i][used]].all()
        lin = (v <= 0).any(axis=0)
        n_linear += int(lin.sum())
        expect = np.where(lin, w[i][used] @ v, np.exp(w[i][used] @ np.log(np.where(v > 0, v, 1.0))))
        np.testing.assert_allclose(flat[i], expect, rtol=1e-12)
    assert r.fill_method[2, 3, 1, 1, 1] == FILL_METHOD_CODES["kappa_fit"]
    assert (r.fill_sources[2, 3, 1, 1, 1] >= 0).sum() == 4  # all four other stands
    assert r.attrs["provenance"]["fill_method"] == "kappa-fit"
    assert n_linear == 1  # the one channel with a source below zero


def test_direction_no_stand_measured_falls_back_to_the_paper_rule():
    truth = _smooth_table(KGRID)
    valid = np.ones(KGRID.shape, bool)
    valid[:, 1, 1, 1, 1] = False  # one direction unmeasured on every stand
    valid[3, 2, 1, 1, 1] = False  # another measured on four stands
    r = fill(np.where(valid[..., None], truth, np.nan), valid, KGRID, method="kappa-fit")
    near, src, _ = fill_nearest(np.where(valid[..., None], truth, np.nan), valid, KGRID)
    np.testing.assert_array_equal(r.values[:, 1, 1, 1, 1], near[:, 1, 1, 1, 1])
    np.testing.assert_array_equal(r.fill_source[:, 1, 1, 1, 1], src[:, 1, 1, 1, 1])
    assert (r.fill_method[:, 1, 1, 1, 1] == FILL_METHOD_CODES["nearest"]).all()
    assert r.fill_method[3, 2, 1, 1, 1] == FILL_METHOD_CODES["kappa_fit"]


def test_nearest_method_is_the_paper_rule_bit_for_bit(grid):
    rng = np.random.default_rng(1)
    v = rng.random(grid.shape + (3,))
    s = rng.random(grid.shape + (3,))
    valid = rng.random(grid.shape) > 0.4
    out, src, std = fill_nearest(np.where(valid[..., None], v, np.nan), valid, grid, std=s)
    r = fill(np.where(valid[..., None], v, np.nan), valid, grid, method="nearest", std=s)
    np.testing.assert_array_equal(r.values, out)
    np.testing.assert_array_equal(r.fill_source, src)
    np.testing.assert_array_equal(r.std, std)
    np.testing.assert_array_equal(r.fill_sources[..., 0], np.where(valid, -1, src))
    assert r.fill_sources.shape[-1] == 1 and (r.fill_weights[~valid] == 1).all()


def test_uncertainty_is_calibrated_on_noisy_smooth_data():
    """1 % multiplicative noise: the fitted sigma covers the true errors about as a normal law says."""
    g = Grid(kappa=[-0.22, -0.13, 0.0, 0.13, 0.22], theta_l=[0, 15, 30, 45, 60, 75], phi_l=np.arange(0, 360, 45),
             theta_v=[0, 15, 30, 45, 60, 75], phi_v=np.arange(0, 360, 45))
    truth = _smooth_table(g)
    noisy = truth * np.exp(0.01 * np.random.default_rng(2).standard_normal(truth.shape))
    valid = np.ones(g.shape, bool)
    valid[0, :, 4:] = False
    valid[0, :, :, :, 4:] = False
    r = fill(np.where(valid[..., None], noisy, np.nan), valid, g, method="kappa-fit")
    z = np.abs(np.log(r.values / truth))[~valid] / (r.fill_std[~valid] / r.values[~valid])
    assert 0.6 <= np.mean(z <= 1) <= 0.95 and np.mean(z <= 2) >= 0.93
    assert (r.fill_std[valid] == 0).all()
    (model,) = r.summary["uncertainty"]
    # the check: the directions the stand hides, measured on each other stand, hidden there too and
    # filled the same way (the fill's own regime); calibrated to hold 95 % of its errors within 2 sigma
    assert model["check_samples"] == 4 * (~valid[0]).sum() and model["check_pooled"] == "hidden-like"
    assert model["sigma_scale"] >= 1.0


def test_too_few_checks_give_an_unknown_uncertainty():
    g = Grid(kappa=[-0.2, 0.0, 0.2], theta_l=[0, 40], phi_l=[0, 180], theta_v=[0, 30], phi_v=[0, 180])
    truth = _smooth_table(g)
    valid = np.ones(g.shape, bool)
    valid[0, :, 1, :, 1] = False
    r = fill(np.where(valid[..., None], truth, np.nan), valid, g, method="kappa-fit")
    assert valid[0].sum() < MIN_CHECK_SAMPLES
    np.testing.assert_allclose(r.fill_std[~valid], r.values[~valid])  # 100 %: no check was possible
    assert r.summary["uncertainty"][0]["check_pooled"] == "none"


def test_every_method_refuses_a_curvature_with_nothing_measured(grid):
    valid = np.ones(grid.shape, bool)
    valid[0] = False
    for method in FILL_METHODS:
        with pytest.raises(TableError, match="kappa = -0.2 1/mm: no sample was measured"):
            fill(np.ones(grid.shape + (3,)), valid, grid, method=method)


# -- the model fill and the choice by evidence ------------------------------------------------
def test_model_fill_carries_the_model_change_and_cancels_its_level():
    """The model fill applies the fitted model's change with curvature to the measured values: a model
    that is wrong by a factor per direction (its level) but right in its change fills exactly."""
    from cdbrdf.measure.fill_model import ModelFit, model_fill_weights, model_predict

    truth = _smooth_table(KGRID)
    nk = KGRID.shape[0]
    flat = truth.reshape(nk, -1, 3)
    d = np.arange(flat.shape[1])
    level = 1.0 + 0.5 * np.sin(d)[None, :, None]
    fit = ModelFit(preset="test", weights=np.ones((3, 1)), fit_rel_rms=0.0, directions=d, values=flat * level)
    ids = np.array([3, 17, 40])
    value, reach, w = model_predict(fit, truth, 0, ids, (2, 3, 4), KGRID.kappa)
    np.testing.assert_allclose(value, flat[0, ids], rtol=1e-12)
    np.testing.assert_allclose(w, model_fill_weights(KGRID.kappa[[2, 3, 4]], KGRID.kappa[0]))
    np.testing.assert_allclose(w, np.array([1 / 0.22, 1 / 0.35, 1 / 0.44]) / np.sum([1 / 0.22, 1 / 0.35, 1 / 0.44]))
    np.testing.assert_allclose(reach, np.abs(np.log(flat[0, ids] / flat[2, ids])), rtol=1e-12)


def test_auto_chooses_the_method_whose_check_errs_least():
    """One channel (no model): kappa-fit is exact for a log-linear curvature dependence, so its check errs
    least and auto fills with it, recording the choice and every candidate's check error."""
    truth = _smooth_table(KGRID)[..., :1]
    valid = _hidden(KGRID)
    r = fill(np.where(valid[..., None], truth, np.nan), valid, KGRID, method="auto")
    sel = r.summary["selection"]
    assert set(sel) == {"-0.22", "-0.13"}
    for v in sel.values():
        assert v["method"] == "kappa-fit" and "model" not in v["check_median_abs_log_error"]
    # at -0.22 every candidate could be checked (kappa-fit exactly); at -0.13 too few samples are hidden
    # for any check, and the order of preference decides
    scores = sel["-0.22"]["check_median_abs_log_error"]
    assert scores["kappa-fit"] == 0.0 < scores["nearest-stand"] < scores["nearest"]
    assert set(sel["-0.13"]["check_median_abs_log_error"].values()) == {None}
    np.testing.assert_allclose(r.values, truth, rtol=1e-9)
    assert r.method == "auto" and "model" not in r.summary


def test_btf_takes_the_data_fills_only(tmp_path):
    from cdbrdf.errors import OptionError
    from cdbrdf.measure import MeasureOptions
    from cdbrdf.measure.btf import measure_btf

    for method in ("model", "auto"):
        with pytest.raises(OptionError, match=rf"fill: '{method}' fills a CDBRDF, not a CD-BTF's texels"):
            measure_btf(tmp_path, None, texels=4, options=MeasureOptions(fill=method))


def _quick_fill_errors(truth, name, methods, seed=3):
    """Median / coverage of each method on the quick demo grid: the truth with 0.5 % noise, the paper's stands."""
    from cdbrdf.colour import luminance
    from cdbrdf.demo import CONFIGS
    from cdbrdf.measure.stands import Stand, hidden_mask

    cfg = CONFIGS["quick"]
    g = cfg.grid
    valid = hidden_mask(g, [Stand(float(k)) for k in g.kappa], pixel_mm=cfg.field_mm / cfg.image_px) == 0
    meas = truth * (1 + 0.005 * np.random.default_rng(seed).standard_normal(truth.shape))
    yt = luminance(truth)
    out = {}
    for method in methods:
        r = fill(np.where(valid[..., None], meas, np.nan), valid, g, method=method, material=name)
        err = np.abs(luminance(r.values) - yt)
        sig = luminance(r.fill_std)
        out[method] = [(float(np.median(err[k][~valid[k]] / yt[k][~valid[k]])),
                        float(np.mean(err[k][~valid[k]] <= 2 * sig[k][~valid[k]])))
                       for k in range(g.shape[0]) if (~valid[k]).any()]
    return out


@pytest.mark.slow
@pytest.mark.parametrize("name", ["denim", "shot", "velvet", "towel"])
def test_default_fill_beats_the_paper_rule_on_the_bundled_fabrics(name):
    """Issue 35 on the quick demo grid: the default fill is no worse than the paper's rule at any hidden
    stand, and holds at least 90 % of its filled samples within 2 sigma of the truth."""
    from cdbrdf import materials
    from cdbrdf.demo import CONFIGS

    g = CONFIGS["quick"].grid
    m = g.mesh()
    truth = materials.load(name).evaluate(m["theta_v"], m["phi_v"], m["theta_l"], m["phi_l"], m["kappa"])
    res = _quick_fill_errors(truth, name, [DEFAULT_FILL, "nearest"])
    for (med, cover), (med_near, _) in zip(res[DEFAULT_FILL], res["nearest"], strict=True):
        assert med <= med_near and cover >= 0.9, (res)


@pytest.mark.slow
def test_model_fill_on_a_fabric_whose_parameters_it_does_not_know():
    """The truth: velvet with a taller, sparser, more leaning pile than the preset the fill fits
    (scripts/fill_model_study.py has the other cases). The model's change with curvature still fills the
    hidden samples within a few percent, far better than the paper's rule; auto's uncertainty, checked where
    the stands can see, holds 85 % or more of them within 2 sigma (measured: 89 % and 96 %)."""
    from cdbrdf.demo import CONFIGS
    from cdbrdf.synth import presets

    g = CONFIGS["quick"].grid
    truth = presets.model("velvet", pile_height_mm=2.4, strands_per_mm2=15.0, lean_deg=10.0).tabulate(g).values
    res = _quick_fill_errors(truth.astype(np.float64), "velvet", ["model", "auto", "nearest"])
    for (med_m, _), (med_a, cover_a), (med_n, _) in zip(res["model"], res["auto"], res["nearest"], strict=True):
        assert med_m < 0.05 and med_m < med_n / 5
        assert med_a <= med_n and cover_a >= 0.85
