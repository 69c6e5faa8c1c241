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

``viewer-maps.png``: ``cdbrdf view shot.h5 --mesh cad-top.obj --normal-map wrinkles.png`` (the CAD garment
of ``cdbrdf.mesh.garment_mesh`` as it is, 12 mm edges, with a normal map of horizontal sine wrinkles, 1 mm
deep and 20 mm long, as in docs/rendering.md's example) as the page opens on it, split BRDF | CDBRDF; the
same with the map off; the curvature overlay with the map. ``--only maps`` makes only that one.
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
    ap.add_argument("--only", choices=("all", "tables", "btf", "maps"), default="all", help="which figures")
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

    if args.only in ("all", "maps"):
        _maps_figure(chromium, save)
    if args.only in ("all", "btf"):
        _btf_figure(chromium, args.btf, save)
    if args.only in ("btf", "maps"):
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


def _panels(pngs: list[bytes], name: str) -> bytes:
    """Screenshots side by side, 6 pixels apart, as one PNG."""
    from PIL import Image

    ims = [Image.open(io.BytesIO(_check(png, name))).convert("RGB") for png in pngs]
    gap = 6
    out = Image.new("RGB", (sum(i.width for i in ims) + gap * (len(ims) - 1), ims[0].height), (30, 30, 30))
    x = 0
    for im in ims:
        out.paste(im, (x, 0))
        x += im.width + gap
    buf = io.BytesIO()
    out.save(buf, format="PNG", optimize=True)
    return buf.getvalue()


def _maps_figure(chromium: str, save) -> None:
    """viewer-maps.png: the CAD garment with a wrinkle normal map, split BRDF | CDBRDF; the map off; the overlay."""
    import trimesh
    from playwright.sync_api import sync_playwright

    from cdbrdf import materials
    from cdbrdf.cli import main as cli
    from cdbrdf.images import write_png
    from cdbrdf.mesh import garment_mesh

    panels = []
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        m = garment_mesh()
        trimesh.Trimesh(m.vertices, m.faces, visual=trimesh.visual.TextureVisuals(uv=m.uv),
                        process=False).export(d / "cad-top.obj")
        vv = 1 - (np.arange(2048) + 0.5) / 2048  # rows from the top
        slope = 2 * np.pi / 20 * np.cos(2 * np.pi * vv * 620 / 20)  # dh/dy of h = sin(2 pi y / 20 mm), 1 mm deep
        n = np.zeros((2048, 64, 3))
        n[..., 1], n[..., 2] = -slope[:, None], 1
        n /= np.linalg.norm(n, axis=-1, keepdims=True)
        write_png(d / "wrinkles.png", np.round((n + 1) / 2 * 65535).astype(np.uint16))
        if cli(["view", str(materials.path("shot")), "--mesh", str(d / "cad-top.obj"), "--normal-map",
                str(d / "wrinkles.png"), "--neighbourhood", "5", "--export", str(d / "v")]) != 0:
            raise SystemExit("cdbrdf view failed")
        with sync_playwright() as p:
            browser = p.chromium.launch(executable_path=chromium, headless=True, args=ARGS)
            try:
                page = browser.new_page(viewport={"width": 1300, "height": 1000})
                page.goto((d / "v" / "index.html").resolve().as_uri())
                page.evaluate("cdbrdfViewer.ready")
                v = "cdbrdfViewer"
                page.evaluate(f"{v}.setSize(288, 300)")  # the page opens on the garment, framed
                page.evaluate(f"{v}.setLight(40, -60)")
                page.evaluate(f"{v}.setMode('split')")
                print(page.evaluate(f"{v}.state()")["mapText"])
                panels.append(page.locator("#view").screenshot())
                page.evaluate(f"{v}.setMaps(false)")
                panels.append(page.locator("#view").screenshot())
                page.evaluate(f"{v}.setMaps(true)")
                page.evaluate(f"{v}.setMode('cdbrdf')")
                page.evaluate(f"{v}.setOverlay(true)")
                panels.append(page.locator("#view").screenshot())
            finally:
                browser.close()
    save("viewer-maps.png", _panels(panels, "viewer-maps.png"))


def _btf_figure(chromium: str, path: str | None, save) -> None:
    """viewer-btf.png: the weave close up on the sheet, the same view with the tile mean, the stand, the drape."""
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
    save("viewer-btf.png", _panels(panels, "viewer-btf.png"))


if __name__ == "__main__":
    sys.exit(main())
