"""The CD-BTF of the presets: compression ratio and error, the tile mean against the CDBRDF of synth.

Run: ``python benchmarks/bench_btf.py [--texels 32] [--grid paper|coarse] [--preset denim ...]``;
``--modes`` adds the error of keeping the leading singular vectors of each mode of the table
(texel x kappa x light x view x channel: channel, kappa, light and view). ``--noise`` measures the
integration noise of the texels instead (``--texels 16``: the relative RMS difference of the texel
values at 16, 64 and 256 points per texel from those at 1,024, on 27 direction pairs at kappa 0.22).

For each preset: tabulate per texel (:func:`cdbrdf.synth.texels.tabulate_texels`; for a pile
preset :func:`cdbrdf.synth.pile_texels.tabulate_pile_texels`),
compress at ``--max-error`` (the rank, its recorded errors and ratio), the
error at a 100:1 ratio, the relative RMS error of ``CDBTF.evaluate`` against
the uncompressed texels looked up by the same rule on ``--queries`` random
queries, and the median relative difference of the tile mean from
the model's ``tabulate`` (``cdbrdf synth``). Prints one JSON object per preset.
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

from cdbrdf import CDBTF, Grid
from cdbrdf.interp import evaluate, prepare
from cdbrdf.synth import PileModel, presets
from cdbrdf.synth.pile_texels import tabulate_pile_texels
from cdbrdf.synth.texels import tabulate_texels


class _Dense:
    """Every texel's table as the channels of one table: the uncompressed lookup."""

    def __init__(self, dense: np.ndarray, grid: Grid) -> None:
        nv, nu = dense.shape[:2]
        self.nu, self.nv = nu, nv
        self.lg = prepare(grid, np.ascontiguousarray(np.moveaxis(dense, (0, 1), (5, 6)).reshape(grid.shape + (-1,))))

    def lookup_grid(self):
        return self.lg


def _dense_evaluate(d: _Dense, repeat, u, v, q, chunk=1024):
    """Periodic bilinear over texel centres of the uncompressed texels' lookups."""
    nu, nv = d.nu, d.nv
    out = np.empty((u.size, 3))
    for s in range(0, u.size, chunk):
        e = min(u.size, s + chunk)
        all_tex = evaluate(d, *(x[s:e] for x in q)).reshape(e - s, nv, nu, 3)  # channels: (v, u, c)
        fu = np.mod(u[s:e], repeat[0]) / repeat[0] * nu - 0.5
        fv = np.mod(v[s:e], repeat[1]) / repeat[1] * nv - 0.5
        i0, j0 = np.floor(fu).astype(int), np.floor(fv).astype(int)
        a, b = fu - i0, fv - j0
        n = np.arange(e - s)
        acc = 0.0
        for dj, wj in ((0, 1 - b), (1, b)):
            for di, wi in ((0, 1 - a), (1, a)):
                acc = acc + (wj * wi)[:, None] * all_tex[n, (j0 + dj) % nv, (i0 + di) % nu]
        out[s:e] = acc
    return out


def _noise(name: str, texels: int) -> None:
    """Relative RMS difference of the texels (and of the tile mean) from those at 1,024 points per texel."""
    from cdbrdf.frames import direction_from_angles
    from cdbrdf.synth.texels import texel_model

    model = presets.model(name)
    tv, pv = np.meshgrid([0.0, 30.0, 60.0], [0.0, 90.0, 200.0])
    v = direction_from_angles(tv.reshape(-1), pv.reshape(-1))
    lights = direction_from_angles(np.array([15.0, 45.0, 60.0]), np.array([180.0, 90.0, 300.0]))
    vv, ll = np.repeat(v, 3, axis=0), np.tile(lights, (v.shape[0], 1))
    res = {}
    for ppt in (16, 64, 256, 1024):
        res[ppt] = texel_model(model, texels, points_per_texel=ppt)._pairs(vv, ll, 0.22, (texels, texels))
    ref = res.pop(1024)

    def rel(a: np.ndarray, b: np.ndarray) -> float:
        return round(float(np.sqrt(np.sum((a - b) ** 2) / np.sum(b ** 2))), 5)

    print(json.dumps({
        "preset": name, "texels": texels,
        "texel_noise": {ppt: rel(x, ref) for ppt, x in res.items()},
        "tile_mean_noise": {ppt: rel(x.mean(axis=1), ref.mean(axis=1)) for ppt, x in res.items()},
        "texture": rel(np.broadcast_to(ref.mean(axis=1, keepdims=True), ref.shape), ref),
    }), flush=True)


