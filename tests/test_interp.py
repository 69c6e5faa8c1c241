"""The 5-D lookup: reference values, nodes, wrap, clamping, pole, NaN, broadcasting."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.interpolate import RegularGridInterpolator

import cdbrdf
from cdbrdf import CDBRDF, Grid, QueryError
from cdbrdf.interp import evaluate, evaluate_reference, prepare

from .conftest import make_table


def _scipy_reference(t: CDBRDF):
    """An independent multilinear interpolator: scipy's, azimuths padded by one period."""
    g = t.grid
    v = t.values.astype(np.float64)
    v = np.concatenate([v, v[:, :1]], axis=1)
    v = np.concatenate([v, v[:, :, :, :1]], axis=3)
    pl = np.append(g.phi_l, g.phi_l[0] + 360.0)
    pv = np.append(g.phi_v, g.phi_v[0] + 360.0)
    rgi = RegularGridInterpolator((g.kappa, pl, g.theta_l, pv, g.theta_v), v)

    def f(tv, phv, tl, phl, k):
        phl = g.phi_l[0] + np.mod(phl - g.phi_l[0], 360.0)
        phv = g.phi_v[0] + np.mod(phv - g.phi_v[0], 360.0)
        return rgi(np.stack([k, phl, tl, phv, tv], axis=-1))

    return f


def test_hand_computed_value():
    # f = a + b*kappa + c*theta_v + d*theta_l: multilinear reproduces it exactly
    g = Grid(kappa=[-0.2, 0.1, 0.3], theta_l=[0, 30, 60], phi_l=[0, 120, 240], theta_v=[0, 45, 80], phi_v=[0, 90, 180, 270])
    m = g.mesh()
    f = 0.5 + 2.0 * m["kappa"] + 0.01 * m["theta_v"] + 0.003 * m["theta_l"]
    t = CDBRDF(np.stack([f, 2 * f, 3 * f], -1), **g.axes())
    got = t.evaluate(52.0, 33.0, 17.0, 201.0, 0.0)
    want = 0.5 + 2.0 * 0.0 + 0.01 * 52.0 + 0.003 * 17.0
    np.testing.assert_allclose(got, [want, 2 * want, 3 * want], rtol=1e-13)


def test_hand_computed_bilinear_in_azimuth():
    # values depend on phi_v only: 1 at phi 0, 3 at phi 90 -> 2 at phi 45, 1.5 at 22.5
    g = Grid(kappa=[0.0], theta_l=[10.0], phi_l=[0.0], theta_v=[20.0, 40.0], phi_v=[0, 90, 180, 270])
    v = np.zeros(g.shape + (1,))
    v[0, 0, 0, :, :, 0] = np.array([1.0, 3.0, 5.0, 7.0])[:, None]
    t = CDBRDF(v, **g.axes())
    np.testing.assert_allclose(t.evaluate(30.0, [45.0, 22.5, 315.0, -45.0], 10.0, 0.0)[:, 0], [2, 1.5, 4, 4])


def test_nodes_are_reproduced_exactly(paper_table):
    t = paper_table
    m = t.grid.mesh()
    sel = tuple(slice(None) if i == 0 else slice(1, None) for i in range(5))  # off the pole
    sel = (slice(None), slice(None), slice(1, None), slice(None), slice(1, None))
    got = t.evaluate(m["theta_v"][sel], m["phi_v"][sel], m["theta_l"][sel], m["phi_l"][sel], m["kappa"][sel])
    np.testing.assert_array_equal(got, t.values[sel])


def test_agrees_with_independent_multilinear(paper_table):
    t = paper_table
    rng = np.random.default_rng(1)
    n = 20000
    tv, tl = rng.uniform(15, 75, (2, n))  # both elevations at or above the second sample
    pv, pl = rng.uniform(-720, 720, (2, n))
    k = rng.uniform(-0.22, 0.22, n)
    ref = _scipy_reference(t)(tv, pv, tl, pl, k)
    np.testing.assert_allclose(t.evaluate(tv, pv, tl, pl, k), ref, rtol=1e-12, atol=1e-12)


def test_agrees_with_readable_reference_everywhere(small_grid):
    t = make_table(small_grid, seed=3)
    rng = np.random.default_rng(2)
    q = [rng.uniform(0, 90, 300), rng.uniform(-400, 400, 300), rng.uniform(0, 90, 300),
         rng.uniform(-400, 400, 300), rng.uniform(-0.5, 0.5, 300)]
    fast = t.evaluate(*q)
    for i in range(300):
        np.testing.assert_allclose(fast[i], evaluate_reference(t, *(x[i] for x in q)), rtol=1e-12)


