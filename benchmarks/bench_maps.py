"""Benchmark: the render time of a mesh with a curvature map against the same mesh without it.

Run: ``.venv/bin/python benchmarks/bench_maps.py [--size 512] [--spp 64] [--repeat 5] [--texels 1024]``

Same run, same Mitsuba variant (``llvm_ad_rgb``), same scene: the draped
cloth (:func:`cdbrdf.mesh.draped_cloth_mesh`, 100 mm, its own UVs) with the
bundled shot fabric under the studio lighting, path tracer with max_depth 3,
rendered by the ``cdbrdf`` plug-in

- without a map (the mesh's own per-vertex curvature: the reference);
- with a wrinkle normal map baked per texel (``--texels`` square, sine
  wrinkles of 10 mm and 0.4 mm plus a finer weave-like ripple): the map
  looked up per shading point (the level of the pixel's footprint, one of
  the two levels around it chosen stochastically: four texel reads), its
  curvature added to the mesh's shape operator, its normal tilting the
  shading frame (the default, the target's);
- the same map with both levels blended (``map_filter="trilinear"``: eight
  texel reads) and with one fixed level (``"none"``: four, no footprint),
  to show what the filtering costs.

Every scene is rendered once untimed (tracing, compilation), then
``--repeat`` times interleaved; the best CPU time of each counts (wall
times beside it). Target: with the map <= 1.1x without. Exits 1 when missed.
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np

TARGET = 1.1


def wrinkle_normals(texels: int, *, period_mm: float = 10.0, amplitude_mm: float = 0.4,
                    size_mm: float = 100.0) -> np.ndarray:
    """Tangent-space normals of sine wrinkles along u with a weave-like ripple (``texels`` square)."""
    t = (np.arange(texels) + 0.5) / texels * size_mm
    u, v = np.meshgrid(t, t)
    k = 2 * np.pi / period_mm
    hx = amplitude_mm * k * np.cos(k * u) + 0.02 * np.cos(2 * np.pi * u / 0.8) * np.cos(2 * np.pi * v / 0.8)
    hy = 0.02 * np.sin(2 * np.pi * u / 0.8) * np.sin(2 * np.pi * v / 0.8)
    n = np.stack([-hx, hy, np.ones_like(hx)], axis=-1)
    return n / np.linalg.norm(n, axis=-1, keepdims=True)


def timed(mi, dr, scene, spp: int, seed: int) -> tuple[float, float]:
    """``(cpu_s, wall_s)`` of one render, evaluated and synchronised."""
    c0, t0 = time.process_time(), time.perf_counter()
    img = mi.render(scene, spp=spp, seed=seed)
    dr.eval(img)
    dr.sync_thread()
    return time.process_time() - c0, time.perf_counter() - t0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--size", type=int, default=512, help="image width and height (default 512)")
    ap.add_argument("--spp", type=int, default=64, help="samples per pixel (default 64)")
    ap.add_argument("--repeat", type=int, default=5, help="timed renders per scene (default 5)")
    ap.add_argument("--texels", type=int, default=1024, help="the normal map's side in texels (default 1024)")
    args = ap.parse_args(argv)

    import cdbrdf.materials
    import cdbrdf.render as cr
    from cdbrdf.mesh import DrapedCloth, SurfaceMaps, draped_cloth_mesh, normal_map_from_normals, prepare_mesh

    cr.set_variant("llvm_ad_rgb")
    import drjit as dr
    import mitsuba as mi

    from cdbrdf.render import RenderSpec
    from cdbrdf.render.scenes import mesh_scene

    table = cdbrdf.materials.load("shot")
    cloth = draped_cloth_mesh(DrapedCloth())
    cloth.attributes.clear()  # its curvature computed as a user's mesh's
    t0 = time.perf_counter()
    nmap = normal_map_from_normals(wrinkle_normals(args.texels), name="wrinkles")
    mapped = prepare_mesh(cloth, table=table, maps=SurfaceMaps(normal_map=nmap, uv_scale=100.0))
    bake_s = time.perf_counter() - t0
    plain = mapped.copy()
    for key in ("curvature_map", "uv_scale"):
        plain.metadata.pop(key)
    cmap = mapped.metadata["curvature_map"]
    kw = dict(size=(args.size, args.size), spp=args.spp, max_depth=3)
    scenes = {
        "no map": mesh_scene(table, RenderSpec(surface=plain, **kw)),
        "curvature map": mesh_scene(table, RenderSpec(surface=mapped, **kw)),
    }
    for how in ("trilinear", "none"):
        scenes[f"curvature map, {how}"] = mesh_scene(table, RenderSpec(surface=mapped, **kw),
                                                     bsdf={"type": "cdbrdf", "table": table,
                                                           "curvature": "vertex_curvature", "map_filter": how})
    for sc in scenes.values():
        timed(mi, dr, sc, args.spp, 0)
    cpu: dict[str, list[float]] = {name: [] for name in scenes}
    wall: dict[str, list[float]] = {name: [] for name in scenes}
    for r in range(args.repeat):
        for name, sc in scenes.items():
            c, w = timed(mi, dr, sc, args.spp, r + 1)
            cpu[name].append(c)
            wall[name].append(w)
    best = {n: min(v) for n, v in cpu.items()}
    best_w = {n: min(v) for n, v in wall.items()}
    ref, ref_w = best["no map"], best_w["no map"]
    print(f"draped cloth ({mapped.n_vertices} vertices) {args.size}x{args.size}, {args.spp} spp, path max_depth 3, "
          f"llvm_ad_rgb (Mitsuba {mi.__version__}, Dr.Jit {dr.__version__}); best of {args.repeat}")
    print(f"map: {cmap.texels[0]} x {cmap.texels[1]} texels, {cmap.n_levels} levels, {cmap.nbytes / 1e6:.1f} MB; "
          f"prepared and baked in {bake_s:.1f} s")
    print(f"{'scene':<24} {'CPU (s)':>8} {'ratio':>6} {'wall (s)':>9} {'ratio':>6}")
    for name in scenes:
        print(f"{name:<24} {best[name]:>8.2f} {best[name] / ref:>6.3f} {best_w[name]:>9.2f} "
              f"{best_w[name] / ref_w:>6.3f}")
    ratio = best["curvature map"] / ref
    ok = ratio <= TARGET
    print(f"curvature map / no map = {ratio:.3f} (target <= {TARGET}): {'OK' if ok else 'MISSED'}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
