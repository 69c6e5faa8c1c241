"""Hand-made capture folders with known values, for the measurement tests."""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import numpy as np

from cdbrdf import Grid
from cdbrdf.colour import linear_to_srgb
from cdbrdf.images import write_exr, write_png, write_tiff


def encode(lin: np.ndarray, kind: str) -> np.ndarray:
    """Codes for linear values in [0, 1]: png16/png8/tif16/tif8 sRGB, exr/tiflin linear."""
    if kind in ("exr", "tiff32"):
        return lin.astype(np.float32)
    top = 65535 if kind.endswith("16") else 255
    dt = np.uint16 if top == 65535 else np.uint8
    return np.round(linear_to_srgb(np.clip(lin, 0, 1)) * top).astype(dt)


def write_image(path: Path, lin: np.ndarray, kind: str) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    codes = encode(lin, kind)
    if kind.startswith("png"):
        write_png(path, codes)
    elif kind.startswith("tif"):
        write_tiff(path, codes)
    else:
        write_exr(path, codes)


EXT = {"png16": "png", "png8": "png", "tif16": "tif", "tif8": "tif", "tiff32": "tif", "exr": "exr"}


def make_capture(folder: Path, grid: Grid, value, *, kind: str = "png16", size: int = 15,
                 white: float | None = None, stands: list[dict] | None = None,
                 extra_rows: list[dict] | None = None, settings: dict | None = None,
                 ring: float | None = None) -> list[dict]:
    """A capture folder whose sample photographs are uniform images.

    ``value(kappa, theta_v, phi_v, theta_l, phi_l)`` -> linear RGB pixel value
    (what the camera records: reflectance times cos(theta_l) times a scale).
    ``white``: linear value of a white-reference shot per light direction at
    normal incidence (scaled by cos(theta_l)). ``ring``: pixels outside the
    central 7 x 7 patch get this value instead (the patch must not see it).
    """
    folder.mkdir(parents=True, exist_ok=True)
    ext = EXT[kind]
    rows = []
    m = grid.mesh()
    for idx in np.ndindex(grid.shape):
        k, pl, tl, pv, tv = (m[n][idx] for n in ("kappa", "phi_l", "theta_l", "phi_v", "theta_v"))
        f = f"s/{'_'.join(str(i) for i in idx)}.{ext}"
        rows.append(dict(file=f, kappa=k, theta_v=tv, phi_v=pv, theta_l=tl, phi_l=pl, kind="sample"))
        lin = np.broadcast_to(np.asarray(value(k, tv, pv, tl, pl), float), (size, size, 3)).copy()
        if ring is not None:
            c = size // 2
            out = np.ones((size, size), bool)
            out[c - 3 : c + 4, c - 3 : c + 4] = False
            lin[out] = ring
        write_image(folder / f, lin, kind)
    if white is not None:
        for pl in grid.phi_l:
            for tl in grid.theta_l:
                f = f"w/{tl:g}_{pl:g}.{ext}"
                rows.append(dict(file=f, kappa="", theta_v=0, phi_v=0, theta_l=tl, phi_l=pl, kind="white"))
                write_image(folder / f, np.full((size, size, 3), white * np.cos(np.radians(tl))), kind)
    rows += extra_rows or []
    write_csv(folder / "capture.csv", rows)
    if stands is not None or settings is not None:
        doc = {**({"stands": stands} if stands is not None else {}), **(settings or {})}
        (folder / "stands.json").write_text(json.dumps(doc))
    return rows


def write_csv(path: Path, rows: list[dict]) -> None:
    cols: list[str] = []
    for r in rows:
        for c in r:
            if c not in cols:
                cols.append(c)
    with open(path, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=cols)
        w.writeheader()
        w.writerows(rows)


# --------------------------------------------------------------------------- a known material
#: The grid of most hand-made captures, and a smaller one.
GRID = Grid(kappa=[-0.2, 0.0, 0.2], theta_l=[0.0, 40.0], phi_l=[0.0, 180.0],
            theta_v=[0.0, 30.0, 60.0], phi_v=[0.0, 90.0, 180.0, 270.0])
SMALL = Grid(kappa=[0.0, 0.2], theta_l=[0.0, 40.0], phi_l=[0.0, 180.0],
             theta_v=[0.0, 30.0, 60.0], phi_v=[0.0, 90.0, 180.0, 270.0])
ALBEDO = 0.9
SCALE = 2.0
WHITE = ALBEDO / math.pi * SCALE


def brdf(k, tv, pv, tl, pl):
    """A smooth known BRDF (sr^-1), RGB."""
    return np.array([0.08, 0.12, 0.2]) * (1 + k) * (1 + 0.5 * np.cos(np.radians(tv)))


def pixel(k, tv, pv, tl, pl):
    return brdf(k, tv, pv, tl, pl) * np.cos(np.radians(tl)) * SCALE


def truth(grid=GRID):
    m = grid.mesh()
    return brdf(m["kappa"][..., None], m["theta_v"][..., None], 0, 0, 0)


def same_tables(a, b):
    assert a == b  # values, mask, fill source, std, attrs: exactly equal
    np.testing.assert_array_equal(a.values, b.values)


def kill_after_first_batch(folder: Path, out: Path, **measure_kwargs) -> int:
    """Run ``measure(folder, out, **measure_kwargs)`` in a child process, SIGKILL it once its checkpoint holds a
    batch, and return how many batches were saved (the child is slowed by a progress callback that sleeps)."""
    import os
    import signal
    import subprocess
    import sys
    import time

    import cdbrdf
    from cdbrdf.measure.checkpoint import checkpoint_path

    script = (
        "import sys, time, json\n"
        "from cdbrdf.measure import measure\n"
        "measure(sys.argv[1], sys.argv[2], **json.loads(sys.argv[3]), progress=lambda d, t: time.sleep(0.3))\n"
    )
    env = dict(os.environ)
    env["PYTHONPATH"] = str(Path(cdbrdf.__file__).parents[1]) + os.pathsep + env.get("PYTHONPATH", "")
    proc = subprocess.Popen([sys.executable, "-c", script, str(folder), str(out), json.dumps(measure_kwargs)],
                            env=env)
    ck = checkpoint_path(out)
    deadline = time.monotonic() + 60
    while not list(ck.glob("batch-*.npz")) and time.monotonic() < deadline and proc.poll() is None:
        time.sleep(0.02)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    return len(list(ck.glob("batch-*.npz")))
