"""The viewer's screenshots in docs/img/viewer-*.png (headless Chromium, software WebGL2).

Run: ``.venv/bin/python scripts/viewer_figures.py [--out docs/img]``

Exports the viewer of the bundled denim and shot fabric and saves: the
whole page (denim and shot side by side on the sine sheet), the split
BRDF | CDBRDF view of the denim sheet bent hard, the curvature overlay, the
draped cloth, the cylinder stand, and the 2-D views (mosaic with a clicked
point's cell, polar slice). Each screenshot is checked for content (not
blank) before it is written.

``viewer-btf.png``: a CD-BTF of the denim (``cdbrdf.synth.texels.tabulate_btf``,
8 x 8 texels, the paper's grid; about half a minute, or ``--btf FILE``)
close up on the sine sheet with its weave, the same view with the tile mean,
on the cylinder stand, and on the draped cloth (a mesh with UVs). ``--only btf`` makes only that one.
"""

from __future__ import annotations

import argparse
import io
import shutil
import sys
import tempfile
from pathlib import Path

import numpy as np

ARGS = ["--no-sandbox", "--use-angle=swiftshader", "--enable-unsafe-swiftshader", "--no-first-run",
        "--disable-background-networking"]


def _check(png: bytes, name: str) -> bytes:
    from PIL import Image

    a = np.asarray(Image.open(io.BytesIO(png)).convert("RGB"), dtype=np.float64)
    if a.std() < 8:
        raise SystemExit(f"{name}: the screenshot is blank (std {a.std():.1f})")
    return png


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", default=str(Path(__file__).resolve().parents[1] / "docs" / "img"))
    ap.add_argument("--only", choices=("all", "tables", "btf"), default="all", help="which figures")
    ap.add_argument("--btf", metavar="FILE", help="the CD-BTF file of viewer-btf.png (default: synthesised)")
    args = ap.parse_args(argv)
    out = Path(args.out)
    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    if chromium is None:
        raise SystemExit("Debian's chromium is not installed (scripts/setup.sh --test installs it)")
    from playwright.sync_api import sync_playwright

    from cdbrdf import materials
    from cdbrdf.fsutil import atomic_path
    from cdbrdf.view.export import export_viewer, viewer_files

    def save(name: str, png: bytes) -> None:
        with atomic_path(out / name) as tmp:
            Path(tmp).write_bytes(_check(png, name))
        print(f"wrote {out / name}")

    if args.only in ("all", "btf"):
        _btf_figure(chromium, args.btf, save)
    if args.only == "btf":
        return 0
    with tempfile.TemporaryDirectory() as tmp:
        files = viewer_files([("denim.h5", materials.load("denim")), ("shot.h5", materials.load("shot"))])
        index = export_viewer(Path(tmp) / "v", files)
        with sync_playwright() as p:
            browser = p.chromium.launch(executable_path=chromium, headless=True, args=ARGS)
            try:
                page = browser.new_page(viewport={"width": 1300, "height": 1150})
                page.goto(index.resolve().as_uri())
                page.evaluate("cdbrdfViewer.ready")
                v = "cdbrdfViewer"
                page.evaluate(f"{v}.setSize(960, 540)")
                page.evaluate(f"{v}.setLight(40, 10)")
                page.locator("#view").click(position={"x": 240, "y": 300})
                save("viewer-page.png", page.screenshot(full_page=True))
                page.evaluate(f"{v}.setSideBySide(false)")
                page.evaluate(f"{v}.setBend(4)")
                page.evaluate(f"{v}.setMode('split')")
                save("viewer-split.png", page.locator("#view").screenshot())
                page.evaluate(f"{v}.setMode('cdbrdf')")
                page.evaluate(f"{v}.setOverlay(true)")
                save("viewer-overlay.png", page.locator("#view").screenshot())
                page.evaluate(f"{v}.setOverlay(false)")
                page.evaluate(f"{v}.setSurface('drape')")
                page.evaluate(f"{v}.setCamera(45, -60)")
                save("viewer-drape.png", page.locator("#view").screenshot())
                page.evaluate(f"{v}.setSurface('stand')")
                page.evaluate(f"{v}.setStandCurvature(0.22)")
                page.evaluate(f"{v}.setCamera(30, -15, 90)")
                save("viewer-stand.png", page.locator("#view").screenshot())
                save("viewer-2d.png", page.locator("#views2d").screenshot())
            finally:
                browser.close()
    return 0


def _btf_figure(chromium: str, path: str | None, save) -> None:
    """viewer-btf.png: the weave close up on the sheet, the same view with the tile mean, the stand, the drape."""
    from PIL import Image
    from playwright.sync_api import sync_playwright

    from cdbrdf.view.export import drape_entry, export_viewer, viewer_files

    if path is None:
        from cdbrdf.synth import presets
        from cdbrdf.synth.texels import tabulate_btf

        btf = tabulate_btf(presets.model("denim"), texels=8)
    else:
        from cdbrdf.btf import load

        btf = load(path)
    print(btf)
    panels = []
    with tempfile.TemporaryDirectory() as tmp:
        index = export_viewer(Path(tmp) / "v", viewer_files([("denim-btf.h5", btf)], meshes={"drape": drape_entry()}))
        with sync_playwright() as p:
            browser = p.chromium.launch(executable_path=chromium, headless=True, args=ARGS)
            try:
                page = browser.new_page(viewport={"width": 1300, "height": 1000})
                page.goto(index.resolve().as_uri())
                page.evaluate("cdbrdfViewer.ready")
                v = "cdbrdfViewer"
                page.evaluate(f"{v}.setSize(320, 240)")
                page.evaluate(f"{v}.setLight(40, 10)")
                page.evaluate(f"{v}.setBend(3)")
                page.evaluate(f"{v}.setCamera(55, -90, 22)")
                page.evaluate(f"{v}.setComponents({btf.rank})")  # all (software WebGL starts with 8)
                print(page.evaluate(f"{v}.state()")["btfText"])
                panels.append(page.locator("#view").screenshot())
                page.evaluate(f"{v}.setWeave(false)")
                panels.append(page.locator("#view").screenshot())
                page.evaluate(f"{v}.setWeave(true)")
                page.evaluate(f"{v}.setSurface('stand')")
                page.evaluate(f"{v}.setStandCurvature(0.22)")
                page.evaluate(f"{v}.setCamera(35, -60, 30)")
                panels.append(page.locator("#view").screenshot())
                page.evaluate(f"{v}.setSurface('drape')")  # a mesh with UVs: the weave at true size on its folds
                page.evaluate(f"{v}.setCamera(50, -70, 45)")
                panels.append(page.locator("#view").screenshot())
            finally:
                browser.close()
    ims = [Image.open(io.BytesIO(_check(png, "viewer-btf.png"))).convert("RGB") for png in panels]
    gap = 6
    out = Image.new("RGB", (sum(i.width for i in ims) + gap * (len(ims) - 1), ims[0].height), (30, 30, 30))
    x = 0
    for im in ims:
        out.paste(im, (x, 0))
        x += im.width + gap
    buf = io.BytesIO()
    out.save(buf, format="PNG", optimize=True)
    save("viewer-btf.png", buf.getvalue())


if __name__ == "__main__":
    sys.exit(main())
