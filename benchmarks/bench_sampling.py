"""Benchmark: noise of the plug-in's table sampling against cosine sampling, at equal samples and equal time.

Run: ``.venv/bin/python benchmarks/bench_sampling.py [--size 160x120] [--spp 16] [--ref-spp 2048] [--rgl DIR]``

The paper's sine sheet (60 x 60 mm, A = 2 mm, L = 20 mm, curvature from the
mesh), path tracer with max_depth 3, ``llvm_ad_rgb``, under two lights:

- ``envmap``: a sky (0.3 to 1 from the horizon to the zenith) with two soft
  boxes (radiance 20, 12 degrees across) seen in the sheet's reflection;
- ``area``: a studio soft box, a 150 x 150 mm rectangle light 86 mm from the
  sheet's centre, 35 degrees from the zenith (it spans about 80 degrees).

Materials, each rendered by the plug-in with ``sampling="cosine"`` and
``sampling="table"``:

- ``glossy``: a tabulated Blinn-Phong lobe (exponent 200, peak ~ 16 sr^-1)
  on a 5 degree / 10 degree grid;
- ``satin``: RGL's ``satin_rosaline_rgb.bsdf`` (a measured satin vinyl),
  tabulated on the same grid by evaluating Mitsuba's own ``measured`` plug-in;
- ``denim``: the bundled denim table (the paper's grid, 5 curvatures).

Side by side, in the same run: Mitsuba's C++ ``measured`` on the RGL file and
the plug-in on the tabulated satin (each against its own reference).

Noise: relative MSE, ``mean((x - ref)^2 / (ref^2 + 0.01))`` over pixels and
channels, against a ``--ref-spp`` render (table sampling; both samplers are
unbiased for the same image), averaged over ``--seeds`` renders of ``--spp``.
Time: the process's CPU time of one ``--time-spp`` render, per sample per
pixel. Efficiency ratio = (MSE x time) cosine / (MSE x time) table: how much
lower the table sampler's MSE is at equal time. Targets: >= 4 on ``glossy``
(both lights), >= 1 / 1.1 on ``denim``. Exits 1 when one is missed.
"""

from __future__ import annotations

import argparse
import math
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import cdbrdf

RGL_DIR = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "rgl"

TARGET_GLOSSY = 4.0
TARGET_DENIM = 1.0 / 1.1


def unit(theta_deg, phi_deg):
    t, p = np.radians(theta_deg), np.radians(phi_deg)
    return np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], axis=-1)


def fine_grid(kappa=(0.0,)) -> cdbrdf.Grid:
    th = np.arange(0.0, 86.0, 5.0)
    ph = np.arange(0.0, 360.0, 10.0)
    return cdbrdf.Grid(kappa=list(kappa), theta_l=th, phi_l=ph, theta_v=th, phi_v=ph)


def glossy_table(exponent=200.0, ks=0.5, kd=0.03) -> cdbrdf.CDBRDF:
    g = fine_grid()
    m = g.mesh()
    h = unit(m["theta_l"], m["phi_l"]) + unit(m["theta_v"], m["phi_v"])
    h /= np.linalg.norm(h, axis=-1, keepdims=True)
    f = kd + ks * (exponent + 2) / (2 * math.pi) * np.clip(h[..., 2], 0, 1) ** exponent
    rgb = f[..., None] * np.array([1.0, 0.85, 0.7])
    return cdbrdf.CDBRDF(rgb.astype(np.float32), g, attrs={"material": "glossy lobe"})


