"""The file: round trip, layout seen by xarray, atomic writes, every bad-file case."""

from __future__ import annotations

import json
import os
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest

import cdbrdf
from cdbrdf import CDBRDF, FormatError, Grid
from cdbrdf.schema import FORMAT_VERSION

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
    import xarray as xr
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


@pytest.mark.parametrize("compression", ["bogus", "lzf", 4, True])
def test_save_with_an_unknown_compression_lists_the_valid_ones(tmp_path, small_grid, compression):
    from cdbrdf.errors import OptionError

    with pytest.raises(OptionError, match=r"^compression: .* is not one of 'gzip', None$"):
        make_table(small_grid).save(tmp_path / "t.h5", compression=compression)
    assert not list(tmp_path.iterdir())


def _write_then_edit(tmp_path, small_grid, edit, *, keep_digest=False):
    """A file edited in place; without its data digest (as another writer's file) unless ``keep_digest``."""
    p = tmp_path / "t.h5"
    make_table(small_grid).save(p, compression=None)
    with h5py.File(p, "r+") as f:
        edit(f)
        if not keep_digest and "cdbrdf_data_sha256" in f.attrs:
            del f.attrs["cdbrdf_data_sha256"]
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
        (lambda f: (f.attrs.__setitem__("cdbrdf_attrs", "{not json"), f.attrs.__delitem__("cdbrdf_sha256")),
         "not valid JSON"),
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


# -- hardening: hangs, memory, error classes, checksums, spec enforcement -------------------------


from cdbrdf import io, schema  # noqa: E402
from cdbrdf.errors import LimitError  # noqa: E402


def _zero_global_heap(p: Path) -> None:
    b = bytearray(p.read_bytes())
    i = b.find(b"GCOL")
    assert i > 0
    b[i + 700 : i + 1724] = bytes(1024)  # object headers of zero size: HDF5 loops forever on them
    p.write_bytes(bytes(b))


def test_written_files_have_checksummed_metadata_and_fletcher32(tmp_path, rich_table):
    p = tmp_path / "t.h5"
    rich_table.save(p)
    assert io.superblock_version(p) == 3
    with h5py.File(p, "r") as f:
        for name, ds in f.items():
            if name != "channel":
                assert ds.fletcher32, name
        assert f["reflectance"].compression == "gzip" and f["reflectance"].shuffle


@pytest.mark.parametrize("legacy", [False, True])
def test_damaged_global_heap_ends_in_format_error(tmp_path, small_grid, monkeypatch, legacy):
    # zeroed bytes in a global heap made load spin forever inside an attribute read
    if legacy:  # a file with the old superblock, as format 1.0 wrote
        monkeypatch.setattr(io, "_LIBVER", ("earliest", "v110"))
    p = tmp_path / "t.h5"
    make_table(small_grid, attrs={"material": "m"}).save(p)
    monkeypatch.undo()
    assert (io.superblock_version(p) == 0) == legacy
    _zero_global_heap(p)
    monkeypatch.setattr(io, "LEGACY_READ_TIMEOUT_S", 3.0)
    match = r"reading it took longer than 3 s" if legacy else r"the global heap at byte \d+ has a damaged object"
    with pytest.raises(FormatError, match=r"t\.h5: " + match):
        cdbrdf.load(p)


def test_legacy_file_is_read_in_a_child_and_equal(tmp_path, rich_table, monkeypatch):
    monkeypatch.setattr(io, "_LIBVER", ("earliest", "v110"))
    p = tmp_path / "old.h5"
    rich_table.save(p)
    monkeypatch.undo()
    assert io.superblock_version(p) == 0
    assert cdbrdf.load(p) == rich_table


def _legacy_file(tmp_path, table, monkeypatch):
    monkeypatch.setattr(io, "_LIBVER", ("earliest", "v110"))  # superblock 0, B-tree v1: no metadata checksums
    p = tmp_path / "old.h5"
    table.save(p)
    monkeypatch.undo()
    assert io.superblock_version(p) == 0
    return p


