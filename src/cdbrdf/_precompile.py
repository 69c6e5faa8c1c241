"""Compile every numba kernel of the package into its on-disk cache, once, after installing.

``python -m cdbrdf._precompile`` (``scripts/setup.sh`` runs it) calls each
kernel family through the public functions that use it, on tiny inputs of the
types real inputs have: the 5-D lookup (both kernels), the PLY reader, the
curvature fit (at the vertices and over a thinned mesh), the cloth model. The
machine code lands where numba caches it (next to the sources when that is
writable, else the user's cache folder; :mod:`cdbrdf._jit`), so the first
real use, and every test run of a fresh clone, loads it instead of compiling
for half a minute. Cached kernels load in a few seconds; nothing is compiled
twice.
"""

from __future__ import annotations

import logging
import tempfile
import time
from pathlib import Path

__all__ = ["precompile"]

_LOG = logging.getLogger(__name__)


def precompile() -> dict[str, float]:
    """Compile (or load from the cache) every kernel; returns seconds per kernel family."""
    import numpy as np

    from . import interp
    from .grid import Grid
    from .table import CDBRDF

    seconds: dict[str, float] = {}

    t = time.perf_counter()
    g = Grid(kappa=[0.0, 0.1], theta_l=[0.0, 30.0, 60.0], phi_l=[0.0, 180.0], theta_v=[0.0, 30.0, 60.0],
             phi_v=[0.0, 180.0])
    for dtype in (np.float32, np.float64):
        table = CDBRDF(np.full(g.shape + (3,), 0.2, dtype=dtype), g)
        for kernel in ("rgb", "generic"):
            interp.evaluate(table, 10.0, 20.0, 30.0, 40.0, 0.05, kernel=kernel)
    seconds["lookup"] = time.perf_counter() - t

    from .mesh import prepare_mesh, read_mesh

    t = time.perf_counter()
    n = 12
    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / "grid.ply"
        path.write_text(_ascii_ply(n), encoding="ascii")
        mesh = read_mesh(path)
    seconds["ply"] = time.perf_counter() - t
    t = time.perf_counter()
    prepare_mesh(mesh, units="mm", neighbourhood_mm=2.0)  # fitted at the vertices
    prepare_mesh(mesh, units="mm", neighbourhood_mm=50.0)  # over a thinned mesh, carried to the vertices
    seconds["curvature"] = time.perf_counter() - t

    from .synth import presets

    t = time.perf_counter()
    tiny = Grid(kappa=[0.0], theta_l=[20.0], phi_l=[0.0], theta_v=[30.0], phi_v=[0.0])
    presets.model("denim", texels=16, points=34, tilt_samples=1).tabulate(tiny)
    seconds["cloth model"] = time.perf_counter() - t
    t = time.perf_counter()
    presets.model("velvet", layers=2, azimuths=1, rings=1).tabulate(tiny)
    seconds["pile model"] = time.perf_counter() - t
    return seconds


def _ascii_ply(n: int) -> str:
    """An ASCII PLY of an ``n x n`` vertex grid, 1 mm apart, gently curved, in quads (a list property)."""
    lines = []
    for i in range(n):
        for j in range(n):
            lines.append(f"{i:.1f} {j:.1f} {0.02 * (i - n / 2) ** 2:.4f}")
    faces = [f"4 {i * n + j} {(i + 1) * n + j} {(i + 1) * n + j + 1} {i * n + j + 1}"
             for i in range(n - 1) for j in range(n - 1)]
    header = ["ply", "format ascii 1.0", f"element vertex {n * n}", "property float x", "property float y",
              "property float z", f"element face {len(faces)}", "property list uchar int vertex_indices",
              "end_header"]
    return "\n".join(header + lines + faces) + "\n"


def main() -> int:
    """Compile, and print the seconds per kernel family."""
    t = time.perf_counter()
    seconds = precompile()
    parts = ", ".join(f"{k} {v:.1f} s" for k, v in seconds.items())
    print(f"numba kernels compiled or loaded from the cache in {time.perf_counter() - t:.1f} s ({parts})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
