"""The CD-BTF close-ups in docs/img/btf-closeup.png: the bent sine sheet with each CD-BTF and with its tile mean.

Run: ``.venv/bin/python scripts/btf_figures.py FILE [FILE ...] [--out docs/img/btf-closeup.png] [--spp 64]``
with CD-BTF files (``cdbrdf synth denim --btf 32 -o denim-btf.h5``; the docs use denim and velvet at
32 x 32 texels on the paper's grid).

One row per file: a 20 x 14 mm sine sheet (trough at x = -5 mm, crest at x = +5 mm, seen from
above at about one pixel per texel) rendered with the CD-BTF (left, the exact bilinear texel
filter) and with its tile mean, the CDBRDF (right), at the same exposure (the CD-BTF render's
grey card).
"""

from __future__ import annotations

import argparse
from dataclasses import replace
from pathlib import Path


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("files", nargs="+")
    ap.add_argument("--out", default=str(Path(__file__).resolve().parents[1] / "docs" / "img" / "btf-closeup.png"))
    ap.add_argument("--spp", type=int, default=64)
    a = ap.parse_args(argv)

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from cdbrdf.btf import load
    from cdbrdf.colour import tonemap_srgb8
    from cdbrdf.mesh import SineSheet
    from cdbrdf.render import Camera, RenderSpec, render_table, variant

    sheet = SineSheet(width_mm=20.0, depth_mm=14.0, vertices_per_wavelength=256)
    rows = []
    with variant("llvm_ad_rgb"):
        for f in a.files:
            btf = load(f)
            top = Camera(view=(90.0, -90.0))
            spec = RenderSpec(surface=sheet, size=(640, 448), spp=a.spp, camera=top)
            pic = render_table(btf, replace(spec, texel_filter="bilinear"))
            ev = pic.exposure_ev
            mean = render_table(btf.mean(), replace(spec, exposure=ev))
            name = btf.attrs.get("material", Path(f).stem)
            nu, nv = btf.texels
            su, sv = btf.repeat_mm
            rows.append((f"{name}: CD-BTF, {nu} x {nv} texels per {su:.3g} x {sv:.3g} mm repeat",
                         tonemap_srgb8(pic.display("cdbrdf"), exposure_ev=ev), f"{name}: tile mean (CDBRDF)",
                         tonemap_srgb8(mean.display("cdbrdf"), exposure_ev=ev)))
    fig, axes = plt.subplots(len(rows), 2, figsize=(10, 3.6 * len(rows)), squeeze=False)
    for (t1, im1, t2, im2), ax in zip(rows, axes):
        for title, im, x in ((t1, im1, ax[0]), (t2, im2, ax[1])):
            x.imshow(im)
            x.set_title(title, fontsize=9)
            x.set_xticks([])
            x.set_yticks([])
        ax[0].set_xlabel("trough (x = -5 mm)    flat    crest (x = +5 mm)", fontsize=8)
    fig.tight_layout()
    fig.savefig(a.out, dpi=90)
    print(f"wrote {a.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
