"""The table of real garments in docs/rendering.md and its picture, from the shared test data.

Run: ``.venv/bin/python scripts/garment_table.py [--data DIR] [--png docs/img/garments-real.png]``

For every garment of the shared data's ``garments/`` folder (third-party
exports: a knife-pleat dress as CAD panels and draped, two MakeHuman suits,
a simulated and a worn T-shirt, Khronos' SheenCloth; see its README), with
the defaults of ``cdbrdf render --mesh`` and the bundled denim:

- the unit and the up axis cdbrdf decides, with the rule that decided, and
  the up axis the geometry alone gives (the file's statements left out);
- the vertices, and those whose curvature is outside the table's kappa range,
  by location (interior, an opening or another open boundary, a seam), with
  the share of them where the tessellation itself bends at least half as
  tightly (:func:`cdbrdf.mesh.curvature.dihedral_curvature`: the cloth truly
  bends tighter than the table there; the rest would be spikes of the fit),
  and the largest ``|kappa|`` and where it is;
- a plain-BRDF and a CDBRDF render (small, studio lighting, the grey-card
  exposure): the share of the garment's pixels that differ noticeably
  (Delta E*ab > 2.3, the just-noticeable difference, as ``cdbrdf render
  --compare`` shows it: :func:`cdbrdf.plot.displayed_delta_e`) and the share of those
  on a seam (a pixel whose surface point is nearer a seam vertex than the
  other vertices of its triangle: half an edge either side of a seam), beside
  the share of all the garment's pixels on a seam.

The table is printed in Markdown; the picture shows every garment as rendered
(CDBRDF) above its Delta E*ab map, the seams outlined. SheenCloth's normal
map is left out: this table is about the geometry (seams, openings, the up
axis, the unit); maps are another section of docs/rendering.md.
"""

from __future__ import annotations

import argparse
import logging
import sys
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]

#: The garments: path under the shared data's garments/ folder, and a short name.
GARMENTS: tuple[tuple[str, str], ...] = (
    ("codim_ipc_dress_knife/stage.obj", "dress, 14 CAD panels"),
    ("codim_ipc_dress_knife/dress_knife_draped_garment_only.obj", "dress, draped"),
    ("makehuman_male_casualsuit01/male_casualsuit01.obj", "MakeHuman casual suit"),
    ("makehuman_female_elegantsuit01/female_elegantsuit01.obj", "MakeHuman elegant suit"),
    ("pattern_generator_tee_sim/tee_sim.obj", "simulated T-shirt"),
    ("diffcloth_tshirt1900/tshirt1900.obj", "worn T-shirt"),
    ("sheen_cloth/SheenCloth.gltf", "SheenCloth"),
)

#: A noticeable difference, Delta E*ab.
JND = 2.3


@dataclass
class Row:
    """One garment's line of the table."""

    name: str
    vertices: int
    units: str
    up: str
    up_geometry: str
    outside: dict[str, tuple[int, int]]
    true_share: float
    kappa_max: float
    kappa_where: str
    noticeable: float
    on_seams: float
    seam_pixels: float
    warnings: list[str] = field(default_factory=list)
    images: dict[str, np.ndarray] = field(default_factory=dict)


class _Collect(logging.Handler):
    def __init__(self) -> None:
        super().__init__(logging.WARNING)
        self.messages: list[str] = []

    def emit(self, record: logging.LogRecord) -> None:
        self.messages.append(record.getMessage())


def shared_garments(data: Path | None) -> Path:
    if data is not None:
        return data / "garments"
    sys.path.insert(0, str(ROOT))
    from tests.shared_data import shared_data

    return shared_data() / "garments"


