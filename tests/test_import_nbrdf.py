"""Neural-BRDF networks (Keras JSON + HDF5 pairs) through the reader and the import.

Known answers: the network evaluated here from the published encoding,
written again from the authors' C++ plug-in (``nbrdf_npy.cpp``: ``io_to_hd``
with ``rotate_vector`` (Rodrigues' formula) and ``xyz_to_theta_phi`` of
``dj_brdf.h``, ``Net::forward`` of ``nn.h``), in float32 as the plug-in
computes, with the weights read straight from the file by h5py; reciprocity of
the import; the white MERL fabric brighter than the black; format detection;
bad pairs refused in one line naming the file.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from cdbrdf import FormatError
from cdbrdf.colour import luminance
from cdbrdf.importers import detect_format, import_brdf, nbrdf, read_source

from .shared_data import shared_file

FELT = "nbrdf/rgl/acrylic_felt_white_rgb.h5"


# -- the published encoding, written again from the C++ source -------------------------------------------------
def _rotate_vector(x, axis, angle):
    """dj_brdf.h rotate_vector: Rodrigues' rotation of x about a unit axis."""
    c, s = np.float32(np.cos(angle)), np.float32(np.sin(angle))
    return c * x + axis * (np.dot(axis, x) * (np.float32(1.0) - c)) + s * np.cross(axis, x)


def _xyz_to_theta_phi(p):
    if p[2] > 0.99999:
        return np.float32(0.0), np.float32(0.0)
    if p[2] < -0.99999:
        return np.float32(np.pi), np.float32(0.0)
    return np.float32(np.arccos(p[2])), np.float32(np.arctan2(p[1], p[0]))


def _cpp_input(wi, wo):
    """nbrdf_npy::eval: o = bRec.wi (the view), i = bRec.wo (the light); io_to_hd(i, o)."""
    i, o = wo, wi
    h = (i + o) / np.linalg.norm(i + o)
    theta_h, phi_h = _xyz_to_theta_phi(h)
    tmp = _rotate_vector(i, np.array([0, 0, 1], np.float32), -phi_h)
    d = _rotate_vector(tmp, np.array([0, 1, 0], np.float32), -theta_h)
    d = d / np.linalg.norm(d)
    return np.array([np.sin(theta_h), 0.0, np.cos(theta_h), d[0], d[1], d[2]], dtype=np.float32)


def _cpp_forward(weights, x):
    """nn.h Net::forward: relu, relu, then max(exp(a3 + b3) - 1, 0), in float32."""
    (w1, b1), (w2, b2), (w3, b3) = weights
    a1 = np.maximum(x @ w1 + b1, np.float32(0))
    a2 = np.maximum(a1 @ w2 + b2, np.float32(0))
    return np.maximum(np.exp(a2 @ w3 + b3) - np.float32(1), np.float32(0))


def _weights_h5py(path):
    import h5py

    with h5py.File(path, "r") as f:
        out = []
        for name in f.attrs["layer_names"]:
            g = f[name]
            names = list(g.attrs["weight_names"])
            if names:
                out.append(tuple(np.asarray(g[n], dtype=np.float32) for n in names))
    return out


def _unit(theta_deg, phi_deg):
    t, p = np.radians(theta_deg), np.radians(phi_deg)
    return np.array([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], dtype=np.float32)


DIRECTIONS = [  # (theta_v, phi_v, theta_l, phi_l), degrees
    (0.0, 0.0, 0.0, 0.0), (30.0, 0.0, 30.0, 180.0), (45.0, 90.0, 20.0, 200.0), (60.0, 10.0, 60.0, 10.0),
    (70.0, 300.0, 15.0, 45.0), (10.0, 123.0, 80.0, 250.0), (50.0, 0.0, 50.0, 90.0), (85.0, 180.0, 5.0, 0.0),
]