@pytest.mark.parametrize("phi", [-30.0, 0.0, 360.0, 390.0, 720.0, -360.0])
def test_periodic_wrap(paper_table, phi):
    t = paper_table
    base = t.evaluate(30.0, np.mod(phi, 360.0), 45.0, 60.0, 0.1)
    np.testing.assert_allclose(t.evaluate(30.0, phi, 45.0, 60.0, 0.1), base, rtol=1e-14)
    np.testing.assert_allclose(t.evaluate(30.0, 60.0, 45.0, phi, 0.1), t.evaluate(30.0, 60.0, 45.0, np.mod(phi, 360.0), 0.1), rtol=1e-14)


def test_wrap_between_last_and_first_azimuth(paper_table):
    t = paper_table
    mid = t.evaluate(30.0, 345.0, 45.0, 90.0, 0.0)
    np.testing.assert_allclose(mid, 0.5 * (t.values[2, 3, 3, 11, 2] + t.values[2, 3, 3, 0, 2]), rtol=1e-12)


def test_clamping(paper_table):
    t = paper_table
    # curvature clamps to the axis ends
    np.testing.assert_array_equal(t.evaluate(30, 30, 30, 30, 5.0), t.evaluate(30, 30, 30, 30, 0.22))
    np.testing.assert_array_equal(t.evaluate(30, 30, 30, 30, -5.0), t.evaluate(30, 30, 30, 30, -0.22))
    # elevation beyond the last sample (75) clamps
    np.testing.assert_array_equal(t.evaluate(89.0, 30, 30, 30, 0.0), t.evaluate(75.0, 30, 30, 30, 0.0))
    np.testing.assert_array_equal(t.evaluate(30, 30, 90.0, 30, 0.0), t.evaluate(30, 30, 75.0, 30, 0.0))


def test_pole_azimuth_does_not_matter(paper_table):
    t = paper_table
    phis = np.linspace(-180, 540, 37)
    v = t.evaluate(0.0, phis, 40.0, 75.0, 0.07)
    assert np.all(v == v[0])
    lv = t.evaluate(25.0, 10.0, 0.0, phis, -0.1)
    assert np.all(lv == lv[0])
    both = t.evaluate(0.0, phis, 0.0, phis[::-1], 0.0)
    assert np.all(both == both[0])


def test_pole_value_is_ring_mean_and_blend_is_continuous(paper_table):
    t = paper_table
    # at the pole: the mean of the stored theta_v = 0 ring
    want = t.values[2, 4, 2, :, 0].mean(axis=0)
    np.testing.assert_allclose(t.evaluate(0.0, 123.0, 30.0, 120.0, 0.0), want, rtol=1e-6)
    # linear blend up to theta = 15: halfway is the average of pole and ring value
    ring = t.values[2, 4, 2, 3, 1]  # phi_v = 90, theta_v = 15
    np.testing.assert_allclose(t.evaluate(7.5, 90.0, 30.0, 120.0, 0.0), 0.5 * (want + ring), rtol=1e-6)
    # continuity near the pole
    eps = t.evaluate(1e-9, [0.0, 77.0, 200.0], 30.0, 120.0, 0.0)
    np.testing.assert_allclose(eps, np.broadcast_to(want, eps.shape), rtol=1e-9)


def test_virtual_pole_when_first_elevation_is_not_zero():
    g = Grid(kappa=[0.0], theta_l=[10.0, 40.0], phi_l=[0.0, 180.0], theta_v=[10.0, 40.0], phi_v=[0.0, 180.0])
    t = make_table(g, seed=5)
    v = t.evaluate(0.0, [0.0, 90.0, 180.0], 40.0, 0.0)
    assert np.all(v == v[0])
    np.testing.assert_allclose(v[0], t.values[0, 0, 1, :, 0].mean(axis=0), rtol=1e-12)
    # exact at the stored first ring
    np.testing.assert_array_equal(t.evaluate(10.0, 180.0, 40.0, 0.0)[..., :], t.values[0, 0, 1, 1, 0])


