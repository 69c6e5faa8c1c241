"""The demo's HTML report: what each stage found, with its figures and numbers (:func:`cdbrdf.demo.run_demo`).

It reads the demo's :class:`~cdbrdf.demo.DemoConfig` and
:class:`~cdbrdf.demo.MaterialResult` objects (typed ``Any`` here: the demo
imports this module, not the reverse).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:  # pragma: no cover
    from .measure.stands import Stand

__all__ = ["write_report", "viewer_dirs", "COMPARED_FILL", "VIEWER_DIR"]

#: The fill method the demo compares the default with (the paper's rule).
COMPARED_FILL = "nearest"

#: Folder of the interactive viewer inside the output folder (its ``index.html`` opens from disk).
VIEWER_DIR = "viewer"


def viewer_dirs(results: Sequence[Any]) -> list[tuple[str, list[Any]]]:
    """The viewers' folders and their materials: two side by side, the first pair in :data:`VIEWER_DIR`."""
    pairs = [list(results[i:i + 2]) for i in range(0, len(results), 2)]
    return [(VIEWER_DIR if i == 0 else "-".join([VIEWER_DIR] + [m.name for m in p]), p) for i, p in enumerate(pairs)]


def _stands_text(stands: Sequence[Stand]) -> str:
    """The stands' geometry in words (the concave ones': face width and wall height)."""
    from .measure.stands import DEFAULT_FACE_WIDTH_MM, DEFAULT_WALL_HEIGHT_MM

    shapes = sorted({(st.face_width_mm, st.wall_height_mm) for st in stands if st.kappa < 0})
    if not shapes:
        return "no concave stand"
    words = "; ".join(f"faces {w:g} mm wide, walls {h:g} mm high" for w, h in shapes)
    paper = shapes == [(DEFAULT_FACE_WIDTH_MM, DEFAULT_WALL_HEIGHT_MM)]
    return f"concave stands: {words}" + (" (the default, as the paper's)" if paper else "")


def write_report(folder: Path, config: Any, results: Sequence[Any], seconds: float,
                  stands: Sequence[Stand]) -> Path:
    from .report import Report

    g = config.grid
    r = Report(
        "cdbrdf: curvature-dependent BRDFs of fabrics, end to end",
        lead=(
            "After Matsufuji &amp; Kawai, <i>Measurement and Rendering of Curvature Dependent BRDF</i>. "
            f"Run <code>{config.name}</code>: {g.phi_v.size * g.theta_v.size} view x "
            f"{g.phi_l.size * g.theta_l.size} light directions x {g.kappa.size} stand curvatures "
            f"({', '.join(f'{k:g}' for k in g.kappa)} mm<sup>-1</sup>), photographs of "
            f"{config.image_px} x {config.image_px} pixels ({config.field_mm:g} mm wide at the stand) from a "
            f"simulated rig ({_stands_text(stands)}); "
            "total time "
            f"{seconds / 60:.1f} min."
        ),
    )
    intro = _intro(r, results)
    compared = _tables(intro, results)
    for m in results:
        _material_section(r, m, config, compared)
    return r.write(folder)


def _intro(r: Any, results: Sequence[Any]) -> Any:
    """The report's first section: what the run shows, where the surfaces bend."""
    intro = r.section(
        "What this shows",
        "Each fabric is a micro-structure model whose reflectance depends on how it is bent "
        "(the ground truth): woven cloth (denim, shot fabric), whose gaps between the yarns open on a "
        "convex bend, or pile (velvet, towelling), whose fibres or loops fan apart on a convex bend "
        "and show the ground, and crowd on a concave one. A simulated capture rig photographs it on "
        "five cylindrical stands, convex and concave; cdbrdf measures the photographs into a CDBRDF "
        "table exactly as it would a lab's, fills the directions a concave stand hides, and renders surfaces with the "
        "table, taking the curvature at every point. Compare the CDBRDF renders with the plain "
        "BRDF (the flat stand's slice) at the crests and valleys, or bend the sheet yourself in the "
        "interactive viewer (WebGL2; it opens from disk): "
        + ", ".join(f'<a href="{d}/index.html">{" and ".join(m.name for m in p)}</a>' for d, p in viewer_dirs(results))
        + ".",
    )
    intro.figure("surfaces-curvature.png", "Where the surfaces bend",
                 "The two rendered surfaces coloured by the curvature the renderer looks up at each "
                 "point: red convex (crests, fold ridges, the dome), blue concave (troughs, fold "
                 "valleys), white flat. The CDBRDF renders below differ from the plain BRDF exactly "
                 "where these colours are strong.")
    intro.table(
        "Samples per stand: measured, filled (hidden by the stand), and the error of the measured "
        "table against the ground truth (relative, luminance)",
        ["material", "kappa (1/mm)", "samples", "measured", "filled", "median error measured",
         "95th pct error measured", "median error filled"],
        [[m.name, f"{s['kappa']:+g}", s["samples"], s["measured"], s["filled"],
          f"{100 * s['median_rel_error_measured']:.2f} %", f"{100 * s['p95_rel_error_measured']:.2f} %",
          "-" if not s["filled"] else f"{100 * s['median_rel_error_filled']:.1f} %"]
         for m in results for s in m.per_stand],
    )
    return intro


