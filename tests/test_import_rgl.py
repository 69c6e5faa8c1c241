"""RGL ``.bsdf`` files: the tensor reader, the material checks, the measured share, spectral files, the import.

Real files from ``../shared/data/rgl`` (skipped when absent); spectral,
polarised, transmission, truncated and damaged files are written by the tests
with :func:`cdbrdf.importers.rgl.write_tensor_file`.
"""

from __future__ import annotations

import numpy as np
import pytest

from cdbrdf import FormatError
from cdbrdf.importers import detect_format, import_brdf, read_source, rgl

from .import_helpers import need_mitsuba, rgl_path


@pytest.fixture(scope="module")
def matte_fields():
    p = rgl_path("matte")
    return rgl.read_tensor_file(p, p.read_bytes())


def test_tensor_file_fields_and_description(matte_fields):
    f = matte_fields
    assert bytes(f["description"]).decode() == "White A4 paper (160 gsm)"
    assert f["rgb"].shape == (1, 8, 3, 32, 32) and f["rgb"].dtype == np.float32
    assert f["vndf"].shape == (1, 8, 128, 128)
    assert np.degrees(f["theta_i"][-1]) == pytest.approx(90.0, abs=1e-3)
    checked = rgl._validate(rgl_path("matte"), f)
    assert checked["valid"].shape == (1, 8, 32, 32) and 0 < checked["valid"].sum() < checked["valid"].size
    assert not checked["spectral"]


def test_tensor_file_round_trip(tmp_path, matte_fields):
    p = tmp_path / "copy.bsdf"
    rgl.write_tensor_file(p, {k: np.asarray(v) for k, v in matte_fields.items()})
    back = rgl.read_tensor_file(p, p.read_bytes())
    assert set(back) == set(matte_fields)
    for k in back:
        np.testing.assert_array_equal(back[k], matte_fields[k])


def test_measured_share_uses_the_plug_ins_own_parameterisation():
    """The grid positions found by inverting the VNDF warp reproduce Mitsuba's eval when used on the rgb field."""
    need_mitsuba()
    import drjit as dr
    import mitsuba as mi

    from cdbrdf.render import set_variant

    set_variant("llvm_ad_rgb")  # this test calls Mitsuba itself (the importer gives the caller's variant back)

    p = rgl_path("glossy")
    src = read_source(p)
    ev = src.evaluate
    fields = rgl._validate(p, rgl.read_tensor_file(p, p.read_bytes()))
    rng = np.random.default_rng(3)
    n = 4000
    tv, pv = rng.uniform(5, 80, n), rng.uniform(-180, 180, n)
    tl, pl = rng.uniform(5, 80, n), rng.uniform(-180, 180, n)
    f, measured = ev(tv, pv, tl, pl)
    assert measured is not None and np.all((measured >= 0) & (measured <= 1)) and 0.5 < measured.mean() < 1.0
    # rebuild the value from the rgb field at the positions the measured share used
    spectra = mi.MarginalContinuous2D3(np.array(fields["rgb"]), ev.params + [[0.0, 1.0, 2.0]], False, False)
    ndf = mi.MarginalContinuous2D0(np.array(fields["ndf"]), [], False, False)
    sigma = mi.MarginalContinuous2D0(np.array(fields["sigma"]), [], False, False)

    def d(t, q):
        st, ct = dr.sincos(mi.Float(np.radians(t).astype(np.float32)))
        sq, cq = dr.sincos(mi.Float(np.radians(q).astype(np.float32)))
        return mi.Vector3f(st * cq, st * sq, ct)

    wi, wo = d(tv, pv), d(tl, pl)
    # positions as in rgl._Evaluator._measured
    m = dr.normalize(wi + wo)
    el = lambda v: 2.0 * dr.safe_asin(0.5 * dr.sqrt(dr.square(v.x) + dr.square(v.y) + dr.square(v.z - 1.0)))  # noqa: E731
    th_i, ph_i, th_m, ph_m = el(wi), dr.atan2(wi.y, wi.x), el(m), dr.atan2(m.y, m.x) - dr.atan2(wi.y, wi.x)
    u = (ph_m + dr.pi) * (0.5 / dr.pi)
    um = mi.Point2f(dr.sqrt(th_m * (2 / dr.pi)), u - dr.floor(u))
    params = mi.Point2f(ph_i, th_i)
    sample, _ = ev.vndf.invert(um, params)
    uwi = mi.Point2f(dr.sqrt(th_i * (2 / dr.pi)), (ph_i + dr.pi) * (0.5 / dr.pi))
    jac = ndf.eval(um) / (4 * sigma.eval(uwi))
    rebuilt = np.stack([np.array(spectra.eval(sample, mi.Point3f(ph_i, th_i, mi.Float(float(c)))) * jac)
                        for c in range(3)], axis=1) / np.cos(np.radians(tl))[:, None]
    np.testing.assert_allclose(rebuilt, f, rtol=2e-3, atol=1e-5 * np.abs(f).max())


