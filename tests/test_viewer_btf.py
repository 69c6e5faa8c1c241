"""The viewer shows a CD-BTF: its packed asset, the command line, and the weave in headless Chromium.

The CD-BTFs here are built from their linear form (tile mean + weights x
basis, :class:`cdbrdf.CDBTF`), not by the compression, so that the checks
hold whatever factorisation made a file.
"""

from __future__ import annotations

import base64
import re

import numpy as np
import pytest

import cdbrdf
from cdbrdf import materials
from cdbrdf.cli import main
from cdbrdf.errors import LimitError, OptionError
from cdbrdf.view.asset import WEBGL2_MIN_LIMITS, table_asset
from cdbrdf.view.btf_asset import btf_asset, btf_rank_that_fits
from cdbrdf.view.export import export_viewer, viewer_files

from .conftest import make_table
from .test_viewer import needs_chromium, open_page, rel_close

REPEAT_MM = (1.6, 2.2)


def random_btf(grid: cdbrdf.Grid, *, rank: int = 5, texels: tuple[int, int] = (6, 4), seed: int = 0) -> cdbrdf.CDBTF:
    """Random mean, components of decreasing size and weights in [-1, 1]."""
    rng = np.random.default_rng(seed)
    mean = make_table(grid, seed=seed, dtype=np.float32, attrs={"material": "random-btf", "quantity": "relative"})
    basis = rng.normal(size=grid.shape + (rank, 3)) * (0.05 / (1 + np.arange(rank)))[:, None]
    weights = rng.uniform(-1, 1, (texels[1], texels[0], rank))
    return cdbrdf.CDBTF(mean, weights, basis.astype(np.float32), repeat_mm=REPEAT_MM)


def iso_grid() -> cdbrdf.Grid:
    """Isotropic, elevations from 10 degrees (a virtual pole node), uneven curvatures."""
    return cdbrdf.Grid(kappa=[-0.2, -0.05, 0.0, 0.25], theta_l=[10.0, 35.0, 60.0, 80.0], phi_l=[0.0],
                       theta_v=[10.0, 30.0, 55.0, 70.0, 85.0], phi_v=np.arange(0.0, 360.0, 45.0), symmetry="isotropic")


def aniso_grid() -> cdbrdf.Grid:
    return cdbrdf.Grid(kappa=[-0.2, 0.0, 0.2], theta_l=[0.0, 30.0, 60.0], phi_l=np.arange(0.0, 360.0, 60.0),
                       theta_v=[0.0, 30.0, 60.0], phi_v=np.arange(0.0, 360.0, 90.0))


def weave_btf() -> cdbrdf.CDBTF:
    """The bundled denim as tile mean, with a twill-like pattern of two components: the weave is known."""
    mean = materials.load("denim")
    m = mean.values.astype(np.float32)
    basis = np.stack([0.6 * m, 0.3 * m[..., ::-1]], axis=-2)
    iu, iv = np.meshgrid(np.arange(8), np.arange(8))
    weights = np.stack([np.where((iu + iv) % 4 < 2, 1.0, -1.0), np.where(iu % 2 == 0, 1.0, -1.0)], axis=-1)
    return cdbrdf.CDBTF(mean, weights, basis, repeat_mm=REPEAT_MM)