def tabulate_measured(mi, dr, path: Path) -> cdbrdf.CDBRDF:
    """The RGL file through Mitsuba's ``measured`` plug-in, sampled on :func:`fine_grid` (f = eval / cos)."""
    g = fine_grid()
    m = g.mesh()
    bsdf = mi.load_dict({"type": "measured", "filename": str(path)})
    wi = unit(m["theta_v"], m["phi_v"]).reshape(-1, 3)
    wo = unit(m["theta_l"], m["phi_l"]).reshape(-1, 3)
    si = dr.zeros(mi.SurfaceInteraction3f, wi.shape[0])
    si.wi = mi.Vector3f(np.ascontiguousarray(wi.T, dtype=np.float32))
    si.sh_frame = mi.Frame3f(mi.Vector3f(0, 0, 1))
    v = np.array(bsdf.eval(mi.BSDFContext(), si, mi.Vector3f(np.ascontiguousarray(wo.T, dtype=np.float32)))).T
    f = v / np.maximum(wo[:, 2:3], 1e-6)
    return cdbrdf.CDBRDF(f.reshape(g.shape + (3,)).clip(0).astype(np.float32), g,
                         attrs={"material": path.stem})


def sky(path: Path) -> None:
    """The environment map (lat-long, 128 x 256): gradient sky and two soft boxes."""
    import mitsuba as mi

    h, w = 128, 256
    th = (np.arange(h) + 0.5) / h * 180.0  # from the map's zenith (Mitsuba's +Y; turned to +z in the scene)
    ph = (np.arange(w) + 0.5) / w * 360.0
    T, P = np.meshgrid(th, ph, indexing="ij")
    img = np.clip(1.0 - T / 90.0 * 0.7, 0.3, 1.0)[..., None] * np.array([0.6, 0.75, 1.0])
    d = unit(T, P)
    for tc, pc in ((35.0, 80.0), (55.0, 250.0)):
        c = unit(tc, pc)
        img[(d @ c) > math.cos(math.radians(6.0))] = 20.0
    mi.Bitmap(img.astype(np.float32)).write(str(path))


def scene(mi, *, light: str, env: Path, size, bsdf) -> object:
    """The sine sheet with ``bsdf`` under the sky (z up) or the rectangle light."""
    import cdbrdf.render as cr
    from cdbrdf.mesh import write_ply
    from cdbrdf.render import scenes

    mesh = scenes.sine_sheet_mesh(scenes.SineSheet())
    T = mi.ScalarTransform4f
    if light == "envmap":
        emitter = {"type": "envmap", "filename": str(env), "to_world": T().rotate([1, 0, 0], 90.0)}
    else:
        emitter = {"type": "rectangle",
                   "to_world": T().look_at(origin=[0, 50, 70], target=[0, 0, 0], up=[0, 0, 1]) @ T().scale([75, 75, 1]),
                   "emitter": {"type": "area", "radiance": {"type": "rgb", "value": 2.0}}}
    with tempfile.TemporaryDirectory() as tmp:
        ply = Path(tmp) / "sheet.ply"
        write_ply(ply, mesh)
        e = math.radians(40.0)  # the camera 40 degrees above the sheet, from -y (across the corrugations)
        return cr.load_dict({
            "type": "scene",
            "integrator": {"type": "path", "max_depth": 3},
            "sensor": {"type": "perspective", "fov": 40.0, "fov_axis": "smaller",
                       "to_world": T().look_at(origin=[0.0, -110.0 * math.cos(e), 110.0 * math.sin(e)],
                                               target=[0, 0, 0], up=[0, 0, 1]),
                       "film": {"type": "hdrfilm", "width": size[0], "height": size[1]},
                       "sampler": {"type": "independent", "sample_count": 16}},
            "sheet": {"type": "ply", "filename": str(ply), "bsdf": bsdf},
            "light": emitter,
        })


