"""What ``cdbrdf measure --btf`` recovers from the simulated rig, and what a real rig needs.

Run: ``.venv/bin/python scripts/btf_rig_study.py {repeat,registration,pixels,denim} [--folder DIR]``

Each study renders captures with :func:`cdbrdf.rig.simulate_capture`,
measures them with ``measure(..., btf=...)`` and prints one line per case:
the median relative error on the measured samples against the CD-BTF the rig
rendered (decoded at the same texels and samples), over all and per stand.

``repeat``
    A random-texel test texture (8 x 8 texels, each an independent multiple
    0.5..1.5 of a glossy lobe; the texture of ``tests/test_measure_btf.py``)
    with repeats of 1.6 x 1.2, 0.8 x 0.6 and 0.4 x 0.3 mm, one fabric
    position; then 1.6 x 1.2 mm with 4 positions (a scan).
``registration``
    The 0.4 x 0.3 mm capture measured with its registration shifted by 0.1,
    0.25 and 0.5 texel along u and 0.25, 0.5 along v.
``pixels``
    The 0.4 x 0.3 mm texture at 1.5 to 6 pixels per texel.
``denim``
    The denim model's CD-BTF (8 x 8 texels, 16 points per texel) at 4 or 16
    samples per pixel, 1, 4 or 8 fabric positions, with and without brackets.

The grid: theta 0/30/60, phi every 90 degrees, kappa -0.22/0/0.22.
``docs/capture.md`` ("Measuring a CD-BTF") quotes its output.
"""

from __future__ import annotations

import argparse
import json
import shutil
import sys
import tempfile
import time
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from cdbrdf import CDBTF, Grid
from cdbrdf.errors import CaptureError
from cdbrdf.frames import direction_from_angles
from cdbrdf.measure import measure
from cdbrdf.rig import RigOptions, simulate_capture

GRID = Grid.regular(theta_step_deg=30, phi_step_deg=90, theta_max_deg=60, kappa=[-0.22, 0.0, 0.22])


def texture(repeat_mm: tuple[float, float], texels: int = 8, seed: int = 3) -> CDBTF:
    """Random texel multiples of a glossy, curvature-dependent lobe (as tests/test_measure_btf.py)."""
    rng = np.random.default_rng(seed)
    m = GRID.mesh()
    h = direction_from_angles(m["theta_l"], m["phi_l"]) + direction_from_angles(m["theta_v"], m["phi_v"])
    h /= np.linalg.norm(h, axis=-1, keepdims=True)
    base = (0.05 + 0.3 * np.clip(h[..., 2], 0, 1) ** 8 * (1 + m["kappa"]))[..., None] * [1.0, 0.7, 0.4]
    tilt = (0.05 * h[..., 0] * (1 + m["kappa"]))[..., None] * [0.2, 0.3, 0.6]
    w = rng.uniform(-1, 1, (texels, texels, 1))[..., None, None, None, None, None]
    vals = np.maximum(base[None, None] * (1 + 0.5 * w) + w * tilt, 0.0)
    return CDBTF.from_values(vals, GRID, repeat_mm=repeat_mm, max_error=1e-4, attrs={"material": "texels"})


def line(name: str, truth: CDBTF, folder: Path, t0: float) -> str:
    """Measure ``folder`` and describe the errors against ``truth``."""
    t1 = time.perf_counter()
    got, rep = measure(folder, btf=truth.texels)
    t = truth.decode().astype(np.float64)
    rel = np.abs(got.decode() - t) / np.maximum(np.abs(t), 1e-6)
    m = rep.measured
    per = " / ".join(f"{100 * np.median(rel[:, :, k][:, :, m[k]]):.2f}" for k in range(m.shape[0]))
    return (f"{name}: median {100 * np.median(rel[:, :, m]):.2f} % (per stand {per} %), "
            f"p90 {100 * np.percentile(rel[:, :, m], 90):.1f} %, {rep.n_measured}/{m.size} measured, "
            f"{rep.px_per_texel:.1f} px/texel; {t1 - t0:.0f} s rendering, {time.perf_counter() - t1:.0f} s measuring")


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("study", choices=("repeat", "registration", "pixels", "denim"))
    ap.add_argument("--folder", type=Path, default=None, help="work folder (default: a temporary one)")
    args = ap.parse_args(argv)
    work = args.folder or Path(tempfile.mkdtemp(prefix="btf-study-"))
    cap = work / "cap"
    if args.study == "repeat":
        for rp, shifts in (((1.6, 1.2), 1), ((0.8, 0.6), 1), ((0.4, 0.3), 1), ((1.6, 1.2), 4)):
            btf, t0 = texture(rp), time.perf_counter()
            simulate_capture(btf, cap, RigOptions(seed=1, shifts=shifts))
            print(line(f"repeat {rp[0]:g} x {rp[1]:g} mm, {shifts} position(s)", btf, cap, t0), flush=True)
    elif args.study == "registration":
        btf, t0 = texture((0.4, 0.3)), time.perf_counter()
        simulate_capture(btf, cap, RigOptions(seed=1))
        print(line("registered", btf, cap, t0), flush=True)
        for axis, frac in ((0, 0.1), (0, 0.25), (0, 0.5), (1, 0.25), (1, 0.5)):
            moved = work / "moved"
            shutil.rmtree(moved, ignore_errors=True)
            shutil.copytree(cap, moved)
            doc = json.loads((moved / "stands.json").read_text())
            for e in doc["registration"]["stands"]:
                e["uv"[axis] + "_mm"] += frac * btf.repeat_mm[axis] / btf.texels[axis]
            (moved / "stands.json").write_text(json.dumps(doc))
            print(line(f"registration off by {frac:g} texel along {'uv'[axis]}", btf, moved, time.perf_counter()),
                  flush=True)
    elif args.study == "pixels":
        btf = texture((0.4, 0.3))
        for ppt in (1.5, 2.0, 2.5, 3.0, 4.0, 6.0):
            t0 = time.perf_counter()
            simulate_capture(btf, cap, RigOptions(seed=1, px_per_texel=ppt))
            try:
                print(line(f"{ppt:g} px/texel", btf, cap, t0), flush=True)
            except CaptureError as exc:
                print(f"{ppt:g} px/texel: refused: {exc}", flush=True)
    else:
        from cdbrdf.synth import presets
        from cdbrdf.synth.texels import tabulate_btf

        btf = tabulate_btf(presets.model("denim"), GRID, texels=8, points_per_texel=16)
        for spp, shifts, exps in ((4, 1, (1.0,)), (16, 1, (1.0,)), (16, 4, (1.0,)), (16, 4, (1.0, 8.0)),
                                  (16, 8, (1.0, 8.0))):
            t0 = time.perf_counter()
            simulate_capture(btf, cap, RigOptions(seed=1, spp=spp, shifts=shifts, exposures=exps))
            print(line(f"denim, {spp} spp, {shifts} position(s), exposures {exps}", btf, cap, t0), flush=True)
    if args.folder is None:
        shutil.rmtree(work, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
