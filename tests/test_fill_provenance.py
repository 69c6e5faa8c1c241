"""How every filled sample was filled: in the table, the file (format 1.2), xarray, the mosaic, the command line."""

from __future__ import annotations

import json

import h5py
import numpy as np
import pytest

import cdbrdf
from cdbrdf import CDBRDF, Grid, TableError, io
from cdbrdf.errors import OptionError
from cdbrdf.measure import measure
from cdbrdf.measure.fill import refill
from cdbrdf.schema import FILL_METHOD_CODES, TableParts

from .measure_helpers import GRID, WHITE, make_capture

KGRID = Grid(kappa=[-0.22, 0.0, 0.22], theta_l=[0, 40], phi_l=[0, 180], theta_v=[0, 30, 60], phi_v=[0, 90, 180, 270])


def _measured(method="kappa-fit"):
    """A table whose grazing views at kappa = -0.22 are filled by ``method``."""
    m = KGRID.mesh()
    v = (0.2 + 0.1 * np.cos(np.radians(m["theta_v"] - m["phi_l"] / 4)) * (1 + m["kappa"]))[..., None] * [1, 1.1, 0.9]
    valid = np.ones(KGRID.shape, bool)
    valid[0, :, :, :, 2] = False
    valid[0, 1, 1, 1, 1] = False
    t = CDBRDF(np.where(valid[..., None], v, 0.0), KGRID, measured=valid,
               std=np.full(v.shape, 0.01), attrs={"quantity": "brdf", "provenance": {"capture": "x"}})
    return refill(t, method=method)


def test_round_trip_through_the_file_and_xarray(tmp_path):
    xr = pytest.importorskip("xarray")
    t = _measured()
    assert t.fill_std is not None and (t.fill_sources[~t.measured] >= 0).sum() == 2 * (~t.measured).sum()
    p = tmp_path / "t.h5"
    t.save(p)
    back = cdbrdf.load(p)
    assert back == t
    np.testing.assert_array_equal(back.fill_weights, t.fill_weights)
    with xr.open_dataset(p, engine="h5netcdf") as ds:
        assert ds.attrs["format_version"] == "1.5"
        assert ds["fill_method"].attrs["flag_meanings"] == "measured unknown nearest nearest_stand kappa_fit model"
        assert ds["fill_sources"].dims[-1] == "fill_slot" and ds.sizes["fill_slot"] == 2
        sel = dict(kappa=-0.22, phi_l=0.0, theta_l=0.0, phi_v=0.0, theta_v=60.0)
        assert int(ds["fill_method"].sel(**sel)) == FILL_METHOD_CODES["kappa_fit"]
        # the sources: the same direction on the flat and on the convex stand
        src = ds["fill_sources"].sel(**sel).values
        np.testing.assert_array_equal(np.unravel_index(src, KGRID.shape)[0], [1, 2])
        u = CDBRDF.from_xarray(ds)
        for name in ("values", "measured", "fill_source", "fill_method", "fill_sources", "fill_weights", "fill_std"):
            np.testing.assert_array_equal(getattr(u, name), getattr(t, name))
    assert CDBRDF.from_xarray(t.to_xarray()) == t
    assert list(t.fill_method_names()[0, 0, 0, 0]) == ["measured", "measured", "kappa_fit"]


def _write_old(table, path, version):
    """``table`` as a file of an earlier format: no fill provenance variables (1.0 also the old superblock)."""
    parts = TableParts(values=table.values, axes=table.grid.axes(), measured=table.measured,
                       fill_source=table.fill_source, std=table.std, attrs=table.attrs)
    io.write(parts, path)
    with h5py.File(path, "r+") as f:
        f.attrs["format_version"] = version
        assert not any(name.startswith("fill_") and name != "fill_source" for name in f)


@pytest.mark.parametrize("version", ["1.0", "1.1"])
def test_older_files_load_identically(tmp_path, version):
    t = _measured(method="nearest")
    src = t.fill_source.copy()
    src[0, 1, 1, 1, 1] = -2  # one source not recorded
    old = CDBRDF(t.values, t.grid, measured=t.measured, fill_source=src, std=t.std, attrs=t.attrs)
    p = tmp_path / "old.h5"
    _write_old(old, p, version)
    back = cdbrdf.load(p)
    for name in ("values", "measured", "fill_source", "std"):
        np.testing.assert_array_equal(getattr(back, name), getattr(old, name))
    assert back.attrs == old.attrs and back.fill_std is None
    # their filled samples read as the paper's rule, or unknown where the source is unknown
    names = back.fill_method_names()
    assert set(names[~back.measured & (src >= 0)]) == {"nearest"} and names[0, 1, 1, 1, 1] == "unknown"
    assert back == old


