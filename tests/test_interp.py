"""The 5-D lookup's interface: hand-computed values, broadcasting, query types, errors, the prepared grid.

The rule itself (nodes, pole, clamps, wrap, NaN, huge angles) is checked for every
implementation in ``tests/test_lookup_conformance.py``.
"""

from __future__ import annotations

import numpy as np
import pytest

import cdbrdf
from cdbrdf import CDBRDF, Grid, QueryError
from cdbrdf.interp import evaluate, prepare

from .conftest import make_table


def test_hand_computed_value():
    # f = a + b*kappa + c*theta_v + d*theta_l: multilinear reproduces it exactly
    g = Grid(kappa=[-0.2, 0.1, 0.3], theta_l=[0, 30, 60], phi_l=[0, 120, 240], theta_v=[0, 45, 80], phi_v=[0, 90, 180, 270])
    m = g.mesh()
    f = 0.5 + 2.0 * m["kappa"] + 0.01 * m["theta_v"] + 0.003 * m["theta_l"]
    t = CDBRDF(np.stack([f, 2 * f, 3 * f], -1), g)
    got = t.evaluate(52.0, 33.0, 17.0, 201.0, 0.0)
    want = 0.5 + 2.0 * 0.0 + 0.01 * 52.0 + 0.003 * 17.0
    np.testing.assert_allclose(got, [want, 2 * want, 3 * want], rtol=1e-13)


def test_hand_computed_bilinear_in_azimuth():
    # values depend on phi_v only: 1 at phi 0, 3 at phi 90 -> 2 at phi 45, 1.5 at 22.5
    g = Grid(kappa=[0.0], theta_l=[10.0], phi_l=[0.0], theta_v=[20.0, 40.0], phi_v=[0, 90, 180, 270])
    v = np.zeros(g.shape + (1,))
    v[0, 0, 0, :, :, 0] = np.array([1.0, 3.0, 5.0, 7.0])[:, None]
    t = CDBRDF(v, g)
    np.testing.assert_allclose(t.evaluate(30.0, [45.0, 22.5, 315.0, -45.0], 10.0, 0.0)[:, 0], [2, 1.5, 4, 4])


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


def test_prepared_grid_is_cached_by_the_table(paper_table):
    assert paper_table.lookup_grid() is paper_table.lookup_grid()
    lg = prepare(paper_table.grid, paper_table.values)  # builds a new one, equal to the cached grid
    assert lg is not paper_table.lookup_grid()
    np.testing.assert_array_equal(lg.values, paper_table.lookup_grid().values)
    assert lg.theta_l[0] == 0 and lg.phi_l_step == 30.0
    assert lg.phi_l_inv_step == 1 / 30.0 and lg.rgb_kernel and lg.stride == 4
    assert lg.shape == (5, 12, 6, 12, 6, 3) and lg.flat.size == 5 * 12 * 6 * 12 * 6 * 4
    # the table's dtype is kept
    t32 = make_table(Grid.paper(kappa=[0.0]), dtype=np.float32)
    assert prepare(t32.grid, t32.values).values.dtype == np.float32 and t32.lookup_grid().flat.dtype == np.float32


def test_prepared_grid_is_immutable(paper_table):
    lg = paper_table.lookup_grid()
    with pytest.raises(AttributeError):
        lg.values = None  # type: ignore[misc]
    for name in ("values", "flat", "kappa", "kappa_inv_d", "theta_l", "theta_l_inv_d", "theta_v", "theta_v_inv_d"):
        assert not getattr(lg, name).flags.writeable, name
    assert "LookupGrid(shape=(5, 12, 6, 12, 6, 3)" in repr(lg)


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
        "import cdbrdf, cdbrdf.synth, cdbrdf.images, cdbrdf._kernels as k\n"
        "assert cdbrdf.__file__.startswith(sys.argv[1]), cdbrdf.__file__\n"
        "assert k.lookup_generic._cache.__class__.__name__ == 'NullCache'\n"
        "g = cdbrdf.Grid(kappa=[0.0], theta_l=[0.0, 40.0], phi_l=[0.0, 180.0], theta_v=[0.0, 40.0], phi_v=[0.0, 180.0])\n"
        "t = cdbrdf.CDBRDF(np.full(g.shape + (1,), 0.25), g)\n"
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


def test_a_cache_write_that_fails_costs_only_the_cache(tmp_path):
    """A full disk (here a 1-byte file size limit) while numba writes its cache: the lookup still answers."""
    import os
    import resource
    import subprocess
    import sys

    def tiny_files():
        resource.setrlimit(resource.RLIMIT_FSIZE, (1, 1))

    code = (
        "import numpy as np, cdbrdf\n"
        "g = cdbrdf.Grid(kappa=[0.0], theta_l=[0.0, 40.0], phi_l=[0.0, 180.0], theta_v=[0.0, 40.0], phi_v=[0.0, 180.0])\n"
        "t = cdbrdf.CDBRDF(np.full(g.shape + (1,), 0.25), g)\n"
        "assert np.allclose(t.evaluate(30.0, 10.0, 20.0, 10.0), 0.25)\n"
        "print('ok')\n"
    )
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"), PYTHONDONTWRITEBYTECODE="1")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, cwd=tmp_path,
                       preexec_fn=tiny_files, timeout=600)
    assert r.returncode == 0 and r.stdout.strip() == "ok", r.stderr[-2000:]
    assert not any(p.stat().st_size > 1 for p in (tmp_path / "cache").rglob("*.nbc"))  # nothing was cached