def test_non_uniform_kappa(small_grid):
    t = make_table(small_grid, seed=4)
    # kappa axis [-0.2, 0, 0.05, 0.3]: 0.1 is 1/5 of the way from 0.05 to 0.3
    q = (30.0, 120.0, 20.0, 90.0)
    got = t.evaluate(*q, 0.1)
    want = 0.8 * t.values[2, 1, 1, 1, 1] + 0.2 * t.values[3, 1, 1, 1, 1]
    np.testing.assert_allclose(got, want, rtol=1e-13)


def test_non_uniform_theta():
    g = Grid(kappa=[0.0], theta_l=[0.0, 10.0, 50.0, 80.0], phi_l=[0.0], theta_v=[0.0, 5.0, 60.0], phi_v=[0.0])
    t = make_table(g, seed=6)
    got = t.evaluate(32.5, 0.0, 30.0, 0.0)  # theta_v halfway 5..60, theta_l halfway 10..50
    v = t.values[0, 0, :, 0, :]
    want = 0.25 * (v[1, 1] + v[1, 2] + v[2, 1] + v[2, 2])
    np.testing.assert_allclose(got, want, rtol=1e-13)


def test_single_kappa_and_single_azimuth_tables():
    g = Grid(kappa=[0.0], theta_l=[0.0, 45.0], phi_l=[0.0], theta_v=[0.0, 45.0], phi_v=[0.0])
    t = make_table(g, seed=7)
    a = t.evaluate(30.0, [0.0, 100.0, 250.0], 20.0, [5.0, 50.0, 300.0], [-1.0, 0.0, 1.0])
    assert np.all(a == a[0])


def test_broadcasting_shapes(paper_table):
    t = paper_table
    assert t.evaluate(10.0, 20.0, 30.0, 40.0, 0.0).shape == (3,)
    tv = np.linspace(0, 75, 7)[:, None]
    pv = np.linspace(0, 330, 5)[None, :]
    out = t.evaluate(tv, pv, 30.0, 40.0, np.zeros((2, 1, 1)))
    assert out.shape == (2, 7, 5, 3)
    # broadcast result equals the element-wise one
    full = [np.broadcast_to(x, (2, 7, 5)).copy() for x in (tv, pv, 30.0, 40.0, np.zeros((2, 1, 1)))]
    np.testing.assert_array_equal(out, t.evaluate(*full))
    # non-contiguous views go through the chunked path and agree
    q = np.random.default_rng(0).uniform(0, 75, (4, 300000))
    np.testing.assert_array_equal(t.evaluate(q[0, ::3], q[1, ::3], q[2, ::3], q[3, ::3], 0.0),
                                  t.evaluate(*(np.ascontiguousarray(x[::3]) for x in q[:4]), 0.0))
    assert t.evaluate(np.empty((0, 4)), 0.0, 0.0, 0.0).shape == (0, 4, 3)


def test_float32_and_integer_queries(paper_table):
    t = paper_table
    a = t.evaluate(np.float32(30.0), np.int64(45), 30, 60, 0)
    b = t.evaluate(30.0, 45.0, 30.0, 60.0, 0.0)
    np.testing.assert_array_equal(a, b)


def test_nan_rows(paper_table):
    t = paper_table
    q = np.array([30.0, np.nan, 45.0, 60.0])
    out = t.evaluate(q, 20.0, 30.0, 40.0, [0.0, 0.0, np.nan, np.inf])
    assert np.isfinite(out[0]).all()
    assert np.isnan(out[1:]).all()


def test_impossible_elevations_raise(paper_table):
    t = paper_table
    with pytest.raises(QueryError, match=r"theta_v \(1 queries\)"):
        t.evaluate([30.0, 91.0], 0.0, 30.0, 0.0)
    with pytest.raises(QueryError, match=r"theta_l \(2 queries\)"):
        t.evaluate(30.0, 0.0, [-1.0, 100.0], 0.0)
    out = evaluate(t, [30.0, 91.0], 0.0, 30.0, 0.0, on_invalid="nan")
    assert np.isfinite(out[0]).all() and np.isnan(out[1]).all()
    with pytest.raises(ValueError, match="on_invalid"):
        evaluate(t, 30.0, 0.0, 30.0, 0.0, on_invalid="clip")


def test_bad_query_types(paper_table):
    with pytest.raises(QueryError, match="theta_v: expected numbers"):
        paper_table.evaluate("abc", 0.0, 30.0, 0.0)
    with pytest.raises(QueryError, match="do not broadcast"):
        paper_table.evaluate(np.zeros(3), np.zeros(4), 30.0, 0.0)


