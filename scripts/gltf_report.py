"""The glTF export's numbers and figure (docs/export.md): assets of real garments, the renderer against Mitsuba.

    .venv/bin/python scripts/gltf_report.py [--figure docs/img/gltf-shirt.png] [--size 320x240]

For denim on the CAD shirt (cdbrdf.mesh.garment_mesh) and on the shared data's garments: the asset's size,
vertices, the Khronos validator's verdict, the table read back (median relative error), the quantisation and
fallback errors; then the CAD shirt seen by the browser renderer (headless Chromium, SwiftShader) and by
Mitsuba with the same mesh, camera and light (Delta E*ab as shown), and the renderer's frame time in software
WebGL at 960 x 600 (one light; the light and the studio sky). The figure: the renderer's CDBRDF, Mitsuba's,
the plain three.js page (the fallback) and the Delta E*ab heat map.
"""

from __future__ import annotations

import argparse
import base64
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

#: Garments: the file in the shared data (None: cdbrdf.mesh.garment_mesh) and its unit (its README's).
GARMENTS = {
    "CAD shirt (cdbrdf.mesh.garment_mesh, mm, Z-up)": (None, None),
    "pattern_generator_tee_sim (cm)": ("garments/pattern_generator_tee_sim/tee_sim.obj", "cm"),
    "codim_ipc_dress_knife, draped (m)": ("garments/codim_ipc_dress_knife/dress_knife_draped_garment_only.obj", "m"),
}


def validator(path: Path) -> dict:
    r = subprocess.run(["node", str(ROOT / "js" / "validate.mjs"), str(path)], capture_output=True, text=True,
                       check=True)
    return json.loads(r.stdout.splitlines()[0])["report"]["issues"]


def assets(denim, out: Path) -> None:
    from tests.shared_data import shared_data

    import cdbrdf
    from cdbrdf.export.gltf import build_gltf, export_mesh, write_gltf
    from cdbrdf.mesh import MeshSurface, garment_mesh

    print("| garment | vertices | triangles | GLB | validator errors/warnings | read back: median relative error |")
    print("|---|---|---|---|---|---|")
    for name, (rel, units) in GARMENTS.items():
        src = garment_mesh() if rel is None else shared_data() / rel
        if rel is not None and not Path(src).is_file():
            print(f"| {name} | (absent) | | | | |")
            continue
        t0 = time.perf_counter()
        mesh = export_mesh(MeshSurface(src, units=units), table=denim)
        asset = build_gltf(denim, mesh)
        path = out / (name.split()[0] + ".glb")
        write_gltf(asset, path)
        dt = time.perf_counter() - t0
        issues = validator(path)
        back = cdbrdf.load(path)
        med = float(np.median(np.abs(back.values - denim.values) / np.abs(denim.values)))
        print(f"| {name} | {mesh.n_vertices:,} | {mesh.faces.shape[0]:,} | {path.stat().st_size / 1e6:.2f} MB "
              f"({dt:.1f} s) | {issues['numErrors']} / {issues['numWarnings']} | {med:.1e} |")
    err = asset.encoding_error
    fit = asset.fallback
    print(f"\nquantisation: max {err['maxAbsoluteOverRange']:.2e} of the range, median relative "
          f"{err['medianRelative']:.2e}, p99 {err['p99Relative']:.2e}, max relative {err['maxRelative']:.2e}")
    print(f"fallback: {json.dumps(fit.as_json())}")


