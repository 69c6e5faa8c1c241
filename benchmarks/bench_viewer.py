"""Benchmark: the viewer's frame time at 1280 x 720 in headless Chromium, against a flat-shaded draw.

Run: ``.venv/bin/python benchmarks/bench_viewer.py [--frames 10] [--size 1280x720]``

Exports the viewer of the bundled denim, opens it in Debian's Chromium
(headless; WebGL2 in software, SwiftShader, unless the machine has a GPU
Chromium uses) and times, per surface, frames of the table lookup (one draw
call, at most 32 texel fetches per lookup) and, as the reference measured in
the same run, a flat-shaded (Lambert) draw of the same mesh with the same
program layout. Each frame is finished on the GPU (a 1-pixel read-back)
before the next starts. Reports milliseconds per frame and the ratio to the
reference (target: <= 60x with one light, i.e. a frame of the lookup costs
what some 60 flat-shaded draws do; a laptop GPU draws the flat mesh in well
under 0.2 ms, so the lookup stays beyond 60 frames per second; the
environment light looks up 9 directions and costs about 9 times more). Exits 1 when the target is
missed.

A curvature map (``cdbrdf view --mesh M --normal-map N``): the draped cloth with the wrinkle
normal map of ``bench_maps.py`` (``--texels`` square, sine wrinkles and a fine ripple) under the
bundled shot fabric, the map looked up per fragment (16 texel reads: two levels, four texels, two
texels each) and, in the same run, the same mesh with the map off; the map's cost is the ratio of
the two (reported; the flat-draw target holds for it too).
"""

from __future__ import annotations

import argparse
import shutil
import sys
import tempfile
from pathlib import Path

TARGET_RATIO = 60.0

ARGS = ["--no-sandbox", "--use-angle=swiftshader", "--enable-unsafe-swiftshader", "--no-first-run",
        "--disable-background-networking"]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--frames", type=int, default=10)
    ap.add_argument("--size", default="1280x720")
    ap.add_argument("--texels", type=int, default=1024, help="the wrinkle normal map's side (default 1024)")
    args = ap.parse_args(argv)
    w, h = (int(x) for x in args.size.lower().split("x"))
    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    if chromium is None:
        print("Debian's chromium is not installed (scripts/setup.sh --test installs it)")
        return 1
    from playwright.sync_api import sync_playwright

    from cdbrdf import materials
    from cdbrdf.view.export import export_viewer, viewer_files

    rows = []
    worst = 0.0
    with tempfile.TemporaryDirectory() as tmp:
        index = export_viewer(Path(tmp) / "v", viewer_files([("denim.h5", materials.load("denim"))]))
        mapped = export_viewer(Path(tmp) / "m", viewer_files([("shot.h5", materials.load("shot"))],
                                                            meshes={"drape": _wrinkled_drape(args.texels)}))
        with sync_playwright() as p:
            browser = p.chromium.launch(executable_path=chromium, headless=True, args=ARGS)
            try:
                page = browser.new_page(viewport={"width": w + 400, "height": h + 400})
                page.goto(index.resolve().as_uri())
                page.evaluate("cdbrdfViewer.ready")
                page.evaluate(f"cdbrdfViewer.setSize({w}, {h})")
                for surface, mode, env in (("sheet", "cdbrdf", False), ("sheet", "brdf", False),
                                           ("drape", "cdbrdf", False), ("sheet", "cdbrdf", True)):
                    page.evaluate(f"cdbrdfViewer.setSurface('{surface}')")
                    page.evaluate(f"cdbrdfViewer.setMode('{mode}')")
                    page.evaluate(f"cdbrdfViewer.setEnvironment({str(env).lower()})")
                    lookup = page.evaluate(f"cdbrdfViewer.frameTime({args.frames})")
                    flat = page.evaluate(f"cdbrdfViewer.frameTime({args.frames}, true)")
                    label = f"{surface}, {mode}" + (", environment (9 lights)" if env else "")
                    rows.append((label, lookup, flat, lookup / flat))
                    if not env:
                        worst = max(worst, lookup / flat)
                page.goto(mapped.resolve().as_uri())
                page.evaluate("cdbrdfViewer.ready")
                page.evaluate(f"cdbrdfViewer.setSize({w}, {h})")
                page.evaluate("cdbrdfViewer.setSurface('drape')")
                for mode, on in (("cdbrdf", True), ("cdbrdf", False), ("brdf", True), ("brdf", False)):
                    page.evaluate(f"cdbrdfViewer.setMode('{mode}')")
                    page.evaluate(f"cdbrdfViewer.setMaps({str(on).lower()})")
                    lookup = page.evaluate(f"cdbrdfViewer.frameTime({args.frames})")
                    flat = page.evaluate(f"cdbrdfViewer.frameTime({args.frames}, true)")
                    label = f"drape, shot, {mode}, " + (f"wrinkle map {args.texels}^2" if on else "map off")
                    rows.append((label, lookup, flat, lookup / flat))
                    worst = max(worst, lookup / flat)
                renderer = page.evaluate(
                    "(() => { const g = document.createElement('canvas').getContext('webgl2');"
                    " const e = g.getExtension('WEBGL_debug_renderer_info');"
                    " return e ? g.getParameter(e.UNMASKED_RENDERER_WEBGL) : g.getParameter(g.RENDERER); })()")
            finally:
                browser.close()
    print(f"viewer frame time at {w} x {h}, headless Chromium ({renderer}), {args.frames} frames each")
    width = max(len(r[0]) for r in rows)
    print(f"{'surface, mode':<{width}}  {'lookup ms':>10}  {'flat ms':>8}  ratio")
    for label, lookup, flat, ratio in rows:
        print(f"{label:<{width}}  {lookup:10.1f}  {flat:8.1f}  {ratio:5.1f}x")
    for mode in ("cdbrdf", "brdf"):
        on, off = (next(r[1] for r in rows if r[0].startswith(f"drape, shot, {mode}, ") and (k in r[0]))
                   for k in ("wrinkle", "off"))
        print(f"the map's cost ({mode}): {on / off:.2f}x the same mesh without it")
    ok = worst <= TARGET_RATIO
    print(f"worst ratio (one light) {worst:.1f}x  (target <= {TARGET_RATIO:.0f}x)")
    print("PASS" if ok else "FAIL")
    return 0 if ok else 1


def _wrinkled_drape(texels: int) -> tuple:
    """The draped cloth with bench_maps.py's wrinkle normal map, as a viewer mesh entry."""
    from bench_maps import wrinkle_normals

    from cdbrdf.mesh import DrapedCloth, SurfaceMaps, draped_cloth_mesh, normal_map_from_normals, prepare_mesh
    from cdbrdf.view.export import DRAPE_RESOLUTION, drape_entry

    nmap = normal_map_from_normals(wrinkle_normals(texels), name="wrinkles")
    cloth = prepare_mesh(draped_cloth_mesh(DrapedCloth(resolution=DRAPE_RESOLUTION)), maps=SurfaceMaps(normal_map=nmap))
    return drape_entry(cloth)


if __name__ == "__main__":
    sys.exit(main())