@pytest.mark.parametrize("damage", ["address", "record", "size"])
def test_damaged_chunk_index_of_a_legacy_file_is_a_format_error(tmp_path, rich_table, monkeypatch, damage):
    """A zeroed B-tree record made HDF5 read whole chunks as the fill value (0): silently changed values."""
    import struct

    p = _legacy_file(tmp_path, rich_table, monkeypatch)
    with h5py.File(p, "r") as f:
        ci = f["reflectance"].id.get_chunk_info(1)
    b = bytearray(p.read_bytes())
    addr = struct.pack("<Q", ci.byte_offset)
    i = b.find(addr)
    while i >= 0 and b[i - 64 : i - 60] != struct.pack("<I", ci.size):  # the child address after its key
        i = b.find(addr, i + 1)
    assert i > 0
    if damage == "address":
        b[i : i + 8] = bytes(8)
    elif damage == "record":
        b[i - 64 : i + 8] = bytes(72)  # key (size, filter mask, offsets) and address
    else:
        b[i - 64 : i - 60] = bytes(4)
    p.write_bytes(bytes(b))
    with pytest.raises(FormatError, match=r"old\.h5: .*'reflectance'"):
        cdbrdf.load(p)


@pytest.mark.slow
def test_no_zeroed_block_of_a_legacy_file_loads_with_other_values(tmp_path, rich_table, monkeypatch):
    """Every 1 KiB block zeroed in turn: each load is refused or equal to the original, never different."""
    p = _legacy_file(tmp_path, rich_table, monkeypatch)
    data = p.read_bytes()
    q = tmp_path / "z.h5"
    for off in range(0, len(data), 1024):
        b = bytearray(data)
        b[off : off + 1024] = bytes(len(b[off : off + 1024]))
        q.write_bytes(bytes(b))
        try:
            t = cdbrdf.load(q)
        except cdbrdf.CDBRDFError:
            continue
        assert t == rich_table, f"zeroed bytes {off}..{off + 1023} loaded with other values"


def test_xarray_reads_written_files(tmp_path, rich_table):
    import xarray as xr
    p = tmp_path / "t.h5"
    rich_table.save(p)
    with xr.open_dataset(p, engine="h5netcdf") as ds:
        np.testing.assert_array_equal(ds["reflectance"].values, rich_table.values)
        np.testing.assert_array_equal(ds["reflectance_std"].values, rich_table.std)