def test_bundled_tables_still_load_as_measured():
    from cdbrdf import materials

    t = materials.load("denim")
    assert (t.fill_method == FILL_METHOD_CODES["measured"]).all() and t.fill_std is None


def test_plain_brdf_keeps_the_methods_and_drops_other_curvatures_sources():
    t = _measured()
    b = t.brdf(-0.22)
    assert b.fill_method.shape == (1, *KGRID.shape[1:])
    np.testing.assert_array_equal(b.fill_method[0], t.fill_method[0])
    filled = ~b.measured
    assert (b.fill_source[filled] == -2).all() and (b.fill_sources[filled] == -1).all()
    np.testing.assert_array_equal(b.fill_std[0], t.fill_std[0])
    n = _measured(method="nearest").brdf(-0.22)  # sources at the same curvature are kept
    assert (n.fill_source[~n.measured] >= 0).all() and n.measured.ravel()[n.fill_source[~n.measured]].all()


@pytest.mark.parametrize(
    "change, message",
    [
        (dict(fill_method=lambda t: np.where(t.measured, 0, 9)), "fill_method: codes must be one of 0 .measured."),
        (dict(fill_method=lambda t: np.zeros(t.measured.shape, np.uint8)), "must be 0 .measured. exactly where"),
        (dict(fill_sources=lambda t: np.concatenate([t.fill_sources[..., 1:], t.fill_sources[..., :1]], -1)),
         "used slots must come first|the first slot must be fill_source"),
        (dict(fill_sources=lambda t: np.where(t.fill_sources >= 0, 0, -1)), "the first slot must be fill_source"),
        (dict(fill_weights=lambda t: t.fill_weights[..., :1]), "fill_weights: shape"),
        (dict(fill_weights=lambda t: np.where(t.fill_sources < 0, 1.0, t.fill_weights)), "0 in unused slots"),
        (dict(fill_std=lambda t: t.fill_std + 1), "fill_std: must be 0 wherever the sample is measured"),
        (dict(fill_std=lambda t: -t.fill_std), "fill_std: standard deviations must be non-negative"),
    ],
)
def test_inconsistent_provenance_is_refused(change, message):
    t = _measured()
    kw = dict(measured=t.measured, fill_source=t.fill_source, fill_method=t.fill_method,
              fill_sources=t.fill_sources, fill_weights=t.fill_weights, fill_std=t.fill_std)
    for key, f in change.items():
        kw[key] = f(t)
    with pytest.raises(TableError, match=message):
        CDBRDF(t.values, t.grid, **kw)


def test_several_sources_need_weights():
    t = _measured()
    with pytest.raises(TableError, match="fill_weights: needed"):
        CDBRDF(t.values, t.grid, measured=t.measured, fill_sources=t.fill_sources)
    # fill_source is derived from the first slot when not given
    u = CDBRDF(t.values, t.grid, measured=t.measured, fill_sources=t.fill_sources,
               fill_weights=t.fill_weights, fill_method=t.fill_method)
    np.testing.assert_array_equal(u.fill_source, t.fill_source)


def test_mosaic_marks_direction_and_curvature_fills_apart():
    from matplotlib.patches import PathPatch

    from cdbrdf.plot import mosaic_arrays, plot_mosaic
    from cdbrdf.plot.mosaic import FILL_MARKS

    t = _measured()  # grazing views at -0.22 filled along the curvature
    valid = t.measured.copy()
    valid[:, 1, 0, 2, 0] = False  # a direction measured on no stand: the paper's rule fills it
    t = refill(CDBRDF(t.values, t.grid, measured=valid, attrs=t.attrs), method="kappa-fit")
    m = mosaic_arrays(t)
    codes = set(np.unique(m.fill_method[0][m.filled[0]]).tolist())
    assert codes == {FILL_METHOD_CODES["kappa_fit"], FILL_METHOD_CODES["nearest"]}
    fig = plot_mosaic(t)
    ax = fig.axes[0]
    patches = [p for p in ax.patches if isinstance(p, PathPatch)]
    assert len(patches) == 2 and len({p.get_hatch() for p in patches}) == 2
    labels = [x.get_text() for a in fig.axes if a.get_legend() for x in a.get_legend().get_texts()]
    assert FILL_MARKS[0][3] in labels and FILL_MARKS[1][3] in labels


