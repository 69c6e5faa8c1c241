"""The CD-BTF: texel lookup, compression to an error target, the file."""

from __future__ import annotations

import h5py
import numpy as np
import pytest

import cdbrdf
from cdbrdf import CDBRDF, CDBTF, Grid
from cdbrdf.btf import is_btf, load
from cdbrdf.errors import FormatError, QueryError, TableError

GRID = Grid.regular(theta_step_deg=30, phi_step_deg=90, kappa=[-0.2, 0.0, 0.2])
REPEAT = (2.0, 1.5)


def _dense(rank=2, noise=0.0, nv=6, nu=8, seed=1):
    """Texels of an exact low rank (plus optional noise): (nv, nu) + grid + (3,)."""
    rng = np.random.default_rng(seed)
    base = 0.2 + rng.random(GRID.shape + (3,))
    comps = rng.standard_normal((rank,) + GRID.shape + (3,))
    w = rng.standard_normal((nv, nu, rank))
    vals = base[None, None] + 0.1 * np.einsum("vur,r...->vu...", w, comps)
    return vals + noise * rng.standard_normal(vals.shape)


def _dense_lookup(vals, u, v, tv, pv, tl, pl, k):
    """Reference: each texel's own CDBRDF looked up, combined by periodic bilinear weights written out."""
    nv, nu = vals.shape[:2]
    tables = [[CDBRDF(vals[j, i], GRID) for i in range(nu)] for j in range(nv)]
    fu = np.mod(u, REPEAT[0]) / REPEAT[0] * nu - 0.5
    fv = np.mod(v, REPEAT[1]) / REPEAT[1] * nv - 0.5
    i0, j0 = int(np.floor(fu)), int(np.floor(fv))
    a, b = fu - i0, fv - j0
    out = 0.0
    for dj, wj in ((0, 1 - b), (1, b)):
        for di, wi in ((0, 1 - a), (1, a)):
            out = out + wj * wi * tables[(j0 + dj) % nv][(i0 + di) % nu].evaluate(tv, pv, tl, pl, k)
    return out


@pytest.fixture(scope="module")
def exact():
    vals = _dense()
    return vals, CDBTF.from_values(vals, GRID, repeat_mm=REPEAT, max_error=1e-4)


def test_exact_rank_is_found_and_texels_are_reproduced(exact):
    vals, btf = exact
    assert btf.rank == 2
    assert btf.texels == (8, 6) and btf.repeat_mm == REPEAT
    np.testing.assert_allclose(btf.decode(), vals, rtol=1e-5, atol=1e-5)
    assert btf.compression["relative_rms_error"] < 1e-5


def test_evaluate_at_texel_centres_and_nodes_gives_the_samples(exact):
    vals, btf = exact
    cu, cv = btf.texel_centres_mm()
    got = btf.evaluate(cu[3], cv[2], 30.0, 90.0, 60.0, 180.0, 0.2)
    # values axes: (v, u, kappa, phi_l, theta_l, phi_v, theta_v, channel)
    np.testing.assert_allclose(got, vals[2, 3, 2, 2, 2, 1, 1], rtol=1e-5)


def test_evaluate_is_periodic_and_bilinear_between_centres(exact):
    vals, btf = exact
    cu, cv = btf.texel_centres_mm()
    q = (30.0, 90.0, 60.0, 180.0, 0.0)
    a = btf.evaluate(cu[0], cv[0], *q)
    np.testing.assert_allclose(btf.evaluate(cu[0] + 3 * REPEAT[0], cv[0] - 2 * REPEAT[1], *q), a, rtol=1e-6)
    # half way between the last and the first centre along u: across the seam of the repeat
    mid = btf.evaluate(0.0, cv[0], *q)
    np.testing.assert_allclose(mid, 0.5 * (vals[0, 0, 1, 2, 2, 1, 1] + vals[0, -1, 1, 2, 2, 1, 1]), rtol=1e-5)


def test_evaluate_equals_each_texels_own_table_at_random_queries(exact):
    vals, btf = exact
    rng = np.random.default_rng(7)
    for _ in range(20):
        q = (rng.uniform(-5, 5), rng.uniform(-5, 5), rng.uniform(0, 90), rng.uniform(0, 360), rng.uniform(0, 90),
             rng.uniform(0, 360), rng.uniform(-0.3, 0.3))
        np.testing.assert_allclose(btf.evaluate(*q), _dense_lookup(vals, *q), rtol=1e-5, atol=1e-6)


