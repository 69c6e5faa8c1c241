"""One conformance suite for every implementation of the lookup rule (:mod:`cdbrdf.interp`).

The implementations (the readable reference, both numba kernels, the
renderer's Dr.Jit lookup and the plug-in in ``scalar_rgb``), the tables and
the queries live in ``tests/lookup_cases.py``. Tables: 1 to 9 curvatures,
even and uneven elevations, a virtual pole, single-azimuth and
single-elevation axes, 720 azimuths, 1, 3 and 5 channels, float32 and
float64 values, isotropic tables (phi_v = the azimuth difference; every
lookup rotates the query). Cases: nodes reproduced exactly and queries within the snap
tolerance of a node, on either side, snapped to it; the pole rule; clamps;
the periodic wrap; agreement with the reference and with scipy's independent
interpolator; NaN, infinite and impossible queries; huge finite angles.
Tolerances: float64 implementations agree with the reference to 1e-12
relative and reproduce nodes bit for bit; the float32 renderer agrees to
3e-5 of the table's range.
"""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest

from cdbrdf import QueryError
from cdbrdf.interp import SNAP_TOLERANCE, evaluate, snap_tolerance

from .lookup_cases import (
    F32_MAX,
    IMPLS,
    TABLE_NAMES,
    close,
    close_gltf_page,
    get_run,
    has_off_pole,
    is_isotropic,
    kernel_tables,
    need_mitsuba,
    pairs,
    run_reference,
    scipy_multilinear,
    tables,
)


@pytest.fixture(scope="module", autouse=True)
def _close_the_browser():
    """The glTF renderer's browser, opened by the first browser case, is closed after the module."""
    yield
    close_gltf_page()


# -- the cases ---------------------------------------------------------------------------------------
@pytest.mark.parametrize("impl,table", pairs("nodes", where=has_off_pole))
def test_nodes_reproduced_and_snapped(impl, table):
    im, _, c, got, _, scale = get_run(impl, table, "nodes")
    m = c.info["m"]
    want = c.info["want"]
    at_node = got[:m]
    if im.exact:
        # every node, also turns away and within the snap tolerance on either side: bit for bit
        for j, kind in enumerate(c.info["kinds"]):
            np.testing.assert_array_equal(got[j * m:(j + 1) * m], want, err_msg=kind)
    else:
        np.testing.assert_allclose(at_node, want, rtol=im.rtol, atol=im.rtol * scale)
        for j, kind in enumerate(c.info["kinds"]):
            part = got[j * m:(j + 1) * m]
            if kind.startswith("axis"):
                # snapped onto the node: the same value as at the node, exactly
                np.testing.assert_array_equal(part, at_node, err_msg=kind)
            else:
                np.testing.assert_allclose(part, want, rtol=im.rtol, atol=im.rtol * scale, err_msg=kind)


@pytest.mark.parametrize("impl,table", pairs("pole"))
def test_pole_rule(impl, table):
    im, t, c, got, ref, scale = get_run(impl, table, "pole")
    sizes = c.info["sizes"]
    parts = np.split(got, np.cumsum(sizes)[:-1])
    mean_tol = 1e-6 if t.values.dtype == np.float32 else 1e-12  # the pole's mean is stored in the table's dtype
    ring_tol = {"rtol": max(im.rtol, mean_tol), "atol": im.rtol * scale}
    for p in parts[:4]:
        # every azimuth at theta = 0 gives one value, bit for bit
        assert np.all(p == p[0]), p
    # the pole holds the ring mean
    np.testing.assert_allclose(parts[0][0], c.info["want_v"], **ring_tol)
    np.testing.assert_allclose(parts[1][0], c.info["want_l"], **ring_tol)
    # continuity: just above the pole the value is within ~ theta/step of the mean
    near = parts[4].reshape(len(c.info["near"]), 3, -1)
    for k, eps in enumerate(c.info["near"]):
        np.testing.assert_allclose(near[k], np.broadcast_to(c.info["want_v"], near[k].shape),
                                   rtol=max(im.rtol, 10 * eps, mean_tol), atol=im.rtol * scale)
    if "half" in c.info:
        # linear blend from the pole to the next elevation node
        np.testing.assert_allclose(parts[5][0], c.info["half"], **ring_tol)
    if "half_l" in c.info:
        # isotropic: the same blend from the light pole, at any light azimuth
        np.testing.assert_allclose(parts[-1][0], c.info["half_l"], **ring_tol)
    if impl != "reference":
        close(im, got, ref, scale)