def test_generic_channel_count(small_grid):
    t1 = make_table(small_grid, seed=8, channels=1)
    t5 = make_table(small_grid, seed=8, channels=5)
    rng = np.random.default_rng(3)
    q = [rng.uniform(0, 90, 50), rng.uniform(0, 360, 50), rng.uniform(0, 90, 50), rng.uniform(0, 360, 50), rng.uniform(-0.3, 0.4, 50)]
    for t in (t1, t5):
        fast = t.evaluate(*q)
        ref = np.array([evaluate_reference(t, *(x[i] for x in q)) for i in range(50)])
        np.testing.assert_allclose(fast, ref, rtol=1e-12)


def test_float32_table_is_exact_at_nodes():
    g = Grid.paper(kappa=[0.0])
    t = make_table(g, dtype=np.float32)
    assert prepare(t).values.dtype == np.float32
    np.testing.assert_array_equal(t.evaluate(45.0, 90.0, 30.0, 300.0), t.values[0, 10, 2, 3, 3])


def test_prepared_grid_is_cached_by_the_table(paper_table):
    assert paper_table.lookup_grid() is paper_table.lookup_grid()
    lg = prepare(paper_table)  # builds a new one, equal to the cached grid
    assert lg is not paper_table.lookup_grid()
    np.testing.assert_array_equal(lg.values, paper_table.lookup_grid().values)
    assert lg.theta_l[0] == 0 and lg.phi_l_step == 30.0
    assert lg.phi_l_inv_step == 1 / 30.0 and lg.rgb_kernel and lg.stride == 4
    assert lg.shape == (5, 12, 6, 12, 6, 3) and lg.flat.size == 5 * 12 * 6 * 12 * 6 * 4


def test_prepared_grid_is_immutable(paper_table):
    lg = paper_table.lookup_grid()
    with pytest.raises(AttributeError):
        lg.values = None  # type: ignore[misc]
    for name in ("values", "flat", "kappa", "kappa_inv_d", "theta_l", "theta_l_inv_d", "theta_v", "theta_v_inv_d"):
        assert not getattr(lg, name).flags.writeable, name
    assert "LookupGrid(shape=(5, 12, 6, 12, 6, 3)" in repr(lg)


# -- robustness of the index math (huge, tiny and non-finite queries) ----------------------
def _kernel_tables() -> dict[str, CDBRDF]:
    """One table per kernel path: RGB, generic 1-channel, > 8 curvatures, uneven elevations, 1 kappa."""
    paper = Grid.paper()
    many_k = Grid.paper(kappa=np.linspace(-0.3, 0.3, 11))
    uneven = Grid(kappa=[-0.2, 0.0, 0.2], theta_l=[0.0, 10.0, 35.0, 70.0], phi_l=np.arange(0.0, 360.0, 45.0),
                  theta_v=[5.0, 20.0, 60.0], phi_v=np.arange(0.0, 360.0, 72.0) + 10.0)
    return {
        "rgb": make_table(paper, seed=11),
        "rgb_float32": make_table(paper, seed=12, dtype=np.float32),
        "one_channel": make_table(paper, seed=13, channels=1),
        "many_kappa": make_table(many_k, seed=14),
        "uneven_theta": make_table(uneven, seed=15),
        "single_kappa": make_table(Grid.paper(kappa=[0.0]), seed=16),
        "fine_azimuth": make_table(Grid(kappa=[0.0], theta_l=[0.0, 30.0, 60.0], phi_l=np.arange(720) * 0.5,
                                        theta_v=[0.0, 30.0, 60.0], phi_v=np.arange(720) * 0.5), seed=17),
    }


#: Extreme finite azimuths, degrees (float64 and float32 ones).
_HUGE_AZIMUTHS = [1e15, 1e16, 1e23, -1e23, 1e30, -1e30, 3.4e38, -3.4e38, 1e300, 1e308, -1.7976931348623157e308,
                  float(np.float32(3.4028235e38)), float(np.float32(-1e30)), 5e-324, -5e-324, -0.0,
                  360.0 - 1e-13, -360.0 + 1e-13, 720.0, -720.0, 2.0**53 + 1.0, 2.0**63]


