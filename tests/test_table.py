"""The CDBRDF object: construction, validation, properties."""

from __future__ import annotations

import numpy as np
import pytest

import cdbrdf
from cdbrdf import CDBRDF, Grid, TableError

from .conftest import make_table


def test_paper_grid_matches_the_paper():
    g = Grid.paper()
    assert g.shape == (5, 12, 6, 12, 6)
    np.testing.assert_array_equal(g.theta_l, [0, 15, 30, 45, 60, 75])
    np.testing.assert_array_equal(g.phi_v, np.arange(0, 360, 30))
    np.testing.assert_array_equal(g.kappa, [-0.22, -0.13, 0.0, 0.13, 0.22])
    # 72 x 72 x 5 photographs
    assert np.prod(g.shape) == 72 * 72 * 5


def test_properties_and_defaults(paper_table):
    t = paper_table
    assert t.shape == (5, 12, 6, 12, 6, 3)
    assert t.measured.shape == t.shape[:-1] and t.measured.all()
    assert (t.fill_source == -1).all()
    assert t.quantity == "relative"
    assert t.channels == ["R", "G", "B"]
    assert t.attrs["material"] == "random"
    with pytest.raises(ValueError):
        t.values[0, 0, 0, 0, 0, 0] = 1.0  # read-only


def test_values_are_copied():
    g = Grid.paper(kappa=[0.0])
    v = np.ones(g.shape + (3,))
    t = CDBRDF(v, **g.axes())
    v[...] = 5
    assert t.values.max() == 1.0


def test_fig7_layout(small_grid):
    t = make_table(small_grid)
    f = t.fig7()
    k, pl, tl, pv, tv, c = t.shape
    assert f.shape == (k, pl * tl, pv * tv, c)
    # row = light (azimuth group, elevation inside); column = view likewise
    np.testing.assert_array_equal(f[2, 1 * tl + 2, 2 * tv + 1], t.values[2, 1, 2, 2, 1])


@pytest.mark.parametrize(
    "axes, match",
    [
        (dict(kappa=[0.1, 0.0]), "kappa: must be strictly increasing"),
        (dict(kappa=[0.0, 0.0]), "kappa: must be strictly increasing"),
        (dict(theta_l=[0.0, 90.0]), r"theta_l: elevations must lie in \[0, 90\)"),
        (dict(theta_v=[-5.0, 10.0]), r"theta_v: elevations must lie in \[0, 90\)"),
        (dict(phi_l=[0.0, 100.0, 240.0]), "phi_l: azimuths must be evenly spaced"),
        (dict(phi_v=[0.0, 360.0]), r"phi_v: azimuths must lie in \[0, 360\)"),
        (dict(kappa=[np.nan]), "kappa: contains NaN"),
        (dict(kappa=[[0.0]]), "kappa: expected a 1-D axis"),
        (dict(kappa=[]), "kappa: the axis is empty"),
        (dict(theta_v=["a"]), "theta_v: cannot be read as numbers"),
    ],
)
def test_bad_axes(axes, match):
    base = dict(kappa=[0.0], theta_l=[0.0, 30.0], phi_l=[0.0, 180.0], theta_v=[0.0, 30.0], phi_v=[0.0, 180.0])
    base.update(axes)
    shape = tuple(np.size(base[n]) for n in ("kappa", "phi_l", "theta_l", "phi_v", "theta_v"))
    with pytest.raises(TableError, match=match):
        CDBRDF(np.ones(shape + (3,)), **base)


def test_phi_may_start_off_zero():
    g = Grid(kappa=[0.0], theta_l=[10.0], phi_l=[15.0, 135.0, 255.0], theta_v=[10.0], phi_v=[45.0])
    assert g.shape == (1, 3, 1, 1, 1)


@pytest.mark.parametrize(
    "values, match",
    [
        (np.ones((5, 12, 6, 12, 6)), "values: expected 6 dimensions"),
        (np.ones((5, 12, 6, 12, 5, 3)), "values: shape .* does not match the axes"),
        (np.full((5, 12, 6, 12, 6, 3), np.nan), "values: contains .* NaN"),
        (np.full((5, 12, 6, 12, 6, 3), np.inf), "values: contains .* NaN or infinite"),
        (np.full((5, 12, 6, 12, 6, 3), "x"), "values: expected numbers"),
    ],
)
def test_bad_values(values, match):
    with pytest.raises(TableError, match=match):
        CDBRDF(values, **Grid.paper().axes())


def test_errors_are_value_errors():
    assert issubclass(TableError, ValueError)
    assert issubclass(cdbrdf.FormatError, ValueError)
    assert issubclass(cdbrdf.QueryError, ValueError)


