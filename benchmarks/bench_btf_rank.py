"""Why a CD-BTF of the cloth model compresses as it does: noise, symmetry and local PCA on a coarse grid.

Run: ``python benchmarks/bench_btf_rank.py [--preset denim ...] [--texels 32] [--cache DIR]``;
``--methods`` instead compares the representations on the paper's grid (below).

For each preset the texels are tabulated (:func:`cdbrdf.synth.texels.tabulate_texels`) on a coarse grid
(theta step 30, phi step 90 degrees, kappa 0 and 0.22) at 16, 64, 256 and 1,024 points per texel
(``--cache`` keeps them as ``PRESET_PPT.npy``). Prints one JSON object per preset with

- ``noise``: the relative RMS difference of the texels from those at 1,024 points per texel;
- ``rank_at_3pct`` and ``error_at_rank``: the PCA over texels of :func:`cdbrdf.btf._factor.factorise`
  (its own relative RMS error) at each number of points per texel;
- ``error_vs_1024_at_rank``: the PCA of each table against the texels at 1,024 points per texel (what
  a low rank keeps of the texture rather than of the noise);
- ``symmetry``: the relative RMS difference of the texels at 1,024 points per texel from their copy
  shifted by whole yarns (a twill's texels are shifted copies), for the closest shift;
- ``local_pca``: clustered PCA (Kambhatla & Leen 1997, as in Mueller et al. 2003 for BTFs): ``k``
  clusters of texels, each with its mean and ``r`` components, texels reassigned to the cluster that
  reconstructs them best; its error at ``k (r + 1)`` stored vectors against the global PCA with as
  many (``rank = k (r + 1) - 1``). On the paper's grid (many more samples per texel than texels) the
  ratio against raw float32 is about ``n_texels / stored vectors``: 100:1 at 32 x 32 texels is
  about 10 vectors.

``--methods`` (``--preset denim --preset shot --preset velvet``, 32 x 32 texels on the paper's grid,
64 points per texel; ``--cache`` keeps the texels as ``PRESET_paper_32.npy``): compression ratio against
raw float32 and relative RMS error against the uncompressed texels (over all curvatures, and the worst
curvature slice) for

- ``pca``: one PCA over the texels at several ranks (mean, basis and weights in float32);
- ``clustered_pca``: ``k`` clusters of rank ``r`` (as above; vectors in float32);
- ``vq``: vector quantisation of every (texel, kappa, view) slice over the light directions and channels
  (``72 x 3`` numbers) with a k-means codebook of ``K`` vectors (float32) and one index per slice
  (``log2 K`` bits): the per-view light slices of Havran et al. 2010, one level;
- ``neural``: :meth:`cdbrdf.CDBTF.from_values` with ``method="neural"`` (the tile mean and the codes in
  float16, the decoder in float32; no residual components), at the default fit and at ``--fit-variants``;
  with the fit's process CPU time.

Prints one JSON object per preset (``"methods"``: a list of ``{method, setting, ratio, error,
worst_kappa_error}``).
"""

from __future__ import annotations

import argparse
import json
import os

import numpy as np

from cdbrdf import Grid
from cdbrdf.btf._factor import factorise
from cdbrdf.synth import presets
from cdbrdf.synth.texels import tabulate_texels

PPTS = (16, 64, 256, 1024)
RANKS = (4, 9, 19, 39)


def _rel(a: np.ndarray, b: np.ndarray) -> float:
    return round(float(np.sqrt(np.sum((a - b) ** 2) / np.sum(b ** 2))), 4)


def _pca(x: np.ndarray, rank: int) -> np.ndarray:
    """Rank-``rank`` reconstruction of the rows of ``x`` (mean kept)."""
    m = x.mean(axis=0)
    if rank == 0:
        return np.broadcast_to(m, x.shape).copy()
    u, s, vt = np.linalg.svd(x - m, full_matrices=False)
    return m + (u[:, :rank] * s[:rank]) @ vt[:rank]


def _local_pca(x: np.ndarray, k: int, r: int, iters: int = 15, seed: int = 0) -> np.ndarray:
    """Clustered PCA: ``k`` clusters, rank ``r`` each; the reconstruction of the rows of ``x``."""
    rng = np.random.default_rng(seed)
    # start: k-means++ seeds in the space of the leading components
    m = x.mean(axis=0)
    u, s, _ = np.linalg.svd(x - m, full_matrices=False)
    y = u[:, :20] * s[:20]
    centres = [y[rng.integers(len(y))]]
    for _ in range(1, k):
        d2 = np.min([np.sum((y - c) ** 2, axis=1) for c in centres], axis=0)
        centres.append(y[rng.choice(len(y), p=d2 / d2.sum())])
    label = np.argmin([np.sum((y - c) ** 2, axis=1) for c in centres], axis=0)
    best = None
    for _ in range(iters):
        err = np.full((k, len(x)), np.inf)
        recon = np.zeros((k,) + x.shape)
        for c in range(k):
            sel = label == c
            if not sel.any():
                continue
            mc = x[sel].mean(axis=0)
            if r > 0 and sel.sum() > 1:
                _, _, vt = np.linalg.svd(x[sel] - mc, full_matrices=False)
                b = vt[:r]
                recon[c] = mc + ((x - mc) @ b.T) @ b
            else:
                recon[c] = mc
            err[c] = np.sum((x - recon[c]) ** 2, axis=1)
        new = np.argmin(err, axis=0)
        best = recon[new, np.arange(len(x))]
        if np.array_equal(new, label):
            break
        label = new
    assert best is not None
    return best