def test_the_import_matches_the_published_encoding():
    path = shared_file(FELT)
    weights = _weights_h5py(path)
    src = read_source(path)
    tv, pv, tl, pl = (np.array(c) for c in zip(*DIRECTIONS))
    got, measured = src.evaluate(tv, pv, tl, pl)
    assert measured is None and got.shape == (len(DIRECTIONS), 3)
    raw = np.array([_cpp_forward(weights, _cpp_input(_unit(a, b), _unit(c, d))) for a, b, c, d in DIRECTIONS])
    swapped = np.array([_cpp_forward(weights, _cpp_input(_unit(c, d), _unit(a, b))) for a, b, c, d in DIRECTIONS])
    # the reader evaluates the mean of both orders (the module's description); float32 against float64
    np.testing.assert_allclose(got, 0.5 * (raw + swapped), rtol=2e-4, atol=1e-6)
    net, details, _ = nbrdf.read_network(path)
    np.testing.assert_allclose(net.forward(nbrdf.encode(tv, pv, tl, pl)), raw, rtol=2e-4, atol=1e-6)
    assert net.sizes == (6, 21, 21, 3) and details["output_decode"] == "max(exp(y) - 1, 0)"
    # the raw network is not symmetric (that is why the mean is taken), but nearly
    assert not np.allclose(raw, swapped, rtol=1e-6)
    assert np.median(np.abs(raw - swapped) / (0.5 * (raw + swapped))) < 0.05
    # a white felt: pi f near 0.6-0.9 at moderate angles, blue-ish white as RGL measured it
    assert np.all((np.pi * got[1] > 0.5) & (np.pi * got[1] < 1.0))


def test_reciprocity_and_the_json_half_of_the_pair():
    path = shared_file(FELT)
    src = read_source(path.with_suffix(".json"))
    assert src.path == path and src.format == "nbrdf" and src.symmetry == "isotropic" and src.quantity == "brdf"
    rng = np.random.default_rng(3)
    n = 500
    tv, tl = rng.uniform(0, 89, n), rng.uniform(0, 89, n)
    pv, pl = rng.uniform(0, 360, n), rng.uniform(0, 360, n)
    a, _ = src.evaluate(tv, pv, tl, pl)
    b, _ = src.evaluate(tl, pl, tv, pv)
    np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-15)
    # isotropic: a rotation of both azimuths changes nothing (phi_h is dropped by the encoding)
    c, _ = src.evaluate(tv, pv + 77.0, tl, pl + 77.0)
    np.testing.assert_allclose(a, c, rtol=1e-9, atol=1e-12)
    assert src.details["network_asymmetry_median"] > 0


def test_white_fabric_is_brighter_than_black():
    white = read_source(shared_file("nbrdf/merl/white-fabric.h5"))
    black = read_source(shared_file("nbrdf/merl/black-fabric.h5"))
    t = np.linspace(0, 70, 15)
    tv, tl = np.meshgrid(t, t)
    args = (tv.ravel(), np.zeros(tv.size), tl.ravel(), np.full(tv.size, 180.0))
    yw, yb = luminance(white.evaluate(*args)[0]), luminance(black.evaluate(*args)[0])
    assert np.all(yw > 3 * yb)
    assert 0.05 < np.pi * np.median(yw) < 1.0 and np.pi * np.median(yb) < 0.05


def test_detection_and_import_onto_a_grid():
    path = shared_file(FELT)
    assert detect_format(path) == "nbrdf" and detect_format(path.with_suffix(".json")) == "nbrdf"
    table = import_brdf(path, grid="regular:15,30,75")
    assert table.symmetry == "isotropic" and table.quantity == "brdf"
    prov = table.attrs["provenance"]
    assert prov["source"]["format"] == "nbrdf" and prov["source"]["details"]["layers"] == [6, 21, 21, 3]
    # cell means of a smooth felt: the table at its nodes within a few % of the network
    g = table.grid
    tl, dp, tv = np.meshgrid(g.theta_l, g.phi_v, g.theta_v, indexing="ij")
    src = read_source(path)
    f = src.evaluate(tv.ravel(), dp.ravel(), tl.ravel(), np.zeros(tv.size))[0]
    t = table.evaluate(tv.ravel(), dp.ravel(), tl.ravel(), np.zeros(tv.size), 0.0)
    low = (tv.ravel() <= 60) & (tl.ravel() <= 60)
    assert np.median(np.abs(t[low] - f[low]) / f[low]) < 0.02