def test_evaluate_broadcasts_and_gives_nan_for_non_finite_positions(exact):
    _, btf = exact
    out = btf.evaluate(np.zeros((4, 1)), np.array([0.0, np.nan]), 30.0, 0.0, 30.0, 180.0)
    assert out.shape == (4, 2, 3)
    assert np.all(np.isfinite(out[:, 0])) and np.all(np.isnan(out[:, 1]))
    with pytest.raises(QueryError, match="theta_v"):
        btf.evaluate(0.0, 0.0, 95.0, 0.0, 30.0, 0.0)


def test_mean_is_the_tile_average(exact):
    vals, btf = exact
    m = btf.mean()
    assert isinstance(m, CDBRDF)
    np.testing.assert_allclose(m.values, vals.mean(axis=(0, 1)), rtol=1e-5)
    cu, cv = btf.texel_centres_mm()
    U, V = np.meshgrid(cu, cv)
    avg = btf.evaluate(U, V, 40.0, 100.0, 20.0, 250.0, 0.1).mean(axis=(0, 1))
    np.testing.assert_allclose(avg, m.evaluate(40.0, 100.0, 20.0, 250.0, 0.1), rtol=1e-5)


def test_rank_follows_the_error_target_and_the_recorded_errors_are_true():
    vals = _dense(rank=6, noise=0.002)
    ranks = []
    for target in (0.2, 0.05, 0.01):
        btf = CDBTF.from_values(vals, GRID, repeat_mm=REPEAT, max_error=target)
        c = btf.compression
        err = btf.decode() - vals
        true = np.sqrt(np.sum(err ** 2) / np.sum(vals ** 2))
        per_k = np.sqrt(np.sum(err ** 2, axis=(0, 1, 3, 4, 5, 6, 7)) / np.sum(vals ** 2, axis=(0, 1, 3, 4, 5, 6, 7)))
        assert c["relative_rms_error"] == pytest.approx(true, rel=1e-3, abs=1e-6)
        np.testing.assert_allclose(c["relative_rms_error_per_kappa"], per_k, rtol=1e-3, atol=1e-6)
        assert true <= target and np.all(per_k <= target)
        if btf.rank:  # the rank is the smallest that meets the target
            less = CDBTF.from_values(vals, GRID, repeat_mm=REPEAT, max_error=target, max_rank=btf.rank - 1)
            lc = less.compression
            assert max(lc["relative_rms_error"], *lc["relative_rms_error_per_kappa"]) > target
        ranks.append(btf.rank)
        assert c["compression_ratio"] == pytest.approx(btf.nbytes_ratio())
    assert ranks == sorted(ranks) and ranks[0] < ranks[-1]


def test_file_round_trip_and_the_tile_mean_is_a_cdbrdf_file(exact, tmp_path):
    _, btf = exact
    path = tmp_path / "b.h5"
    btf.save(path)
    assert is_btf(path)
    back = load(path)
    np.testing.assert_array_equal(back.weights, btf.weights)
    np.testing.assert_array_equal(back.basis, btf.basis)
    assert back.mean() == btf.mean()
    assert back.repeat_mm == btf.repeat_mm
    assert back.compression == btf.compression
    assert cdbrdf.load(path) == btf.mean()
    with h5py.File(path, "r") as f:
        assert f.attrs["format_version"] == "1.5"


def test_damaged_or_plain_files_are_refused(exact, tmp_path):
    _, btf = exact
    plain = tmp_path / "plain.h5"
    btf.mean().save(plain)
    assert not is_btf(plain)
    with pytest.raises(FormatError, match="without the CD-BTF variables"):
        load(plain)
    path = tmp_path / "b.h5"
    btf.save(path)
    with h5py.File(path, "r+") as f:
        f["btf_weights"][0, 0, 0] = f["btf_weights"][0, 0, 0] + 1.0
    with pytest.raises(FormatError, match="checksum mismatch"):
        load(path)


@pytest.mark.parametrize(("kwargs", "match"), [
    ({"max_error": 1.5}, "max_error"),
    ({"max_error": "0.1"}, "max_error"),
    ({"max_rank": -1}, "max_rank"),
    ({"repeat_mm": (1.0, 0.0)}, "repeat_mm"),
])
def test_bad_options_are_one_line_errors(kwargs, match):
    args = {"repeat_mm": REPEAT, **kwargs}
    with pytest.raises(TableError, match=match):
        CDBTF.from_values(_dense(nv=2, nu=2), GRID, **args)