def check_huge_azimuths() -> None:
    """Every kernel: a huge finite azimuth gives the value at its exact place on the circle.

    Run in a child process by the test below (before the fix these queries
    read outside the table and could kill the process).
    """
    az = np.array(_HUGE_AZIMUTHS)
    for name, t in _kernel_tables().items():
        lo, hi = float(t.values.min()), float(t.values.max())
        for a_dtype in (np.float64, np.float32):
            a = az[np.abs(az) <= np.finfo(a_dtype).max].astype(a_dtype)
            w = np.fmod(a.astype(np.float64), 360.0)  # exact
            for args, ref in (((40.0, a, 30.0, 270.0, 0.1), (40.0, w, 30.0, 270.0, 0.1)),
                              ((40.0, 100.0, 30.0, a, -0.1), (40.0, 100.0, 30.0, w, -0.1)),
                              ((1e-300, a, 89.999999, a[::-1], 1e308), (1e-300, w, 89.999999, w[::-1], 1e308))):
                got = t.evaluate(*args)
                assert np.all(np.isfinite(got)), (name, a_dtype, got)
                assert np.all((got >= lo) & (got <= hi)), (name, a_dtype, got.min(), got.max(), lo, hi)
                np.testing.assert_allclose(got, t.evaluate(*ref), rtol=1e-12, atol=0, err_msg=name)


def test_huge_finite_azimuths_stay_in_the_table_in_every_kernel():
    import os
    import subprocess
    import sys

    env = dict(os.environ, PYTHONPATH=os.pathsep.join(p for p in sys.path if p))
    r = subprocess.run([sys.executable, "-c", "import tests.test_interp as m; m.check_huge_azimuths()"],
                       capture_output=True, text=True, env=env, timeout=600)
    assert r.returncode == 0, f"exit code {r.returncode}: {r.stderr[-2000:]}"


@pytest.mark.parametrize("name", list(_kernel_tables()))
def test_nodes_and_wraps_in_every_kernel(name):
    t = _kernel_tables()[name]
    g = t.grid
    # every grid node off the pole is reproduced exactly, also one or many turns away
    il, iv = min(1, g.theta_l.size - 1), min(1, g.theta_v.size - 1)
    for turns in (0.0, 1.0, -3.0, 1e6):
        got = t.evaluate(g.theta_v[iv], g.phi_v + 360.0 * turns, g.theta_l[il], g.phi_l[-1] - 360.0 * turns, g.kappa[-1])
        np.testing.assert_allclose(got, t.values[-1, -1, il, :, iv], rtol=1e-9)
    # elevations at and near the ends of [0, 90]
    v = t.evaluate([0.0, 5e-324, 1e-300, 90.0 - 1e-13, 90.0], 10.0, [90.0, 89.9999, 0.0, 5e-324, 0.0], 370.0)
    assert np.isfinite(v).all() and (v >= t.values.min()).all() and (v <= t.values.max()).all()
    # non-finite queries give NaN rows, bad elevations a QueryError, in every kernel
    bad = t.evaluate(30.0, [np.nan, np.inf, -np.inf, 10.0], 30.0, 0.0, [0.0, 0.0, 0.0, np.nan])
    assert np.isnan(bad).all()
    with pytest.raises(QueryError, match="theta_v"):
        t.evaluate(90.0 + 1e-13, 0.0, 30.0, 0.0)
    with pytest.raises(QueryError, match="theta_l"):
        t.evaluate(30.0, 0.0, -5e-324, 1e30)