@pytest.mark.parametrize("impl,table", pairs("rotation", where=is_isotropic))
def test_isotropic_tables_ignore_a_rotation_about_the_normal(impl, table):
    im, t, c, got, ref, scale = get_run(impl, table, "rotation")
    m = c.info["m"]
    base = got[:m]
    rtol = 1e-12 if im.precision == "float64" else im.rtol
    for j in range(c.info["n_turns"]):
        # both azimuths turned by the same angle: the same value (to rounding of the azimuth difference)
        np.testing.assert_allclose(got[(j + 1) * m:(j + 2) * m], base, rtol=rtol, atol=rtol * scale,
                                   err_msg=f"turn {j}")
    # a direction along the normal: bit for bit independent of both azimuths
    for j in range(c.info["n_turns"] + 1):
        np.testing.assert_array_equal(got[j * m:j * m + 8], base[:8])
    if impl != "reference":
        close(im, got, ref, scale)


def test_isotropic_table_equals_its_anisotropic_expansion_at_stored_light_azimuths():
    """An isotropic table against the anisotropic table holding the same values rotated onto every light azimuth."""
    t = tables()["iso_rgb"]
    g = t.grid
    n = g.phi_v.size
    v = t.values[:, 0]  # (kappa, theta_l, dphi, theta_v, c)
    shift = (np.arange(n)[None, :] - np.arange(n)[:, None]) % n  # [i_l, i_v] -> dphi index
    expanded = np.moveaxis(v[:, :, shift], 2, 1)  # (kappa, phi_l, theta_l, phi_v, theta_v, c)
    from cdbrdf import CDBRDF

    a = CDBRDF(expanded, kappa=g.kappa, theta_l=g.theta_l, phi_l=g.phi_v, theta_v=g.theta_v, phi_v=g.phi_v)
    rng = np.random.default_rng(5)
    m = 500
    # light azimuths on the stored nodes (where bilinear in (phi_l, phi_v) is linear in the difference)
    pl = rng.choice(g.phi_v, m) + 360.0 * rng.integers(-2, 3, m)
    q = (rng.uniform(1, 89, m), rng.uniform(-400, 400, m), rng.uniform(1, 89, m), pl, rng.uniform(-0.3, 0.3, m))
    for kernel in ("rgb", "generic"):
        np.testing.assert_allclose(evaluate(t, *q, kernel=kernel), evaluate(a, *q, kernel=kernel), rtol=1e-12)


@pytest.mark.parametrize("impl,table", pairs("clamps"))
def test_clamps(impl, table):
    im, _, c, got, ref, scale = get_run(impl, table, "clamps")
    m = c.info["m"]
    for j in range(c.info["n_pairs"]):
        beyond = got[2 * j * m:(2 * j + 1) * m]
        end = got[(2 * j + 1) * m:(2 * j + 2) * m]
        # beyond the last elevation, beyond either end of kappa: the end's value, exactly
        np.testing.assert_array_equal(beyond, end, err_msg=f"pair {j}")
    assert np.isfinite(got).all()
    if impl != "reference":
        close(im, got, ref, scale)


@pytest.mark.parametrize("impl,table", pairs("wrap"))
def test_periodic_wrap(impl, table):
    im, t, c, got, ref, scale = get_run(impl, table, "wrap")
    m = c.info["m"]
    base = got[:m]
    rtol = 1e-14 if im.precision == "float64" else im.rtol
    for j in range(c.info["n_variants"]):
        # phi + 360 k, negative azimuths: the value at phi
        np.testing.assert_allclose(got[(j + 1) * m:(j + 2) * m], base, rtol=rtol, atol=rtol * scale,
                                   err_msg=f"variant {j}")
    if "seam" in c.info:
        # halfway between the last and the first azimuth: the mean of both nodes
        np.testing.assert_allclose(got[-1], c.info["seam"], rtol=max(im.rtol, 1e-12), atol=im.rtol * scale)
    g = t.grid
    if g.phi_v.size == 1 and g.phi_l.size == 1:
        # a single azimuth: no azimuth matters
        for j in range(c.info["n_variants"] + 1):
            rows = got[j * m:(j + 1) * m]
            np.testing.assert_array_equal(rows, base)
    if impl != "reference":
        close(im, got, ref, scale)


@pytest.mark.parametrize("impl,table", pairs("random", skip_reference=True)
                         + [p for p in pairs("directions") if IMPLS[p.values[0]].cases])
def test_agrees_with_reference(impl, table):
    # random queries (elevations 0 to 90, azimuths -720 to 720, kappa beyond both ends); from
    # well-defined directions for the plug-in's eval
    im, _, _, got, ref, scale = get_run(impl, table, "random" if IMPLS[impl].cases is None else "directions")
    assert np.isfinite(got).all()
    close(im, got, ref, scale)


@pytest.mark.parametrize("impl,table", pairs("scipy", where=has_off_pole))
def test_agrees_with_independent_multilinear_off_the_pole(impl, table):
    im, t, c, got, _, scale = get_run(impl, table, "scipy")
    rtol = max(im.rtol, 1e-12)
    np.testing.assert_allclose(got, scipy_multilinear(t, c.q), rtol=rtol, atol=rtol * scale)