def test_flipped_byte_in_a_chunk_is_a_checksum_error(tmp_path, small_grid):
    p = tmp_path / "t.h5"
    make_table(small_grid).save(p, compression=None)
    with h5py.File(p, "r") as f:
        info = f["reflectance"].id.get_chunk_info(5)
    b = bytearray(p.read_bytes())
    b[info.byte_offset + info.size // 2] ^= 0x10
    p.write_bytes(bytes(b))
    with pytest.raises(FormatError, match=r"t\.h5: checksum mismatch in 'reflectance': the file is damaged"):
        cdbrdf.load(p)


def test_huge_declared_reflectance_is_refused_before_reading(tmp_path, small_grid):
    def edit(f):
        for name in schema.SAMPLE_AXES:
            del f[name]
            f.create_dataset(name, shape=(100,), dtype="f8", chunks=(100,))  # declared, never written

    p = _write_then_edit(tmp_path, small_grid, edit)
    assert p.stat().st_size < 100_000
    with pytest.raises(LimitError, match=r"t\.h5: 'reflectance' of shape \(100, 100, 100, 100, 100, 3\)"):
        cdbrdf.load(p)


def test_table_samples_limit_applies(tmp_path, small_grid, monkeypatch):
    p = tmp_path / "t.h5"
    make_table(small_grid).save(p)
    monkeypatch.setenv("CDBRDF_MAX_TABLE_SAMPLES", "100")
    with pytest.raises(LimitError, match="CDBRDF_MAX_TABLE_SAMPLES"):
        cdbrdf.load(p)


@pytest.mark.parametrize("keep", [100, 5000, -2000, -7])
def test_truncated_file(tmp_path, small_grid, keep):
    p = tmp_path / "t.h5"
    make_table(small_grid).save(p)
    p.write_bytes(p.read_bytes()[:keep])
    with pytest.raises(FormatError, match=r"t\.h5: "):
        cdbrdf.load(p)


@pytest.mark.parametrize("name", schema.REQUIRED_ATTRS)
def test_missing_required_attribute(tmp_path, small_grid, name):
    p = _write_then_edit(tmp_path, small_grid, lambda f: f.attrs.__delitem__(name))
    with pytest.raises(FormatError, match=f"t\\.h5: .*{name}"):
        cdbrdf.load(p)


def _set_attrs_json(f, attrs):
    f.attrs["cdbrdf_attrs"] = json.dumps(attrs)
    del f.attrs["cdbrdf_sha256"]


def _attrs_of(f):
    return json.loads(f.attrs["cdbrdf_attrs"])


@pytest.mark.parametrize(
    "edit, match",
    [
        (lambda f: f.__delitem__("channel"), "missing the variable 'channel'"),
        (lambda f: _set_attrs_json(f, {**_attrs_of(f), "channels": list("ABCDEFG")}),
         "names the channels .* but the 'channel' variable holds"),
        (lambda f: _set_attrs_json(f, {**_attrs_of(f), "quantity": "brdf"}),
         "'quantity' disagrees with its entry in 'cdbrdf_attrs'"),
        (lambda f: f.attrs.__setitem__("material", "other"), "'material' disagrees"),
        (lambda f: f.attrs.__setitem__("cdbrdf_attrs", "x" * 10), "checksum mismatch in 'cdbrdf_attrs'"),
        (lambda f: f.attrs.__setitem__("format_version", 1.0), "'format_version' is not a string"),
        (lambda f: f.attrs.__setitem__("format_version", np.bytes_(b"1.\xff")), "not valid UTF-8"),
        (lambda f: f.attrs.__setitem__("format_version", "1.0.3"), "unreadable format_version"),
        (lambda f: _replace(f, "kappa", np.array([-0.2, 0, 0.05, 0.3]) + 0j), "axis 'kappa' has dtype complex128"),
        (lambda f: _replace(f, "theta_l", np.array([0, 20, 50])), "axis 'theta_l' has dtype int64"),
        (lambda f: _replace(f, "fill_source", np.full(f["fill_source"].shape, 2**64 - 1, np.uint64)),
         "'fill_source' holds indices outside"),
        (lambda f: _replace(f, "reflectance", f["reflectance"][()].astype(np.int32)), "'reflectance' has dtype int32"),
        (lambda f: _replace(f, "measured", f["measured"][()].astype(np.float32)), "'measured' has dtype float32"),
        (lambda f: _replace(f, "channel", np.array([1, 2, 3])), "'channel' has dtype int64"),
        (lambda f: _replace(f, "reflectance_std", np.ones(f["reflectance"].shape[:5] + (2,))),
         "'reflectance_std' has shape"),
    ],
)
def test_spec_is_enforced(tmp_path, small_grid, edit, match):
    p = tmp_path / "t.h5"
    make_table(small_grid, attrs={"material": "m"}, std=np.full(small_grid.shape + (3,), 0.1)).save(p)
    with h5py.File(p, "r+") as f:
        edit(f)
        del f.attrs["cdbrdf_data_sha256"]  # as another writer's file: each rule, not the digest, refuses it
    with pytest.raises(FormatError, match=match) as info:
        cdbrdf.load(p)
    assert str(info.value).startswith(str(p) + ": ")
    assert "\n" not in str(info.value)


def _replace(f, name, data):
    """Replace a variable keeping its dimension scales (as a NetCDF writer would)."""
    old = f[name]
    dims = [d[0] for d in old.dims if len(d)] if name not in schema.AXES else []
    is_scale = name in schema.AXES
    del f[name]
    new = f.create_dataset(name, data=data)
    if is_scale:
        new.make_scale(name)
        return
    for i, scale in enumerate(dims):
        new.dims[i].attach_scale(scale)


def test_save_refuses_channel_names_of_the_wrong_length(tmp_path, small_grid):
    with pytest.raises(cdbrdf.TableError, match=r"attrs\['channels'\]"):
        make_table(small_grid, attrs={"channels": list("ABCDEFG")}).save(tmp_path / "t.h5")


def test_other_channel_names_round_trip(tmp_path, small_grid):
    t = make_table(small_grid, channels=2, attrs={"channels": ["nir", "uv"]})
    t.save(tmp_path / "t.h5")
    assert cdbrdf.load(tmp_path / "t.h5") == t


@pytest.mark.skipif(os.geteuid() == 0, reason="root reads every file")
def test_unreadable_file(tmp_path, small_grid):
    p = tmp_path / "t.h5"
    make_table(small_grid).save(p)
    p.chmod(0)
    with pytest.raises(FormatError, match=r"t\.h5: cannot be read"):
        cdbrdf.load(p)


def test_damaged_string_reference_in_channel(tmp_path, small_grid):
    # a 4-byte change in the raw heap reference of a channel name made HDF5 spin (fuzz input #323)
    p = tmp_path / "t.h5"
    make_table(small_grid).save(p)
    with h5py.File(p, "r") as f:
        offset = f["channel"].id.get_offset()
    b = bytearray(p.read_bytes())
    b[offset + 16 : offset + 20] = (0xFFFF7F01).to_bytes(4, "little")  # length of the 2nd name
    p.write_bytes(bytes(b))
    with pytest.raises(FormatError, match=r"t\.h5: 'channel' entry 1 points at no stored string"):
        cdbrdf.load(p)


def test_booleans_and_big_integers_in_attrs_round_trip(tmp_path, small_grid):
    # NetCDF-4 has no boolean attribute and HDF5 no integer over 64 bits: the
    # global-attribute mirrors of such values are JSON text; the table keeps them.
    t = make_table(small_grid, attrs={"calibrated": True, "draft": False, "count": 2**70, "n": -5})
    p = tmp_path / "b.h5"
    t.save(p)
    back = cdbrdf.load(p)
    assert back.attrs["calibrated"] is True and back.attrs["draft"] is False
    assert back.attrs["count"] == 2**70 and back.attrs["n"] == -5
    assert back == t
    with h5py.File(p, "r") as f:
        assert f.attrs["calibrated"] in ("true", b"true")
        assert np.asarray(f.attrs["n"]).item() == -5


def test_load_of_something_that_is_not_a_file_name_or_not_a_regular_file(tmp_path):
    import os

    from cdbrdf.errors import OptionError

    for bad in (None, 3, ["t.h5"]):
        with pytest.raises(OptionError, match="path: expected a file name"):
            cdbrdf.load(bad)
    fifo = tmp_path / "t.h5"
    os.mkfifo(fifo)  # reading it would block forever
    with pytest.raises(FormatError, match=r"t\.h5: not a regular file \(a FIFO\)"):
        cdbrdf.load(fifo)
    dev = tmp_path / "zero.h5"
    dev.symlink_to("/dev/zero")
    with pytest.raises(FormatError, match=r"zero\.h5: not a regular file \(a character device\)"):
        cdbrdf.load(dev)


# -- hostile input, second round --------------------------------------------------------------------------
def _looping_legacy_file(tmp_path, table, monkeypatch):
    """A file without metadata checksums whose damaged global heap makes HDF5 loop forever."""
    p = _legacy_file(tmp_path, table, monkeypatch)
    _zero_global_heap(p)
    return p


def test_the_legacy_reader_never_imports_from_the_current_folder(tmp_path, rich_table, monkeypatch):
    """`cd dataset && cdbrdf info legacy.nc` with a pickle.py beside the file ran that file."""
    import subprocess
    import sys

    p = _legacy_file(tmp_path, rich_table, monkeypatch)
    marker = tmp_path / "ran"
    for name in ("pickle", "json", "numpy", "h5py", "cdbrdf", "io", "selectors", "ctypes"):
        (tmp_path / f"{name}.py").write_text(f"open({str(marker)!r}, 'a').write({name!r})\n")
    code = "import cdbrdf, sys; t = cdbrdf.load(sys.argv[1]); print(t.shape)"
    env = dict(os.environ, PYTHONSAFEPATH="1")  # the test's own interpreter must not import them either
    r = subprocess.run([sys.executable, "-c", code, p.name], cwd=tmp_path, capture_output=True, text=True,
                       env=env, timeout=120)
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip() == str(rich_table.shape) and not marker.exists()


def test_a_looping_legacy_file_is_refused_within_seconds(tmp_path, rich_table, monkeypatch):
    import time

    p = _looping_legacy_file(tmp_path, rich_table, monkeypatch)
    monkeypatch.setattr(io, "LEGACY_READ_TIMEOUT_S", 3.0)  # the default, whatever another test set
    t0 = time.monotonic()
    with pytest.raises(FormatError, match=r"old\.h5: reading it took longer than 3 s and was stopped"):
        cdbrdf.load(p)
    assert time.monotonic() - t0 < 10.0  # 3 s after the reader started (about 4 s here); 30 s and more before


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="/proc lists a process's children")
def test_killing_the_reader_s_parent_leaves_no_process(tmp_path, rich_table, monkeypatch):
    """kill -9 of a `cdbrdf info` reading a damaged file: its reader spun on at full CPU for ever before."""
    import signal
    import subprocess
    import time

    p = _looping_legacy_file(tmp_path, rich_table, monkeypatch)
    parent = subprocess.Popen([sys.executable, "-m", "cdbrdf.cli", "info", str(p)], stdout=subprocess.DEVNULL,
                              stderr=subprocess.DEVNULL)
    child = None
    deadline = time.monotonic() + 60
    while child is None and time.monotonic() < deadline and parent.poll() is None:
        for task in Path(f"/proc/{parent.pid}/task").glob("*/children"):
            kids = task.read_text().split()
            if kids:
                child = int(kids[0])
        time.sleep(0.05)
    assert child is not None, "the reader's child was not seen"
    parent.send_signal(signal.SIGKILL)
    parent.wait()
    deadline = time.monotonic() + 10
    while time.monotonic() < deadline:
        try:
            state = Path(f"/proc/{child}/stat").read_text().split(")")[-1].split()[0]
        except FileNotFoundError:
            break
        if state in ("Z", "X"):  # dead, waiting to be reaped by init
            break
        time.sleep(0.05)
    else:
        os.kill(child, signal.SIGKILL)
        pytest.fail("the reader outlived its parent")


