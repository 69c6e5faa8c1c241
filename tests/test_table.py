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


def test_grid_axes_are_keywords_in_one_order():
    """Grid(*g.axes().values()) used to swap theta and phi silently: axes are keywords, stored in the table's order."""
    g = Grid(theta_v=[0, 40], phi_v=[0, 180], theta_l=[0, 30, 60], phi_l=[0, 120, 240], kappa=[0.0, 0.1])
    assert list(g.axes()) == ["kappa", "phi_l", "theta_l", "phi_v", "theta_v"]
    assert g.shape == (2, 3, 3, 2, 2) and Grid(**g.axes()) == g
    with pytest.raises(TypeError):
        Grid(*g.axes().values())  # type: ignore[misc]
    with pytest.raises(TypeError):
        CDBRDF(np.zeros(g.shape + (3,)), *g.axes().values())  # type: ignore[misc]


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
    t = CDBRDF(v, g)
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
        (dict(theta_v=["a"]), "theta_v: expected numbers, got dtype <U1"),
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


@pytest.mark.parametrize("bad", ["a", None, [0.1], True, np.nan, np.inf])
def test_brdf_refuses_what_is_not_a_finite_number(small_grid, bad):
    with pytest.raises(cdbrdf.TableError, match="kappa"):
        make_table(small_grid).brdf(bad)


def test_xarray_round_trip(small_grid):
    import xarray as xr
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
    assert CDBRDF.from_xarray(ds.transpose("fill_slot", "channel", "theta_v", "phi_v", "theta_l", "phi_l", "kappa")) == t
    with pytest.raises(TableError, match="no variable 'reflectance'"):
        CDBRDF.from_xarray(ds.drop_vars("reflectance"))
    assert isinstance(ds, xr.Dataset)


@pytest.mark.parametrize(("name", "units"), [("kappa", "1/m"), ("theta_v", "radian"), ("phi_l", "rad"),
                                             ("reflectance", "1/m2")])
def test_from_xarray_honours_units_as_load_does(small_grid, name, units, tmp_path):
    """kappa in 1/m was read as 1/mm and a theta_v in radian accepted (cdbrdf.load of the same file refused)."""
    ds = make_table(small_grid, attrs={"quantity": "brdf"}).to_xarray()
    ds[name].attrs["units"] = units
    with pytest.raises(TableError, match=rf"ds: '{name}' is in '{units}'"):
        CDBRDF.from_xarray(ds)
    ds.to_netcdf(tmp_path / "t.h5", engine="h5netcdf")
    with pytest.raises(cdbrdf.FormatError, match=rf"'{name}' is in '{units}'"):
        cdbrdf.load(tmp_path / "t.h5")
    ds[name].attrs["units"] = {"kappa": "mm-1", "reflectance": "sr-1"}.get(name, "degrees")  # other spellings
    assert CDBRDF.from_xarray(ds) == make_table(small_grid, attrs={"quantity": "brdf"})


# -- hardening: axes, dtypes, masked arrays, fill sources, size limit -------------------------
_BASE = dict(kappa=[0.0], theta_l=[0.0, 30.0], phi_l=[0.0, 180.0], theta_v=[0.0, 30.0], phi_v=[0.0, 180.0])


def _table(values=None, **axes):
    a = dict(_BASE, **axes)
    shape = tuple(np.size(a[n]) for n in ("kappa", "phi_l", "theta_l", "phi_v", "theta_v"))
    return CDBRDF(np.ones(shape + (3,)) if values is None else values, **a)