def test_bad_shapes_are_refused():
    with pytest.raises(TableError, match="values"):
        CDBTF.from_values(np.zeros((2, 2) + GRID.shape), GRID, repeat_mm=REPEAT)
    m = CDBRDF(np.ones(GRID.shape + (3,)), GRID)
    with pytest.raises(TableError, match="basis"):
        CDBTF(m, np.zeros((2, 2, 1)), np.zeros(GRID.shape + (2, 3)), repeat_mm=REPEAT)


def test_uniform_texels_have_rank_zero_and_round_trip(tmp_path):
    vals = np.broadcast_to(_dense(nv=1, nu=1)[0, 0], (3, 4) + GRID.shape + (3,))
    btf = CDBTF.from_values(vals, GRID, repeat_mm=REPEAT, max_error=0.0)
    assert btf.rank == 0 and btf.compression["relative_rms_error"] < 1e-9
    np.testing.assert_allclose(btf.evaluate(0.3, 1.1, 30.0, 10.0, 45.0, 200.0, 0.1),
                               btf.mean().evaluate(30.0, 10.0, 45.0, 200.0, 0.1), rtol=1e-6)
    btf.save(tmp_path / "u.h5")
    back = load(tmp_path / "u.h5")
    assert back.rank == 0 and back.texels == (4, 3) and back.mean() == btf.mean()


def _errors(vals, btf):
    """Relative RMS error of the decoded texels against ``vals``: whole and per kappa."""
    d = btf.decode().astype(np.float64) - vals
    whole = np.sqrt(np.sum(d**2) / np.sum(vals**2))
    per_k = np.sqrt(np.sum(np.moveaxis(d, 2, 0).reshape(vals.shape[2], -1) ** 2, axis=1)
                    / np.sum(np.moveaxis(vals, 2, 0).reshape(vals.shape[2], -1) ** 2, axis=1))
    return whole, per_k


def test_truncation_records_its_true_errors(tmp_path):
    """The leading components of a PCA: the errors of the truncation are those against the texels."""
    vals = _dense(rank=5, noise=0.01, seed=4)
    full = CDBTF.from_values(vals, GRID, repeat_mm=REPEAT, max_error=0.02)
    assert 5 <= full.rank < 47
    for r in (0, 2, 4):
        t = full.truncated(r)
        assert t.rank == r and t.mean() is full.mean()
        whole, per_k = _errors(vals, t)
        c = t.compression
        assert c["relative_rms_error"] == pytest.approx(whole, rel=1e-4)
        np.testing.assert_allclose(c["relative_rms_error_per_kappa"], per_k, rtol=1e-4)
        assert c["truncated_from"] == full.rank and c["max_error"] == 0.02
        assert c["compression_ratio"] == pytest.approx(t.nbytes_ratio()) and t.nbytes_ratio() > full.nbytes_ratio()
        np.testing.assert_array_equal(t.weights, full.weights[..., :r])
    assert full.truncated(full.rank) is full
    t = full.truncated(3)
    t.save(tmp_path / "t.h5")
    back = load(tmp_path / "t.h5")
    assert back.compression["truncated_from"] == full.rank and back.rank == 3
    assert back.compression["relative_rms_error"] == pytest.approx(t.compression["relative_rms_error"])
    # truncating a truncation counts from the first factorisation
    assert back.truncated(1).compression["truncated_from"] == full.rank
    assert back.truncated(1).compression["relative_rms_error"] == pytest.approx(_errors(vals, full.truncated(1))[0],
                                                                                rel=1e-4)


@pytest.mark.parametrize("rank", [-1, 99, 1.5, True, "2"])
def test_truncation_to_a_bad_rank_is_refused(exact, rank):
    with pytest.raises(TableError, match=r"rank: expected an integer in \[0, 2\]"):
        exact[1].truncated(rank)