def test_import_of_the_matte_file(tmp_path):
    need_mitsuba()
    p = rgl_path("matte")
    assert detect_format(p) == "rgl"
    t = import_brdf(p, grid="regular:10,10", kappa=0.13)
    assert t.isotropic and t.kappa.tolist() == [0.13] and t.quantity == "brdf"
    assert t.attrs["material"] == "White A4 paper (160 gsm)"
    prov = t.attrs["provenance"]
    assert prov["kind"] == "imported" and prov["source"]["format"] == "rgl"
    assert prov["source"]["file_name"] == p.name and len(prov["source"]["sha256"]) == 64
    assert prov["grid"]["theta_l"]["step"] == 10.0 and prov["resampling"]["spacing_deg"] == 1.0
    assert prov["expected_error"]["brdf_relative_l1"] < 0.02
    # a matte white paper: albedo near 0.8, nearly constant f
    assert 0.2 < float(np.median(t.values)) < 0.35
    # the measured share comes from the file's valid bits
    assert 0.0 < t.measured.mean() < 0.5
    out = tmp_path / "paper.h5"
    t.save(out)
    import cdbrdf

    assert cdbrdf.load(out) == t


def _fields(**change):
    """A small, valid RGB material (isotropic, 3 incident elevations, 4 x 4 reflectance grid)."""
    rng = np.random.default_rng(0)
    f = {
        "version": np.array([1, 0], np.uint32),
        "description": "test material",
        "phi_i": np.zeros(1, np.float32),
        "theta_i": np.radians([0.0, 45.0, 89.9]).astype(np.float32),
        "sigma": np.ones((2, 8), np.float32),
        "ndf": np.ones((2, 8), np.float32),
        "vndf": np.ones((1, 3, 8, 8), np.float32),
        "luminance": np.ones((1, 3, 4, 4), np.float32),
        "rgb": (0.1 + rng.random((1, 3, 3, 4, 4))).astype(np.float32),
        "jacobian": np.array([1], np.uint8),
        "valid": np.packbits(np.ones(3 * 16, np.uint8)),
    }
    f.update(change)
    return {k: v for k, v in f.items() if v is not None}


def test_spectral_file_is_converted_through_the_cie_observer(tmp_path):
    need_mitsuba()
    flat = _fields()
    wl = np.linspace(360, 830, 48).astype(np.float32)
    grey = flat["rgb"][:, :, 1:2]  # the green channel as a flat spectrum
    spectral = _fields(rgb=None, wavelengths=wl, spectra=np.repeat(grey, wl.size, axis=2))
    rgb_ref = _fields(rgb=np.repeat(grey, 3, axis=2))
    ps, pr = tmp_path / "spec.bsdf", tmp_path / "rgb.bsdf"
    rgl.write_tensor_file(ps, spectral)
    rgl.write_tensor_file(pr, rgb_ref)
    s, r = read_source(ps), read_source(pr)
    assert s.details["channels"] == "spectral" and "CIE 1931" in s.details["spectral"]["conversion"]
    q = [np.array([30.0, 50.0, 10.0]), np.array([0.0, 90.0, 200.0]), np.array([40.0, 20.0, 60.0]),
         np.array([180.0, 0.0, 10.0])]
    # a flat spectrum becomes grey: R = G = B = the spectrum's value
    np.testing.assert_allclose(s.evaluate(*q)[0], r.evaluate(*q)[0], rtol=1e-5)
    # a reddish ramp (in gamut): the weights agree with Mitsuba's own spectrum -> sRGB under D65
    w = rgl.spectral_to_rgb_weights(wl)
    import mitsuba as mi

    from cdbrdf.render import set_variant

    set_variant("llvm_ad_rgb")  # this test calls Mitsuba itself

    blue = 0.2 + 0.6 * (wl - 360.0) / 470.0
    mine = w @ blue
    theirs = np.array(mi.spectrum_list_to_srgb(list(map(float, wl)), list(blue), bounded=False, d65=True))
    np.testing.assert_allclose(mine, theirs / np.array(mi.spectrum_list_to_srgb(
        list(map(float, wl)), [1.0] * wl.size, bounded=False, d65=True)), rtol=2e-2, atol=2e-3)
    np.testing.assert_allclose(w.sum(axis=1), 1.0, rtol=1e-12)