def test_fletcher32_blind_spot_is_covered_by_the_data_digest(tmp_path, small_grid):
    """Two bytes 0x0000 -> 0xFFFF inside theta_l keep Fletcher-32's sums: 15 degrees loaded as 15.49999."""
    p = tmp_path / "t.h5"
    make_table(small_grid).save(p)
    data = bytearray(p.read_bytes())
    axis = np.asarray(small_grid.theta_l, "<f8")
    i = data.find(axis.tobytes())
    assert i > 0 and axis[1] != 0.0
    data[i + 8 + 2 : i + 8 + 4] = b"\xff\xff"  # a zero 16-bit word of theta_l[1]
    p.write_bytes(bytes(data))
    with h5py.File(p, "r") as f:  # HDF5's checksum does not see it
        assert {f["theta_l"][1], f["theta_v"][1]} != {axis[1]}
    with pytest.raises(FormatError, match=r"t\.h5: checksum mismatch in the data"):
        cdbrdf.load(p)


@pytest.mark.parametrize("edit", [
    lambda f: f["reflectance"].__setitem__((0, 0, 0, 0, 0, 0), 0.123),
    lambda f: f["kappa"].__setitem__(0, -0.5),
    lambda f: f["measured"].__setitem__((0, 0, 0, 0, 0), 0),
])
def test_changed_data_of_a_1_3_file_is_a_checksum_mismatch(tmp_path, small_grid, edit):
    p = _write_then_edit(tmp_path, small_grid, edit, keep_digest=True)
    with pytest.raises(FormatError, match="checksum mismatch in the data"):
        cdbrdf.load(p)