def rel_mse(x: np.ndarray, ref: np.ndarray) -> float:
    return float(np.mean((x - ref) ** 2 / (ref**2 + 0.01)))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--size", default="160x120", help="image size WxH (default 160x120)")
    ap.add_argument("--spp", type=int, default=16, help="samples per pixel of the measured renders (default 16)")
    ap.add_argument("--seeds", type=int, default=8, help="renders averaged per MSE (default 8)")
    ap.add_argument("--ref-spp", type=int, default=2048, help="samples per pixel of the references (default 2048)")
    ap.add_argument("--time-spp", type=int, default=128, help="samples per pixel of the timed render (default 128)")
    ap.add_argument("--rgl", type=Path, default=RGL_DIR, help=f"folder of the RGL .bsdf files (default {RGL_DIR})")
    args = ap.parse_args(argv)
    size = tuple(int(x) for x in args.size.split("x"))

    import cdbrdf.render as cr

    cr.set_variant("llvm_ad_rgb")
    import drjit as dr
    import mitsuba as mi

    from cdbrdf.materials import load as load_material

    satin_file = args.rgl / "satin_rosaline_rgb.bsdf"
    materials = {"glossy": glossy_table(), "denim": load_material("denim")}
    if satin_file.is_file():
        materials["satin"] = tabulate_measured(mi, dr, satin_file)
    else:
        print(f"({satin_file} not found: the measured satin and Mitsuba's measured are skipped)")

    def render(sc, spp, seed):
        img = mi.render(sc, spp=spp, seed=seed)
        return np.array(img, dtype=np.float64)[..., :3]

    def cpu(sc, spp):
        render(sc, 4, 99)  # compiled
        c0 = time.process_time()
        img = mi.render(sc, spp=spp, seed=98)
        dr.eval(img)
        dr.sync_thread()
        return (time.process_time() - c0) / spp

    def measure(sc, ref):
        mse = np.mean([rel_mse(render(sc, args.spp, 1000 + s), ref) for s in range(args.seeds)])
        return mse, cpu(sc, args.time_spp)

    rows = []
    ok = True
    with tempfile.TemporaryDirectory() as tmp:
        env = Path(tmp) / "sky.exr"
        sky(env)
        for light in ("envmap", "area"):
            for name, table in materials.items():
                kinds = {s: {"type": "cdbrdf", "table": table, "sampling": s} for s in ("cosine", "table")}
                if name == "satin":
                    kinds["measured (C++)"] = {"type": "measured", "filename": str(satin_file)}
                res = {}
                ref_t = None
                for kind, bsdf in kinds.items():
                    sc = scene(mi, light=light, env=env, size=size, bsdf=bsdf)
                    if kind == "cosine":
                        continue  # its reference is the table sampler's (same image)
                    ref = render(sc, args.ref_spp, 7)
                    if kind == "table":
                        ref_t = ref
                    res[kind] = measure(sc, ref)
                sc = scene(mi, light=light, env=env, size=size, bsdf=kinds["cosine"])
                res["cosine"] = measure(sc, ref_t)
                eff = (res["cosine"][0] * res["cosine"][1]) / (res["table"][0] * res["table"][1])
                rows.append((light, name, res, eff))
                if name == "glossy":
                    ok &= eff >= TARGET_GLOSSY
                if name == "denim":
                    ok &= eff >= TARGET_DENIM
    print(f"sine sheet {size[0]}x{size[1]}, path max_depth 3, llvm_ad_rgb (Mitsuba {mi.__version__}); "
          f"relMSE of {args.spp} spp (mean of {args.seeds}) against {args.ref_spp} spp; "
          f"CPU time per spp of a {args.time_spp} spp render")
    print(f"{'light':<7} {'material':<8} {'sampler':<15} {'relMSE':>10} {'ms/spp':>7} {'MSE x t':>10}")
    for light, name, res, eff in rows:
        for kind, (mse, t) in res.items():
            print(f"{light:<7} {name:<8} {kind:<15} {mse:>10.3e} {1e3 * t:>7.2f} {mse * t:>10.3e}")
        mse_ratio = res["cosine"][0] / res["table"][0]
        print(f"{'':<7} {name:<8} table vs cosine: {mse_ratio:.2f}x lower MSE at equal samples, "
              f"{eff:.2f}x at equal time")
    print("targets: glossy >= 4x at equal time, denim >= 1/1.1 (no worse than 1.1x):", "OK" if ok else "MISSED")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
