"""MERL ``.binary`` and UTIA ``.bin`` files written from analytic BRDFs, through the readers and the import.

Known answers: the readers return the stored values at the sample centres
(MERL, with its channel scales) and directions (UTIA, sRGB-decoded); the
half/difference angles agree with the published reader's convention; the
imported tables match the analytic BRDF; unmeasured samples are marked; bad
files are refused in one line naming them.
"""

from __future__ import annotations

import numpy as np
import pytest

from cdbrdf import FormatError
from cdbrdf.colour import linear_to_srgb
from cdbrdf.importers import detect_format, import_brdf, merl, read_source, utia

from .import_helpers import aniso_brdf, lobe_brdf, merl_centres, write_merl, write_utia


@pytest.fixture(scope="module")
def merl_file(tmp_path_factory):
    return write_merl(tmp_path_factory.mktemp("merl") / "lobe.binary")


@pytest.fixture(scope="module")
def utia_file(tmp_path_factory):
    return write_utia(tmp_path_factory.mktemp("utia") / "m001_test.bin")


def _reference_merl_index(theta_h, theta_d, phi_d):
    """The published reader's index arithmetic (BRDFRead.cpp), for comparison."""
    th = np.clip(np.sqrt(np.clip(theta_h / (np.pi / 2), 0, 1)) * 90, 0, 89).astype(int)
    td = np.clip(theta_d / (np.pi / 2) * 90, 0, 89).astype(int)
    pd = np.where(phi_d < 0, phi_d + np.pi, phi_d)
    pd = np.clip(pd / np.pi * 180, 0, 179).astype(int)
    return th, td, pd


@pytest.mark.slow
def test_merl_layout_scales_and_half_difference_angles(merl_file):
    data = merl_file.read_bytes()
    assert len(data) == merl.FILE_BYTES == 12 + 3 * 90 * 90 * 180 * 8
    assert tuple(np.frombuffer(data[:12], "<i4")) == (90, 90, 180)
    raw = np.frombuffer(data, "<f8", offset=12).reshape(3, 90, 90, 180)
    tv, pv, tl, pl = merl_centres()
    want = lobe_brdf(tv, pv, tl, pl)
    ok = (tv < 90) & (tl < 90)
    # stored value x the reader's scale = the BRDF
    np.testing.assert_allclose(raw[1][ok] * 1.15 / 1500, want[..., 1][ok], rtol=1e-12)
    # our half/difference angles land each sample centre in its own cell of the published reader
    sel = np.flatnonzero(ok.ravel())[::997]
    th, td, pd = merl.half_diff(tv.ravel()[sel], pv.ravel()[sel], tl.ravel()[sel], pl.ravel()[sel])
    idx = np.unravel_index(sel, (90, 90, 180))
    got = _reference_merl_index(th, td, pd)
    for a, b in zip(got, idx):
        np.testing.assert_array_equal(a, b)


def test_merl_reader_reproduces_the_samples_and_marks_unmeasured(merl_file):
    src = read_source(merl_file)
    assert src.format == "merl" and src.isotropic and src.quantity == "brdf"
    tv, pv, tl, pl = (a.ravel() for a in merl_centres())
    ok = (tv < 89) & (tl < 89)
    sel = np.flatnonzero(ok)[::513]
    f, m = src.evaluate(tv[sel], pv[sel], tl[sel], pl[sel])
    np.testing.assert_allclose(f, lobe_brdf(tv[sel], pv[sel], tl[sel], pl[sel]), rtol=1e-9)
    # at a sample centre next to unmeasured (below-horizon) samples only the measured ones count
    assert np.all(m > 0.99)
    assert src.details["unmeasured_samples"] > 0