@pytest.mark.parametrize("variable, attrs, match", [
    ("reflectance", {"scale_factor": 2.0}, r"'reflectance' is packed \(scale_factor = 2\.0\)"),
    ("reflectance", {"add_offset": 1.0}, r"'reflectance' is packed \(add_offset = 1\.0\)"),
    ("theta_l", {"scale_factor": np.float32(0.5)}, r"'theta_l' is packed"),
    ("measured", {"scale_factor": 2}, r"'measured' is packed"),
    ("kappa", {"units": "1/m"}, r"'kappa' is in '1/m', expected '1/mm'"),
    ("theta_v", {"units": "radian"}, r"'theta_v' is in 'radian', expected 'degree'"),
    ("reflectance", {"units": "1"}, r"'reflectance' is in '1', expected '1/sr'"),
    ("reflectance", {"_FillValue": np.float32(0.5)}, r"'reflectance' holds 1 value\(s\) equal to its _FillValue"),
    ("measured", {"missing_value": np.uint8(1)}, r"'measured' holds \d+ value\(s\) equal to its missing_value"),
])
def test_cf_packing_units_and_missing_values_are_never_ignored(tmp_path, small_grid, variable, attrs, match):
    """xarray applies them: read as stored, a scale_factor of 2 gave half of xarray's values."""
    values = make_table(small_grid).values.copy()
    values[0, 0, 0, 0, 0, 0] = 0.5
    p = tmp_path / "t.h5"
    CDBRDF(values, small_grid, attrs={"quantity": "brdf"}).save(p)
    with h5py.File(p, "r+") as f:
        for k, v in attrs.items():
            f[variable].attrs[k] = v
    with pytest.raises(FormatError, match=r"t\.h5: " + match):
        cdbrdf.load(p)