def _tables(intro: Any, results: Sequence[Any]) -> str:
    """The first section's tables (samples, fills, what bending does, times); the compared fill's name."""
    fill_name = results[0].fill_method if results else ""
    compared = results[0].compared_fill.get("method", COMPARED_FILL) if results else COMPARED_FILL
    intro.table(
        f"Filled samples against the ground truth: the default fill, {fill_name} (the same "
        "direction on the other stands, fitted along the curvature) and, beside it, the paper's rule, "
        f"{compared} (the nearest measured direction at the same curvature); relative error "
        "of the luminance, and the share of filled samples whose error lies within 1 and 2 of the "
        "standard deviations the fill estimated for them (a calibrated estimate gives about 68 % and 95 %)",
        ["material", "kappa (1/mm)", "filled", f"median {fill_name}", f"95th pct {fill_name}",
         "within 1 sigma", "within 2 sigma", f"median {compared}", f"95th pct {compared}"],
        [[m.name, f"{s['kappa']:+g}", s["filled"],
          f"{100 * s['median_rel_error_filled']:.2f} %", f"{100 * s['p95_rel_error_filled']:.1f} %",
          _pct(s["fill_within_1_sigma"]), _pct(s["fill_within_2_sigma"]),
          f"{100 * c['median_rel_error_filled']:.1f} %", f"{100 * c['p95_rel_error_filled']:.1f} %"]
         for m in results
         for s, c in zip(m.per_stand, m.compared_fill.get("per_stand", m.per_stand), strict=True)
         if s["filled"]],
    )
    intro.table(
        "What bending does: the median colour difference Delta E*ab near the normal (view and light "
        "elevations up to 30 degrees, 20,000 direction pairs, the flat table's median luminance scaled to 0.3) "
        "between each bent stand and the flat one, in the measured table and in the ground truth, and the "
        "change of the measured mean colour's lightness L*, chroma C* and hue h; on the rendered sine sheet, the "
        "median Delta E*ab between the plain BRDF and the CDBRDF at the crests, in the troughs and where the sheet "
        "is flat (the eye notices Delta E*ab above about 2; the flat pixels show the render's noise)",
        ["material", "kappa (1/mm)", "Delta E*ab measured", "Delta E*ab truth", "Delta L*", "Delta C*",
         "Delta h (deg)", "colour bent / flat (sRGB)", "sine sheet crests / troughs / flat"],
        [[m.name, f"{a['kappa']:+g}", f"{a['median_delta_e']:.1f}",
          "-" if b is None else f"{b['median_delta_e']:.1f}",
          f"{a['lightness_change']:+.1f}", f"{a['chroma_change']:+.1f}", f"{a['hue_change_deg']:+.0f}",
          "#{:02x}{:02x}{:02x} / #{:02x}{:02x}{:02x}".format(*a["srgb8"], *a["flat_srgb8"]),
          " / ".join(f"{m.contrast['sine'][k]:.1f}" for k in ("crest_delta_e", "trough_delta_e", "flat_delta_e"))
          if i == 0 else ""]
         for m in results if m.contrast
         for truth in [{r["kappa"]: r for r in m.contrast["table"]["truth"]}]
         for i, (a, b) in enumerate((a, truth.get(a["kappa"])) for a in m.contrast["table"]["measured"])],
    )
    intro.table(
        "Times (seconds)",
        ["material", "photographs", "measuring", "figures", "render sine sheet", "render draped cloth"],
        [[m.name] + [f"{m.seconds.get(k, float('nan')):.1f}" for k in
                     ("photographs", "measuring", "figures", "render_sine", "render_drape")]
         for m in results],
    )
    return compared