@pytest.mark.parametrize(
    "axes, match",
    [
        (dict(kappa=[-1e308, 1e308]), r"kappa: curvatures must lie in \[-1000, 1000\] 1/mm"),
        (dict(kappa=[1e308]), r"kappa: curvatures must lie in"),
        (dict(kappa=[-1.7e308, 0.0, 1.7e308]), r"kappa: curvatures must lie in"),
        (dict(kappa=[0.0, 5e-324]), "kappa: neighbouring samples are .* closer than 1e-09"),
        (dict(theta_l=[0.0, 1e-12]), "theta_l: neighbouring samples"),
        (dict(kappa=[1 + 2j]), "kappa: expected numbers, got dtype complex128"),
        (dict(kappa=np.array([0.0, 0.1], dtype=np.complex64)), "kappa: expected numbers, got dtype complex64"),
        (dict(kappa=np.array([1], dtype="timedelta64[s]")), "kappa: expected numbers, got dtype timedelta64"),
        (dict(theta_l=np.array(["2020-01-01", "2020-01-02"], dtype="datetime64[D]")),
         "theta_l: expected numbers, got dtype datetime64"),
        (dict(phi_v=np.array([0.0, 180.0], dtype=object)), "phi_v: expected numbers, got dtype object"),
        (dict(kappa=[True]), "kappa: expected numbers, got dtype bool"),
        (dict(theta_v=["0", "30"]), "theta_v: expected numbers, got dtype <U2"),
        (dict(theta_v=[b"0", b"30"]), "theta_v: expected numbers, got dtype |S2"),
        (dict(kappa=[0.0, None]), "kappa: expected numbers, got dtype object"),
        (dict(kappa=np.ma.masked_array([0.0, 0.1], mask=[False, True])),
         "kappa: masked array with 1 masked entries; fill them first"),
    ],
)
def test_bad_axes_are_refused(axes, match):
    with pytest.raises(TableError, match=match):
        _table(**axes)


def test_axis_bounds_are_inclusive_and_unmasked_masked_arrays_work():
    t = _table(kappa=[-1e3, 0.0, 1e3])
    assert t.kappa[-1] == 1e3
    t = _table(kappa=np.ma.masked_array([0.0, 0.5], mask=False), theta_l=np.array([0, 30], dtype=np.int16))
    assert t.kappa.dtype == np.float64 and t.theta_l.dtype == np.float64
    assert not isinstance(t.kappa, np.ma.MaskedArray)


@pytest.mark.parametrize(
    "make, match",
    [
        (lambda s: np.ones(s, dtype=np.complex128), "values: expected numbers, got dtype complex128"),
        (lambda s: np.ones(s, dtype=bool), "values: expected numbers, got dtype bool"),
        (lambda s: np.ones(s, dtype="timedelta64[ns]"), "values: expected numbers, got dtype timedelta64"),
        (lambda s: np.ones(s, dtype="datetime64[ns]"), "values: expected numbers, got dtype datetime64"),
        (lambda s: np.ones(s).astype(object), "values: expected numbers, got dtype object"),
        (lambda s: np.full(s, "1.0"), "values: expected numbers, got dtype <U3"),
        (lambda s: np.ma.masked_array(np.ones(s), mask=np.arange(np.prod(s)).reshape(s) == 3),
         "values: masked array with 1 masked entries; fill them first"),
        (lambda s: np.full(s, 1e300, dtype=np.longdouble) * np.longdouble(1e300), "values: contains .* infinite"),
    ],
)
def test_bad_value_dtypes_are_refused(make, match):
    shape = (1, 2, 2, 2, 2, 3)
    with pytest.raises(TableError, match=match):
        _table(make(shape))
    # the same for std
    with pytest.raises(TableError, match=match.replace("values", "std")):
        CDBRDF(np.ones(shape), **_BASE, std=make(shape))


def test_integer_and_float16_values_are_converted():
    shape = (1, 2, 2, 2, 2, 3)
    assert _table(np.ones(shape, dtype=np.int32)).values.dtype == np.float64
    assert _table(np.ones(shape, dtype=np.float16)).values.dtype == np.float64
    assert _table(np.ma.masked_array(np.ones(shape), mask=False)).values.dtype == np.float64


