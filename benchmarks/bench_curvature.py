"""Benchmark: the curvature of a mesh (repair, scale-aware fit, frame) per 100k vertices.

Run: ``.venv/bin/python benchmarks/bench_curvature.py [--vertices 100000] [--large-faces 1000000] [--repeat 3]``

The meshes: the generated garment (:func:`cdbrdf.mesh.skirt_mesh`:
two sewn panels with opposite winding, folds, a double-sided sash), in mm,
at two resolutions, about ``--vertices`` vertices (edges of about 3 mm,
coarser than the neighbourhood, as a garment from a CAD tool) and about
``--large-faces`` faces; and a scan: a jittered half-cylinder of radius
1/0.22 mm with about ``--vertices`` vertices (0.1 mm edges, 0.02 mm noise,
much finer than the neighbourhood: the thinned path). For each, timed in
the same run:

- :func:`cdbrdf.mesh.surface_curvature` (everything ``cdbrdf
  curvature`` does between reading and writing: repair, fit, frame) at the
  default neighbourhood (5 mm), at the denim's measured spot (1 mm) and at
  a large one (50 mm);
- the reference: libigl's ``principal_curvature`` (radius 2 edge lengths,
  the estimator cdbrdf used before) on the same, already repaired surface.

Each case runs once untimed (numba compilation, caches), then ``--repeat``
times; the best time counts. Targets: <= 3 s per 100k vertices at the
default neighbourhood, and the large mesh in under 60 s at every
neighbourhood. Exits 1 when a target is missed.
"""

from __future__ import annotations

import argparse
import math
import os
import sys

from cdbrdf._jit import cpu_count

from _common import best_seconds, jittered_triangulation

TARGET_S_PER_100K = 3.0
TARGET_LARGE_S = 60.0


def _skirt(n_vertices: int):
    from cdbrdf.mesh import Skirt, skirt_mesh

    # two panels of around x down vertices: around = 1.6 down keeps the triangles near-square
    down = max(8, int(round(math.sqrt(n_vertices / (2 * 1.6)))))
    return skirt_mesh(Skirt(around=int(1.6 * down), down=down))


def _scan(n_vertices: int):
    import numpy as np

    from cdbrdf.mesh import Mesh

    rng = np.random.default_rng(0)
    uv, f = jittered_triangulation(n_vertices, rng)
    r = 1 / 0.22
    a = (uv[:, 0] - 0.5) * math.pi
    p = np.c_[r * np.sin(a), (uv[:, 1] - 0.5) * math.pi * r, r * np.cos(a)]
    p += rng.normal(scale=0.02, size=p.shape)
    return Mesh(p, f, None, uv)



def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--vertices", type=int, default=100_000, help="vertices of the first mesh (default 100000)")
    ap.add_argument("--large-faces", type=int, default=1_000_000, help="faces of the large mesh (default 1000000)")
    ap.add_argument("--repeat", type=int, default=3, help="timed runs per case (default 3; 1 for the large mesh)")
    args = ap.parse_args(argv)

    import igl

    from cdbrdf.mesh import repair, surface_curvature

    ok = True
    print(f"cores: {os.cpu_count()}, threads: {cpu_count()}")
    for label, mesh, repeat in (("mesh", _skirt(args.vertices), args.repeat),
                                ("scan", _scan(args.vertices), args.repeat),
                                ("large", _skirt(args.large_faces // 2), 1)):
        v, f, uv = mesh.vertices, mesh.faces, mesh.uv
        n = v.shape[0]
        print(f"{label}: {n:,} vertices, {f.shape[0]:,} faces")
        rep = repair(v, f, uv=uv)
        t_igl = best_seconds(lambda rep=rep: igl.principal_curvature(rep.vertices, rep.faces, 2, False), repeat)
        print(f"  libigl principal_curvature (radius 2 edges, repaired surface): {t_igl:7.2f} s "
              f"({t_igl / n * 1e5:.2f} s per 100k vertices)")
        for nb in (5.0, 1.0, 50.0):
            t = best_seconds(lambda nb=nb, v=v, f=f, uv=uv: surface_curvature(v, f, uv=uv, neighbourhood_mm=nb), repeat)
            per = t / n * 1e5
            flag = ""
            if label in ("mesh", "scan") and nb == 5.0 and per > TARGET_S_PER_100K:
                flag, ok = f"  MISSED (target {TARGET_S_PER_100K:g} s per 100k)", False
            if label == "large" and t > TARGET_LARGE_S:
                flag, ok = f"  MISSED (target {TARGET_LARGE_S:g} s)", False
            print(f"  surface_curvature, neighbourhood {nb:4g} mm: {t:7.2f} s ({per:.2f} s per 100k vertices, "
                  f"{t / t_igl:.2f} x libigl){flag}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
