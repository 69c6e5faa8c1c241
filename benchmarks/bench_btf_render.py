"""Rendering a CD-BTF: the close-up shows the weave and its change along the crests; far away it is the CDBRDF.

Run: ``python benchmarks/bench_btf_render.py FILE [--picture out.png] [--spp 64] [--variant V] [--repeat 5]
[--no-close-up]`` with a CD-BTF file (``cdbrdf synth denim --btf 32 -o denim-btf.h5``).

- close-up: a 20 x 14 mm sine sheet (trough at x = -5 mm, crest at +5 mm) at
  about one pixel per texel; the texel-scale variation (standard deviation of
  the luminance after removing a 9-pixel box blur, over the mean) in the
  band around the crest and in the band around the flat (zero-curvature)
  line at x = 0, with the default texel filter; and the mean absolute
  difference of the ``stochastic`` close-up from the ``bilinear`` one, over the
  mean, beside that of two ``bilinear`` renders with different seeds (the
  render noise at that spp);
- distant: the paper's 60 x 60 mm sheet with the CD-BTF (every texel filter)
  and with its tile mean (the CDBRDF), the ratio of the mean pixel values and
  the per-channel means;
- time (a neural CD-BTF with the camera's ``pixel_angle``, so its pyramid level follows the footprint):
  the CDBRDF plug-in and the CD-BTF with every texel filter on the same
  built scene (same spp and seed), rendered in turn ``--repeat`` times; the
  shortest wall time and the shortest process CPU time of each and their
  ratios to the CDBRDF's of the same run (the CPU time is the steadier
  measure on a shared machine).

Prints one JSON object.
"""

from __future__ import annotations

import argparse
import json
import math
import time
from dataclasses import replace