def test_drjit_lookup_index_stays_in_the_table():
    """The plug-in's Dr.Jit lookup: no float32 input (huge, infinite, NaN) indexes outside the table."""
    pytest.importorskip("mitsuba")
    pytest.importorskip("drjit")
    from cdbrdf.render import _llvm

    if not _llvm.find_llvm().ok:
        pytest.skip(_llvm.llvm_message(_llvm.find_llvm()))
    import mitsuba as mi

    import cdbrdf.render as cr
    from cdbrdf.render._lookup_jit import lookup_jit, pack_table

    cr.set_variant("llvm_ad_rgb")
    specials = np.array([np.nan, np.inf, -np.inf, 3.4028235e38, -3.4028235e38, 1e30, -1e30, 1e20, 2.0**24 + 3.0,
                         -0.0, 1e-45, 359.99997, 720.0, -1e-30], dtype=np.float32)
    rng = np.random.default_rng(0)
    for name in ("rgb", "one_channel", "many_kappa", "uneven_theta", "fine_azimuth"):
        t = _kernel_tables()[name]
        lg = prepare(t)
        packed = pack_table(mi, lg)
        n = 4000
        pv = rng.choice(specials, n)
        pl = rng.choice(specials, n)
        tv = rng.uniform(0, 90, n).astype(np.float32)
        tl = rng.uniform(0, 90, n).astype(np.float32)
        k = rng.uniform(-1, 1, n).astype(np.float32)
        got = np.array(lookup_jit(mi, lg, packed, mi.Float(tv), mi.Float(pv), mi.Float(tl), mi.Float(pl),
                                  mi.Float(k))).T
        lo, hi = float(t.values.min()), float(t.values.max())
        tol = 1e-5 * (hi - lo) + 1e-6
        assert np.isfinite(got).all(), name
        assert (got >= lo - tol).all() and (got <= hi + tol).all(), (name, got.min(), got.max(), lo, hi)
        # finite azimuths that float32 wraps exactly agree with the float64 lookup
        ok = np.isfinite(pv) & np.isfinite(pl) & (np.abs(pv) <= 720) & (np.abs(pl) <= 720)
        ref = t.evaluate(tv[ok], pv[ok], tl[ok], pl[ok], k[ok])
        np.testing.assert_allclose(got[ok][:, :t.n_channels], ref, rtol=1e-4, atol=1e-5 * hi)


# -- numba caching in a read-only install ------------------------------------------------------
def _read_only_install(root):
    """A copy of the package where numba can write no cache, even for root.

    Every package folder gets a regular *file* named ``__pycache__`` (so no
    cache folder can be made next to the sources) and HOME holds a file
    ``.cache`` (so no user cache folder either); then everything is made
    read-only.
    """
    import os
    import shutil
    from pathlib import Path

    src = Path(cdbrdf.__file__).parent
    pkg = Path(root) / "site" / "cdbrdf"
    shutil.copytree(src, pkg, ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
    for d in [pkg, *(p for p in pkg.rglob("*") if p.is_dir())]:
        (d / "__pycache__").write_text("")
    home = Path(root) / "home"
    home.mkdir()
    (home / ".cache").write_text("")
    for p in [*pkg.parent.rglob("*"), pkg.parent, home / ".cache", home]:
        os.chmod(p, 0o555 if p.is_dir() else 0o444)
    env = {k: v for k, v in os.environ.items() if k not in ("NUMBA_CACHE_DIR", "XDG_CACHE_HOME", "PYTHONPATH")}
    env.update(HOME=str(home), PYTHONPATH=str(pkg.parent), PYTHONDONTWRITEBYTECODE="1")
    return pkg.parent, env


@pytest.mark.slow
def test_read_only_install_without_writable_home_compiles_in_memory(tmp_path):
    import subprocess
    import sys

    site, env = _read_only_install(tmp_path)
    code = (
        "import sys, numpy as np\n"
        "import cdbrdf.cli\n"
        "try:\n    cdbrdf.cli.main(['--version'])\nexcept SystemExit as e:\n    assert e.code == 0, e.code\n"
        "assert 'numba' not in sys.modules, 'cdbrdf --version imported numba'\n"
        "import cdbrdf, cdbrdf.synth, cdbrdf.measure.images, cdbrdf._kernels as k\n"
        "assert cdbrdf.__file__.startswith(sys.argv[1]), cdbrdf.__file__\n"
        "assert k.lookup_generic._cache.__class__.__name__ == 'NullCache'\n"
        "g = cdbrdf.Grid(kappa=[0.0], theta_l=[0.0, 40.0], phi_l=[0.0, 180.0], theta_v=[0.0, 40.0], phi_v=[0.0, 180.0])\n"
        "t = cdbrdf.CDBRDF(np.full(g.shape + (1,), 0.25), **g.axes())\n"
        "assert np.allclose(t.evaluate(30.0, 1e30, 20.0, 10.0), 0.25)\n"
        "print('ok')\n"
    )
    try:
        r = subprocess.run([sys.executable, "-c", code, str(site)], capture_output=True, text=True, env=env,
                           cwd=tmp_path, timeout=600)
    finally:
        for p in [site, *site.rglob("*"), tmp_path / "home"]:
            p.chmod(0o755 if p.is_dir() else 0o644)
    assert r.returncode == 0 and r.stdout.strip().endswith("ok"), r.stderr[-3000:]