def measure(path: Path, name: str, table, *, size: tuple[int, int], spp: int) -> Row:
    from cdbrdf.mesh import Mesh, MeshSurface, detect_up, prepare_mesh, read_mesh
    from cdbrdf.mesh.curvature import LOCATIONS, dihedral_curvature
    from cdbrdf.plot import displayed_delta_e
    from cdbrdf.render import RenderSpec, curvature_image, mesh_scene, render_table, variant
    from cdbrdf.render.plugin import DEFAULT_VARIANT

    log = _Collect()
    logging.getLogger("cdbrdf").addHandler(log)
    try:
        mesh = read_mesh(path)
        for key in ("normal_map", "height_map"):  # the geometry's curvature only
            mesh.metadata.pop(key, None)
        prep = prepare_mesh(mesh, table=table)
        up, why = detect_up(prep)
        bare = Mesh(mesh.vertices, mesh.faces, None, mesh.uv, {}, None, {"format": "obj"})
        up_geometry = detect_up(bare)
    finally:
        logging.getLogger("cdbrdf").removeHandler(log)
    meta = prep.metadata
    k = np.asarray(prep.attributes["curvature"])
    loc = np.asarray(meta["location"])
    lo, hi = float(np.min(table.kappa)), float(np.max(table.kappa))
    out = (k < lo) | (k > hi)
    bend = dihedral_curvature(prep.vertices, prep.faces, units=meta["units"])
    true_share = float(np.mean(bend[out] >= 0.5 * np.abs(k[out]))) if out.any() else float("nan")
    i = int(np.argmax(np.abs(k)))
    a = "xyz".index(up)
    h = prep.vertices[:, a]
    where = f"{LOCATIONS[loc[i]]}, {100 * (h[i] - h.min()) / max(np.ptp(h), 1e-300):.0f} % up"
    pic = render_table(table, RenderSpec(surface=MeshSurface(prep, up=up), modes=("brdf", "cdbrdf"), size=size,
                                         spp=spp))
    d = displayed_delta_e(pic.display("brdf"), pic.display("cdbrdf"), exposure_ev=pic.exposure_ev, metric="ab")
    marked = prep.copy()
    marked.attributes = {**prep.attributes, "seam": (loc == LOCATIONS.index("seam")).astype(np.float64)}
    with variant(DEFAULT_VARIANT):
        scene = mesh_scene(table, RenderSpec(surface=MeshSurface(marked, up=up), size=size, spp=1))
        seam_img = curvature_image(scene, attribute="vertex_seam")
    seen = np.isfinite(seam_img)
    on_seam = seen & (seam_img > 0.5)
    noticeable = seen & (d > JND)
    n_seen = max(int(seen.sum()), 1)
    return Row(name=name, vertices=prep.n_vertices, units=meta["units_note"].removeprefix("units: "),
               up=f"{up} ({why})", up_geometry=f"{up_geometry[0]} ({up_geometry[1]})",
               outside=dict(meta["outside_by_location"]), true_share=true_share,
               kappa_max=float(np.abs(k[i])), kappa_where=where,
               noticeable=float(noticeable.sum()) / n_seen,
               on_seams=float((noticeable & on_seam).sum()) / max(int(noticeable.sum()), 1),
               seam_pixels=float(on_seam.sum()) / n_seen, warnings=log.messages,
               images={"cdbrdf": pic.display("cdbrdf"), "delta_e": np.where(seen, d, np.nan), "seam": on_seam,
                       "exposure": np.array(pic.exposure_ev)})


def _pct(x: float) -> str:
    return "-" if not np.isfinite(x) else f"{100 * x:.2f} %"


#: Short names of the rules in the notes, for the table's columns (the notes follow it in full).
_RULES = (("inferred", "inferred from the size"), ("the file's header", "the file's header"),
          ("MakeHuman", "MakeHuman's"), ("glTF", "glTF's specification"), ("recorded", "recorded"),
          ("given", "given"), ("opening", "its openings"), ("separate panels", "separate panels"),
          ("one sheet", "one sheet"), ("flat base", "a flat base"), ("mirror", "its mirror plane"),
          ("tallest", "its tallest axis"), ("convention", "the format's convention"))


def _rule(text: str) -> str:
    return next((short for key, short in _RULES if key in text), text)


