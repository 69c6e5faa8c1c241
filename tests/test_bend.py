"""cdbrdf bend: a CDBRDF from a flat measurement, bent by a fitted fabric model.

On a real measured felt (the RGL white acrylic felt as a Neural-BRDF
network): the flat slice within 2 % (median) of the measurement, the
curvature axis with both signs, reciprocity within 0.5 % at kappa = 0.1,
energy, the provenance rules, and the fit recorded in the file (round trip
through cdbrdf.load, the recorded parameters rebuilding the model that made
the bent values). Then the other input formats (MERL, UTIA, a one-curvature
CDBRDF), the command line, and refusals.
"""

from __future__ import annotations

import functools

import numpy as np
import pytest

import cdbrdf
from cdbrdf.bend import RATIO_EPSILON, bend
from cdbrdf.errors import OptionError, TableError
from cdbrdf.importers import read_source
from cdbrdf.schema import FILL_METHOD_CODES

from .shared_data import shared_file

FELT = "nbrdf/rgl/acrylic_felt_white_rgb.h5"
KAPPA = [-0.2, 0.1, 0.2]


@functools.cache
def _bent_felt(tmp: str):
    from pathlib import Path

    path = shared_file(FELT)
    table = bend(path, model="pile", kappa=KAPPA, max_evaluations=10)  # the bending, not the fit, is tested
    out = Path(tmp) / "felt.h5"
    table.save(out)
    return path, table, cdbrdf.load(out)


@pytest.fixture(scope="module")
def felt(tmp_path_factory):
    return _bent_felt(str(tmp_path_factory.mktemp("bend")))


def test_the_flat_slice_is_the_measurement(felt):
    path, table, _ = felt
    src = read_source(path)
    i0 = int(np.flatnonzero(table.kappa == 0)[0])
    g = table.grid
    pl, tl, pv, tv = (a.ravel() for a in np.meshgrid(g.phi_l, g.theta_l, g.phi_v, g.theta_v, indexing="ij"))
    want = src.evaluate(tv, pv, tl, pl)[0]
    got = table.values[i0].reshape(-1, 3)
    low = (tv <= 70) & (tl <= 70)
    rel = np.abs(got[low] - want[low]) / want[low]
    assert np.median(rel) < 0.02, np.median(rel)
    assert table.measured[i0].all() and not table.measured[np.arange(table.kappa.size) != i0].any()


def test_the_curvature_axis_has_both_signs_and_bends(felt):
    _, table, _ = felt
    assert table.kappa.min() < 0 < table.kappa.max() and 0.0 in table.kappa
    np.testing.assert_allclose(table.kappa, [-0.2, 0.0, 0.1, 0.2])
    i0 = 1
    for i in (0, 2, 3):  # every bent slice differs from the flat one
        change = np.median(np.abs(table.values[i] / table.values[i0] - 1))
        assert change > 1e-3, (table.kappa[i], change)


def test_reciprocity_at_kappa_0_1(felt):
    _, table, _ = felt
    rng = np.random.default_rng(5)
    n = 4000
    tv, tl = rng.uniform(0, 75, n), rng.uniform(0, 75, n)
    pv, pl = rng.uniform(0, 360, n), rng.uniform(0, 360, n)
    a = table.evaluate(tv, pv, tl, pl, 0.1)
    b = table.evaluate(tl, pl, tv, pv, 0.1)
    assert np.max(np.abs(a - b) / (0.5 * (a + b))) < 0.005


def test_energy_and_the_provenance_arrays(felt):
    _, table, _ = felt
    prov = table.attrs["provenance"]["bending"]
    assert all(a <= max(1.0, prov["albedo_max"][1]) + 1e-6 for a in prov["albedo_max"])
    assert prov["albedo_limit"] >= 1.0 and all(0 < s <= 1 for s in prov["energy_scale"])
    bent = np.arange(table.kappa.size) != 1
    assert (table.fill_method[bent] == FILL_METHOD_CODES["model"]).all()
    assert (table.fill_method[1] == FILL_METHOD_CODES["measured"]).all()
    # sources: the flat sample of the same direction and of its mirror, 1/2 each
    flat = np.arange(table.measured.size).reshape(table.measured.shape)[1]
    s = table.fill_sources[2]
    np.testing.assert_array_equal(s[..., 0], flat)
    np.testing.assert_array_equal(s[..., 1], np.transpose(flat, (2, 3, 0, 1)))
    np.testing.assert_allclose(table.fill_weights[bent].sum(axis=-1), 1.0)


