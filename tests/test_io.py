"""The file: round trip, layout seen by xarray, atomic writes, every bad-file case."""

from __future__ import annotations

import json
import os

import h5py
import numpy as np
import pytest

import cdbrdf
from cdbrdf import CDBRDF, FormatError, Grid
from cdbrdf.io import FORMAT_VERSION

from .conftest import make_table


@pytest.fixture
def rich_table(small_grid) -> CDBRDF:
    shape = small_grid.shape
    measured = np.ones(shape, bool)
    measured[0, 1, 2, 0, 2] = False
    src = np.full(shape, -1)
    src[0, 1, 2, 0, 2] = np.ravel_multi_index((0, 1, 1, 0, 2), shape)
    return make_table(
        small_grid,
        dtype=np.float32,
        measured=measured,
        fill_source=src,
        std=np.full(shape + (3,), 0.01, np.float32),
        attrs={
            "quantity": "brdf",
            "material": "test cloth",
            "provenance": {"made_by": "test", "params": [1, 2.5, None], "nested": {"a": True}},
            "count": 3,
        },
    )


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_round_trip_is_bit_exact(tmp_path, small_grid, dtype):
    t = make_table(small_grid, dtype=dtype, attrs={"material": "m", "provenance": "synthetic"})
    p = tmp_path / "t.h5"
    t.save(p)
    u = cdbrdf.load(p)
    assert u == t
    assert u.values.dtype == dtype
    assert u.values.tobytes() == t.values.tobytes()


def test_round_trip_keeps_mask_sources_std_attrs(tmp_path, rich_table):
    p = tmp_path / "rich.h5"
    rich_table.save(p, compression=None)
    u = cdbrdf.load(p)
    assert u == rich_table
    assert u.attrs["provenance"]["params"] == [1, 2.5, None]
    assert not u.measured[0, 1, 2, 0, 2]
    np.testing.assert_array_equal(u.std, rich_table.std)


def test_xarray_sees_named_dims_and_units(tmp_path, rich_table):
    xr = pytest.importorskip("xarray")
    p = tmp_path / "x.h5"
    rich_table.save(p)
    with xr.open_dataset(p, engine="h5netcdf") as ds:
        assert ds["reflectance"].dims == ("kappa", "phi_l", "theta_l", "phi_v", "theta_v", "channel")
        assert ds["measured"].dims == ("kappa", "phi_l", "theta_l", "phi_v", "theta_v")
        assert ds["kappa"].attrs["units"] == "1/mm"
        assert ds["theta_v"].attrs["units"] == "degree"
        assert ds["reflectance"].attrs["units"] == "1/sr"
        assert list(ds["channel"].values) == ["R", "G", "B"]
        assert ds.attrs["format"] == "cdbrdf"
        assert ds.attrs["format_version"] == FORMAT_VERSION
        assert ds.attrs["quantity"] == "brdf"
        assert ds.attrs["material"] == "test cloth"
        assert json.loads(ds.attrs["provenance"])["made_by"] == "test"
        sel = ds["reflectance"].sel(kappa=0.05, theta_l=20.0, phi_l=90.0, theta_v=30.0, phi_v=120.0)
        np.testing.assert_array_equal(sel.values, rich_table.values[2, 1, 1, 1, 1])


def test_atomic_write_leaves_nothing_on_failure(tmp_path, rich_table, monkeypatch):
    p = tmp_path / "t.h5"
    rich_table.save(p)
    before = p.read_bytes()

    import h5netcdf

    def boom(*a, **k):
        raise RuntimeError("disk on fire")

    monkeypatch.setattr(h5netcdf.File, "create_variable", boom)
    with pytest.raises(RuntimeError, match="disk on fire"):
        make_table(Grid.paper(kappa=[0.0])).save(p)
    assert p.read_bytes() == before  # old file intact
    assert sorted(os.listdir(tmp_path)) == ["t.h5"]  # no temporary left


def test_attrs_that_cannot_be_stored(tmp_path, small_grid):
    t = make_table(small_grid, attrs={"bad": object()})
    with pytest.raises(cdbrdf.TableError, match=r"attrs\['\*'\]|attrs\['bad'\]"):
        t.save(tmp_path / "t.h5")
    assert not list(tmp_path.iterdir())