def markdown(rows: list[Row], table_name: str, kappa_range: tuple[float, float]) -> str:
    lines = [f"| garment | vertices rendered | unit | up (the geometry alone) | outside [{kappa_range[0]:g}, "
             f"{kappa_range[1]:g}] mm^-1 (interior / opening / seam) | of those, the mesh bends as tightly | "
             "largest abs(kappa), mm^-1 | pixels with Delta E*ab > 2.3 | of those on a seam (seam pixels) |",
             "|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        o = r.outside
        n_out = sum(x for x, _ in o.values())
        by = " / ".join(f"{o[k][0]} of {o[k][1]}" for k in ("interior", "boundary", "seam"))
        unit, up = r.units.split(" ", 1)[0] if not r.units.startswith("inferred") else r.units.split()[1], r.up[0]
        lines.append(f"| {r.name} | {r.vertices} | {unit} ({_rule(r.units)}) | {up} ({_rule(r.up)}; the geometry: "
                     f"{r.up_geometry[0]}, {_rule(r.up_geometry)}) | "
                     f"{_pct(n_out / r.vertices)} ({by}) | {_pct(r.true_share)} | {r.kappa_max:.3g} "
                     f"({r.kappa_where}) | {_pct(r.noticeable)} | {_pct(r.on_seams)} ({_pct(r.seam_pixels)}) |")
    lines += ["", f"Bundled {table_name}. What cdbrdf says of each:", ""]
    for r in rows:
        lines.append(f"- {r.name}: units: {r.units}; up axis: {r.up}; from the geometry alone (an OBJ "
                     f"saying nothing): {r.up_geometry}")
        for w in r.warnings:
            lines.append(f"  - warning: {w.split(': ', 1)[-1] if w.startswith('/') else w}")
    return "\n".join(lines)


def figure(rows: list[Row], png: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from cdbrdf.colour import tonemap_srgb8
    from cdbrdf.fsutil import atomic_path

    n = len(rows)
    h, w = rows[0].images["delta_e"].shape
    fig = plt.figure(figsize=(1.3 * n + 0.5, 2.6 * h / w + 0.3), dpi=110)
    grid = fig.add_gridspec(2, n + 1, width_ratios=[1.0] * n + [0.06], wspace=0.03, hspace=0.04)
    im = None
    for j, r in enumerate(rows):
        top, bottom = fig.add_subplot(grid[0, j]), fig.add_subplot(grid[1, j])
        top.imshow(tonemap_srgb8(r.images["cdbrdf"], exposure_ev=float(r.images["exposure"])))
        top.set_title(r.name, fontsize=5.5)
        im = bottom.imshow(np.nan_to_num(r.images["delta_e"], nan=0.0), cmap="magma", vmin=0.0, vmax=6.0)
        bottom.contour(r.images["seam"].astype(float), levels=[0.5], colors="cyan", linewidths=0.3)
        for ax in (top, bottom):
            ax.set_xticks([])
            ax.set_yticks([])
    cax = fig.add_subplot(grid[1, n])
    cb = fig.colorbar(im, cax=cax)
    cb.set_label("Delta E*ab, BRDF vs CDBRDF (cyan: seams)", fontsize=5)
    cb.ax.tick_params(labelsize=5)
    with atomic_path(png) as tmp:
        fig.savefig(tmp, format="png", bbox_inches="tight", pad_inches=0.02)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--data", type=Path, help="the shared data folder (default: as the tests find it)")
    ap.add_argument("--png", type=Path, default=ROOT / "docs" / "img" / "garments-real.png")
    ap.add_argument("--size", default="160x200", help="WxH of each render")
    ap.add_argument("--spp", type=int, default=32)
    ap.add_argument("--material", default="denim", help="a bundled material")
    args = ap.parse_args(argv)
    size = tuple(int(x) for x in args.size.lower().split("x"))
    folder = shared_garments(args.data)
    from cdbrdf import materials

    table = materials.load(args.material)
    rows = []
    for rel, name in GARMENTS:
        path = folder / rel
        if not path.is_file():
            print(f"{path}: absent, skipped", file=sys.stderr)
            continue
        rows.append(measure(path, name, table, size=size, spp=args.spp))
        print(f"{name}: done", file=sys.stderr)
    if not rows:
        raise SystemExit(f"{folder}: no garment found")
    print(markdown(rows, args.material, (float(np.min(table.kappa)), float(np.max(table.kappa)))))
    figure(rows, args.png)
    print(f"{args.png}: written", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
