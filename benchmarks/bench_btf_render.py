"""Rendering a CD-BTF: the close-up shows the weave and its change along the crests; far away it is the CDBRDF.

Run: ``python benchmarks/bench_btf_render.py FILE [--picture out.png] [--spp 64]`` with a CD-BTF
file (``cdbrdf synth denim --btf 32 -o denim-btf.h5``).

- close-up: a 20 x 14 mm sine sheet (trough at x = -5 mm, crest at +5 mm) at
  about one pixel per texel; the texel-scale variation (standard deviation of
  the luminance after removing a 9-pixel box blur, over the mean) in the
  band around the crest and in the band around the flat (zero-curvature)
  line at x = 0;
- distant: the paper's 60 x 60 mm sheet with the CD-BTF and with its tile
  mean (the CDBRDF), the ratio of the mean pixel values and the per-channel
  means;
- time: the shortest of three renders of each (same scene, spp, seed), their ratio.

Prints one JSON object.
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

from _common import best_seconds


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("file")
    ap.add_argument("--picture", default=None, help="PNG of the close-up")
    ap.add_argument("--spp", type=int, default=64)
    a = ap.parse_args()

    import mitsuba as mi

    mi.set_variant("llvm_ad_rgb")
    from cdbrdf.btf import load
    from cdbrdf.colour import LUMINANCE_WEIGHTS
    from cdbrdf.mesh import SineSheet
    from cdbrdf.render import render_table

    btf = load(a.file)
    out: dict = {"file": a.file, "texels": btf.texels, "rank": btf.rank}
    close = SineSheet(width_mm=20.0, depth_mm=14.0, vertices_per_wavelength=256)
    size = (640, 448)
    t0 = time.perf_counter()
    pic = render_table(btf, close, size=size, spp=a.spp, view=(90.0, -90.0))
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
    far = SineSheet()
    imgs, secs = {}, {}
    for kind, table in (("btf", btf), ("cdbrdf", btf.mean())):
        imgs[kind] = render_table(table, far, size=(256, 192), spp=a.spp, exposure=0.0).images["cdbrdf"][..., :3]
    b, c = imgs["btf"].astype(np.float64), imgs["cdbrdf"].astype(np.float64)
    out["distant_mean_ratio"] = round(float(b.mean() / c.mean()), 5)
    out["distant_channel_ratio"] = [round(float(x), 5) for x in b.mean(axis=(0, 1)) / c.mean(axis=(0, 1))]
    # render time on a built scene (the upload of the texels is set-up, timed apart)
    from cdbrdf.render.plugin import make_bsdf
    from cdbrdf.render.scenes import sine_scene

    for kind, kw in (("cdbrdf", None), ("btf_bilinear", "bilinear"), ("btf_nearest", "nearest")):
        t0 = time.perf_counter()
        bsdf = (make_bsdf(btf.mean()) if kw is None
                else make_bsdf(btf, uv_scale=(far.width_mm, far.depth_mm), texel_filter=kw))
        setup = time.perf_counter() - t0
        scene = sine_scene(btf.mean(), sheet=far, bsdf=bsdf, size=(256, 192), spp=a.spp)
        secs[kind] = best_seconds(lambda scene=scene: mi.render(scene, spp=a.spp), 3)
        out[f"setup_seconds_{kind}"] = round(setup, 2)
    out["render_seconds"] = {k: round(v, 3) for k, v in secs.items()}
    out["render_time_ratio_bilinear"] = round(secs["btf_bilinear"] / secs["cdbrdf"], 2)
    out["render_time_ratio_nearest"] = round(secs["btf_nearest"] / secs["cdbrdf"], 2)
    print(json.dumps(out))


if __name__ == "__main__":
    main()
