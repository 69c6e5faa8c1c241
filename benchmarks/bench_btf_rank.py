"""Why a CD-BTF of the cloth model compresses as it does: noise, symmetry and local PCA on a coarse grid.

Run: ``python benchmarks/bench_btf_rank.py [--preset denim ...] [--texels 32] [--cache DIR]``.

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


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--preset", action="append", default=None)
    ap.add_argument("--texels", type=int, default=32)
    ap.add_argument("--cache", default=None, help="folder keeping the tabulated texels")
    a = ap.parse_args()
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