def test_save_into_missing_folder(tmp_path, small_grid):
    with pytest.raises(FileNotFoundError, match="does not exist"):
        make_table(small_grid).save(tmp_path / "nope" / "t.h5")


def _write_then_edit(tmp_path, small_grid, edit):
    p = tmp_path / "t.h5"
    make_table(small_grid).save(p, compression=None)
    with h5py.File(p, "r+") as f:
        edit(f)
    return p


def test_missing_file(tmp_path):
    with pytest.raises(FileNotFoundError, match="no such file"):
        cdbrdf.load(tmp_path / "missing.h5")


def test_not_hdf5(tmp_path):
    p = tmp_path / "image.png"
    p.write_bytes(b"\x89PNG\r\n\x1a\n" + b"0" * 100)
    with pytest.raises(FormatError, match=r"image\.png: not an HDF5 file"):
        cdbrdf.load(p)


def test_folder(tmp_path):
    with pytest.raises(FormatError, match="is a folder"):
        cdbrdf.load(tmp_path)


def test_other_hdf5(tmp_path):
    p = tmp_path / "other.h5"
    with h5py.File(p, "w") as f:
        f["x"] = np.arange(3)
    with pytest.raises(FormatError, match=r"other\.h5: not a CDBRDF file"):
        cdbrdf.load(p)


@pytest.mark.parametrize(
    "edit, match",
    [
        (lambda f: f.attrs.__setitem__("format_version", "2.0"), "format version 2.0 is newer"),
        (lambda f: f.attrs.__setitem__("format_version", "one"), "unreadable format_version"),
        (lambda f: f.attrs.__delitem__("format_version"), "missing the global attribute 'format_version'"),
        (lambda f: f.__delitem__("measured"), "missing the variable 'measured'"),
        (lambda f: f.__delitem__("reflectance"), "missing the variable 'reflectance'"),
        (lambda f: f["reflectance"].__setitem__((0, 0, 0, 0, 0, 0), np.nan), "NaN or infinite"),
        (lambda f: f["reflectance"].__setitem__((0, 0, 0, 0, 0, 1), np.inf), "NaN or infinite"),
        (lambda f: f["kappa"].__setitem__(0, 1.0), "kappa: must be strictly increasing"),
        (lambda f: f["theta_v"].__setitem__(2, 95.0), r"theta_v: elevations must lie in \[0, 90\)"),
        (lambda f: f["measured"].__setitem__((0, 0, 0, 0, 0), 7), "'measured' holds values other than 0 and 1"),
        (lambda f: f.attrs.__setitem__("cdbrdf_attrs", "{not json"), "not valid JSON"),
    ],
)
def test_bad_files(tmp_path, small_grid, edit, match):
    p = _write_then_edit(tmp_path, small_grid, edit)
    with pytest.raises(FormatError, match=match) as info:
        cdbrdf.load(p)
    assert str(p) in str(info.value)


def test_shapes_that_disagree(tmp_path, small_grid):
    def edit(f):
        data = f["measured"][()]
        del f["measured"]
        f["measured"] = data[:, :2]

    p = _write_then_edit(tmp_path, small_grid, edit)
    with pytest.raises(FormatError, match="'measured' has shape"):
        cdbrdf.load(p)


def test_reflectance_with_wrong_dims(tmp_path, small_grid):
    def edit(f):
        data = f["reflectance"][()]
        del f["reflectance"]
        f["reflectance"] = data  # no dimension scales attached

    p = _write_then_edit(tmp_path, small_grid, edit)
    with pytest.raises(FormatError, match="'reflectance' has dimensions"):
        cdbrdf.load(p)


def test_older_minor_version_is_read(tmp_path, small_grid):
    p = _write_then_edit(tmp_path, small_grid, lambda f: f.attrs.__setitem__("format_version", "1.7"))
    assert cdbrdf.load(p).shape == small_grid.shape + (3,)


def test_saved_file_has_umask_permissions(tmp_path, small_grid):
    old = os.umask(0o022)
    try:
        p = tmp_path / "t.h5"
        make_table(small_grid).save(p)
        assert (p.stat().st_mode & 0o777) == 0o644
    finally:
        os.umask(old)
