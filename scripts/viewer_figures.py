"""The viewer's screenshots in docs/img/viewer-*.png (headless Chromium, software WebGL2).

Run: ``.venv/bin/python scripts/viewer_figures.py [--out docs/img]``

Exports the viewer of the bundled denim and shot fabric and saves: the
whole page (denim and shot side by side on the sine sheet), the split
BRDF | CDBRDF view of the denim sheet bent hard, the curvature overlay, the
draped cloth, the cylinder stand, and the 2-D views (mosaic with a clicked
point's cell, polar slice). Each screenshot is checked for content (not
blank) before it is written.
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


if __name__ == "__main__":
    sys.exit(main())