def test_the_provenance_reaches_the_tile_mean():
    """A measured CD-BTF's mask and fill provenance (one Provenance record) go to its tile mean."""
    from cdbrdf.provenance import Provenance

    vals = _dense()
    measured = np.ones(GRID.shape, bool)
    measured[:, :, -1] = False  # the most grazing light elevation: filled
    src = np.where(measured, -1, 0)
    btf = CDBTF.from_values(vals, GRID, repeat_mm=REPEAT, provenance=Provenance(measured=measured, fill_source=src))
    np.testing.assert_array_equal(btf.mean().measured, measured)
    np.testing.assert_array_equal(btf.mean().fill_source, src)
    with pytest.raises(TableError, match="^provenance: expected a cdbrdf.provenance.Provenance, got dict$"):
        CDBTF.from_values(vals, GRID, repeat_mm=REPEAT, provenance={"measured": measured})  # type: ignore[arg-type]


# -- the neural CD-BTF (schema 2) -----------------------------------------------------------------
def _fit():
    from cdbrdf.btf._neural import FitOptions

    return FitOptions(steps=40, latent_dims=4, hidden=(16, 12), samples_per_batch=256, texels_per_batch=32)


@pytest.fixture(scope="module")
def neural():
    vals = _dense(rank=4, noise=0.01)
    return vals, CDBTF.from_values(vals, GRID, repeat_mm=REPEAT, method="neural", max_error=0.9, fit=_fit())


def _true_errors(vals, btf):
    err = btf.decode() - vals
    axes = (0, 1, 3, 4, 5, 6, 7)
    return (float(np.sqrt(np.sum(err ** 2) / np.sum(vals ** 2))),
            np.sqrt(np.sum(err ** 2, axis=axes) / np.sum(vals ** 2, axis=axes)))


def test_neural_records_its_true_errors_and_a_ratio_from_its_stored_sizes(neural):
    vals, btf = neural
    c = btf.compression
    assert btf.method == "neural" and btf.rank == 0 and c["method"] == "neural"
    true, per_k = _true_errors(vals, btf)
    assert c["relative_rms_error"] == pytest.approx(true, rel=1e-3)
    np.testing.assert_allclose(c["relative_rms_error_per_kappa"], per_k, rtol=1e-3)
    assert c["neural_relative_rms_error"] == pytest.approx(true, rel=1e-3)
    assert 0.0 < true < 0.9  # the fit learnt something: less than the tile mean alone
    mean_only = np.sqrt(np.sum((vals - vals.mean(axis=(0, 1))) ** 2) / np.sum(vals ** 2))
    assert true < mean_only
    net = btf.neural
    raw = 4 * vals.size
    stored = 2 * btf.mean().values.size + 2 * net.n_latent_values + 4 * net.n_parameters
    assert c["compression_ratio"] == pytest.approx(raw / stored)
    # the tile mean is the texels' mean, in float16 numbers
    np.testing.assert_allclose(btf.mean().values, vals.mean(axis=(0, 1)), rtol=1e-3)
    assert np.array_equal(btf.mean().values, btf.mean().values.astype(np.float16).astype(np.float32))


def test_neural_meets_the_error_target_with_residual_components():
    vals = _dense(rank=4, noise=0.01)
    for target in (0.05, 0.01):
        btf = CDBTF.from_values(vals, GRID, repeat_mm=REPEAT, method="neural", max_error=target, fit=_fit())
        true, per_k = _true_errors(vals, btf)
        c = btf.compression
        assert true <= target and np.all(per_k <= target) and btf.rank > 0
        assert c["relative_rms_error"] == pytest.approx(true, rel=1e-3, abs=1e-6)
        assert c["neural_relative_rms_error"] > target
        # the decoder plus residual components, or the PCA alone where that takes fewer bytes
        pca = CDBTF.from_values(vals, GRID, repeat_mm=REPEAT, method="pca", max_error=target)
        assert btf.nbytes_ratio() >= pca.nbytes_ratio()
        assert btf.method == ("pca" if btf.neural is None else "neural")