def comparison(denim, size: tuple[int, int], figure: Path | None) -> None:
    from playwright.sync_api import sync_playwright
    from scipy.ndimage import binary_erosion
    from tests.test_gltf_renderer import LIGHT, mitsuba_view
    from tests.test_viewer import CHROMIUM, CHROMIUM_ARGS

    from cdbrdf.colour import card_exposure_ev, delta_e, srgb_encode, srgb_to_lab
    from cdbrdf.export.gltf import build_gltf, export_mesh
    from cdbrdf.mesh import garment_mesh
    from cdbrdf.render.lighting import card_irradiance
    from cdbrdf.view.export import write_viewer
    from cdbrdf.view.gltf_page import gltf_viewer_files, view_options

    w, h = size
    glb = build_gltf(denim, export_mesh(garment_mesh(), table=denim)).glb()
    image, camera = mitsuba_view(denim, w, h)
    ev = card_exposure_ev(card_irradiance(LIGHT, None))
    opts = {"camera": camera, "light": list(LIGHT), "exposure_ev": ev, "width": w, "height": h, "environment": False}

    def shot(page, api="cdbrdfGltf"):
        p = page.evaluate(f"{api}.pixels()")
        return np.frombuffer(base64.b64decode(p["data"]), np.uint8).reshape(p["height"], p["width"], 4)[::-1, :, :3]

    with tempfile.TemporaryDirectory() as d, sync_playwright() as pw:
        b = pw.chromium.launch(executable_path=CHROMIUM, headless=True, args=CHROMIUM_ARGS)
        index = write_viewer(Path(d) / "v", gltf_viewer_files(glb, name="shirt.glb", options=opts))
        page = b.new_page()
        page.goto(index.resolve().as_uri())
        page.evaluate("cdbrdfGltf.ready")
        ours = shot(page)
        page.evaluate("cdbrdfGltf.setMode('brdf')")
        flat = shot(page)
        page.evaluate("cdbrdfGltf.setMode('fallback')")
        fallback = shot(page)
        page.close()
        big = write_viewer(Path(d) / "big", gltf_viewer_files(glb, name="shirt.glb",
                                                             options=view_options(glb, size=(960, 600))))
        page = b.new_page()
        page.goto(big.resolve().as_uri())
        st = page.evaluate("cdbrdfGltf.ready")
        t_env = page.evaluate("cdbrdfGltf.frameTime(2)")
        page.evaluate("cdbrdfGltf.setEnvironment(false)")
        t_one = page.evaluate("cdbrdfGltf.frameTime(3)")
        page.evaluate("cdbrdfGltf.setShadows(false)")
        t_noshadow = page.evaluate("cdbrdfGltf.frameTime(3)")
        page.close()
        b.close()
    theirs = np.round(255 * srgb_encode(np.clip(image[..., :3] * 2.0**ev, 0, 1))).astype(np.uint8)
    seen = binary_erosion(image[..., 3] > 0.999, iterations=1)
    for label, pic in (("CDBRDF (the extension)", ours), ("plain BRDF (kappa 0)", flat),
                       ("fallback material", fallback)):
        de = delta_e(srgb_to_lab(pic), srgb_to_lab(theirs), metric="ab")[seen]
        print(f"{label} vs Mitsuba's CDBRDF, {w} x {h}, {seen.sum()} pixels: Delta E*ab median {np.median(de):.2f}, "
              f"p90 {np.percentile(de, 90):.2f}, p99 {np.percentile(de, 99):.2f}")
    print(f"frame time, 960 x 600, {st['renderer']}: light + sky (32 directions) + shadow {t_env:.0f} ms; "
          f"one light + shadow {t_one:.0f} ms; one light, no shadow {t_noshadow:.0f} ms")
    if figure is not None:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        de = delta_e(srgb_to_lab(ours), srgb_to_lab(theirs), metric="ab")
        de[~(image[..., 3] > 0.5)] = np.nan
        fig, ax = plt.subplots(1, 4, figsize=(14, 3.2))
        for a, pic, title in ((ax[0], ours, "browser renderer (CDBRDF)"), (ax[1], theirs, "Mitsuba (CDBRDF)"),
                              (ax[2], fallback, "fallback (standard material)")):
            a.imshow(pic)
            a.set_title(title, fontsize=10)
        im = ax[3].imshow(de, cmap="magma", vmin=0, vmax=5)
        ax[3].set_title("Delta E*ab: renderer vs Mitsuba", fontsize=10)
        fig.colorbar(im, ax=ax[3], fraction=0.046)
        for a in ax:
            a.axis("off")
        fig.tight_layout()
        fig.savefig(figure, dpi=110)
        print(f"wrote {figure}")


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--figure", type=Path, default=None)
    p.add_argument("--size", default="320x240")
    args = p.parse_args()
    from cdbrdf import materials

    denim = materials.load("denim")
    with tempfile.TemporaryDirectory() as d:
        assets(denim, Path(d))
    w, h = (int(x) for x in args.size.split("x"))
    comparison(denim, (w, h), args.figure)


if __name__ == "__main__":
    main()