def test_bad_measured_and_fill_source_dtypes(small_grid):
    shape = small_grid.shape
    measured = np.ones(shape, bool)
    measured[0, 0, 2, 0, 2] = False
    with pytest.raises(TableError, match="measured: expected booleans, got dtype timedelta64"):
        make_table(small_grid, measured=np.ones(shape, dtype="timedelta64[s]"))
    with pytest.raises(TableError, match="measured: expected booleans, got dtype float64"):
        make_table(small_grid, measured=np.ones(shape))
    with pytest.raises(TableError, match="measured: masked array with 1 masked entries"):
        make_table(small_grid, measured=np.ma.masked_array(measured, mask=~measured))
    src = np.full(shape, -1)
    src[0, 0, 2, 0, 2] = 5
    for bad, match in ((src.astype("timedelta64[s]"), "fill_source: expected integers, got dtype timedelta64"),
                       (src.astype(bool), "fill_source: expected integers, got dtype bool"),
                       (src.astype(np.float64), "fill_source: expected integers, got dtype float64"),
                       (np.where(src == -1, 2**64 - 1, src).astype(np.uint64), r"fill_source: indices must be in")):
        with pytest.raises(TableError, match=match):
            make_table(small_grid, measured=measured, fill_source=bad)


def test_fill_source_minus_one_on_a_filled_sample_is_refused(small_grid):
    shape = small_grid.shape
    measured = np.ones(shape, bool)
    measured[0, 0, 2, 0, 2] = False
    measured[1, 0, 2, 0, 2] = False
    src = np.full(shape, -1)
    src[0, 0, 2, 0, 2] = np.ravel_multi_index((0, 0, 1, 0, 2), shape)
    with pytest.raises(TableError, match=r"fill_source: 1 filled sample\(s\) have -1 \(measured\)"):
        make_table(small_grid, measured=measured, fill_source=src)
    src[1, 0, 2, 0, 2] = -2  # unknown source: fine
    assert make_table(small_grid, measured=measured, fill_source=src).fill_source[1, 0, 2, 0, 2] == -2


def test_table_larger_than_the_limit_is_refused_before_allocating(monkeypatch):
    from cdbrdf.errors import LimitError

    monkeypatch.setenv("CDBRDF_MAX_TABLE_SAMPLES", "1000")
    with pytest.raises(LimitError, match=r"grid of 5 x 12 x 6 x 12 x 6 samples: 25,920 values exceed the limit "
                                         r"of 1,000 \(raise it with CDBRDF_MAX_TABLE_SAMPLES\)"):
        Grid.paper()
    # values whose shape is over the limit (a broadcast view: nothing allocated yet)
    monkeypatch.setenv("CDBRDF_MAX_TABLE_SAMPLES", "30000")
    g = Grid.paper()
    with pytest.raises(LimitError, match=r"values: table of shape \(5, 12, 6, 12, 6, 3\): 77,760 values"):
        CDBRDF(np.broadcast_to(np.float32(1), g.shape + (3,)), g)
    # a grid of 10^15 samples is refused without building anything
    monkeypatch.delenv("CDBRDF_MAX_TABLE_SAMPLES")
    with pytest.raises(LimitError, match="regular grid of 5 x 36000 x 75001 x 36000 x 75001 samples"):
        Grid.regular(theta_step_deg=0.001, phi_step_deg=0.01)
    big = np.arange(10_000) * 1e-3
    with pytest.raises(LimitError, match="grid of 10000 x 1 x 10000 x 1 x 10000 samples"):
        Grid(kappa=big, theta_l=big * 8e-3, phi_l=[0.0], theta_v=big * 8e-3, phi_v=[0.0])


@pytest.mark.parametrize(
    "kw, match",
    [
        (dict(theta_step_deg=float("nan"), phi_step_deg=30.0), "theta_step_deg: must be positive and finite"),
        (dict(theta_step_deg=15.0, phi_step_deg=1e-300), r"phi_step_deg: .* does not divide 360|table_samples|limit"),
        (dict(theta_step_deg=15.0, phi_step_deg=720.0), r"phi_step_deg: must lie in \(0, 360\]"),
        (dict(theta_step_deg=15.0, phi_step_deg=30.0, theta_max_deg=90.0), r"theta_max_deg: must lie in \[0, 90\)"),
        (dict(theta_step_deg=15.0, phi_step_deg=30.0, kappa=[1e308]), "kappa: curvatures must lie in"),
    ],
)
def test_bad_regular_grids(kw, match):
    from cdbrdf.errors import CDBRDFError

    with pytest.raises(CDBRDFError, match=match):
        Grid.regular(**kw)