def test_neural_evaluate_decodes_the_nodes_and_is_the_tile_mean_from_far_away(neural):
    vals, btf = neural
    d = btf.decode()
    cu, cv = btf.texel_centres_mm()
    # at a texel centre and grid nodes: the decoded sample (footprint 0: the texel itself)
    np.testing.assert_allclose(btf.evaluate(cu[3], cv[2], 30.0, 90.0, 60.0, 180.0, 0.2), d[2, 3, 2, 2, 2, 1, 1],
                               rtol=1e-5)
    rng = np.random.default_rng(3)
    q = (rng.uniform(-5, 5, 200), rng.uniform(-5, 5, 200), rng.uniform(0, 90, 200), rng.uniform(0, 360, 200),
         rng.uniform(0, 90, 200), rng.uniform(0, 360, 200), rng.uniform(-0.3, 0.3, 200))
    far = btf.evaluate(*q, footprint_mm=10 * max(REPEAT))
    np.testing.assert_allclose(far, btf.mean().evaluate(*q[2:]), rtol=1e-12)
    near = btf.evaluate(*q)
    assert np.abs(near - far).max() > 1e-3  # up close the texels differ from the mean
    # between: a footprint of a few texels averages the codes; the values stay between near and far in the mean
    mid = btf.evaluate(*q, footprint_mm=2 * REPEAT[0] / 8)
    assert np.all(np.isfinite(mid))
    assert np.abs(mid - far).mean() < np.abs(near - far).mean()


def test_neural_file_round_trip_is_schema_2_and_a_newer_schema_is_refused(neural, tmp_path):
    _, btf = neural
    path = tmp_path / "n.h5"
    btf.save(path)
    with h5py.File(path, "r") as f:
        assert np.asarray(f.attrs["btf_format_version"]).item() == 2
        assert "btf_rank" not in f.attrs and np.asarray(f.attrs["btf_residual_rank"]).item() == 0
        assert f["btf_latents"].dtype == np.float16 and f["btf_decoder"].dtype == np.float32
    back = load(path)
    assert back.method == "neural" and back.texels == btf.texels
    np.testing.assert_array_equal(back.decode(), btf.decode())
    assert back.compression["relative_rms_error"] == pytest.approx(btf.compression["relative_rms_error"])
    assert cdbrdf.load(path) == btf.mean()
    with h5py.File(path, "r+") as f:
        f.attrs["btf_format_version"] = np.int64(3)
    with pytest.raises(FormatError, match="schema 3"):
        load(path)
    btf.save(path)
    with h5py.File(path, "r+") as f:
        f.attrs["btf_decoder_layers"] = np.array([9, 16, 3], dtype=np.int64)
    with pytest.raises(FormatError, match="btf_decoder_layers"):
        load(path)


def test_pca_weights_are_filtered_by_the_footprint(exact):
    vals, btf = exact
    rng = np.random.default_rng(4)
    u, v = rng.uniform(-5, 5, 50), rng.uniform(-5, 5, 50)
    np.testing.assert_allclose(btf.texel_weights(u, v, 0.0), btf.texel_weights(u, v))
    assert np.all(btf.texel_weights(u, v, 20.0) == 0.0)  # from the repeat's size on: the tile mean
    far = btf.evaluate(u, v, 30.0, 90.0, 60.0, 180.0, 0.1, footprint_mm=20.0)
    np.testing.assert_allclose(far, np.broadcast_to(btf.mean().evaluate(30.0, 90.0, 60.0, 180.0, 0.1), far.shape))
    # one level up: the weights of 2 x 2 blocks of texels, at their centres
    from cdbrdf.btf._neural import block_means

    w1 = block_means(btf.weights, (3, 4))
    su, sv = REPEAT
    got = btf.texel_weights((0 + 0.5) * su / 4, (1 + 0.5) * sv / 3, 2.0 * su / 8)
    np.testing.assert_allclose(got, w1[1, 0], rtol=1e-5, atol=1e-7)


def test_neural_residual_components_meet_the_target_and_their_errors_are_true():
    """The decoder plus residual components (what from_values keeps where it takes fewer bytes than a PCA)."""
    from cdbrdf.btf._neural import compress

    vals = _dense(rank=4, noise=0.01)
    m, net, res, comp = compress(vals, GRID, max_error=0.02, max_rank=64, options=_fit())
    btf = CDBTF(CDBRDF(m, GRID), res.weights.reshape(6, 8, -1),
                np.moveaxis(res.basis.reshape((-1,) + GRID.shape + (3,)), 0, -2), repeat_mm=REPEAT,
                compression=comp, neural=net)
    true, per_k = _true_errors(vals, btf)
    assert btf.rank > 0 and comp["neural_relative_rms_error"] > 0.02
    assert true <= 0.02 and np.all(per_k <= 0.02)
    assert comp["relative_rms_error"] == pytest.approx(true, rel=1e-3, abs=1e-6)
    np.testing.assert_allclose(comp["relative_rms_error_per_kappa"], per_k, rtol=1e-3, atol=1e-6)