def test_mask_and_fill_source(small_grid):
    shape = small_grid.shape
    measured = np.ones(shape, bool)
    measured[0, 0, 2, 0, 2] = False
    src = np.full(shape, -1)
    src[0, 0, 2, 0, 2] = np.ravel_multi_index((0, 0, 1, 0, 2), shape)
    t = make_table(small_grid, measured=measured, fill_source=src)
    assert not t.measured[0, 0, 2, 0, 2]
    assert t.fill_source[0, 0, 2, 0, 2] == np.ravel_multi_index((0, 0, 1, 0, 2), shape)
    # without sources, filled samples are marked "unknown" (-2)
    t2 = make_table(small_grid, measured=measured)
    assert t2.fill_source[0, 0, 2, 0, 2] == -2
    with pytest.raises(TableError, match="measured: shape"):
        make_table(small_grid, measured=np.ones(shape[:-1], bool))
    with pytest.raises(TableError, match="fill_source: must be -1 wherever"):
        make_table(small_grid, measured=measured, fill_source=np.zeros(shape, int))
    bad = src.copy()
    bad[0, 0, 2, 0, 2] = np.ravel_multi_index((0, 0, 2, 0, 2), shape)  # points at itself
    with pytest.raises(TableError, match="points at a sample that is not measured"):
        make_table(small_grid, measured=measured, fill_source=bad)
    bad[0, 0, 2, 0, 2] = 10**9
    with pytest.raises(TableError, match="fill_source: indices must be in"):
        make_table(small_grid, measured=measured, fill_source=bad)


def test_std_validation(small_grid):
    shape = small_grid.shape + (3,)
    t = make_table(small_grid, std=np.full(shape, 0.01))
    assert t.std.shape == shape
    with pytest.raises(TableError, match="std: standard deviations must be non-negative"):
        make_table(small_grid, std=np.full(shape, -0.01))


def test_attrs_validation(small_grid):
    with pytest.raises(TableError, match=r"attrs\['quantity'\]: 'watts' is not one of brdf, relative"):
        make_table(small_grid, attrs={"quantity": "watts"})
    with pytest.raises(TableError, match="attrs: expected a mapping"):
        make_table(small_grid, attrs=[("a", 1)])


def test_brdf_is_the_flat_slice(small_grid):
    t = make_table(small_grid)
    b = t.brdf()
    assert b.shape == (1,) + t.shape[1:]
    np.testing.assert_array_equal(b.values[0], t.values[1])  # kappa axis holds 0 at index 1
    np.testing.assert_array_equal(b.kappa, [0.0])
    # a one-kappa table ignores the curvature of the query
    q = (40.0, 70.0, 25.0, 300.0)
    np.testing.assert_array_equal(b.evaluate(*q, -0.2), b.evaluate(*q, 0.3))
    np.testing.assert_allclose(b.evaluate(*q, 0.3), t.evaluate(*q, 0.0), rtol=0, atol=1e-14)


def test_brdf_between_samples_interpolates(small_grid):
    t = make_table(small_grid)
    b = t.brdf(0.025)  # halfway between 0 and 0.05
    np.testing.assert_allclose(b.values[0], 0.5 * (t.values[1] + t.values[2]), rtol=1e-12)


def test_equality_and_repr(small_grid):
    a = make_table(small_grid, seed=1)
    b = make_table(small_grid, seed=1)
    c = make_table(small_grid, seed=2)
    assert a == b and a != c
    assert "CDBRDF(" in repr(a) and "kappa=" in repr(a)
    assert a.with_attrs(material="x").attrs["material"] == "x"


def test_regular_grid():
    g = Grid.regular(theta_step_deg=30, phi_step_deg=90, kappa=[0.0])
    np.testing.assert_array_equal(g.theta_l, [0, 30, 60])
    np.testing.assert_array_equal(g.phi_l, [0, 90, 180, 270])
    with pytest.raises(TableError, match="does not divide 360"):
        Grid.regular(theta_step_deg=30, phi_step_deg=70)


def test_brdf_clamps_outside_the_curvature_range(small_grid):
    t = make_table(small_grid)
    np.testing.assert_array_equal(t.brdf(5.0).values[0], t.values[-1])
    np.testing.assert_array_equal(t.brdf(-5.0).values[0], t.values[0])
    single = t.brdf(0.0)
    np.testing.assert_array_equal(single.brdf(0.3).values, single.values)


def test_xarray_round_trip(small_grid):
    xr = pytest.importorskip("xarray")
    measured = np.ones(small_grid.shape, bool)
    measured[1, 2, 2, 0, 2] = False
    src = np.full(small_grid.shape, -1)
    src[1, 2, 2, 0, 2] = np.ravel_multi_index((1, 2, 1, 0, 2), small_grid.shape)
    t = make_table(small_grid, measured=measured, fill_source=src, std=np.full(small_grid.shape + (3,), 0.02),
                   attrs={"material": "m", "quantity": "brdf", "provenance": {"a": [1, 2]}})
    ds = t.to_xarray()
    assert ds["reflectance"].dims == ("kappa", "phi_l", "theta_l", "phi_v", "theta_v", "channel")
    assert ds["kappa"].attrs["units"] == "1/mm" and ds["reflectance"].attrs["units"] == "1/sr"
    v = ds["reflectance"].sel(kappa=0.05, phi_l=90.0, theta_l=20.0, phi_v=120.0, theta_v=30.0, channel="G")
    assert float(v) == t.values[2, 1, 1, 1, 1, 1]
    assert CDBRDF.from_xarray(ds) == t
    # any dimension order is accepted
    assert CDBRDF.from_xarray(ds.transpose("channel", "theta_v", "phi_v", "theta_l", "phi_l", "kappa")) == t
    with pytest.raises(TableError, match="no variable 'reflectance'"):
        CDBRDF.from_xarray(ds.drop_vars("reflectance"))
    assert isinstance(ds, xr.Dataset)