def test_merl_import_matches_the_analytic_brdf(merl_file):
    t = import_brdf(merl_file, grid="regular:5,5", spacing_deg=2.5)
    assert t.isotropic and t.attrs["material"] == "lobe"
    rng = np.random.default_rng(1)
    n = 3000
    q = (rng.uniform(0, 80, n), rng.uniform(-180, 180, n), rng.uniform(0, 80, n), rng.uniform(-180, 180, n))
    got = t.evaluate(*q)
    want = lobe_brdf(*q)
    rel = np.sum(np.abs(got - want)) / np.sum(want)
    assert rel < 0.03, rel
    est = t.attrs["provenance"]["expected_error"]
    assert est["brdf_relative_l1"] < 0.03 and est["albedo_relative_error_mean"] < 0.01


@pytest.mark.parametrize("case,match", [
    ("size", "a MERL file of the wrong size: 34991004 bytes, expected 34992012"),
    ("header", "its header gives 90 x 90 x 360 samples"),
    ("nan", "holds 1 NaN or infinite value"),
    ("empty", "holds no measured sample"),
])
def test_bad_merl_files(tmp_path, merl_file, case, match):
    data = bytearray(merl_file.read_bytes())
    if case == "size":
        data = data[:-1008]
    elif case == "header":
        data[8:12] = np.array([360], "<i4").tobytes()
    elif case == "nan":
        data[12 + 8 * 1000:12 + 8 * 1001] = np.array([np.nan], "<f8").tobytes()
    elif case == "empty":
        data[12:] = np.full(3 * 90 * 90 * 180, -1.0).astype("<f8").tobytes()
    p = tmp_path / f"{case}.binary"
    p.write_bytes(bytes(data))
    with pytest.raises(FormatError, match=match) as err:
        read_source(p)
    assert str(err.value).startswith(str(p)) and "\n" not in str(err.value)


def test_utia_layout_and_srgb_decoding(utia_file, tmp_path):
    assert detect_format(utia_file) == "utia"
    raw = np.frombuffer(utia_file.read_bytes(), "<f8").reshape(utia.SHAPE)
    # [channel][theta_i][phi_i][theta_v][phi_v], sRGB-encoded
    want = aniso_brdf(45.0, 30.0, 60.0, 15.0)
    np.testing.assert_allclose(raw[:, 4, 2, 3, 4], linear_to_srgb(want), rtol=1e-12)
    src = read_source(utia_file)
    assert src.format == "utia" and not src.isotropic and src.quantity == "relative"
    f, m = src.evaluate(np.array([45.0]), np.array([30.0]), np.array([60.0]), np.array([15.0]))
    np.testing.assert_allclose(f[0], want, rtol=1e-9)
    assert m is None  # every sample measured
    lin = write_utia(tmp_path / "lin.bin", encoding="linear")
    f2, _ = read_source(lin, encoding="linear").evaluate(np.array([45.0]), np.array([30.0]), np.array([60.0]),
                                                          np.array([15.0]))
    np.testing.assert_allclose(f2[0], want, rtol=1e-12)


def test_utia_native_grid_is_an_exact_copy_and_the_paper_grid_averages(utia_file):
    native = import_brdf(utia_file, grid="native", dtype=np.float64)
    assert native.shape == (1, 48, 6, 48, 6, 3)
    assert native.attrs["provenance"]["resampling"]["method"].startswith("copied")
    np.testing.assert_allclose(native.values[0, 2, 4, 4, 3], aniso_brdf(45.0, 30.0, 60.0, 15.0), rtol=1e-12)
    paper = import_brdf(utia_file, spacing_deg=3.75)
    assert paper.shape == (1, 12, 6, 12, 6, 3) and not paper.isotropic
    rng = np.random.default_rng(2)
    q = (rng.uniform(0, 75, 2000), rng.uniform(0, 360, 2000), rng.uniform(0, 75, 2000), rng.uniform(0, 360, 2000))
    want = aniso_brdf(*q)
    assert np.sum(np.abs(paper.evaluate(*q) - want)) / np.sum(want) < 0.02