# -- measuring with a fill method ---------------------------------------------------------
def _wiggly(k, tv, pv, tl, pl):
    """Pixel values that change with direction and curvature; one saturated sample at kappa = 0.2."""
    base = np.array([0.05, 0.09, 0.16]) * (1 + 2 * k) * (1 + 0.6 * np.cos(np.radians(tv - 20)))
    base = base * (1 + 0.3 * np.cos(np.radians(pv + 2 * pl)) * np.sin(np.radians(tl + 10)))
    if k == 0.2 and tv == 60.0 and pv == 90.0 and tl == 40.0 and pl == 0.0:
        return np.array([1.5, 1.5, 1.5])
    return base * np.cos(np.radians(tl)) * 2.0


def _paper_rule_sources(valid, grid):
    """The paper's nearest-direction rule, written out as earlier versions of cdbrdf applied it.

    For every sample not measured: among the measured samples at the same
    curvature, the one minimising ``angle(v, v') + angle(l, l')`` (great-circle
    angles in degrees, ``atan2(|a x b|, a . b)``), ties to the smallest C-order
    flat index. Returns the flat source index per sample (-1 where measured).
    Independent of :mod:`cdbrdf.measure.fill`: a plain loop over candidates.
    """
    def unit(theta, phi):
        t, p = np.radians(theta), np.radians(phi)
        return np.array([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)])

    def angle(a, b):
        return np.degrees(np.arctan2(np.linalg.norm(np.cross(a, b)), np.dot(a, b)))

    nk, npl, ntl, npv, ntv = grid.shape
    lights = [unit(grid.theta_l[b], grid.phi_l[a]) for a in range(npl) for b in range(ntl)]
    views = [unit(grid.theta_v[b], grid.phi_v[a]) for a in range(npv) for b in range(ntv)]
    n_l, n_v = len(lights), len(views)
    out = np.full(grid.shape, -1, dtype=np.int64).reshape(nk, n_l, n_v)
    ok = valid.reshape(nk, n_l, n_v)
    for k in range(nk):
        for li in range(n_l):
            for vi in range(n_v):
                if ok[k, li, vi]:
                    continue
                best, best_j = np.inf, -1
                for lj in range(n_l):
                    for vj in range(n_v):
                        if not ok[k, lj, vj]:
                            continue
                        d = angle(lights[li], lights[lj]) + angle(views[vi], views[vj])
                        # grid directions differ by whole degrees: a tie is a difference of rounding only
                        if d < best - 1e-6:
                            best, best_j = d, (k * n_l + lj) * n_v + vj
                out[k, li, vi] = best_j
    return out.reshape(grid.shape)


@pytest.fixture(scope="module")
def wiggly_capture(tmp_path_factory):
    d = tmp_path_factory.mktemp("cap")
    stands = [{"kappa": -0.2, "face_width_mm": 6.0, "wall_height_mm": 6.0}, {"kappa": 0.0}, {"kappa": 0.2}]
    make_capture(d, GRID, _wiggly, kind="png16", stands=stands, white=WHITE)
    return d


def test_nearest_reproduces_the_paper_rule_bit_for_bit(wiggly_capture):
    """``fill="nearest"`` is the paper's rule of earlier versions, exactly, on any machine.

    The promise is a property, checked on the machine that runs the test: the
    measured samples are those every fill method measures (bit for bit: the
    fill never touches them), each filled sample takes the source the paper's
    rule picks (:func:`_paper_rule_sources`), and its value and standard
    deviation are exact copies of that source's.
    """
    t, rep = measure(wiggly_capture, fill="nearest")
    other, _ = measure(wiggly_capture, fill="nearest-stand")
    np.testing.assert_array_equal(t.measured, other.measured)
    np.testing.assert_array_equal(t.values[t.measured], other.values[other.measured])
    np.testing.assert_array_equal(t.std[t.measured], other.std[other.measured])
    src = _paper_rule_sources(t.measured, t.grid)
    np.testing.assert_array_equal(t.fill_source, src)
    hidden = ~t.measured
    flat_values = t.values.reshape(t.measured.size, -1)
    flat_std = t.std.reshape(t.measured.size, -1)
    np.testing.assert_array_equal(t.values[hidden], flat_values[src[hidden]])
    np.testing.assert_array_equal(t.std[hidden], flat_std[src[hidden]])
    assert rep.n_filled == 33 and rep.n_filled_by == {"nearest": 33, "nearest_stand": 0, "kappa_fit": 0,
                                                          "model": 0}
    assert t.attrs["provenance"]["fill"].startswith("nearest measured direction at the same curvature")


