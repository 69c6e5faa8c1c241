"""Building a CD-BTF: the time of each stage of ``cdbrdf synth PRESET --btf N`` (tabulation, fit, error, file).

Run: ``python benchmarks/bench_btf_build.py [--preset denim] [--texels 32] [--max-error 0.03] [-o FILE]``.

Tabulates the preset's texels on the paper's grid (:func:`cdbrdf.synth.texels.tabulate_texels`; a pile:
:func:`cdbrdf.synth.pile_texels.tabulate_pile_texels`), compresses them as ``cdbrdf synth --btf`` does
(:meth:`cdbrdf.CDBTF.from_values`, ``method="neural"``: the fit, the error over every sample, residual
components while ``--max-error`` needs them) and writes the file. Prints one JSON object: the wall and the
process CPU seconds of each stage and in all, the load average of the machine before and after (the
wall time on a shared machine is the CPU time stretched by the load), the CD-BTF's method, rank, errors and
ratio, and the file's size and its ratio against raw float32.
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
import time

import numpy as np


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--preset", default="denim")
    ap.add_argument("--texels", type=int, default=32)
    ap.add_argument("--max-error", type=float, default=0.03)
    ap.add_argument("--method", default="neural")
    ap.add_argument("-o", "--output", default=None, help="keep the file here")
    a = ap.parse_args()

    from cdbrdf import CDBTF, Grid
    from cdbrdf.synth import PileModel, presets
    from cdbrdf.synth.pile_texels import tabulate_pile_texels
    from cdbrdf.synth.texels import POINTS_PER_TEXEL, tabulate_texels, texel_model

    out: dict = {"preset": a.preset, "texels": a.texels, "max_error": a.max_error, "cpus": os.cpu_count(),
                 "load_before": os.getloadavg()[0]}
    grid = Grid.paper()
    model = presets.model(a.preset)
    w0, c0 = time.perf_counter(), time.process_time()
    if isinstance(model, PileModel):
        dense, layout = tabulate_pile_texels(model, grid, texels=(a.texels, a.texels))
        attrs, repeat = model.attrs(), layout.repeat_mm
    else:
        dense = tabulate_texels(model, grid, texels=a.texels)
        attrs = texel_model(model, a.texels, points_per_texel=POINTS_PER_TEXEL).attrs()
        repeat = model.heightfield(0.0).size_mm
    w1, c1 = time.perf_counter(), time.process_time()
    btf = CDBTF.from_values(dense, grid, repeat_mm=repeat, max_error=a.max_error, attrs=attrs, method=a.method)
    w2, c2 = time.perf_counter(), time.process_time()
    path = a.output or os.path.join(tempfile.mkdtemp(), "btf.h5")
    btf.save(path)
    w3, c3 = time.perf_counter(), time.process_time()
    c = btf.compression
    out.update({
        "tabulate_seconds": round(w1 - w0, 1), "tabulate_cpu_seconds": round(c1 - c0, 1),
        "compress_seconds": round(w2 - w1, 1), "compress_cpu_seconds": round(c2 - c1, 1),
        "fit_seconds": c.get("fit_seconds"), "write_seconds": round(w3 - w2, 1),
        "total_seconds": round(w3 - w0, 1), "total_cpu_seconds": round(c3 - c0, 1),
        "load_after": os.getloadavg()[0], "method": btf.method, "rank": btf.rank,
        "relative_rms_error": round(c["relative_rms_error"], 4),
        "relative_rms_error_per_kappa": [round(e, 4) for e in c["relative_rms_error_per_kappa"]],
        "neural_relative_rms_error": c.get("neural_relative_rms_error"),
        "compression_ratio": round(c["compression_ratio"], 1), "file_bytes": os.path.getsize(path),
        "file_ratio": round(4.0 * dense.size / os.path.getsize(path), 1),
        "tile_mean_vs_texel_mean": round(float(np.max(np.abs(btf.mean().values - dense.mean(axis=(0, 1))))
                                               / np.max(np.abs(dense.mean(axis=(0, 1))))), 6),
    })
    print(json.dumps(out))


if __name__ == "__main__":
    main()