def test_utia_negative_values_are_unmeasured_and_bad_files_refused(tmp_path, utia_file):
    raw = np.frombuffer(utia_file.read_bytes(), "<f8").copy().reshape(utia.SHAPE)
    raw[0, 1, 5, 2, 7] = -0.5
    p = tmp_path / "neg.bin"
    p.write_bytes(raw.astype("<f8").tobytes())
    t = import_brdf(p, grid="native")
    assert not t.measured[0, 5, 1, 7, 2] and t.measured.sum() == t.measured.size - 1
    assert t.values[0, 5, 1, 7, 2, 0] == 0.0
    short = tmp_path / "short.bin"
    short.write_bytes(utia_file.read_bytes()[:-8])
    with pytest.raises(FormatError, match="a UTIA BRDF file of the wrong size: 1990648 bytes, expected 1990656"):
        read_source(short)
    raw[2, 0, 0, 0, 0] = np.inf
    p.write_bytes(raw.astype("<f8").tobytes())
    with pytest.raises(FormatError, match="holds 1 NaN or infinite"):
        read_source(p)
    with pytest.raises(FormatError, match="encoding: 'gamma' is not one of srgb, linear"):
        read_source(utia_file, encoding="gamma")


def test_unknown_files_name_the_formats(tmp_path):
    p = tmp_path / "x.dat"
    p.write_bytes(b"hello world, not a brdf")
    with pytest.raises(FormatError, match="cannot tell its format .* give the format .rgl, merl, utia, nbrdf, cdbrdf."):
        detect_format(p)
    with pytest.raises(FormatError, match="format: 'brdf' is not one of auto, rgl"):
        read_source(p, format="brdf")


# -- hostile input, second round: one plausibility bound for every format, special files -----------------
@pytest.mark.parametrize("encoding, stored", [("srgb", 9e5), ("linear", 9e5), ("srgb", 200.0), ("linear", 2e5)])
def test_an_absurd_utia_value_is_refused_by_the_shared_bound(tmp_path, utia_file, encoding, stored):
    """One value of 9e5 (under the old bound of 1e6) turned the table's mean from 0.3 into 4.2e8."""
    src = write_utia(tmp_path / "a.bin", encoding=encoding) if encoding == "linear" else utia_file
    raw = np.frombuffer(src.read_bytes(), "<f8").copy().reshape(utia.SHAPE)
    raw[1, 2, 3, 4, 5] = stored
    p = tmp_path / "absurd.bin"
    p.write_bytes(raw.astype("<f8").tobytes())
    with pytest.raises(FormatError, match=r"absurd\.bin: .*beyond .*1e\+05") as err:
        read_source(p, encoding=encoding)
    assert "\n" not in str(err.value)


def test_an_absurd_merl_value_is_refused_by_the_shared_bound(tmp_path, merl_file):
    data = bytearray(merl_file.read_bytes())
    data[12 + 8 * 5000:12 + 8 * 5001] = np.array([1e9], "<f8").tobytes()  # 6.7e5 sr^-1 once scaled
    p = tmp_path / "absurd.binary"
    p.write_bytes(bytes(data))
    with pytest.raises(FormatError, match=r"absurd\.binary: BRDF values .* up to 6\.67e\+05, beyond 1e\+05"):
        read_source(p)


@pytest.mark.parametrize("kind", ["fifo", "/dev/zero", "folder"])
@pytest.mark.parametrize("fmt", ["auto", "merl", "utia", "rgl"])
def test_special_files_are_refused_before_they_are_read(tmp_path, kind, fmt):
    """read_source('fifo.bin') hung; read_source('/dev/zero', format='merl') raised a bare MemoryError."""
    import os

    p = tmp_path / "x.bin"
    if kind == "fifo":
        os.mkfifo(p)
    elif kind == "folder":
        p.mkdir()
    else:
        p.symlink_to(kind)
    with pytest.raises(FormatError, match=r"x\.bin: (not a regular file|is a folder)"):
        read_source(p, format=fmt)
