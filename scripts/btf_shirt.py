"""The neural CD-BTF on a shirt, close up and far away (docs/img/btf-shirt.png).

Run: ``.venv/bin/python scripts/btf_shirt.py FILE [--mesh tee_sim.obj] [--out docs/img/btf-shirt.png]
[--spp 16]`` with a CD-BTF file (``cdbrdf synth denim --btf 32 --max-error 0.5 -o denim-btf.h5``) and a
garment with UVs of its own (the docs: the simulated T-shirt of the Garment-Pattern-Generator, its UVs
the sewing pattern in cm, so ``--uv-scale 10`` mm per UV unit, the mesh in cm).

Two panels: the whole shirt (the weave far smaller than a pixel: the lookup's footprint, from the
camera's pixel angle that render_table gives the plug-in, picks the coarse levels and the tile mean, so
no moire), and a close-up of a patch of the chest (the mesh cut to a box around the front point nearest
the shirt's centre, which render_table then frames), at the same exposure.
"""

from __future__ import annotations

import argparse
from pathlib import Path


def _patch(mesh_path: str, out: Path, half_width: float) -> Path:
    """The faces of ``mesh_path`` within ``half_width`` (mesh units) of the front point nearest the centre (at least
    the four nearest)."""
    import numpy as np
    import trimesh

    m = trimesh.load(mesh_path, process=False, force="mesh")
    c = m.bounds.mean(axis=0)
    front = m.vertices[:, 2] > c[2]
    centre = m.vertices[front][np.argmin(np.linalg.norm(m.vertices[front][:, :2] - c[:2], axis=1))]
    d = np.linalg.norm(m.triangles_center - centre, axis=1)
    keep = np.flatnonzero(d < half_width)
    if keep.size < 4:  # a coarse mesh: the few faces nearest the point
        keep = np.argsort(d)[:4]
    sub = m.submesh([keep], append=True)
    sub.export(out)
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("file")
    ap.add_argument("--mesh", required=True)
    ap.add_argument("--units", default="cm")
    ap.add_argument("--uv-scale", type=float, default=10.0)
    ap.add_argument("--out", default=str(Path(__file__).resolve().parents[1] / "docs" / "img" / "btf-shirt.png"))
    ap.add_argument("--spp", type=int, default=16)
    ap.add_argument("--size", type=int, default=360)
    ap.add_argument("--patch", type=float, default=1.5, help="half width of the close-up's box, mesh units")
    ap.add_argument("--up", default="y", help="the mesh's up axis")
    a = ap.parse_args(argv)

    import tempfile

    import matplotlib

    matplotlib.use("Agg")
    from dataclasses import replace

    import matplotlib.pyplot as plt

    from cdbrdf.btf import load
    from cdbrdf.colour import tonemap_srgb8
    from cdbrdf.mesh import MeshSurface, SurfaceMaps
    from cdbrdf.render import Camera, RenderSpec, render_table, variant

    btf = load(a.file)
    spec = RenderSpec(surface=MeshSurface(a.mesh, units=a.units, up=a.up), maps=SurfaceMaps(uv_scale=a.uv_scale),
                      spp=a.spp, size=(a.size, a.size), texel_filter="bilinear", camera=Camera(view=(10.0, -90.0)))
    panels = []
    with variant("llvm_ad_rgb"), tempfile.TemporaryDirectory() as tmp:
        far = render_table(btf, spec)
        ev = far.exposure_ev
        panels.append(("whole shirt: footprint filtering (pyramid, tile mean)", tonemap_srgb8(far.display("cdbrdf"),
                                                                                                exposure_ev=ev)))
        patch = _patch(a.mesh, Path(tmp) / "patch.obj", a.patch)
        close = render_table(btf, replace(spec, surface=MeshSurface(str(patch), units=a.units, up=a.up),
                                          exposure=ev))
        panels.append(("close-up: the faces nearest the chest's centre", tonemap_srgb8(close.display("cdbrdf"),
                                                                                          exposure_ev=ev)))
    fig, axes = plt.subplots(1, len(panels), figsize=(5 * len(panels), 5.2))
    nu, nv = btf.texels
    for (title, im), ax in zip(panels, axes):
        ax.imshow(im)
        ax.set_title(title, fontsize=9)
        ax.set_xticks([])
        ax.set_yticks([])
    c = btf.compression
    fig.suptitle(f"{btf.attrs.get('material', '?')} CD-BTF ({btf.method}, {nu} x {nv} texels per "
                 f"{btf.repeat_mm[0]:.3g} x {btf.repeat_mm[1]:.3g} mm, {c.get('compression_ratio', 0):.0f}:1)",
                 fontsize=10)
    fig.tight_layout()
    fig.savefig(a.out, dpi=80)
    print(f"wrote {a.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
