"""Forged CD-BTF files and hostile queries (issue 38, items 4, 5, 7 and 9): one-line FormatError naming the file and
the attribute, bounded values, texel coordinates that never leave the table."""

from __future__ import annotations

import numpy as np
import pytest

from cdbrdf import CDBTF, Grid
from cdbrdf.errors import FormatError, QueryError, TableError

GRID = Grid(kappa=[-0.1, 0.0, 0.2], theta_l=[0, 40, 80], phi_l=[0, 120, 240], theta_v=[0, 40, 80],
            phi_v=[0, 120, 240])


def _values(seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return rng.uniform(0.05, 0.4, (3, 4) + GRID.shape + (3,))


@pytest.fixture(scope="module")
def pca() -> CDBTF:
    return CDBTF.from_values(_values(), GRID, repeat_mm=(2.0, 1.5), max_error=0.01)


@pytest.fixture(scope="module")
def neural() -> CDBTF:
    from cdbrdf.btf._neural import FitOptions

    return CDBTF.from_values(_values(1), GRID, repeat_mm=(2.0, 1.5), method="neural", max_error=0.9,
                             fit=FitOptions(steps=10, latent_dims=3, hidden=(8,)))


def forge(path, *, attrs=None, datasets=None, delete=(), digest=True):
    """Edit a CD-BTF file in place: global attributes, variables replaced (a group or scalar too), then a
    valid digest of the CD-BTF variables, so that only the forged content can be refused."""
    import h5py

    with h5py.File(path, "r+") as f:
        for k, v in (attrs or {}).items():
            f.attrs[k] = v
        for k in delete:
            del f.attrs[k]
        for k, v in (datasets or {}).items():
            if k in f:
                f[k].attrs.clear() if isinstance(f[k], h5py.Dataset) else None
                del f[k]
            if isinstance(v, str) and v == "group":
                f.create_group(k)
            else:
                f.create_dataset(k, data=v)
        if digest:
            f.attrs["btf_sha256"] = _digest(f)


def _digest(f):
    """The digest the reader computes (``btf.file._stored``) of what the file holds now."""
    import h5py

    from cdbrdf._fileattrs import data_digest
    from cdbrdf.btf import file as bf

    def get(n):
        ok = n in f and isinstance(f[n], h5py.Dataset) and f[n].size is not None and f[n].size <= 1 << 24
        return np.asarray(f[n][()]) if ok else None

    try:
        rep = np.asarray(f.attrs["btf_repeat_mm"], np.float64).reshape(-1)[[0, -1]]
        nu, nv = f["texel_u"].shape[0], f["texel_v"].shape[0]
        if max(nu, nv) > 1 << 20:
            raise ValueError("refused before the digest")
    except Exception:  # noqa: BLE001 - a forged layout the reader refuses before the digest
        return np.zeros(32, np.uint8)
    shape = f["reflectance"].shape
    w, b = get(bf.WEIGHTS), get(bf.BASIS)
    if w is None:
        w, b = np.zeros((nv, nu, 0), np.float32), np.zeros(shape[:-1] + (0, shape[-1]), np.float32)
    arrays = [(bf.TEXEL_U, (np.arange(nu) + 0.5) * rep[0] / nu), (bf.TEXEL_V, (np.arange(nv) + 0.5) * rep[-1] / nv),
              (bf.WEIGHTS, np.asarray(w, "<f4")), (bf.BASIS, np.asarray(b, "<f4"))]
    with np.errstate(all="ignore"):
        for n, dt in ((bf.LATENTS, "<f2"), (bf.DECODER, "<f4")):
            if get(n) is not None:
                arrays.append((n, np.asarray(get(n), dt)))
        return data_digest(arrays)


def _refused(path, *words):
    from cdbrdf.btf import load

    with pytest.raises(FormatError) as info:
        load(path)
    msg = str(info.value)
    assert "\n" not in msg and str(path) in msg, msg
    for w in words:
        assert w in msg, msg
    return msg


# -- item 4: the repeat's size ----------------------------------------------------------------------------
@pytest.mark.parametrize("repeat", [[1e-300, 1e-300], [1e-3, 1.0], [1.0, 1e6], [np.inf, 1.0], [np.nan, 1.0],
                                    [-1.0, 1.0], [0.0, 1.0], [1.0], [1.0, 1.0, 1.0]])
def test_repeat_outside_the_physical_range_is_refused(pca, tmp_path, repeat):
    p = tmp_path / "b.h5"
    pca.save(p)
    forge(p, attrs={"btf_repeat_mm": np.array(repeat, np.float64)})
    _refused(p, "btf_repeat_mm")
    with pytest.raises(TableError, match="repeat_mm"):
        CDBTF(pca.mean(), pca.weights, pca.basis, repeat_mm=repeat)


def test_repeat_at_the_ends_of_the_range_loads(pca, tmp_path):
    from cdbrdf.btf import load
    from cdbrdf.btf.file import REPEAT_MM_RANGE

    p = tmp_path / "b.h5"
    pca.save(p)
    forge(p, attrs={"btf_repeat_mm": np.array(REPEAT_MM_RANGE, np.float64)})
    assert load(p).repeat_mm == REPEAT_MM_RANGE


def test_simulate_capture_refuses_a_repeat_of_1e_300(pca, tmp_path):
    from .test_fuzz_hostile3 import _run_cli

    p = tmp_path / "b.h5"
    pca.save(p)
    forge(p, attrs={"btf_repeat_mm": np.array([1e-300, 1e-300])})
    status, err = _run_cli(["simulate-capture", str(p), "-o", str(tmp_path / "cap")])
    assert status == 2 and err.count("\n") == 1 and "btf_repeat_mm" in err, err
    assert not (tmp_path / "cap").exists()


# -- item 5: values and metadata ---------------------------------------------------------------------------
def test_weights_and_basis_of_1e20_with_a_valid_digest_are_refused(pca, tmp_path):
    p = tmp_path / "b.h5"
    pca.save(p)
    forge(p, datasets={"btf_weights": pca.weights * np.float32(1e20), "btf_basis": pca.basis * np.float32(1e20)})
    _refused(p, "btf_weights", "btf_basis", "1e+30")
    with pytest.raises(TableError, match="beyond"):
        CDBTF(pca.mean(), pca.weights * 1e20, pca.basis * 1e20, repeat_mm=(2.0, 1.5))


def test_the_value_bound_holds_for_what_loads(pca, neural):
    """The bound is a true bound: no query of random positions, footprints and directions exceeds it."""
    from cdbrdf.btf._neural import decoded_bound

    rng = np.random.default_rng(0)
    n = 4000
    for b in (pca, neural):
        bound = decoded_bound(b.mean().values, b.weights, b.basis, b.neural, GRID.kappa)
        got = b.evaluate(rng.uniform(-9, 9, n), rng.uniform(-9, 9, n), rng.uniform(0, 90, n), rng.uniform(0, 360, n),
                         rng.uniform(0, 90, n), rng.uniform(0, 360, n), rng.uniform(-0.2, 0.3, n),
                         footprint_mm=rng.uniform(0, 3, n))
        assert np.abs(got).max() <= bound < 1e3


def test_a_decoder_of_huge_weights_is_refused(neural, tmp_path):
    p = tmp_path / "n.h5"
    neural.save(p)
    import h5py

    with h5py.File(p, "r") as f:
        dec = np.asarray(f["btf_decoder"][()])
    forge(p, datasets={"btf_decoder": dec * np.float32(1e20)})
    _refused(p, "btf_decoder", "beyond")


def test_decoder_constants_that_blow_up_the_features_are_refused(neural, tmp_path):
    p = tmp_path / "n.h5"
    neural.save(p)
    forge(p, attrs={"btf_decoder_constants": np.array([1e-300, 1e-3, 0.0])})
    _refused(p, "beyond")


@pytest.mark.parametrize(("name", "value", "word"), [
    ("btf_relative_rms_error", -5.0, "btf_relative_rms_error"),
    ("btf_relative_rms_error", np.nan, "btf_relative_rms_error"),
    ("btf_relative_rms_error", 1e9, "btf_relative_rms_error"),
    ("btf_max_error", -1.0, "btf_max_error"),
    ("btf_compression_ratio", 0.0, "btf_compression_ratio"),
    ("btf_relative_rms_error_per_kappa", np.array([np.nan, 0.1, 0.1]), "btf_relative_rms_error_per_kappa"),
    ("btf_relative_rms_error_per_kappa", np.array([0.1, 0.1]), "one per curvature"),
    ("btf_truncated_from", np.int64(-7), "btf_truncated_from"),
    ("btf_truncated_from", np.int64(1), "below the rank"),
    ("btf_rank", 2.5, "btf_rank"),
    ("btf_rank", "three", "btf_rank"),
    ("btf_relative_rms_error", "0.01", "btf_relative_rms_error"),
])
def test_metadata_out_of_range_is_refused(pca, tmp_path, name, value, word):
    assert pca.rank >= 2
    p = tmp_path / "b.h5"
    pca.save(p)
    forge(p, attrs={name: value})
    _refused(p, word)


def test_metadata_in_range_loads_and_truncated_keeps_it(pca, tmp_path):
    from cdbrdf.btf import load

    p = tmp_path / "b.h5"
    pca.truncated(1).save(p)
    b = load(p)
    assert b.compression["truncated_from"] == pca.rank and b.rank == 1
    assert 0 <= b.compression["relative_rms_error"] < 1


# -- item 7: empty attributes, a group for an axis ------------------------------------------------------
@pytest.mark.parametrize("name", ["btf_repeat_mm", "btf_relative_rms_error_per_kappa", "btf_rank",
                                  "btf_relative_rms_error", "btf_truncated_from"])
def test_empty_attributes_are_refused_in_one_line(pca, tmp_path, name):
    import h5py

    p = tmp_path / "b.h5"
    pca.truncated(1).save(p)
    forge(p, attrs={name: h5py.Empty("f8")})
    _refused(p, name)


@pytest.mark.parametrize("axis", ["texel_u", "texel_v"])
@pytest.mark.parametrize("kind", ["group", "scalar", "2d", "empty"])
def test_texel_axis_that_is_no_axis_is_refused(pca, tmp_path, axis, kind):
    p = tmp_path / "b.h5"
    pca.save(p)
    value = {"group": "group", "scalar": np.float64(0.5), "2d": np.zeros((2, 2)), "empty": np.zeros(0)}[kind]
    forge(p, datasets={axis: value})
    _refused(p, axis)


def test_texel_axes_of_2_33_are_refused_before_allocating(pca, tmp_path):
    import h5py

    p = tmp_path / "b.h5"
    pca.save(p)
    with h5py.File(p, "r+") as f:
        del f["texel_u"]
        f.create_dataset("texel_u", shape=(1 << 33,), dtype="f8", chunks=(1 << 16,))
    _refused(p, "texel_u")


def test_neural_schema_attributes_forged(neural, tmp_path):
    for attrs, word in (({"btf_latent_levels": "two"}, "btf_latent_levels"),
                        ({"btf_decoder_layers": np.array([], np.int64)}, "btf_decoder_layers"),
                        ({"btf_decoder_constants": np.array([1.0, np.nan, 0.0])}, "btf_decoder_constants"),
                        ({"btf_format_version": np.float64(2.5)}, "btf_format_version"),
                        ({"btf_residual_rank": np.int64(-1)}, "btf_residual_rank")):
        p = tmp_path / "n.h5"
        neural.save(p)
        forge(p, attrs=attrs)
        _refused(p, word)


# -- item 9: queries -------------------------------------------------------------------------------------------
def test_evaluate_with_an_integer_beyond_float64_is_a_query_error_as_for_cdbrdf(pca):
    with pytest.raises(QueryError) as btf_err:
        pca.evaluate(10**400, 0.0, 0, 0, 0, 0)
    with pytest.raises(QueryError) as table_err:
        pca.mean().evaluate(10**400, 0, 0, 0)
    assert str(btf_err.value).startswith("u_mm: ") and "\n" not in str(btf_err.value)
    assert str(btf_err.value).removeprefix("u_mm") == str(table_err.value).removeprefix("theta_v")
    with pytest.raises(QueryError, match="^kappa: "):
        pca.evaluate(0.0, 0.0, 0, 0, 0, 0, "x")
    with pytest.raises(QueryError, match="broadcast"):
        pca.evaluate(np.zeros(2), np.zeros(3), 0, 0, 0, 0)


def test_huge_positions_read_a_texel(pca, neural):
    """A position beyond float32 (or any finite float64) is wrapped exactly: a texel's value, never NaN or 0."""
    q = (30.0, 40.0, 20.0, 200.0, 0.1)
    for b in (pca, neural):
        got = b.evaluate(np.array([3.3e38, 1e300, -1e300]), 1e39, *q)
        u = np.mod(np.array([3.3e38, 1e300, -1e300]), 2.0)
        want = b.evaluate(u, np.mod(1e39, 1.5), *q)
        np.testing.assert_allclose(got, want, rtol=1e-12)
        assert np.all(got > 0)


# -- item 4: the renderer's texel coordinates ---------------------------------------------------------------
def _plugin_values(b, uv, texel_filter, uv_scale, variant="llvm_ad_rgb"):
    import cdbrdf.render as cr

    from .render_helpers import local_si, mi, vec

    cr.set_variant(variant)
    try:
        wi = np.tile([[0.3, 0.2, 0.93]], (len(uv), 1))
        wi /= np.linalg.norm(wi, axis=1, keepdims=True)
        wo = np.tile([[-0.4, 0.1, 0.91]], (len(uv), 1))
        wo /= np.linalg.norm(wo, axis=1, keepdims=True)
        bsdf = cr.make_bsdf(b, curvature=0.1, uv_scale=uv_scale, texel_filter=texel_filter)
        if variant.startswith("scalar"):
            out = []
            for (u, v), a, c in zip(uv, wi, wo):
                si = mi.SurfaceInteraction3f()
                si.wi = mi.Vector3f(*map(float, a))
                si.sh_frame = mi.Frame3f(mi.Vector3f(0, 0, 1))
                si.n = mi.Normal3f(0, 0, 1)
                si.uv = mi.Point2f(float(u), float(v))
                out.append(np.array(bsdf.eval(mi.BSDFContext(), si, mi.Vector3f(*map(float, c)))).reshape(-1))
            return np.array(out)
        si = local_si(wi)
        si.uv = mi.Point2f(np.ascontiguousarray(uv[:, 0], np.float32), np.ascontiguousarray(uv[:, 1], np.float32))
        return np.array(bsdf.eval(mi.BSDFContext(), si, vec(wo))).T
    finally:
        cr.set_variant("llvm_ad_rgb")


@pytest.mark.parametrize("which", ["pca", "neural"])
@pytest.mark.parametrize("texel_filter", ["bilinear", "nearest", "stochastic"])
def test_uvs_beyond_float32_read_the_texel_the_rule_gives(pca, neural, which, texel_filter):
    """UV x uv_scale beyond float32 (3.3e38 x 10; 1e30 x 1e9): the position is wrapped in float64, an exact multiple
    of the repeat reads what UV 0 reads; never black (an index outside the table), never another texel."""
    from .render_helpers import needs_llvm_marker

    if needs_llvm_marker().args[0]:
        pytest.skip("needs libLLVM for Mitsuba's llvm variant")
    b = pca if which == "pca" else neural
    for scale, big in ((10.0, 3.3e38), (1e9, 1e30)):
        uv = np.array([[big, big], [0.0, 0.0], [-big, big], [np.inf, 0.0]])
        got = _plugin_values(b, uv, texel_filter, scale)
        assert np.all(np.isfinite(got)) and np.all(got > 0), got
        if texel_filter != "stochastic":
            np.testing.assert_allclose(got[[0, 2, 3]], np.tile(got[1], (3, 1)), rtol=1e-5)
        else:  # one of the texels around UV 0
            dense = b.decode()
            assert np.all(got <= 1.01 * dense.max())
        scalar = _plugin_values(b, uv, "bilinear", scale, variant="scalar_rgb")
        if texel_filter == "bilinear":
            np.testing.assert_allclose(scalar, got, rtol=1e-3)


@pytest.mark.parametrize(("which", "name"), [("pca", "btf_weights"), ("pca", "btf_basis"), ("neural", "btf_latents"),
                                             ("neural", "btf_decoder")])
def test_a_variable_that_is_a_group_is_refused(pca, neural, tmp_path, which, name):
    """Found by the fuzzer (AttributeError: 'Group' object has no attribute 'shape')."""
    p = tmp_path / "b.h5"
    (pca if which == "pca" else neural).save(p)
    forge(p, datasets={name: "group"})
    _refused(p, name, "not a variable")