@pytest.mark.parametrize("impl,table", pairs("bad"))
def test_non_finite_and_impossible_queries(impl, table):
    im, t, c, got, _, scale = get_run(impl, table, "bad")
    if im.nan_rows:
        # NaN, infinities and elevations outside [0, 90]: NaN rows
        assert np.isnan(got).all(), got
        return
    # the renderer: no read outside the table; the caller masks these lanes
    lo, hi = float(t.values.min()), float(t.values.max())
    tol = 3e-5 * scale
    inside = (got >= lo - tol) & (got <= hi + tol)
    assert (np.isnan(got) | inside).all(), got
    az = np.array(c.info["nonfinite_azimuth_only"])
    assert np.isfinite(got[az]).all() and inside[az].all()  # a NaN/inf azimuth reads node 0 with weight 0


@pytest.mark.parametrize("impl,table", pairs("huge"))
def test_huge_finite_angles(impl, table):
    im, t, c, got, ref, scale = get_run(impl, table, "huge")
    lo, hi = float(t.values.min()), float(t.values.max())
    tol = 3e-5 * scale if not im.exact else 0.0
    # a huge finite azimuth (1e30, 1e308; 3e38 in float32) stays within the table's range
    assert np.isfinite(got).all(), got
    assert ((got >= lo - tol) & (got <= hi + tol)).all(), (got.min(), got.max(), lo, hi)
    if im.precision == "float64":
        # ... at its exact place on the circle: the reference at the fmod-wrapped azimuth
        q = c.q.copy()
        q[[1, 3]] = np.fmod(q[[1, 3]], 360.0)
        np.testing.assert_allclose(got, run_reference(t, q), rtol=max(im.rtol, 1e-12), atol=1e-12 * scale)
    else:
        # float32: the azimuths float32 wraps exactly agree with the float64 lookup
        ok = (np.abs(c.q[[1, 3]]) <= 720.0).all(axis=0)
        np.testing.assert_allclose(got[ok], ref[ok], rtol=im.rtol, atol=im.rtol * scale)


@pytest.mark.parametrize("kernel", ["rgb", "generic"])
@pytest.mark.parametrize("table", TABLE_NAMES)
def test_impossible_elevations_raise_in_every_kernel(kernel, table):
    t = tables()[table]
    if kernel == "rgb" and not t.lookup_grid().rgb_kernel:
        with pytest.raises(QueryError, match="kernel: 'rgb' needs 3 channels"):
            evaluate(t, 30.0, 0.0, 30.0, 0.0, kernel=kernel)
        return
    with pytest.raises(QueryError, match="theta_v"):
        evaluate(t, 90.0 + 1e-13, 0.0, 30.0, 0.0, kernel=kernel)
    with pytest.raises(QueryError, match="theta_l"):
        evaluate(t, 30.0, 0.0, -5e-324, 1e30, kernel=kernel)


def test_kernel_choice_is_validated(paper_table):
    with pytest.raises(QueryError, match="kernel: 'fast' is not one of auto, rgb, generic"):
        evaluate(paper_table, 30.0, 0.0, 30.0, 0.0, kernel="fast")


def test_snap_tolerance_is_one_rule_per_precision():
    assert dict(SNAP_TOLERANCE) == {"float64": 1e-9, "float32": 1e-6}
    assert snap_tolerance(np.float64) == snap_tolerance("float64") == 1e-9
    assert snap_tolerance(np.dtype(np.float32)) == 1e-6
    with pytest.raises(QueryError, match="precision: 'float16' is not one of float64, float32"):
        snap_tolerance("float16")


def test_drjit_indices_stay_in_the_table():
    """The renderer's index math: every float32 input (NaN, inf, huge, tiny) gives an index inside the axis."""
    need_mitsuba()
    import drjit as dr
    import mitsuba as mi

    import cdbrdf.render as cr
    from cdbrdf.render import _lookup_jit as lj

    cr.set_variant("llvm_ad_rgb")
    x = np.array([np.nan, np.inf, -np.inf, F32_MAX, -F32_MAX, 1e30, -1e30, 1e20, 2.0**24 + 3.0, -0.0, 1e-45,
                  359.99997, 720.0, -1e-30, 0.0, 15.0, 74.99999, 75.0], dtype=np.float32)
    X = mi.Float(x)
    tol = snap_tolerance("float32")
    for n, phi0 in ((1, 0.0), (5, 10.0), (12, 0.0), (720, 0.0)):
        i, w = lj._locate_periodic(dr, mi.Float, mi.UInt32, phi0, n / 360.0, n, X, tol)
        i, w = np.broadcast_to(np.array(i), x.shape), np.broadcast_to(np.array(w), x.shape)
        assert ((i >= 0) & (i < n)).all(), (n, i)
        assert ((w >= 0) & (w < 1)).all(), (n, w)
    for axis in (np.array([0.0]), np.array([0.0, 45.0]), np.arange(0.0, 76.0, 15.0), np.array([0.0, 5.0, 60.0, 80.0])):
        inv_d = 1.0 / np.diff(axis) if axis.size > 1 else np.zeros(1)
        i, w = lj._locate(dr, mi.Float, mi.UInt32, axis, inv_d, X, tol)
        i, w = np.broadcast_to(np.array(i), x.shape), np.broadcast_to(np.array(w), x.shape)
        assert ((i >= 0) & (i <= max(axis.size - 2, 0))).all(), (axis, i)
        fin = np.isfinite(x)
        assert ((w[fin] >= 0) & (w[fin] <= 1)).all()


