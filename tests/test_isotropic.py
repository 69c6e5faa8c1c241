"""The isotropic table layout: the grid, the table, the file (format 1.2), xarray and the lookup's pole rule.

An isotropic table (``symmetry = "isotropic"``) has ``phi_l = [0]`` and stores
the azimuth difference ``phi_v - phi_l`` on its ``phi_v`` axis; the lookup
rotates every query (the conformance suite, ``tests/test_lookup_conformance.py``,
runs every implementation on isotropic tables too).
"""

from __future__ import annotations

import json

import h5py
import numpy as np
import pytest

import cdbrdf
from cdbrdf import CDBRDF, FormatError, Grid, TableError
from cdbrdf.schema import FORMAT_VERSION, SYMMETRIES

from .conftest import make_table


def _iso_grid(**kw) -> Grid:
    return Grid.regular(theta_step_deg=15.0, phi_step_deg=30.0, kappa=[0.0], symmetry="isotropic", **kw)


def test_isotropic_grid_has_one_light_azimuth():
    g = _iso_grid()
    assert g.isotropic and g.symmetry == "isotropic"
    assert g.phi_l.tolist() == [0.0] and g.phi_v.size == 12
    assert g.shape == (1, 1, 6, 12, 6)
    assert g != Grid(**g.axes())  # the same axes read anisotropically are another grid
    assert "symmetry='isotropic'" in repr(g)
    assert Grid.paper(symmetry="isotropic").shape == (5, 1, 6, 12, 6)
    assert SYMMETRIES == ("anisotropic", "isotropic")


@pytest.mark.parametrize("phi_l", [[0.0, 180.0], [30.0]])
def test_isotropic_grid_refuses_other_light_azimuths(phi_l):
    with pytest.raises(TableError, match=r"phi_l: an isotropic grid has the single light azimuth \[0\]"):
        Grid(kappa=[0.0], theta_l=[0.0, 30.0], phi_l=phi_l, theta_v=[0.0, 30.0], phi_v=[0.0, 180.0],
             symmetry="isotropic")


def test_unknown_symmetry_is_refused_with_the_choices():
    with pytest.raises(TableError, match="symmetry: 'bilateral' is not one of anisotropic, isotropic"):
        Grid.paper(symmetry="bilateral")
    g = _iso_grid()
    with pytest.raises(TableError, match=r"attrs\['symmetry'\]: 'iso' is not one of anisotropic, isotropic"):
        CDBRDF(np.ones(g.shape + (3,)), g, attrs={"symmetry": "iso"})
    with pytest.raises(TableError, match="symmetry: 'isotropic' disagrees with attrs"):
        CDBRDF(np.ones(g.shape + (3,)), **g.axes(), symmetry="isotropic", attrs={"symmetry": "anisotropic"})


def test_table_symmetry_lives_in_its_attributes():
    g = _iso_grid()
    t = make_table(g, seed=1)
    assert t.isotropic and t.symmetry == "isotropic" and t.attrs["symmetry"] == "isotropic"
    assert t.grid == g
    # from the attributes alone (as the file and xarray give it)
    again = CDBRDF(t.values, g, attrs=t.attrs)
    assert again == t and again.isotropic
    # operations keep it
    assert t.with_attrs(material="x").isotropic and t.brdf().isotropic
    with pytest.raises(TableError, match="disagrees"):
        t.with_attrs(symmetry="anisotropic")
    # an anisotropic table does not gain the attribute
    a = make_table(Grid.paper(), seed=2)
    assert a.symmetry == "anisotropic" and "symmetry" not in a.attrs


def test_isotropic_file_round_trip_and_global_attribute(tmp_path):
    t = make_table(_iso_grid(), seed=3, attrs={"material": "iso", "quantity": "brdf"})
    p = tmp_path / "iso.h5"
    t.save(p)
    back = cdbrdf.load(p)
    assert back == t and back.isotropic
    with h5py.File(p, "r") as f:
        assert f.attrs["symmetry"] == "isotropic"
        assert f.attrs["format_version"] == FORMAT_VERSION == "1.5"
    ds = t.to_xarray()
    assert ds.attrs["symmetry"] == "isotropic"
    assert CDBRDF.from_xarray(ds) == t


def test_file_with_an_unknown_symmetry_is_refused(tmp_path):
    t = make_table(_iso_grid(), seed=4)
    p = tmp_path / "bad.h5"
    t.save(p)
    with h5py.File(p, "r+") as f:
        attrs = json.loads(f.attrs["cdbrdf_attrs"])
        attrs["symmetry"] = "mirror"
        text = json.dumps(attrs, sort_keys=True)
        f.attrs["cdbrdf_attrs"] = text
        f.attrs["symmetry"] = "mirror"
        del f.attrs["cdbrdf_sha256"]
    with pytest.raises(FormatError, match=r"bad\.h5: attrs\['symmetry'\]: 'mirror' is not one of"):
        cdbrdf.load(p)


def test_isotropic_lookup_is_the_difference_of_the_azimuths():
    g = _iso_grid()
    t = make_table(g, seed=5)
    v = t.values[0, 0]  # (theta_l, dphi, theta_v, c)
    # at stored elevations above 0 and a stored difference, any pair of azimuths with that difference
    for pl in (0.0, 33.0, -170.0, 400.0):
        got = t.evaluate(45.0, pl + 60.0, 30.0, pl)
        np.testing.assert_allclose(got, v[2, 2, 3], rtol=1e-12)
    # halfway between two differences: the mean
    np.testing.assert_allclose(t.evaluate(45.0, 100.0 + 75.0, 30.0, 100.0), 0.5 * (v[2, 2, 3] + v[2, 3, 3]),
                               rtol=1e-12)


def test_isotropic_pole_rule_light_along_the_normal():
    """theta_l = 0: the light pole holds, per view elevation, the mean over the azimuth difference ring."""
    t = make_table(_iso_grid(), seed=6)
    v = t.values[0, 0].astype(np.float64)
    want = v[0, :, 3].mean(axis=0)  # theta_l = 0, all differences, theta_v = 45
    got = t.evaluate(45.0, np.linspace(-360, 360, 25), 0.0, np.linspace(500, -50, 25))
    assert np.all(got == got[0])
    np.testing.assert_allclose(got[0], want, rtol=1e-12)
    # and the view pole: the mean over the same ring at theta_v = 0
    got_v = t.evaluate(0.0, np.linspace(-360, 360, 25), 30.0, 17.0)
    assert np.all(got_v == got_v[0])
    np.testing.assert_allclose(got_v[0], v[2, :, 0].mean(axis=0), rtol=1e-12)