def _mode_errors(dense: np.ndarray) -> dict:
    """Relative RMS error of keeping the leading r singular vectors of each non-texel mode (higher-order SVD)."""
    nv, nu, nk, npl, ntl, npv, ntv, nc = dense.shape
    x = dense.reshape(nv * nu, nk, npl * ntl, npv * ntv, nc)
    total = float(np.sum(x.astype(np.float64) ** 2))
    out = {}
    for axis, name in ((4, "channel"), (1, "kappa"), (2, "light"), (3, "view")):
        a = np.moveaxis(x, axis, 0).reshape(x.shape[axis], -1).astype(np.float64)
        lam = np.sort(np.linalg.eigvalsh(a @ a.T))[::-1]
        left = np.maximum(1.0 - np.cumsum(lam) / total, 0.0)
        out[name] = {r: round(float(np.sqrt(left[r - 1])), 5) for r in (1, 2, 4, 8, 16, 24, 32, 40, 48)
                     if r <= lam.size}
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--preset", action="append", default=None)
    ap.add_argument("--texels", type=int, default=32)
    ap.add_argument("--grid", choices=("paper", "coarse"), default="paper")
    ap.add_argument("--max-error", type=float, default=0.03)
    ap.add_argument("--queries", type=int, default=100_000)
    ap.add_argument("--save", default=None, help="folder to write PRESET-btf.h5 into")
    ap.add_argument("--points-per-texel", type=int, default=64)
    ap.add_argument("--noise", action="store_true", help="measure the texels' integration noise instead")
    ap.add_argument("--modes", action="store_true", help="add the error of truncating each mode (HOSVD)")
    a = ap.parse_args()
    if a.noise:
        for name in a.preset or ["denim", "shot"]:
            _noise(name, a.texels)
        return
    grid = Grid.paper() if a.grid == "paper" else Grid.regular(theta_step_deg=30, phi_step_deg=90,
                                                               kappa=[-0.22, 0.0, 0.22])
    rng = np.random.default_rng(0)
    for name in a.preset or ["denim", "shot"]:
        model = presets.model(name)
        t0 = time.perf_counter()
        if isinstance(model, PileModel):
            dense, layout = tabulate_pile_texels(model, grid, texels=(a.texels, a.texels))
            repeat = layout.repeat_mm
        else:
            dense = tabulate_texels(model, grid, texels=a.texels, points_per_texel=a.points_per_texel)
            repeat = model.heightfield(0.0).size_mm
        t_tex = time.perf_counter() - t0
        t0 = time.perf_counter()
        btf = CDBTF.from_values(dense, grid, repeat_mm=repeat, max_error=a.max_error, attrs=model.attrs())
        t_comp = time.perf_counter() - t0
        if a.save:
            btf.save(f"{a.save}/{name}-btf.h5")
        t = a.texels * a.texels
        d = dense[0, 0].size
        rank_100 = max(0, int((t * d / 100 - d) // (t + d)))  # largest rank at >= 100:1
        at_100 = CDBTF.from_values(dense, grid, repeat_mm=repeat, max_error=0.0, max_rank=rank_100)
        t0 = time.perf_counter()
        ref = model.tabulate(grid)
        t_ref = time.perf_counter() - t0
        r, m = ref.values, btf.mean().values
        rel = np.abs(m - r) / np.maximum(np.abs(r), 1e-3 * r.max())
        n = a.queries
        u, v = rng.uniform(0, 10 * repeat[0], n), rng.uniform(0, 10 * repeat[1], n)
        q = (rng.uniform(0, 75, n), rng.uniform(0, 360, n), rng.uniform(0, 75, n), rng.uniform(0, 360, n),
             rng.uniform(grid.kappa[0], grid.kappa[-1], n))
        got = btf.evaluate(u, v, *q)
        want = _dense_evaluate(_Dense(dense, grid), repeat, u, v, q)
        q_err = float(np.sqrt(np.sum((got - want) ** 2) / np.sum(want ** 2)))
        at100 = at_100.evaluate(u, v, *q)
        q_err_100 = float(np.sqrt(np.sum((at100 - want) ** 2) / np.sum(want ** 2)))
        c = btf.compression
        print(json.dumps({
            "preset": name, "texels": a.texels, "grid": a.grid, "rank": btf.rank,
            "relative_rms_error": round(c["relative_rms_error"], 5),
            "relative_rms_error_per_kappa": [round(e, 5) for e in c["relative_rms_error_per_kappa"]],
            "compression_ratio": round(c["compression_ratio"], 2),
            "query_relative_rms_error": round(q_err, 5),
            "rank_at_100_to_1": rank_100, "error_at_100_to_1": round(at_100.compression["relative_rms_error"], 5),
            "query_error_at_100_to_1": round(q_err_100, 5),
            "tile_mean_vs_synth_median": round(float(np.median(rel)), 5),
            "tile_mean_vs_synth_p90": round(float(np.percentile(rel, 90)), 5),
            **({"mode_errors": _mode_errors(dense)} if a.modes else {}),
            "seconds": {"texels": round(t_tex, 1), "compress": round(t_comp, 1), "synth_cdbrdf": round(t_ref, 1)},
        }), flush=True)


if __name__ == "__main__":
    main()