@pytest.mark.parametrize("case,match", [
    ("short", "not an RGL .bsdf tensor file"),
    ("magic", "not an RGL .bsdf tensor file .its first bytes"),
    ("version", "unknown tensor file version 2.0"),
    ("truncated", "runs past the end of the file"),
    ("polarised", "polarised .Mueller-matrix."),
    ("btdf", "transmission .BTDF. data are not supported"),
    ("btdf_field", "BTDFs are not supported"),
    ("nan", "holds 1 NaN or infinite value"),
    ("missing", "no field 'vndf'"),
    ("shape", "'rgb' has shape"),
    ("type", "the unknown type code 42"),
])
def test_bad_files_are_refused_in_one_line_naming_the_file(tmp_path, case, match):
    p = tmp_path / f"{case}.bsdf"
    if case == "polarised":
        rgl.write_tensor_file(p, {"theta_h": np.zeros((1, 4), np.float32), "theta_d": np.zeros((1, 4), np.float32),
                                  "phi_d": np.zeros((1, 4), np.float32), "wvls": np.arange(5, dtype=np.uint16),
                                  "M": np.zeros((4, 4, 4, 5, 4, 4), np.float32)})
    elif case == "btdf":
        rgl.write_tensor_file(p, _fields(theta_i=np.radians([0.0, 45.0, 120.0]).astype(np.float32)))
    elif case == "btdf_field":
        rgl.write_tensor_file(p, _fields(transmission=np.ones(3, np.float32)))
    elif case == "nan":
        bad = _fields()["rgb"].copy()
        bad[0, 1, 2, 3, 0] = np.nan
        rgl.write_tensor_file(p, _fields(rgb=bad))
    elif case == "missing":
        rgl.write_tensor_file(p, _fields(vndf=None))
    elif case == "shape":
        rgl.write_tensor_file(p, _fields(rgb=np.ones((1, 2, 3, 4, 4), np.float32)))
    else:
        rgl.write_tensor_file(p, _fields())
        data = bytearray(p.read_bytes())
        if case == "short":
            data = data[:10]
        elif case == "magic":
            data[:12] = b"not_a_tensor"
        elif case == "version":
            data[12] = 2
        elif case == "truncated":
            data = data[: len(data) - 40]
        elif case == "type":
            data[18 + 2 + len("version") + 2] = 42
        p.write_bytes(bytes(data))
    with pytest.raises(FormatError) as err:
        read_source(p, format="rgl")
    msg = str(err.value)
    assert msg.startswith(str(p)) and "\n" not in msg
    import re

    assert re.search(match, msg), msg


# -- hostile input, second round ------------------------------------------------------------------------
@pytest.mark.parametrize("wavelengths", [
    [780.0, 680.0, 580.0, 480.0, 380.0],  # descending: imported with other colours
    [380.0, 480.0, 480.0, 680.0, 780.0],  # a duplicate
    [550.0],
])
def test_wavelengths_must_increase(tmp_path, wavelengths):
    wl = np.asarray(wavelengths, np.float32)
    grey = _fields()["rgb"][:, :, 1:2]
    p = tmp_path / "w.bsdf"
    rgl.write_tensor_file(p, _fields(rgb=None, wavelengths=wl, spectra=np.repeat(grey, wl.size, axis=2)))
    with pytest.raises(FormatError, match=r"w\.bsdf: 'wavelengths' must be at least 2, strictly increasing"):
        read_source(p)


def test_a_file_whose_valid_bits_are_all_zero_is_refused_like_merl_and_utia(tmp_path):
    """It imported as a table measured 0 %, exit 0."""
    p = tmp_path / "none.bsdf"
    rgl.write_tensor_file(p, _fields(valid=np.zeros(6, np.uint8)))
    with pytest.raises(FormatError, match=r"none\.bsdf: holds no measured sample \(every 'valid' bit is 0\)"):
        read_source(p)


def test_an_absurd_brdf_value_is_refused_by_the_shared_bound(tmp_path):
    need_mitsuba()
    rgb = _fields()["rgb"].copy()
    rgb[0, 1, :, 2, 2] = 1e12  # finite, within the field bound of 1e30, far beyond any BRDF
    p = tmp_path / "hot.bsdf"
    rgl.write_tensor_file(p, _fields(rgb=rgb))
    with pytest.raises(FormatError, match=r"hot\.bsdf: BRDF values \(Mitsuba's measured plug-in\) up to .*beyond 1e\+05"):
        read_source(p)