import numpy as np


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("file")
    ap.add_argument("--picture", default=None, help="PNG of the close-up")
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--variant", default="llvm_ad_rgb")
    ap.add_argument("--repeat", type=int, default=5, help="timed renders of each")
    ap.add_argument("--no-close-up", action="store_true", help="skip the close-up")
    a = ap.parse_args()

    import drjit as dr
    import mitsuba as mi

    mi.set_variant(a.variant)
    from cdbrdf.btf import load
    from cdbrdf.colour import LUMINANCE_WEIGHTS
    from cdbrdf.mesh import SineSheet
    from cdbrdf.render import Camera, RenderSpec, render_table
    from cdbrdf.render._btf_jit import DEFAULT_TEXEL_FILTER, TEXEL_FILTERS

    btf = load(a.file)
    out: dict = {"file": a.file, "variant": a.variant, "texels": btf.texels, "rank": btf.rank,
                 "default_texel_filter": DEFAULT_TEXEL_FILTER}
    kw = {"variant": a.variant, "spp": a.spp}
    if not a.no_close_up:
        close = SineSheet(width_mm=20.0, depth_mm=14.0, vertices_per_wavelength=256)
        size = (640, 448)
        t0 = time.perf_counter()
        pic = render_table(btf, RenderSpec(surface=close, size=size, camera=Camera(view=(90.0, -90.0)), **kw))
        out["close_up_seconds"] = round(time.perf_counter() - t0, 1)
        img = pic.images["cdbrdf"][..., :3].astype(np.float64)
        if a.picture:
            from cdbrdf.render.output import write_render

            write_render(a.picture, pic.display("cdbrdf"), exposure_ev=pic.exposure_ev)
        lum = img @ LUMINANCE_WEIGHTS
        from scipy.ndimage import uniform_filter

        detail = lum - uniform_filter(lum, 9, mode="nearest")
        # seen from straight above, x maps linearly to the columns; the sheet fills 90 % of the frame's width
        cols = np.arange(size[0])
        x_mm = ((cols + 0.5) / size[0] - 0.5) * close.width_mm / 0.9
        rows = slice(size[1] // 4, 3 * size[1] // 4)
        for name, x0 in (("crest", 5.0), ("flat", 0.0), ("trough", -5.0)):
            band = np.abs(x_mm - x0) < 1.0
            d, m = detail[rows][:, band], lum[rows][:, band]
            out[f"texel_variation_{name}"] = round(float(d.std() / m.mean()), 4)
            out[f"mean_luminance_{name}"] = round(float(m.mean()), 5)
        ex = {"surface": close, "size": size, "camera": Camera(view=(90.0, -90.0)), "exposure": 0.0, **kw}
        bil = [render_table(btf, RenderSpec(texel_filter="bilinear", seed=s, **ex)).images["cdbrdf"][..., :3]
               for s in (0, 1)]
        sto = render_table(btf, RenderSpec(texel_filter="stochastic", **ex)).images["cdbrdf"][..., :3]
        m = float(np.mean(bil[0]))
        out["close_up_stochastic_vs_bilinear"] = round(float(np.abs(sto - bil[0]).mean()) / m, 4)
        out["close_up_bilinear_seed_noise"] = round(float(np.abs(bil[1] - bil[0]).mean()) / m, 4)
    far = SineSheet()
    distant = RenderSpec(surface=far, size=(256, 192), exposure=0.0, **kw)
    imgs = {"cdbrdf": render_table(btf.mean(), distant).images["cdbrdf"][..., :3]}
    for f in TEXEL_FILTERS:
        imgs[f] = render_table(btf, replace(distant, texel_filter=f)).images["cdbrdf"][..., :3]
    c = imgs["cdbrdf"].astype(np.float64)
    for f in TEXEL_FILTERS:
        b = imgs[f].astype(np.float64)
        out[f"distant_mean_ratio_{f}"] = round(float(b.mean() / c.mean()), 5)
        out[f"distant_channel_ratio_{f}"] = [round(float(x), 5) for x in b.mean(axis=(0, 1)) / c.mean(axis=(0, 1))]
    # render time on built scenes (the upload of the texels is set-up, timed apart), in turn
    from cdbrdf.render.plugin import make_bsdf
    from cdbrdf.render.scenes import sine_scene

    scenes = {}
    # the camera's pixel angle (the sine scene's field of view over the smaller side): a neural CD-BTF's footprint
    pixel_angle = math.radians((sine_scene.__kwdefaults__ or {})["fov_deg"]) / 192
    out["method"] = btf.method
    for kind in ("cdbrdf",) + TEXEL_FILTERS:
        t0 = time.perf_counter()
        bsdf = (make_bsdf(btf.mean()) if kind == "cdbrdf"
                else make_bsdf(btf, uv_scale=(far.width_mm, far.depth_mm), texel_filter=kind,
                               pixel_angle=pixel_angle))
        out[f"setup_seconds_{kind}"] = round(time.perf_counter() - t0, 2)
        scenes[kind] = sine_scene(btf.mean(), RenderSpec(surface=far, size=(256, 192), spp=a.spp), bsdf=bsdf)
        dr.eval(mi.render(scenes[kind], spp=a.spp))  # compiles the kernels
    wall = dict.fromkeys(scenes, np.inf)
    cpu = dict.fromkeys(scenes, np.inf)
    for _ in range(max(a.repeat, 1)):
        for kind, scene in scenes.items():
            t0, c0 = time.perf_counter(), time.process_time()
            dr.eval(mi.render(scene, spp=a.spp))
            dr.sync_thread()
            wall[kind] = min(wall[kind], time.perf_counter() - t0)
            cpu[kind] = min(cpu[kind], time.process_time() - c0)
    out["render_seconds"] = {k: round(v, 3) for k, v in wall.items()}
    out["render_cpu_seconds"] = {k: round(v, 3) for k, v in cpu.items()}
    for f in TEXEL_FILTERS:
        out[f"render_time_ratio_{f}"] = round(wall[f] / wall["cdbrdf"], 2)
        out[f"render_cpu_ratio_{f}"] = round(cpu[f] / cpu["cdbrdf"], 2)
    print(json.dumps(out))


if __name__ == "__main__":
    main()
