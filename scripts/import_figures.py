"""Figures of docs/import.md: imported RGL materials rendered beside the bundled fabrics, and an isotropic mosaic.

Run: ``python scripts/import_figures.py docs/img [--data ../shared/data/rgl] [--spp 256]``

Writes ``imported-sine.png`` (the paper's sine sheet under one directional
light in denim and shot, the bundled fabrics, and in the imported satin vinyl
and car paint of the RGL database) and ``ibiza_mosaic.png`` (the car paint's
isotropic table, drawn expanded).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("out", type=Path, help="folder for the PNG files")
    ap.add_argument("--data", type=Path, default=ROOT.parent / "shared" / "data" / "rgl")
    ap.add_argument("--spp", type=int, default=256)
    args = ap.parse_args(argv)

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    import cdbrdf.render as cr
    from cdbrdf import materials
    from cdbrdf.colour import tonemap_srgb8
    from cdbrdf.importers import import_brdf
    from cdbrdf.plot import plot_mosaic
    from cdbrdf.render.picture import render_scene
    from cdbrdf.render.scenes import sine_scene

    cr.set_variant("llvm_ad_rgb")
    tables = {"denim (bundled)": materials.load("denim"), "shot (bundled)": materials.load("shot")}
    for label, name in (("satin vinyl (RGL, imported)", "satin_rosaline_rgb.bsdf"),
                        ("car paint (RGL, imported)", "cc_ibiza_sunset_rgb.bsdf")):
        tables[label] = import_brdf(args.data / name)
    fig, axes = plt.subplots(1, len(tables), figsize=(4 * len(tables), 3.4), layout="constrained")
    for ax, (label, t) in zip(axes, tables.items()):
        img = render_scene(sine_scene(t, cr.RenderSpec(size=(480, 360), spp=args.spp, max_depth=2)), spp=args.spp)
        ax.imshow(tonemap_srgb8(img, exposure_ev=0.0))
        ax.set_title(label, fontsize=10)
        ax.set_axis_off()
    args.out.mkdir(parents=True, exist_ok=True)
    fig.savefig(args.out / "imported-sine.png", dpi=100)
    mos = plot_mosaic(tables["car paint (RGL, imported)"], title="car paint (RGL), isotropic table, expanded")
    mos.savefig(args.out / "ibiza_mosaic.png", dpi=110)
    print(f"wrote {args.out / 'imported-sine.png'} and {args.out / 'ibiza_mosaic.png'}")
    return int(not np.isfinite(img).all())


if __name__ == "__main__":
    raise SystemExit(main())