def _material_section(r: Any, m: Any, config: Any, compared: str) -> None:
    """One fabric's section: photographs, mosaics, renders, errors, provenance."""
    from .render.picture import MAX_AUTO_EV
    from .report import provenance_text

    s = r.section(f"{m.name}: {m.truth_attrs.get('description', m.name)}" if m.truth_attrs.get("description")
                  else m.name)
    s.figure(m.figures["photos"], "The photographs",
             "What the camera saw, one stand per column (concave on the left, convex on the right), "
             "for the normal view and two grazing views. On the concave stands the grazing views "
             "see the white wall or lose the light at the patch: those samples are marked hidden "
             "and filled, never averaged.")
    s.figure(m.figures["mosaic_measured"], "Measured CDBRDF (paper's Fig. 7)",
             "One image per stand curvature: rows are light directions, columns view directions, "
             "grouped by azimuth with the elevation increasing inside each group. Hatched, "
             "outlined cells were hidden by the stand and filled: orange from the same direction "
             "on the other stands (fitted along the curvature), magenta from the nearest measured "
             "direction at the same curvature (where no stand measured the direction); there are "
             "no white wall artefacts. The bottom row is the difference to the flat stand: red "
             "where bending brightens the fabric.")
    s.figure(m.figures["mosaic_truth"], "Ground truth on the paper's grid",
             "The fabric model's own table (72 x 72 directions per curvature), which the rig "
             "rendered; the measured mosaic above should look like it at its coarser sampling.")
    s.figure(m.figures["sine"], "The paper's sine sheet (Figs. 9-10)",
             "Rendered in Mitsuba 3 with (a) the plain BRDF and (b) the measured CDBRDF, the "
             "curvature taken at every point; (c) shows where they differ: along the crests "
             "(convex) and troughs (concave), not on the flanks where the sheet is nearly flat. "
             "Light and camera are near the normal (the light along the crests), where the paper "
             "compares its mosaics. "
             "The swatches below are the mean colour of each render at the convex crests and at the "
             "flat lines, as shown on screen, with their median Delta E*ab. "
             f"Exposure {m.render_exposure_ev:+.1f} EV (0 EV shows a white Lambertian surface facing "
             f"the light as white; at most +{MAX_AUTO_EV:g} EV, so dark fabrics stay dark); "
             f"{config.render_size[0]} x "
             f"{config.render_size[1]} pixels, {config.render_spp} spp.")
    s.figure(m.figures["drape"], "A draped cloth",
             "A generated cloth over a dome with radial folds, its curvature computed from the mesh "
             "(cdbrdf.mesh): the dome and the fold ridges are convex, the fold valleys concave.")
    s.table("Overall error of the measured table against the ground truth",
            ["quantity", "value"],
            [["median relative error, measured samples", f"{100 * m.error['median_rel_error_measured']:.2f} %"],
             ["95th percentile, measured samples", f"{100 * m.error['p95_rel_error_measured']:.2f} %"],
             [f"median relative error, filled samples ({m.fill_method})",
              f"{100 * m.error['median_rel_error_filled']:.2f} %"],
             [f"95th percentile, filled samples ({m.fill_method})",
              f"{100 * m.error['p95_rel_error_filled']:.1f} %"],
             [f"median relative error, filled samples ({compared}, the paper's rule)",
              f"{100 * m.compared_fill['error']['median_rel_error_filled']:.1f} %"]])
    s.detail("Measurement summary", m.summary)
    s.detail("Provenance of the ground-truth material", provenance_text(m.truth_attrs))


def _pct(x: float) -> str:
    return "-" if not np.isfinite(x) else f"{100 * x:.0f} %"