def test_equivalent_unit_spellings_and_unmatched_fill_values_are_read(tmp_path, small_grid):
    t = make_table(small_grid, attrs={"quantity": "brdf"})
    p = tmp_path / "t.h5"
    t.save(p)
    with h5py.File(p, "r+") as f:
        f["theta_l"].attrs["units"] = "degrees"
        f["kappa"].attrs["units"] = "mm-1"
        f["reflectance"].attrs["units"] = "sr-1"
        f["reflectance"].attrs["_FillValue"] = np.float64(np.nan)  # what xarray writes: no value equals it
        f["measured"].attrs["_FillValue"] = np.uint8(255)
    assert cdbrdf.load(p) == t


def test_a_table_round_trips_through_xarray_to_netcdf(tmp_path, rich_table):
    """cdbrdf.load(f).to_xarray().to_netcdf(x) failed: a dict attribute is not netCDF-legal."""
    import xarray as xr

    ds = rich_table.to_xarray()
    for value in ds.attrs.values():  # netCDF-legal: strings, numbers, arrays of numbers
        assert isinstance(value, (str, int, float, np.ndarray, np.number)) and not isinstance(value, bool)
    assert json.loads(ds.attrs["provenance"]) == rich_table.attrs["provenance"]
    x = tmp_path / "x.nc"
    ds.to_netcdf(x)
    back = cdbrdf.load(x)
    assert back == rich_table and back.attrs == rich_table.attrs
    with xr.open_dataset(x) as opened:
        assert CDBRDF.from_xarray(opened) == rich_table
    edited = ds.assign_attrs(material="renamed")  # a mirror edited without cdbrdf_attrs: refused, not guessed
    with pytest.raises(cdbrdf.TableError, match=r"attrs\['material'\]: 'renamed' disagrees"):
        CDBRDF.from_xarray(edited)


def test_a_file_of_another_brdf_format_suggests_cdbrdf_import(tmp_path):
    p = tmp_path / "cc_ibiza_sunset_rgb.bsdf"
    p.write_bytes(b"tensor_file\0\x01\x00" + bytes(100))
    with pytest.raises(FormatError, match=r"\.bsdf: not an HDF5 file .*`cdbrdf import FILE -o OUT\.h5`"):
        cdbrdf.load(p)


def test_saving_keeps_the_mode_of_the_file_it_replaces(tmp_path, small_grid):
    import stat

    p = tmp_path / "t.h5"
    make_table(small_grid).save(p)
    os.chmod(p, 0o600)
    make_table(small_grid, seed=1).save(p)
    assert stat.S_IMODE(p.stat().st_mode) == 0o600


def test_saving_onto_a_full_disk_is_one_line_and_keeps_the_old_file(tmp_path, small_grid):
    import subprocess

    p = tmp_path / "t.h5"
    p.write_bytes(b"old" * 100)
    code = ("import resource, sys, numpy as np, cdbrdf\n"
            "g = cdbrdf.Grid.paper()\n"
            "t = cdbrdf.CDBRDF(np.random.default_rng(0).random(g.shape + (3,)), g)\n"
            "resource.setrlimit(resource.RLIMIT_FSIZE, (8192, 8192))\n"
            "try:\n    t.save(sys.argv[1])\nexcept OSError as e:\n    print(e)\n")
    r = subprocess.run([sys.executable, "-c", code, str(p)], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0 and r.stderr == "", r  # no traceback, no crash in HDF5's close
    assert r.stdout.strip().endswith("t.h5: cannot be written: no space left on the device (or the file-size limit "
                                     "or the quota reached); the old file, if any, is kept")
    assert p.read_bytes() == b"old" * 100 and sorted(q.name for q in tmp_path.iterdir()) == ["t.h5"]