def test_the_fit_is_recorded_and_rebuilds_the_bent_values(felt):
    from cdbrdf.synth.pile import PileModel, PileParams

    _, table, loaded = felt
    np.testing.assert_array_equal(loaded.values, table.values)
    np.testing.assert_array_equal(loaded.fill_method, table.fill_method)
    attrs = loaded.attrs
    assert attrs["model"] == "pile" and "predicted" in attrs and "not measured" in attrs["predicted"]
    m = attrs["provenance"]["model"]
    assert set(m["values"]) == set(m["sigma"]) == set(m["bounds"])
    assert m["errors"]["test"]["pairs"] == 512 and m["errors"]["test"]["delta_e_median"] >= 0
    assert attrs["provenance"]["flat"]["source"]["format"] == "nbrdf"
    # the recorded parameters rebuild the model; flat x its ratio, mirrored, is the bent slice
    model = PileModel(PileParams(**{k: tuple(v) if isinstance(v, list) else v for k, v in m["model_params"].items()}))
    mt = model.tabulate(loaded.grid).values.astype(np.float64)
    eps = RATIO_EPSILON * mt[1].reshape(-1, 3).mean(axis=0)
    flat = loaded.values[1].astype(np.float64)
    for i in (0, 2, 3):
        r = (mt[i] + eps) / (mt[1] + eps)
        want = 0.5 * (flat * r + np.transpose(flat * r, (2, 3, 0, 1, 4)))
        want *= attrs["provenance"]["bending"]["energy_scale"][i]
        np.testing.assert_allclose(loaded.values[i], want, rtol=2e-5)


def test_other_formats_bend(tmp_path):
    from cdbrdf import materials
    from cdbrdf.importers import import_brdf

    from .import_helpers import write_merl, write_utia

    merl = write_merl(tmp_path / "lobe.binary")
    utia = write_utia(tmp_path / "m.bin")
    one = tmp_path / "flat.h5"
    materials.load("denim").brdf(0.0).save(one)
    for src in (merl, utia, one):
        t = bend(src, model="pile", kappa=[-0.1, 0.1], grid="regular:30,60", max_evaluations=8)
        assert t.kappa.tolist() == [-0.1, 0.0, 0.1] and t.shape[1:5] == (6, 3, 6, 3)
        assert np.isfinite(t.values).all() and t.attrs["provenance"]["flat"]["source"]["file_name"] == src.name
    # a one-curvature table at kappa != 0 is not a flat measurement
    bent_one = tmp_path / "stand.h5"
    import_brdf(one, grid="native", kappa=0.13).save(bent_one)
    with pytest.raises(TableError, match="holds curvature 0.13 1/mm; bend needs a flat measurement"):
        bend(bent_one, model="pile")


@pytest.mark.slow
def test_auto_fits_both_models_and_keeps_the_better(tmp_path):
    path = shared_file(FELT)
    t = bend(path, kappa=[-0.22, 0.1, 0.22])
    prov = t.attrs["provenance"]
    assert set(prov["candidates"]) == {"woven", "pile"}
    best = min(prov["candidates"], key=lambda m: prov["candidates"][m]["delta_e_median"])
    assert t.attrs["model"] == best == prov["model"]["model"]
    rng = np.random.default_rng(2)
    tv, tl = rng.uniform(0, 75, 2000), rng.uniform(0, 75, 2000)
    pv, pl = rng.uniform(0, 360, 2000), rng.uniform(0, 360, 2000)
    a, b = t.evaluate(tv, pv, tl, pl, 0.1), t.evaluate(tl, pl, tv, pv, 0.1)
    assert np.max(np.abs(a - b) / (0.5 * (a + b))) < 0.005
    t.save(tmp_path / "felt.h5")
    assert cdbrdf.load(tmp_path / "felt.h5").attrs["provenance"]["model"] == prov["model"]


def test_bad_arguments_are_refused():
    path = shared_file(FELT)
    with pytest.raises(OptionError, match="'knit' is not one of auto, woven, pile"):
        bend(path, model="knit")
    with pytest.raises(TableError, match="kappa: must be finite"):
        bend(path, model="pile", kappa=[0.1, float("nan")])
    with pytest.raises(OptionError, match="kappa: -0.9 1/mm cannot bend the pile model: .*concave bend tighter"):
        bend(path, model="pile", kappa=[-0.9, 0.1])


def test_the_command_line(tmp_path, capsys, monkeypatch):
    import shutil

    from cdbrdf.cli import main
    from cdbrdf.fit.models import PileFit

    monkeypatch.setattr(PileFit, "max_evaluations", 8)  # the command, not the fit (since pile 2.0, ~2 s each)

    path = shared_file(FELT)
    out = tmp_path / "felt.h5"
    assert main(["bend", str(path), "-o", str(out), "--model", "pile", "--kappa=-0.1,0.1", "--grid",
                 "regular:30,60"]) == 0
    said = capsys.readouterr().out
    assert "bent by the pile model" in said and "kappa -0.1, 0, 0.1 1/mm" in said
    assert cdbrdf.load(out).attrs["model"] == "pile"
    # the other half of the network's pair is an input: never overwritten
    pair = tmp_path / "pair"
    pair.mkdir()
    for suffix in (".h5", ".json"):
        shutil.copy(path.with_suffix(suffix), pair / f"felt{suffix}")
    before = (pair / "felt.h5").read_bytes()
    assert main(["bend", str(pair / "felt.json"), "-o", str(pair / "felt.h5")]) == 2
    err = capsys.readouterr().err
    assert "is the input" in err and err.count("\n") == 1 and (pair / "felt.h5").read_bytes() == before