def _paper_texels(name: str, texels: int, cache: str | None) -> np.ndarray:
    """The preset's texels on the paper's grid (cloth: 64 points per texel), cached as ``PRESET_paper_N.npy``."""
    from cdbrdf.synth import PileModel
    from cdbrdf.synth.pile_texels import tabulate_pile_texels

    path = None if cache is None else os.path.join(cache, f"{name}_paper_{texels}.npy")
    if path is not None and os.path.exists(path):
        return np.load(path)
    model = presets.model(name)
    if isinstance(model, PileModel):
        d = tabulate_pile_texels(model, Grid.paper(), texels=(texels, texels))[0]
    else:
        d = tabulate_texels(model, Grid.paper(), texels=texels)
    if path is not None:
        np.save(path, d)
    return d


def _errors(y: np.ndarray, pred: np.ndarray, nk: int) -> tuple[float, float]:
    """Overall and worst-slice relative RMS error of ``pred`` against ``y`` (both ``(T, kappa-major columns)``)."""
    a, b = y.reshape(y.shape[0], nk, -1), pred.reshape(y.shape[0], nk, -1)
    num = np.sum((a - b) ** 2, axis=(0, 2))
    den = np.sum(a.astype(np.float64) ** 2, axis=(0, 2))
    return round(float(np.sqrt(num.sum() / den.sum())), 4), round(float(np.sqrt(np.max(num / den))), 4)


def _vq(y: np.ndarray, grid: Grid, k: int, seed: int = 0) -> np.ndarray:
    """Per-(texel, kappa, view) light slices quantised to a k-means codebook of ``k`` vectors."""
    from scipy.cluster.vq import kmeans2

    nk, npl, ntl, npv, ntv = grid.shape
    t = y.shape[0]
    x = y.reshape(t, nk, npl * ntl, npv * ntv, 3).transpose(0, 1, 3, 2, 4).reshape(-1, npl * ntl * 3)
    x = x.astype(np.float32)
    rng = np.random.default_rng(seed)
    sub = x[rng.choice(len(x), size=min(len(x), 20 * k), replace=False)]
    code, _ = kmeans2(sub, k, iter=10, minit="++", seed=seed)
    label = np.empty(len(x), np.int64)
    for s in range(0, len(x), 16384):  # nearest codeword of every slice
        d = (x[s:s + 16384] ** 2).sum(1)[:, None] - 2 * x[s:s + 16384] @ code.T + (code ** 2).sum(1)[None]
        label[s:s + 16384] = np.argmin(d, axis=1)
    rec = code[label].reshape(t, nk, npv * ntv, npl * ntl, 3).transpose(0, 1, 3, 2, 4)
    return rec.reshape(t, -1)


class _Rows(list):
    """The rows, each printed (one JSON line, flushed) as it is added: a long run shows its progress."""

    def append(self, row: dict) -> None:  # type: ignore[override]
        print(json.dumps(row), flush=True)
        super().append(row)