# -- huge azimuths through every kernel, in a child process ---------------------------------------
#: Extreme finite azimuths, degrees (float64 and float32 ones).
_HUGE_AZIMUTHS = [1e15, 1e16, 1e23, -1e23, 1e30, -1e30, 3.4e38, -3.4e38, 1e300, 1e308, -1.7976931348623157e308,
                  float(np.float32(3.4028235e38)), float(np.float32(-1e30)), 5e-324, -5e-324, -0.0,
                  360.0 - 1e-13, -360.0 + 1e-13, 720.0, -720.0, 2.0**53 + 1.0, 2.0**63]


def check_huge_azimuths() -> None:
    """Every kernel: a huge finite azimuth, in float64 or float32 query arrays, gives the value at its exact place.

    Run in a child process by the test below (before the fix these queries
    read outside the table and could kill the process).
    """
    az = np.array(_HUGE_AZIMUTHS)
    for name, t in kernel_tables().items():
        lo, hi = float(t.values.min()), float(t.values.max())
        kernels = ["generic"] + ["rgb"] * t.lookup_grid().rgb_kernel
        for a_dtype in (np.float64, np.float32):
            a = az[np.abs(az) <= np.finfo(a_dtype).max].astype(a_dtype)
            w = np.fmod(a.astype(np.float64), 360.0)  # exact
            for args, ref in (((40.0, a, 30.0, 270.0, 0.1), (40.0, w, 30.0, 270.0, 0.1)),
                              ((40.0, 100.0, 30.0, a, -0.1), (40.0, 100.0, 30.0, w, -0.1)),
                              ((1e-300, a, 89.999999, a[::-1], 1e308), (1e-300, w, 89.999999, w[::-1], 1e308))):
                for kernel in kernels:
                    got = evaluate(t, *args, kernel=kernel)
                    assert np.all(np.isfinite(got)), (name, a_dtype, got)
                    assert np.all((got >= lo) & (got <= hi)), (name, a_dtype, got.min(), got.max(), lo, hi)
                    np.testing.assert_allclose(got, evaluate(t, *ref, kernel=kernel), rtol=1e-12, atol=0,
                                               err_msg=name)


@pytest.mark.slow
def test_huge_finite_azimuths_stay_in_the_table_in_every_kernel():
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(p for p in sys.path if p))
    r = subprocess.run([sys.executable, "-c", "import tests.test_lookup_conformance as m; m.check_huge_azimuths()"],
                       check=False, capture_output=True, text=True, env=env, timeout=600)
    assert r.returncode == 0, f"exit code {r.returncode}: {r.stderr[-2000:]}"


def test_suite_covers_every_implementation_and_the_table_kinds():
    """Each implementation runs on at least one table; the tables span what the rule must handle."""
    ts = tables()
    for name, im in IMPLS.items():
        assert any(im.applies(t) for t in ts.values()), name
    n_kappa = {t.grid.kappa.size for t in ts.values()}
    assert set(range(1, 10)) <= n_kappa
    assert any(t.lookup_grid().rgb_kernel for t in ts.values())
    assert any(not (t.lookup_grid().theta_l_even and t.lookup_grid().theta_v_even) for t in ts.values())
    assert {t.values.dtype for t in ts.values()} == {np.dtype(np.float32), np.dtype(np.float64)}
    assert any(t.grid.phi_v.size == 1 for t in ts.values()) and any(t.grid.theta_l.size == 1 for t in ts.values())
    assert any(t.grid.theta_v[0] > 0 for t in ts.values())
    iso = [t for t in ts.values() if t.isotropic]
    assert any(t.lookup_grid().rgb_kernel for t in iso) and any(not t.lookup_grid().rgb_kernel for t in iso)
    assert any(t.grid.theta_l[0] > 0 for t in iso) and {t.values.dtype for t in iso} == {
        np.dtype(np.float32), np.dtype(np.float64)}