def test_measure_fills_by_the_chosen_method_and_keeps_measured_samples(wiggly_capture):
    near, _ = measure(wiggly_capture, fill="nearest")
    kfit, rep = measure(wiggly_capture, fill="kappa-fit")
    assert rep.fill_method == "kappa-fit" and "filled by kappa-fit" in rep.summary()
    np.testing.assert_array_equal(kfit.values[kfit.measured], near.values[near.measured])
    np.testing.assert_array_equal(kfit.measured, near.measured)
    names = kfit.fill_method_names()
    # the saturated sample at 0.2 is a grazing view the concave stand hides: that direction was measured
    # on the flat stand alone, and both its samples are copied from there
    sat = (0, 1, 1, 2)
    for k in (0, 2):
        assert not kfit.measured[(k, *sat)] and names[(k, *sat)] == "nearest_stand"
        assert kfit.fill_source[(k, *sat)] == np.ravel_multi_index((1, *sat), GRID.shape)
    # every other sample hidden at -0.2: fitted to the flat and convex stands
    others = ~kfit.measured[0]
    others[sat] = False
    assert set(names[0][others]) == {"kappa_fit"}
    assert (kfit.fill_sources[0][others] // int(np.prod(GRID.shape[1:])) == [1, 2]).all()
    assert kfit.attrs["provenance"]["fill_summary"]["samples"]["kappa_fit"] == 32 - 1
    with pytest.raises(OptionError, match="fill: 'paper' is not one of kappa-fit, nearest-stand, nearest"):
        measure(wiggly_capture, fill="paper")


def test_cli_measure_fill_option(wiggly_capture, tmp_path, capsys):
    from cdbrdf.cli import main

    out = tmp_path / "t.h5"
    assert main(["measure", str(wiggly_capture), "-o", str(out), "--fill", "nearest-stand"]) == 0
    assert "filled by nearest-stand" in capsys.readouterr().out
    t = cdbrdf.load(out)
    assert set(t.fill_method_names()[~t.measured]) == {"nearest_stand"}
    assert json.loads(json.dumps(t.attrs["provenance"]))["fill_method"] == "nearest-stand"
    with pytest.raises(SystemExit) as exc:
        main(["measure", str(wiggly_capture), "-o", str(out), "--fill", "paper"])
    assert exc.value.code == 2
    assert "expected one of kappa-fit, nearest-stand, nearest" in capsys.readouterr().err


@pytest.mark.parametrize(
    "damage, message",
    [
        (lambda f: f["fill_method"].__setitem__((0, 0, 0, 0, 2), 7), "fill_method: codes must be one of"),
        (lambda f: f["fill_method"].__setitem__((1, 0, 0, 0, 0), 4), "must be 0 .measured. exactly where"),
        (lambda f: f["fill_sources"].__setitem__((0, 0, 0, 0, 2, 1), 2), "not measured"),
        (lambda f: f["fill_weights"].__setitem__((0, 0, 0, 0, 2, 0), np.nan), "'fill_weights' holds NaN"),
        (lambda f: f["fill_std"].__setitem__((1, 0, 0, 0, 0, 0), 0.5), "fill_std: must be 0 wherever"),
    ],
)
def test_files_with_inconsistent_provenance_are_refused(tmp_path, damage, message):
    p = tmp_path / "t.h5"
    _measured().save(p)
    with h5py.File(p, "r+") as f:
        damage(f)
        del f.attrs["cdbrdf_data_sha256"]  # else refused as damaged data (the digest) before the rule
    with pytest.raises(cdbrdf.FormatError, match=r"t\.h5: .*" + message):
        cdbrdf.load(p)