# -- hostile input, second round ------------------------------------------------------------------------
@pytest.mark.parametrize("peak", [1e307, -1e307, 1e31])
def test_values_whose_sums_would_overflow_are_refused(peak):
    """A float64 table of 1e307 gave NaN for finite queries (its pole ring means overflowed)."""
    v = np.full((1, 2, 2, 2, 2, 3), 1e307 if abs(peak) > 1e300 else 0.2)
    v[0, 0, 1, 0, 1, 0] = peak
    with pytest.raises(TableError, match=r"values: \d+ value\(s\) beyond \+-1e\+30"):
        _table(v)
    t = _table(np.full((1, 2, 2, 2, 2, 3), 1e29))  # the bound itself is far beyond any reflectance
    assert np.all(np.isfinite(t.evaluate(0.0, 10.0, 30.0, 200.0)))


def test_masked_queries_are_refused_unless_nothing_is_masked():
    from cdbrdf.errors import QueryError

    t = _table()
    q = np.ma.masked_array([10.0, 20.0], mask=[False, True])
    with pytest.raises(QueryError, match=r"phi_v: a masked array with masked entries"):
        t.evaluate(10.0, q, 20.0, 0.0)
    np.testing.assert_array_equal(t.evaluate(10.0, np.ma.masked_array([10.0, 20.0]), 20.0, 0.0),
                                  t.evaluate(10.0, [10.0, 20.0], 20.0, 0.0))


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_the_value_bound_is_the_same_in_either_precision(small_grid, dtype):
    """float32 values of 1e30 were refused with "0 value(s) beyond +-1e+30" (the count compared at float32)."""
    v = np.full(small_grid.shape + (3,), 1e30, dtype)
    assert CDBRDF(v, small_grid).values.max() == v.max()
    v[0, 0, 0, 0, 0, 1] = 3e30
    with pytest.raises(TableError, match=r"values: 1 value\(s\) beyond \+-1e\+30 \(up to 3e\+30\)"):
        CDBRDF(v, small_grid)


def test_a_table_is_its_values_on_a_grid_with_a_provenance():
    """CDBRDF(values, grid, *, std, provenance, attrs): the records whole; the former keywords build the same."""
    from cdbrdf.provenance import Provenance

    g = cdbrdf.Grid.regular(theta_step_deg=30, phi_step_deg=90, kappa=[-0.1, 0.0, 0.1])
    v = np.random.default_rng(2).random(g.shape + (3,)) + 0.1
    measured = np.ones(g.shape, bool)
    measured[0, :, -1] = False
    prov = Provenance(measured=measured, fill_source=np.where(measured, -1, -2))
    t = CDBRDF(v, g, provenance=prov, attrs={"material": "m"})
    assert t.grid == g and t.attrs["material"] == "m"
    np.testing.assert_array_equal(t.provenance.measured, measured)
    assert t == CDBRDF(v, g, measured=measured, fill_source=prov.fill_source, attrs={"material": "m"})
    assert CDBRDF(t.values, t.grid, std=t.std, provenance=t.provenance, attrs=t.attrs) == t
    with pytest.raises(TableError, match="^grid: give the axes and symmetry in the Grid, not beside it"):
        CDBRDF(v, g, kappa=g.kappa)
    with pytest.raises(TableError, match="^provenance: give measured in the Provenance, not beside it"):
        CDBRDF(v, g, provenance=prov, measured=measured)
    with pytest.raises(TableError, match="^grid: expected a cdbrdf.Grid, got dict"):
        CDBRDF(v, g.axes())
    with pytest.raises(TypeError, match="unexpected keyword argument 'kapa'"):
        CDBRDF(v, g, kapa=1)
