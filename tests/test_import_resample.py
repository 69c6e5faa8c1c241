"""The resampler of the importers: cell means over the projected solid angle, the deblur step, the error estimate.

Known answers: a constant source is reproduced exactly; the plain cell means
keep the source's integral over the measure exactly (the hats sum to one); a
lobe much narrower than a cell keeps its energy (point sampling does not); the
budget widens the quadrature; anisotropic sources refuse isotropic grids.
"""

from __future__ import annotations

import numpy as np
import pytest

from cdbrdf import Grid, TableError
from cdbrdf.importers import estimate_error, resample
from cdbrdf.importers.resample import azimuth_rule, elevation_rule
from cdbrdf.importers.source import table_on

from .import_helpers import analytic_source, aniso_brdf, lobe_brdf


def _iso(step=15.0, phi=30.0, top=75.0):
    return Grid.regular(theta_step_deg=step, phi_step_deg=phi, theta_max_deg=top, kappa=[0.0], symmetry="isotropic")


def test_axis_rules_are_partitions_of_unity_with_the_right_measure():
    r = elevation_rule(np.array([0.0, 15.0, 30.0, 45.0, 60.0, 75.0]), 1.0)
    # hats sum to one at every point: the columns of the matrix sum to the point weights
    w = r.matrix.sum(axis=0)
    assert np.all(w > 0) and r.points.min() > 0 and r.points.max() < 90
    # integral of sin cos over [0, 90] degrees (in degree units times radians of the functions) = 90/pi... as quadrature
    np.testing.assert_allclose(w.sum(), np.radians(1) ** -1 * 0.5, rtol=1e-6)
    a = azimuth_rule(np.arange(12) * 30.0, 1.0)
    np.testing.assert_allclose(a.matrix.sum(), 360.0, rtol=1e-12)
    np.testing.assert_allclose(a.norm, 30.0, rtol=1e-12)
    # the mass matrix of the interpolation's blur: rows sum to one, symmetric stencil on the periodic axis
    m = a.mass()
    np.testing.assert_allclose(m.sum(axis=1), 1.0, rtol=1e-12)
    np.testing.assert_allclose(np.diag(m), 2 / 3, rtol=1e-9)
    np.testing.assert_allclose(m[0, 1], 1 / 6, rtol=1e-9)


@pytest.mark.parametrize("correction", ["mean", "deblur", "projection"])
def test_constant_source_is_reproduced_exactly(correction):
    src = analytic_source(lambda tv, pv, tl, pl: np.full(np.shape(tv) + (3,), 0.25), isotropic=True)
    for g in (_iso(), Grid.paper(kappa=[0.0])):
        r = resample(src, g, correction=correction, spacing_deg=3.0)
        np.testing.assert_allclose(r.values, 0.25, rtol=1e-6)  # float32 contraction
        np.testing.assert_allclose(r.measured, 1.0, rtol=1e-6)


def test_cell_means_keep_the_integral_over_the_measure():
    """sum_i m_i * norm_i = integral of f (the hats sum to one), for any source."""
    f = lambda tv, pv, tl, pl: lobe_brdf(tv, pv, tl, pl, n=400.0)  # noqa: E731
    src = analytic_source(f, isotropic=True)
    g = _iso()
    r = resample(src, g, correction="mean", spacing_deg=3.0)
    rl, rv, rp = elevation_rule(g.theta_l, 3.0), elevation_rule(g.theta_v, 3.0), azimuth_rule(g.phi_v, 3.0)
    norm = np.einsum("i,j,k->ijk", rl.norm, rv.norm, rp.norm)
    total_table = np.einsum("ikj,ijk->", r.values[0, :, :, :, 1], norm)
    # the source's integral by the same quadrature points
    TL, TV, DP = np.meshgrid(rl.points, rv.points, rp.points, indexing="ij")
    w = np.einsum("i,j,k->ijk", rl.matrix.sum(0), rv.matrix.sum(0), rp.matrix.sum(0))
    total_src = np.sum(f(TV, DP, TL, np.zeros_like(TL))[..., 1] * w)
    np.testing.assert_allclose(total_table, total_src, rtol=1e-5)  # float32 contraction


def test_a_lobe_narrower_than_a_cell_keeps_its_energy_where_point_sampling_does_not():
    # Blinn-Phong n = 2000: a lobe of about 3 degrees on a 15 x 30 degree grid
    f = lambda tv, pv, tl, pl: lobe_brdf(tv, pv, tl, pl, kd=(0.02, 0.02, 0.02), ks=0.5, n=2000.0)  # noqa: E731
    src = analytic_source(f, isotropic=True)
    g = _iso()
    cell = table_on(g, resample(src, g, spacing_deg=1.0, correction="mean").values[None])
    point = table_on(g, resample(src, g, method="point").values[None])
    est_cell = estimate_error(src, cell, n=1 << 14, n_views=3, albedo_step_deg=0.5)
    est_point = estimate_error(src, point, n=1 << 14, n_views=3, albedo_step_deg=0.5)
    # directional albedo (the energy a uniform environment reflects): cell means within ~10 % (what is left
    # is the blur over the 15-degree view cells), point samples off by a factor
    assert est_cell["albedo_relative_error_mean"] < 0.15, est_cell
    assert est_point["albedo_relative_error_mean"] > 3 * est_cell["albedo_relative_error_mean"], (est_cell, est_point)
    assert est_cell["peak_to_median"] > 1000


def test_finer_grids_converge_to_the_source():
    src = analytic_source(lambda tv, pv, tl, pl: lobe_brdf(tv, pv, tl, pl, n=50.0), isotropic=True)
    errs = []
    for step in (15.0, 7.5, 5.0):
        g = _iso(step, step, 90.0 - step)
        t = table_on(g, resample(src, g, spacing_deg=step / 2).values[None])
        errs.append(estimate_error(src, t, n=1 << 14, n_views=1, albedo_step_deg=3.0)["brdf_relative_l1"])
    assert errs[0] > errs[1] > errs[2] and errs[2] < 0.02, errs


def test_anisotropic_source_on_an_anisotropic_grid_and_refused_on_an_isotropic_one():
    src = analytic_source(aniso_brdf, isotropic=False)
    g = Grid.paper(kappa=[0.0])
    r = resample(src, g, spacing_deg=5.0)
    t = table_on(g, r.values[None])
    est = estimate_error(src, t, n=1 << 13, n_views=2, albedo_step_deg=3.0)
    assert est["brdf_relative_l1"] < 0.02, est
    with pytest.raises(TableError, match="the source is anisotropic; an isotropic table would average"):
        resample(src, _iso())


def test_budget_widens_the_quadrature_and_says_so():
    src = analytic_source(lambda tv, pv, tl, pl: lobe_brdf(tv, pv, tl, pl), isotropic=True)
    g = _iso()
    small = resample(src, g, spacing_deg=0.5, max_evaluations=50_000)
    assert small.evaluations <= 50_000 and small.spacing_deg > 0.5
    assert small.details()["spacing_deg"] == round(small.spacing_deg, 6)


@pytest.mark.parametrize("kw,match", [({"spacing_deg": 0.0}, "spacing_deg"), ({"method": "nearest"}, "method"),
                                      ({"correction": "sharpen"}, "correction")])
def test_bad_parameters_name_themselves(kw, match):
    src = analytic_source(lambda tv, pv, tl, pl: np.ones(np.shape(tv) + (3,)), isotropic=True)
    with pytest.raises(TableError, match=match):
        resample(src, _iso(), **kw)