def _methods(name: str, a: argparse.Namespace) -> dict:
    """Ratio and error of every representation on the preset's paper-grid texels."""
    import time

    from cdbrdf import CDBTF
    from cdbrdf.btf._neural import FitOptions

    grid = Grid.paper()
    dense = _paper_texels(name, a.texels, a.cache)
    t = a.texels * a.texels
    y = dense.reshape(t, -1)
    nk, d = grid.shape[0], y.shape[1]
    raw = 4.0 * y.size
    rows = _Rows()
    which = set(a.only or ("pca", "clustered_pca", "vq", "neural"))
    f = factorise(y, nk, max_error=0.0, max_rank=min(255, t - 1))
    pca_ranks = [r for r in (0, 1, 2, 4, 9, 19, 39, 79, 159, 237) if r <= f.weights.shape[1]]
    for r in pca_ranks if "pca" in which else ():
        rec = f.mean + (f.weights[:, :r].astype(np.float64) @ f.basis[:r].astype(np.float64))
        e, w = _errors(y, rec, nk)
        rows.append({"method": "pca", "setting": f"rank {r}", "ratio": round(raw / (4.0 * (d * (r + 1) + t * r)), 1),
                     "error": e, "worst_kappa_error": w})
    for k, r in ((10, 0), (2, 4)) if "clustered_pca" in which else ():
        rec = _local_pca(y.astype(np.float64), k, r, iters=6)
        e, w = _errors(y, rec, nk)
        rows.append({"method": "clustered_pca", "setting": f"{k} clusters x rank {r}",
                     "ratio": round(raw / (4.0 * (d * k * (r + 1) + t * r)), 1), "error": e, "worst_kappa_error": w})
    slices = t * nk * grid.shape[3] * grid.shape[4]
    for k in (256, 1024) if "vq" in which else ():
        rec = _vq(y, grid, k)
        size = 4.0 * k * grid.shape[1] * grid.shape[2] * 3 + slices * np.ceil(np.log2(k)) / 8
        rows.append({"method": "vq", "setting": f"{k} codewords", "ratio": round(raw / size, 1),
                     **dict(zip(("error", "worst_kappa_error"), _errors(y, rec, nk)))})
    variants = [FitOptions()] + [FitOptions(latent_dims=int(L), hidden=(int(h), int(h)), steps=int(n))
                                 for L, h, n in (v.split(",") for v in a.fit_variants)]
    for opts in variants if "neural" in which else ():
        c0 = time.process_time()
        b = CDBTF.from_values(dense, grid, repeat_mm=(1.0, 1.0), method="neural", max_error=0.99, fit=opts)
        c = b.compression
        rows.append({"method": "neural", "setting": f"codes {opts.latent_dims}, layers {b.neural.layers}, "
                     f"{opts.steps} steps", "ratio": round(c["compression_ratio"], 1),
                     "error": round(c["relative_rms_error"], 4),
                     "worst_kappa_error": round(max(c["relative_rms_error_per_kappa"]), 4),
                     "fit_cpu_seconds": round(time.process_time() - c0, 1)})
    return {"preset": name, "texels": a.texels, "grid": "paper", "methods": rows}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--preset", action="append", default=None)
    ap.add_argument("--texels", type=int, default=32)
    ap.add_argument("--cache", default=None, help="folder keeping the tabulated texels")
    ap.add_argument("--methods", action="store_true", help="compare the representations on the paper's grid")
    ap.add_argument("--only", action="append", default=None, help="with --methods: pca, clustered_pca, vq, neural")
    ap.add_argument("--fit-variants", nargs="*", default=[], metavar="L,H,STEPS",
                    help="more neural fits: code size, hidden width, steps")
    a = ap.parse_args()
    if a.methods:
        for name in a.preset or ["denim", "shot", "velvet"]:
            print(json.dumps(_methods(name, a)), flush=True)
        return
    grid = Grid.regular(theta_step_deg=30, phi_step_deg=90, kappa=[0.0, 0.22])
    for name in a.preset or ["denim", "shot"]:
        model = presets.model(name)
        dense = {}
        for ppt in PPTS:
            path = None if a.cache is None else os.path.join(a.cache, f"{name}_{ppt}.npy")
            if path is not None and os.path.exists(path):
                d = np.load(path)
            else:
                d = tabulate_texels(model, grid, texels=a.texels, points_per_texel=ppt)
                if path is not None:
                    np.save(path, d)
            dense[ppt] = d.reshape(a.texels * a.texels, -1).astype(np.float64)
        ref = dense[1024]
        out: dict = {"preset": name, "texels": a.texels, "samples_per_texel": ref.shape[1]}
        out["noise"] = {p: _rel(dense[p], ref) for p in PPTS[:-1]}
        out["rank_at_3pct"], out["error_at_rank"], out["error_vs_1024_at_rank"] = {}, {}, {}
        for p in PPTS:
            f = factorise(dense[p], grid.shape[0], max_error=0.03, max_rank=min(255, a.texels ** 2 - 1))
            out["rank_at_3pct"][p] = int(f.weights.shape[1])
            out["error_at_rank"][p] = {r: round(float(f.spectrum[r]), 4) for r in RANKS}
            out["error_vs_1024_at_rank"][p] = {r: _rel(_pca(dense[p], r), ref) for r in RANKS}
        # symmetry: shifts by whole yarns
        n_weft, n_warp = model.params.weave_matrix.shape
        cube = ref.reshape(a.texels, a.texels, -1)
        shifts = {}
        for sv in range(n_weft if model.params.warp_along == "y" else n_warp):
            for su in range(n_warp if model.params.warp_along == "y" else n_weft):
                if su == 0 and sv == 0:
                    continue
                dv = sv * a.texels // (n_weft if model.params.warp_along == "y" else n_warp)
                du = su * a.texels // (n_warp if model.params.warp_along == "y" else n_weft)
                shifts[f"{du},{dv}"] = _rel(np.roll(cube, (dv, du), axis=(0, 1)), cube)
        best = min(shifts, key=lambda s: shifts[s])
        out["symmetry"] = {"closest_shift_texels": best, "difference": shifts[best],
                           "texture": _rel(np.broadcast_to(ref.mean(axis=0), ref.shape), ref)}
        out["local_pca"] = []
        for k, r in ((10, 0), (5, 1), (2, 4), (3, 2), (20, 0), (10, 1), (4, 4), (40, 0), (20, 1), (8, 4)):
            vec = k * (r + 1)
            out["local_pca"].append({"k": k, "r": r, "vectors": vec, "error": _rel(_local_pca(ref, k, r), ref),
                                     "global_pca_error": _rel(_pca(ref, vec - 1), ref)})
        print(json.dumps(out), flush=True)


if __name__ == "__main__":
    main()