def test_a_written_network_round_trips(tmp_path):
    rng = np.random.default_rng(0)
    ks = [rng.normal(0, 0.3, (6, 5)), rng.normal(0, 0.3, (5, 3))]
    bs = [rng.normal(0, 0.1, 5), rng.normal(-1, 0.1, 3)]
    arch, h5 = nbrdf.write(tmp_path / "net.h5", ks, bs)
    net, _, _ = nbrdf.read_network(arch)
    assert net.sizes == (6, 5, 3) and net.activations == ("relu", "linear")
    x = nbrdf.encode(np.array([20.0]), np.array([0.0]), np.array([40.0]), np.array([180.0]))
    want = np.maximum(np.expm1(np.maximum(x @ ks[0] + bs[0], 0) @ ks[1] + bs[1]), 0)
    np.testing.assert_allclose(net.forward(x), want, rtol=1e-5)  # float32 storage


def _broken(tmp_path, what):
    rng = np.random.default_rng(1)
    ks = [rng.normal(0, 0.3, (6, 4)), rng.normal(0, 0.3, (4, 3))]
    bs = [np.zeros(4), np.zeros(3)]
    arch, h5 = nbrdf.write(tmp_path / "bad.h5", ks, bs)
    model = json.loads(arch.read_text())
    if what == "no json":
        arch.unlink()
    elif what == "tanh":
        model["config"]["layers"][0]["config"]["activation"] = "tanh"
    elif what == "lambda":
        model["config"]["layers"][-1]["config"]["function"] = ["AAAA\n", None, None]
    elif what == "conv":
        model["config"]["layers"][0]["class_name"] = "Conv2D"
    elif what == "not json":
        arch.write_text("{ nope")
    elif what == "no weights for a layer":
        model["config"]["layers"][0]["config"]["name"] = "dense_9"
    elif what == "not hdf5":
        h5.write_bytes(b"\x89HDF\r\n\x1a\n" + b"\x00" * 64)
    elif what == "outputs":
        nbrdf.write(tmp_path / "bad.h5", [ks[0], rng.normal(0, 0.3, (4, 2))], [bs[0], np.zeros(2)])
        return arch
    if what not in ("no json", "not json") and arch.exists():
        arch.write_text(json.dumps(model))
    return h5


@pytest.mark.parametrize("what, message", [
    ("no json", "missing; a Neural-BRDF network needs both"),
    ("tanh", "activation 'tanh'"),
    ("lambda", "not the published output transform"),
    ("conv", "'Conv2D' layer"),
    ("not json", "not a Keras architecture file"),
    ("no weights for a layer", "has no weights for the layer 'dense_9'"),
    ("not hdf5", "not a readable HDF5 file"),
    ("outputs", "maps 6 inputs to 2 outputs"),
])
def test_bad_pairs_are_refused_in_one_line(tmp_path, what, message):
    path = _broken(tmp_path, what)
    with pytest.raises(FormatError) as e:
        nbrdf.read(path)
    text = str(e.value)
    assert message in text and "\n" not in text and str(tmp_path) in text


def test_a_cdbrdf_file_is_not_taken_for_a_network(tmp_path):
    from cdbrdf import materials

    p = tmp_path / "denim.h5"
    materials.load("denim").brdf(0.0).save(p)
    assert detect_format(p) == "cdbrdf"