def decode_asset(header: dict, blob: bytes) -> cdbrdf.CDBTF:
    """The CD-BTF the exported textures hold, rebuilt in NumPy on the lookup's own nodes."""
    def block(name):
        b = header["blocks"][name]
        dt = {"float32": "<f4", "float16": "<f2"}[b["dtype"]]
        return np.frombuffer(blob, dt, b["bytes"] // np.dtype(dt).itemsize, b["offset"]).reshape(b["shape"])

    lk, bt = header["lookup"], header["btf"]
    k, pl, tl, pv, tv = lk["shape"]
    per, rank = bt["components"]["per_sample"], bt["rank"]
    comps = block("components").astype(np.float32).reshape(k, -1, 4)[:, : pl * tl * pv * tv * per, :3]
    comps = comps.reshape(k, pl, tl, pv, tv, per, 3)
    axes = {"kappa": lk["kappa"], "theta_l": lk["theta_l"], "theta_v": lk["theta_v"],
            "phi_l": lk["phi_l0"] + lk["phi_l_step"] * np.arange(pl),
            "phi_v": lk["phi_v0"] + lk["phi_v_step"] * np.arange(pv)}
    mean = cdbrdf.CDBRDF(comps[..., 0, :], **axes, symmetry=header["symmetry"])
    w = block("weights").reshape(-1, bt["weights"]["height"], bt["weights"]["width"], 4)
    weights = np.moveaxis(w, -1, 1).reshape(-1, *w.shape[1:3])[:rank]  # (rank, n_v, n_u)
    return cdbrdf.CDBTF(mean, np.moveaxis(weights, 0, -1), comps[..., 1:, :], repeat_mm=bt["repeat_mm"])


def random_queries(rng: np.random.Generator, n: int) -> np.ndarray:
    """(u_mm, v_mm, theta_v, phi_v, theta_l, phi_l, kappa): positions beyond the repeat, the poles, clamped kappa."""
    q = np.stack([rng.uniform(-5, 5, n), rng.uniform(-5, 5, n), rng.uniform(0, 90, n), rng.uniform(-360, 720, n),
                  rng.uniform(0, 90, n), rng.uniform(0, 360, n), rng.uniform(-0.4, 0.4, n)], axis=1)
    m = n // 10
    q[:m, 2] = 0.0
    q[m:2 * m, 4] = 0.0
    q[2 * m:3 * m, 0] = rng.choice([0.0, REPEAT_MM[0], -REPEAT_MM[0] / 16], m)  # on a repeat's edge, a centre
    return q


def scale_of(btf: cdbrdf.CDBTF) -> float:
    """The size of the terms summed: the decoded values' magnitude."""
    return float(np.abs(btf.decode()).max())


# -- the asset (no browser) ---------------------------------------------------------------
@pytest.mark.parametrize("grid", [aniso_grid, iso_grid])
@pytest.mark.parametrize("precision, tol", [("float32", 1e-5), ("float16", 2e-3)])
def test_btf_asset_decodes_to_evaluate(grid, precision, tol):
    btf = random_btf(grid())
    a = btf_asset(btf, name="b.h5", precision=precision)
    h = a.header
    assert h["kind"] == "btf" and h["btf"]["rank"] == h["btf"]["rank_total"] == 5
    assert h["btf"]["components"]["type"] == precision and h["btf"]["texels"] == [6, 4]
    assert h["btf"]["weights"]["layers"] == 2  # 5 components in RGBA layers
    back = decode_asset(h, a.blob)
    q = random_queries(np.random.default_rng(1), 2000)
    got, want = back.evaluate(*q.T), btf.evaluate(*q.T)
    assert np.abs(got - want).max() <= tol * scale_of(btf)
    # the tile mean is packed as the mean's own table asset: the mosaic and the meshes without UVs use it
    plain = table_asset(btf.mean(), name="b.h5", precision=precision).header
    assert h["lookup"] == plain["lookup"] and h["blocks"]["lookup"] == plain["blocks"]["lookup"]


def test_auto_precision_is_float16_only_for_large_components():
    small = btf_asset(random_btf(aniso_grid()))
    assert small.header["btf"]["components"]["type"] == "float32"


def test_too_many_components_are_truncated_to_the_leading_ones_and_said():
    btf = random_btf(aniso_grid(), rank=9)
    samples = 3 * 6 * 3 * 4  # per curvature: phi_l, theta_l, phi_v, theta_v
    limits = {**WEBGL2_MIN_LIMITS, "MAX_TEXTURE_SIZE": 32}  # 1,024 texels a layer: 1 + 3 components per sample
    assert btf_rank_that_fits(btf, limits=limits) == 1024 // samples - 1 == 3
    a = btf_asset(btf, limits=limits)
    assert (a.header["btf"]["rank"], a.header["btf"]["rank_total"], a.header["btf"]["rank_fits"]) == (3, 9, 3)
    lead = cdbrdf.CDBTF(btf.mean(), btf.weights[..., :3], btf.basis[..., :3, :], repeat_mm=REPEAT_MM)
    q = random_queries(np.random.default_rng(2), 500)
    np.testing.assert_allclose(decode_asset(a.header, a.blob).evaluate(*q.T), lead.evaluate(*q.T), rtol=1e-5,
                               atol=1e-6)
    b = btf_asset(btf, max_rank=2)
    assert (b.header["btf"]["rank"], b.header["btf"]["rank_fits"]) == (2, 9)
    # the error of what is shown: the truncation's, not the file's
    used = b.header["btf"]["relative_rms_error_used"]
    assert used == pytest.approx(btf.truncated(2).compression["relative_rms_error"])
    assert used > 0.0  # (no error recorded for the full rank: the truncation's own)
    assert btf_asset(btf, max_rank=0).header["btf"]["weights"]["layers"] == 1  # the tile mean alone


def test_bad_sizes_and_ranks_are_one_line_errors():
    btf = random_btf(aniso_grid(), texels=(40, 3))
    with pytest.raises(LimitError, match=r"^b.h5: 40 x 3 texels per repeat exceed the GPU's MAX_TEXTURE_SIZE 32$"):
        btf_asset(btf, name="b.h5", limits={**WEBGL2_MIN_LIMITS, "MAX_TEXTURE_SIZE": 32})
    with pytest.raises(OptionError, match="rank: expected a whole number >= 0, got -1"):
        btf_asset(btf, max_rank=-1)
    tiny = {**WEBGL2_MIN_LIMITS, "MAX_TEXTURE_SIZE": 8}  # not even the tile mean fits
    with pytest.raises(LimitError, match="too large for the viewer's GPU texture"):
        btf_asset(btf, limits=tiny)


# -- the command line ------------------------------------------------------------------------
@pytest.fixture(scope="module")
def btf_file(tmp_path_factory):
    p = tmp_path_factory.mktemp("btf") / "weave.h5"
    random_btf(aniso_grid(), rank=6).save(p)
    return p


def test_cli_exports_a_btf_and_says_when_it_uses_fewer_components(btf_file, tmp_path, capsys):
    import json

    assert main(["view", str(btf_file), "--export", str(tmp_path / "a")]) == 0
    h = json.loads((tmp_path / "a" / "assets" / "table-0.json").read_text())
    assert h["kind"] == "btf" and h["btf"]["rank"] == 6
    capsys.readouterr()
    assert main(["view", str(btf_file), "--rank", "2", "--export", str(tmp_path / "b")]) == 0
    err = capsys.readouterr().err
    assert "weave.h5: CD-BTF of rank 6: the viewer uses its leading 2 components (--rank)" in err
    assert json.loads((tmp_path / "b" / "assets" / "table-0.json").read_text())["btf"]["rank"] == 2


def test_cli_refuses_grid_for_a_btf_in_one_line(btf_file, tmp_path, capsys):
    assert main(["view", str(btf_file), "--grid", "15,30", "--export", str(tmp_path / "v")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("cdbrdf view: error: --grid: weave.h5 is a CD-BTF") and err.count("\n") == 1
    assert "--rank" in err and not (tmp_path / "v").exists()


# -- the page in headless Chromium (the browser fixture: conftest.py) --------------------------


@pytest.fixture(scope="module")
def weave_page(browser, tmp_path_factory):
    """The weave CD-BTF beside a random isotropic one (virtual pole node), one page."""
    tables = [("weave.h5", weave_btf()), ("iso-btf.h5", random_btf(iso_grid(), seed=4))]
    index = export_viewer(tmp_path_factory.mktemp("vb") / "v", viewer_files(tables, meshes={}))
    page, messages = open_page(browser, index.resolve().as_uri(), width=240, height=160)
    page.messages = messages
    yield page
    page.close()


def pixels(page) -> np.ndarray:
    p = page.evaluate("cdbrdfViewer.pixels()")
    a = np.frombuffer(base64.b64decode(p["data"]), np.uint8).reshape(p["height"], p["width"], 4)
    return a[::-1, :, :3].astype(np.float64)


def texel_variance(img: np.ndarray, size: int = 7) -> float:
    """Variance of the image less its local mean (a size x size box): what changes from texel to texel."""
    from scipy.ndimage import uniform_filter

    lum = img @ np.array([0.2126, 0.7152, 0.0722])
    hi = lum - uniform_filter(lum, size, mode="nearest")
    h, w = hi.shape
    return float(hi[h // 4: 3 * h // 4, w // 4: 3 * w // 4].var())  # the middle: no silhouette


@needs_chromium
@pytest.mark.slow  # a page with two CD-BTFs in software WebGL2
def test_page_with_btfs_has_no_console_messages_and_says_the_rank(weave_page):
    assert weave_page.messages == []
    st = weave_page.evaluate("cdbrdfViewer.state()")
    assert st["btf"] == [{"rank": 2, "rankTotal": 2, "used": 2}, {"rank": 5, "rankTotal": 5, "used": 5}]
    assert "weave.h5: CD-BTF, rank 2 used of 2; 8 x 8 texels over 1.60 x 2.20 mm" in st["btfText"]
    st = weave_page.evaluate("cdbrdfViewer.setComponents(3)")
    assert "iso-btf.h5: CD-BTF, rank 3 used of 5" in st["btfText"] and "rank 2 used of 2" in st["btfText"]
    weave_page.evaluate("cdbrdfViewer.setComponents(5)")


@needs_chromium
@pytest.mark.slow
@pytest.mark.parametrize("index", [0, 1])
def test_gpu_decode_matches_btf_evaluate(weave_page, index):
    btf = weave_btf() if index == 0 else random_btf(iso_grid(), seed=4)
    q = random_queries(np.random.default_rng(5 + index), 600)
    gq = np.concatenate([q[:, 2:], q[:, :2]], axis=1)  # (theta_v, phi_v, theta_l, phi_l, kappa, u, v)
    gpu = np.array(weave_page.evaluate("([q, t]) => cdbrdfViewer.evaluateMany(q, {table: t})", [gq.tolist(), index]))
    ref = btf.evaluate(*q.T)
    assert np.abs(gpu - ref).max() <= 1e-4 * scale_of(btf)
    # five numbers: the tile mean, as before
    mean = np.array(weave_page.evaluate("([q, t]) => cdbrdfViewer.evaluateMany(q, {table: t})",
                                        [gq[:50, :5].tolist(), index]))
    assert rel_close(mean, btf.mean().evaluate(*gq[:50, :5].T), 1e-3).all()


@needs_chromium
@pytest.mark.slow
@pytest.mark.parametrize("surface", ["sheet", "stand"])
def test_weave_is_visible_close_up_and_not_with_the_tile_mean(weave_page, surface):
    v = "cdbrdfViewer"
    weave_page.evaluate(f"{v}.setSideBySide(false)")
    weave_page.evaluate(f"{v}.setSurface('{surface}')")
    weave_page.evaluate(f"{v}.setStandCurvature(0.13)")
    weave_page.evaluate(f"{v}.setLight(40, 20)")
    weave_page.evaluate(f"{v}.setCamera(80, -90, 14)")  # a close-up: about 5 mm across, 3 repeats
    weave_page.evaluate(f"{v}.setWeave(true)")
    weave = pixels(weave_page)
    weave_page.evaluate(f"{v}.setWeave(false)")
    mean = pixels(weave_page)
    weave_page.evaluate(f"{v}.setWeave(true)")
    weave_page.evaluate(f"{v}.setComponents(0)")
    zero = pixels(weave_page)
    weave_page.evaluate(f"{v}.setComponents(5)")
    assert weave.std() > 5 and mean.std() > 0  # the surface fills the view
    tw, tm = texel_variance(weave), texel_variance(mean)
    assert tw > 20 * max(tm, 0.05), (tw, tm)
    assert np.abs(zero - mean).max() <= 1  # no components: the tile mean, through the CD-BTF's own texture
    assert weave_page.messages == []


@needs_chromium
@pytest.mark.slow
def test_page_says_the_export_kept_fewer_components(browser, tmp_path):
    """--rank 9 of 10 components; software WebGL then starts with the leading 8: both said."""
    btf = random_btf(aniso_grid(), rank=10)
    index = export_viewer(tmp_path / "v", viewer_files([("r10.h5", btf)], meshes={}, max_rank=9))
    page, messages = open_page(browser, index.resolve().as_uri(), width=64, height=64)
    try:
        st = page.evaluate("cdbrdfViewer.state()")
        assert st["software"]  # SwiftShader
        err = 100 * btf.truncated(9).compression["relative_rms_error"]
        kept = f"the export kept the leading 9 (--rank, relative RMS error {err:.1f} %)"
        assert st["btfText"].startswith(f"r10.h5: CD-BTF, rank 8 used of 10; {kept}; "
                                         "the leading 8 on software rendering, the components slider goes up to 9")
        st = page.evaluate("cdbrdfViewer.setComponents(9)")
        assert st["btfText"].startswith(f"r10.h5: CD-BTF, rank 9 used of 10; {kept}; 6")
        assert messages == []
    finally:
        page.close()


@needs_chromium
@pytest.mark.slow  # a page of its own
def test_page_checks_the_gpus_limits_for_the_components(browser, tmp_path):
    """Components wider than this GPU's MAX_TEXTURE_SIZE: the page says which limit and offers --rank."""
    from cdbrdf.view.export import write_viewer

    files = viewer_files([("b.h5", random_btf(aniso_grid()))], meshes={})
    text, n = re.subn(r'"components":\{"width":\d+', '"components":{"width":1000000', files["data.js"].decode())
    assert n == 1
    files["data.js"] = text.encode()
    index = write_viewer(tmp_path / "v", files)
    page = browser.new_page()
    try:
        page.goto(index.resolve().as_uri(), wait_until="load")
        err = page.evaluate("cdbrdfViewer.ready.then(() => 'ok', e => e.message)")
        shown = page.locator("#message").text_content()
    finally:
        page.close()
    assert "b.h5: the CD-BTF is too large for this GPU's textures (components texture 1000000 x" in err
    assert "--rank N" in err and shown == err


# -- a neural CD-BTF: the decoder in GLSL ----------------------------------------------------------
def neural_btf(grid: cdbrdf.Grid, *, rank: int = 0, seed: int = 3) -> cdbrdf.CDBTF:
    """A small neural CD-BTF fitted to random low-rank texels (a short fit: what matters is its decoder)."""
    from cdbrdf.btf._neural import FitOptions

    base = random_btf(grid, rank=3, texels=(6, 5), seed=seed)
    btf = cdbrdf.CDBTF.from_values(base.decode(), grid, repeat_mm=REPEAT_MM, method="neural", max_error=0.9,
                                   fit=FitOptions(steps=60, latent_dims=5, hidden=(12, 8)))
    if rank == 0:
        return btf
    # residual components on top of the decoder (as a tight error target makes them)
    rng = np.random.default_rng(seed)
    basis = (0.02 * rng.normal(size=grid.shape + (rank, 3))).astype(np.float32)
    return cdbrdf.CDBTF(btf.mean(), rng.uniform(-1, 1, (5, 6, rank)), basis, repeat_mm=REPEAT_MM,
                        neural=btf.neural)


@pytest.fixture(scope="module")
def neural_page(browser, tmp_path_factory):
    tables = [("n-aniso.h5", neural_btf(aniso_grid())), ("n-iso.h5", neural_btf(iso_grid(), rank=2, seed=5))]
    index = export_viewer(tmp_path_factory.mktemp("vn") / "v", viewer_files(tables, meshes={}))
    page, messages = open_page(browser, index.resolve().as_uri(), width=240, height=160)
    page.messages = messages
    yield page, [b for _, b in tables]
    page.close()


@needs_chromium
@pytest.mark.slow
@pytest.mark.parametrize("index", [0, 1])
def test_gpu_neural_decode_matches_evaluate_at_every_footprint(neural_page, index):
    page, btfs = neural_page
    btf = btfs[index]
    assert page.messages == []
    assert btf.neural is not None and btf.rank == (0 if index == 0 else 2)
    text = page.evaluate("cdbrdfViewer.state()")["btfText"]
    assert "n-aniso.h5: CD-BTF, neural (a 12-8 decoder on 3 levels of codes" in text
    assert "+ 2 of 2 residual components" in text
    rng = np.random.default_rng(11 + index)
    q = random_queries(rng, 400)
    texel = max(REPEAT_MM[0] / btf.texels[0], REPEAT_MM[1] / btf.texels[1])
    # the finest level, between levels, the tile mean (components: the viewer fades them at the last level only)
    fp = texel * rng.choice([0.0, 0.5, 1.7, 3.0, 9.0] if btf.rank == 0 else [0.0, 0.5, 9.0], len(q))
    gq = np.concatenate([q[:, 2:], q[:, :2], fp[:, None]], axis=1)
    gpu = np.array(page.evaluate("([q, t]) => cdbrdfViewer.evaluateMany(q, {table: t})", [gq.tolist(), index]))
    ref = btf.evaluate(*q.T, footprint_mm=fp)
    assert np.abs(gpu - ref).max() <= 2e-4 * scale_of(btf)
    far = fp >= 8 * texel  # beyond the pyramid: the tile mean
    assert far.any()
    np.testing.assert_allclose(gpu[far], btf.mean().evaluate(*q[far, 2:].T), rtol=1e-4, atol=1e-5)


def test_neural_export_of_32_by_32_texels_on_the_papers_grid_is_small(tmp_path):
    """The export carries the tile mean, the codes and the decoder: about a CDBRDF's size, not the texels'."""
    from cdbrdf.btf._neural import N_FEATURES, Neural, level_shapes

    rng = np.random.default_rng(0)
    mean = materials.load("denim")
    dims, hidden = 12, (64, 64)
    lat = tuple(rng.normal(size=sh + (dims,)).astype(np.float16).astype(np.float32) for sh in level_shapes(32, 32))
    sizes = [dims + N_FEATURES, *hidden, 3]
    ws = tuple((0.1 * rng.normal(size=(a, b))).astype(np.float32) for a, b in zip(sizes[:-1], sizes[1:]))
    bs = tuple(np.zeros(b, np.float32) for b in sizes[1:])
    net = Neural(lat, ws, bs, (0.22, 1e-3, 0.0))
    btf = cdbrdf.CDBTF(mean, np.zeros((32, 32, 0)), np.zeros(mean.shape[:-1] + (0, 3), np.float32),
                       repeat_mm=REPEAT_MM, neural=net)
    a = btf_asset(btf, name="denim-btf.h5")
    nn = a.header["btf"]["neural"]
    assert nn["layers"] == [6, 64, 64, 3] and [lv[:2] for lv in nn["levels"]] == [[32, 32], [16, 16], [8, 8],
                                                                                   [4, 4], [2, 2]]
    assert len(a.blob) < 4e6  # the mean twice (table and components) in float32, codes and decoder: 2.6 MB
    index = export_viewer(tmp_path / "v", viewer_files([("denim-btf.h5", btf)], meshes={}))
    total = sum(p.stat().st_size for p in index.parent.rglob("*") if p.is_file())
    assert total < 20e6, total
