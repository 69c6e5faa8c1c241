"""The paper end to end, on the bundled fabrics: ``cdbrdf demo``.

For each material (:data:`DEFAULT_FABRICS` by default: denim, shot fabric and velvet):

1. **plan** the capture: every view x light direction of the grid on a stand
   of every curvature, marking the directions a concave stand hides
   (:func:`cdbrdf.measure.plan.write_plan`);
2. **photograph** it with the simulated rig: Mitsuba 3 renders of the fabric on
   its stand, white walls and all, with sensor noise, as 16-bit PNG
   (:func:`cdbrdf.rig.simulate_capture`);
3. **measure** the photographs into a CDBRDF: 7 x 7 patch means, white
   reference, hidden directions filled by the default method (``kappa-fit``:
   the same direction on the other stands, fitted along the curvature)
   (:func:`cdbrdf.measure.measure`);
4. **compare** the measured table with the ground truth (the material's own
   table, which the rig rendered), and the filled samples also with the
   paper's rule (``nearest``, :func:`cdbrdf.measure.fill.refill`);
5. **draw** the Fig. 7 mosaics (filled samples marked, differences to kappa = 0);
6. **render** the paper's sine sheet and a draped cloth under one directional
   light with the plain BRDF and with the CDBRDF (Figs. 9-10);
7. say what bending does to it: the colour difference near the normal
   between the bent stands and the flat one (:func:`cdbrdf.synth.metrics.bend_contrast`);
8. export the interactive viewer (:mod:`cdbrdf.view`) of the measured tables,
   two side by side (``viewer/``; with more than two materials the next pairs
   in ``viewer-<name>-<name>/``), and write ``report.html`` beside the
   figures, linking to them.

The output folder is built beside the destination and swapped in whole at
the end (:func:`cdbrdf.outputs.output_folder`), so results of different runs
are never mixed and a failed run leaves the previous one intact. The
intermediate files (capture plans, and the photographs unless kept) are
written to a work folder inside that partial folder, so a killed run leaves
nothing in the system's temporary folder and its partial folder is removed
by the next run.
"""

from __future__ import annotations

import json
import shutil
import time
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass, field
from os import PathLike
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ._demo_report import COMPARED_FILL, VIEWER_DIR, viewer_dirs, write_report
from .colour import auto_exposure_ev, luminance, srgb_to_linear, tonemap_srgb8
from .table import CDBRDF, PAPER_KAPPA, Grid

if TYPE_CHECKING:
    from .measure.stands import Stand

__all__ = ["DemoConfig", "CONFIGS", "DemoResult", "run_demo", "compare_with_truth", "WORK_DIR", "COMPARED_FILL",
           "VIEWER_DIR", "DEMO_MAKER", "DEMO_SIGNATURE", "DEFAULT_FABRICS"]

#: The materials the demo runs by default: the paper's two woven fabrics and velvet.
DEFAULT_FABRICS: tuple[str, ...] = ("denim", "shot", "velvet")

#: The maker the demo's output folder names in its owner mark (:func:`cdbrdf.outputs.output_folder`).
DEMO_MAKER = "demo"

#: Files every output folder of the demo holds.
DEMO_SIGNATURE: tuple[str, ...] = ("report.html",)

#: The sine sheet's light ``(theta, phi)`` and camera ``(elevation, azimuth)``, degrees: near the
#: normal, as the paper compares its mosaics (the centre of Fig. 7), the light along the crests
#: (a light raking across them lets the raised yarns shade the opened ones).
SINE_LIGHT: tuple[float, float] = (20.0, 90.0)
SINE_VIEW: tuple[float, float] = (70.0, -90.0)

#: Work folder for intermediate files, inside the partial output folder (removed on success).
WORK_DIR = ".work"

#: ``progress(stage, done, total)``: stage is a short label such as "denim: photographs".
Progress = Callable[[str, int, int], None]


@dataclass(frozen=True)
class DemoConfig:
    """Settings of one demo run.

    Attributes
    ----------
    name
        ``"quick"`` or ``"full"``.
    grid
        Capture grid (directions x stand curvatures).
    image_px
        Photograph width and height, pixels.
    capture_spp
        Samples per pixel of each photograph.
    render_size
        Width, height of the comparison renders, pixels.
    render_spp
        Samples per pixel of the comparison renders.
    keep_capture
        Keep the photographs in the output folder (else they are deleted).
    field_mm
        Width of the photographs' field at the stand, mm (the pixel size is
        ``field_mm / image_px``; the 7 x 7 patch the measurement averages is
        7 pixels of that size).
    seconds_per_photo, seconds_per_render_spp_mpix, seconds_fill
        Rough costs on a 2-core machine, for the time estimate printed up front
        (``seconds_fill``: the default fill's model fit, per material).
    """

    name: str
    grid: Grid
    image_px: int
    capture_spp: int
    render_size: tuple[int, int]
    render_spp: int
    keep_capture: bool
    field_mm: float = 1.0
    seconds_per_photo: float = 0.002  # rendering, noise, writing and measuring one photograph (2 cores)
    seconds_per_render_spp_mpix: float = 0.25
    seconds_fill: float = 60.0

    @property
    def n_photos(self) -> int:
        """Photographs per material (samples plus white references)."""
        k, pl, tl, pv, tv = self.grid.shape
        return k * pl * tl * pv * tv + pl * tl

    def expected_seconds(self, n_materials: int) -> float:
        """A rough estimate of the run time on a 2-core machine.

        Parameters
        ----------
        n_materials
            Number of materials run.

        Returns
        -------
        float
            Seconds.
        """
        w, h = self.render_size
        photos = self.n_photos * self.seconds_per_photo
        renders = 4 * self.render_spp * w * h / 1e6 * self.seconds_per_render_spp_mpix
        return n_materials * (photos + renders + self.seconds_fill + 10.0) + 15.0


#: The two standard runs: the paper's grid, and a coarse one for a quick look.
CONFIGS: dict[str, DemoConfig] = {
    "quick": DemoConfig(
        name="quick",
        grid=Grid(
            kappa=np.asarray(PAPER_KAPPA, dtype=np.float64),
            theta_l=np.array([0.0, 30.0, 60.0, 75.0]),
            phi_l=np.array([0.0, 90.0, 180.0, 270.0]),
            theta_v=np.array([0.0, 30.0, 60.0, 75.0]),
            phi_v=np.array([0.0, 90.0, 180.0, 270.0]),
        ),
        image_px=32,
        capture_spp=4,
        render_size=(384, 256),
        render_spp=16,
        keep_capture=True,
        seconds_fill=20.0,
    ),
    "full": DemoConfig(
        name="full",
        grid=Grid.paper(),
        image_px=32,
        capture_spp=4,
        render_size=(768, 512),
        render_spp=64,
        keep_capture=False,
    ),
}


@dataclass
class MaterialResult:
    """What the demo found for one material."""

    name: str
    truth_attrs: dict[str, Any]
    measured_path: Path
    photos: int
    seconds: dict[str, float] = field(default_factory=dict)
    per_stand: list[dict[str, Any]] = field(default_factory=list)
    error: dict[str, float] = field(default_factory=dict)
    fill_method: str = ""
    compared_fill: dict[str, Any] = field(default_factory=dict)
    summary: str = ""
    figures: dict[str, str] = field(default_factory=dict)
    render_exposure_ev: float = 0.0
    contrast: dict[str, Any] = field(default_factory=dict)


@dataclass
class DemoResult:
    """The demo's output folder, report and per-material results.

    Attributes
    ----------
    folder
        The output folder.
    report
        Its ``report.html``.
    config
        The settings run.
    materials
        One result per material, in order.
    seconds
        The whole run, seconds.
    timings_s
        Seconds per stage, summed over the materials (``photographs``,
        ``measuring``, ``figures``, ``render_sine``, ``render_drape``), plus
        ``surfaces_figure``, ``cleanup`` (waiting for the photographs'
        deletion, which runs beside the renders), ``viewer`` and ``total``;
        written to ``results.json`` under the same name.
    """

    folder: Path
    report: Path
    config: DemoConfig
    materials: list[MaterialResult]
    seconds: float
    timings_s: dict[str, float] = field(default_factory=dict)


def compare_with_truth(measured: CDBRDF, truth: CDBRDF) -> tuple[dict[str, float], list[dict[str, Any]]]:
    """Errors of a measured table against the ground truth at its samples.

    The truth is evaluated at every sample of ``measured`` (exact at shared
    nodes).

    Parameters
    ----------
    measured
        The measured table.
    truth
        The table it was photographed from.

    Returns
    -------
    overall : dict
        Statistics over all samples.
    per_stand : list of dict
        One row per stand (curvature): samples, measured, filled, the median
        / 95th-percentile relative error (luminance) of the measured samples
        and of the filled samples, and, when the table records the fill's
        uncertainty (``fill_std``), the fraction of filled samples whose error
        lies within 1 and 2 of their standard deviations (luminance of
        ``fill_std``).
    """
    g = measured.grid.mesh()
    t = truth.evaluate(g["theta_v"], g["phi_v"], g["theta_l"], g["phi_l"], g["kappa"])
    m = measured.values.astype(np.float64)
    rgb = m.shape[-1] == 3

    def lum(a: np.ndarray) -> np.ndarray:
        return luminance(a) if rgb else a.mean(axis=-1)

    ym, yt = lum(m), lum(t)
    scale = 1.0
    if measured.quantity == "relative":
        # unknown scale: compare after the least-squares scale over measured samples
        sel = measured.measured
        scale = float(np.sum(ym[sel] * yt[sel]) / max(np.sum(ym[sel] ** 2), 1e-30))
    err = np.abs(scale * ym - yt)
    rel = err / np.maximum(np.abs(yt), 1e-6)
    sigma = None if measured.fill_std is None else scale * np.abs(lum(measured.fill_std.astype(np.float64)))

    def stat(f: Any, a: np.ndarray) -> float:
        return float(f(a)) if a.size else float("nan")

    def within(sel: np.ndarray, n: float) -> float:
        if sigma is None or not sel.any():
            return float("nan")
        return float(np.mean(err[sel] <= n * sigma[sel]))

    rows = []
    for k, kappa in enumerate(measured.kappa):
        meas = measured.measured[k]
        r_m = rel[k][meas]
        r_f = rel[k][~meas]
        sel = np.zeros(measured.measured.shape, dtype=bool)
        sel[k] = ~meas
        rows.append({
            "kappa": float(kappa),
            "samples": int(meas.size),
            "measured": int(meas.sum()),
            "filled": int((~meas).sum()),
            "median_rel_error_measured": stat(np.median, r_m),
            "p95_rel_error_measured": stat(lambda a: np.percentile(a, 95), r_m),
            "median_rel_error_filled": stat(np.median, r_f),
            "p95_rel_error_filled": stat(lambda a: np.percentile(a, 95), r_f),
            "fill_within_1_sigma": within(sel, 1.0),
            "fill_within_2_sigma": within(sel, 2.0),
        })
    sel = measured.measured
    stats = {
        "median_rel_error_measured": float(np.median(rel[sel])),
        "p95_rel_error_measured": float(np.percentile(rel[sel], 95)),
        "median_rel_error_filled": stat(np.median, rel[~sel]),
        "p95_rel_error_filled": stat(lambda a: np.percentile(a, 95), rel[~sel]),
        "fill_within_1_sigma": within(~sel, 1.0),
        "fill_within_2_sigma": within(~sel, 2.0),
        "scale_applied": scale,
    }
    return stats, rows


#: Renders are exposed at most this many stops above the physical exposure
#: (a white Lambertian surface facing the light at display white), so that

def _stage(progress: Progress | None, label: str) -> Callable[[int, int], None] | None:
    if progress is None:
        return None
    return lambda done, total: progress(label, done, total)


def _contact_sheet(capture_dir: Path, grid: Grid, path: Path, *, material: str) -> None:
    """Photographs of every stand at one light, normal and grazing views."""
    from matplotlib.figure import Figure
    from matplotlib.patches import Rectangle

    from .images import read_image
    from .plot import kappa_label

    tl = grid.theta_l[min(1, grid.theta_l.size - 1)]
    pl = grid.phi_l[0]
    views = [(grid.theta_v[0], grid.phi_v[0]), (grid.theta_v[-1], grid.phi_v[0]),
             (grid.theta_v[-1], grid.phi_v[grid.phi_v.size // 2])]
    fig = Figure(figsize=(2.0 * grid.kappa.size, 2.1 * len(views) + 0.6), dpi=110, layout="constrained")
    axes = fig.subplots(len(views), grid.kappa.size, squeeze=False)
    for k, kappa in enumerate(grid.kappa):
        for r, (tv, pv) in enumerate(views):
            name = f"k{k}/l{tl:g}_{pl:g}_v{tv:g}_{pv:g}.png"
            ax = axes[r, k]
            ax.set_xticks([])
            ax.set_yticks([])
            f = capture_dir / name
            if f.is_file():
                img, info = read_image(f)
                x = img.astype(np.float64) / float(np.iinfo(img.dtype).max) if img.dtype.kind == "u" else img
                x = x[..., :3] if x.ndim == 3 else np.repeat(x[..., None], 3, axis=-1)
                lin = srgb_to_linear(x)
                ev = auto_exposure_ev(lin, target=0.7)
                ax.imshow(tonemap_srgb8(lin, exposure_ev=ev), interpolation="nearest")
                h, w = x.shape[:2]
                ax.add_patch(Rectangle((w // 2 - 3.5, h // 2 - 3.5), 7, 7, fill=False, edgecolor="red",
                                       linewidth=1.0))
            if r == 0:
                ax.set_title(kappa_label(float(kappa)), fontsize=9)
            if k == 0:
                ax.set_ylabel(f"view {tv:g}/{pv:g} deg", fontsize=9)
    fig.suptitle(f"{material}: photographs from the simulated rig (light {tl:g}/{pl:g} deg; "
                 "red square: the 7 x 7 patch)", fontsize=10)
    fig.savefig(path)


def _render_pair(table: CDBRDF, surface: Any, *, config: DemoConfig, progress: Progress | None,
                 label: str, curvature: bool = False, light: tuple[float, float] = (45.0, 0.0),
                 view: tuple[float, float] | None = None) -> tuple[Any, float]:
    """The surface rendered with the plain BRDF and the CDBRDF under one directional light; and the seconds."""
    from .render import Camera, Light, RenderSpec, render_table

    def stage(what: str, done: int, total: int) -> None:
        if progress is not None:
            progress(f"{label} ({what.removeprefix('rendering ')})", done, total)

    t0 = time.perf_counter()
    spec = RenderSpec(surface=surface, modes=("brdf", "cdbrdf"), size=config.render_size, spp=config.render_spp,
                      light=Light(lighting="paper", direction=light), camera=Camera(view=view), exposure="auto",
                      curvature_image=curvature)
    pic = render_table(table, spec, progress=stage)
    return pic, time.perf_counter() - t0


def _material(
    name: str,
    folder: Path,
    work: Path,
    config: DemoConfig,
    stands: Sequence[Stand],
    progress: Progress | None,
    discard: Callable[[Path], object],
) -> MaterialResult:
    """Photograph, measure, draw and render one material; ``discard(folder)`` deletes a folder in the background."""
    from . import materials
    from .measure import measure
    from .measure.fill import refill
    from .measure.plan import write_plan
    from .mesh import draped_cloth_mesh, prepare_mesh
    from .plot import plot_mosaic, plot_render_comparison
    from .render import crest_contrast
    from .rig import RigOptions, simulate_capture
    from .synth.metrics import bend_summary

    truth = materials.load(name)
    res = MaterialResult(name=name, truth_attrs=dict(truth.attrs), measured_path=folder / f"{name}-measured.h5",
                         photos=config.n_photos)
    capture = (folder if config.keep_capture else work) / f"capture-{name}"
    plan = work / f"plan-{name}"

    t0 = time.perf_counter()
    write_plan(plan, config.grid, stands)
    simulate_capture(truth, capture, RigOptions(size=config.image_px, field_mm=config.field_mm,
                                                spp=config.capture_spp, seed=1),
                     plan=plan / "capture.csv", progress=_stage(progress, f"{name}: photographs"))
    res.seconds["photographs"] = time.perf_counter() - t0

    t0 = time.perf_counter()
    measured, rep = measure(capture, res.measured_path, material=name,
                            progress=_stage(progress, f"{name}: measuring"))
    res.seconds["measuring"] = time.perf_counter() - t0
    res.summary = rep.summary()
    res.fill_method = rep.fill_method
    res.error, res.per_stand = compare_with_truth(measured, truth)
    # the paper's rule on the same measured samples, for comparison
    error, per_stand = compare_with_truth(refill(measured, method=COMPARED_FILL), truth)
    res.compared_fill = {"method": COMPARED_FILL, "error": error, "per_stand": per_stand}

    t0 = time.perf_counter()
    _contact_sheet(capture, config.grid, folder / f"{name}-photos.png", material=name)
    res.figures["photos"] = f"{name}-photos.png"
    fig = plot_mosaic(measured, title=f"{name}: measured CDBRDF (simulated capture)")
    fig.savefig(folder / f"{name}-mosaic-measured.png")
    res.figures["mosaic_measured"] = f"{name}-mosaic-measured.png"
    fig = plot_mosaic(truth, title=f"{name}: ground truth (the fabric model's table)")
    fig.savefig(folder / f"{name}-mosaic-truth.png")
    res.figures["mosaic_truth"] = f"{name}-mosaic-truth.png"
    res.seconds["figures"] = time.perf_counter() - t0
    if not config.keep_capture:
        discard(capture)  # 26,000 files: deleted while the renders run

    res.contrast["table"] = {"measured": bend_summary(measured), "truth": bend_summary(truth)}
    pic, res.seconds["render_sine"] = _render_pair(measured, "sine", config=config, progress=progress,
                                                   label=f"{name}: sine sheet", curvature=True, light=SINE_LIGHT,
                                                   view=SINE_VIEW)
    res.render_exposure_ev = pic.exposure_ev
    sheet = crest_contrast(pic)
    res.contrast["sine"] = {"crest_delta_e": sheet.crest_delta_e, "trough_delta_e": sheet.trough_delta_e,
                            "flat_delta_e": sheet.flat_delta_e,
                            "crest_srgb": sheet.crest_srgb, "flat_srgb": sheet.flat_srgb,
                            "crest_kappa": sheet.crest_fraction * sheet.kappa_max}
    fig = plot_render_comparison(pic.display("brdf"), pic.display("cdbrdf"), exposure_ev=pic.exposure_ev,
                                 title=f"{name}: sine sheet, seen and lit from {90 - SINE_VIEW[0]:g} and "
                                       f"{SINE_LIGHT[0]:g} deg off the normal",
                                 swatches=sheet)
    fig.savefig(folder / f"{name}-sine.png")
    res.figures["sine"] = f"{name}-sine.png"

    pic, res.seconds["render_drape"] = _render_pair(measured, prepare_mesh(draped_cloth_mesh()), config=config,
                                                    progress=progress, label=f"{name}: draped cloth")
    fig = plot_render_comparison(pic.display("brdf"), pic.display("cdbrdf"), exposure_ev=pic.exposure_ev,
                                 title=f"{name}: cloth draped over a dome (curvature from the mesh)")
    fig.savefig(folder / f"{name}-drape.png")
    res.figures["drape"] = f"{name}-drape.png"
    return res


def _curvature_figure(path: Path) -> Any:
    """The two rendered surfaces coloured by their curvature; returns the prepared draped cloth (for the viewer)."""
    from .mesh import DrapedCloth, SineSheet, draped_cloth_mesh, prepare_mesh, sine_sheet_mesh
    from .plot import plot_curvature_map

    sheet = sine_sheet_mesh(SineSheet(vertices_per_wavelength=16))
    drape = prepare_mesh(draped_cloth_mesh(DrapedCloth(resolution=81)))
    fig = plot_curvature_map([
        ("sine sheet (analytic curvature)", sheet.vertices, sheet.faces, sheet.attributes["curvature"]),
        ("draped cloth (curvature from the mesh)", drape.vertices, drape.faces, drape.attributes["curvature"]),
    ])
    fig.savefig(path)
    return drape


def _export_viewer(folder: Path, results: Sequence[MaterialResult], drape: Any) -> None:
    """The interactive viewers of the measured tables (two side by side; one alone beside its ground truth)."""
    from . import materials as mats
    from .table import load
    from .view.export import drape_entry, viewer_files, write_viewer

    for sub, pair in viewer_dirs(results):
        tables = [(m.measured_path.name, load(m.measured_path)) for m in pair]
        if len(tables) == 1:
            tables.append((f"{pair[0].name} ground truth", mats.load(pair[0].name)))
        write_viewer(folder / sub, viewer_files(tables, meshes={"drape": drape_entry(drape)},
                                                exposure_ev=pair[0].render_exposure_ev))


def run_demo(
    output: str | PathLike[str],
    *,
    quick: bool = False,
    materials: Sequence[str] = DEFAULT_FABRICS,
    config: DemoConfig | None = None,
    stands: Mapping[float, Stand] | Sequence[Stand] | None = None,
    progress: Progress | None = None,
) -> DemoResult:
    """Run the paper end to end and write ``report.html`` into ``output``.

    Parameters
    ----------
    output
        Output folder; replaced whole when it holds an earlier cdbrdf output,
        refused when it holds anything else (also files added to an earlier
        output since it was written: :func:`cdbrdf.outputs.output_folder`).
    quick
        Use :data:`CONFIGS` ``["quick"]`` (coarse grid, small images: a few
        minutes) instead of ``["full"]`` (the paper's grid).
    materials
        Bundled material names (:func:`cdbrdf.materials.names`).
    config
        Explicit settings (overrides ``quick``).
    stands
        The stands' geometry, one per curvature of the grid (any others are
        ignored); default the paper's (:func:`cdbrdf.measure.stands.default_stand`:
        6 mm faces, concave troughs with 1 mm walls). ``docs/capture.md``
        ("Filling") compares designs.
    progress
        ``progress(stage, done, total)`` callback.

    Returns
    -------
    DemoResult
        The output folder, the report and the numbers.
    """
    from . import materials as mats
    from .outputs import check_output_folder, output_folder
    from .render import check_llvm

    cfg = config or CONFIGS["quick" if quick else "full"]
    from .errors import OptionError

    unknown = [m for m in materials if m not in mats.names()]
    if unknown:
        raise OptionError(f"materials: {unknown} unknown; valid: {', '.join(mats.names())}")
    if not materials:
        raise OptionError("materials: give at least one")
    from .measure.stands import default_stand, stand_for

    kappas = [float(k) for k in cfg.grid.kappa]
    chosen = [default_stand(k) if stands is None else stand_for(stands, k) for k in kappas]
    check_output_folder(output, maker=DEMO_MAKER, signature=DEMO_SIGNATURE)  # fail now, not after the whole run
    check_llvm()  # before anything long starts
    t0 = time.perf_counter()
    results = []
    timings: dict[str, float] = {}
    with output_folder(output, maker=DEMO_MAKER, signature=DEMO_SIGNATURE) as folder:
        # intermediate files live inside the partial folder, so that a killed run's
        # leftovers are swept with it by the next run (cdbrdf.fsutil.sweep_stale)
        work = folder / WORK_DIR
        work.mkdir()
        t = time.perf_counter()
        drape = _curvature_figure(folder / "surfaces-curvature.png")
        timings["surfaces_figure"] = time.perf_counter() - t
        deletions: list[Future] = []
        with ThreadPoolExecutor(max_workers=1) as deleter:  # left only once every deletion is done
            for name in materials:
                results.append(_material(name, folder, work, cfg, chosen, progress,
                                         lambda p: deletions.append(deleter.submit(shutil.rmtree, p))))
            t = time.perf_counter()
        for d in deletions:
            d.result()  # a deletion's error, if any
        timings["cleanup"] = time.perf_counter() - t  # waiting for the deletions still running
        for m in results:
            for stage, sec in m.seconds.items():
                timings[stage] = timings.get(stage, 0.0) + sec
        t = time.perf_counter()
        shutil.rmtree(work)
        _export_viewer(folder, results, drape)
        timings["viewer"] = time.perf_counter() - t
        seconds = time.perf_counter() - t0
        timings["total"] = seconds
        (folder / "results.json").write_text(json.dumps({
            "config": cfg.name,
            "seconds": seconds,
            "timings_s": timings,
            "stands": [st.to_dict() for st in chosen],
            "materials": [{"name": m.name, "fill_method": m.fill_method, "error": m.error,
                           "per_stand": m.per_stand, "compared_fill": m.compared_fill,
                           "seconds": m.seconds, "figures": m.figures, "contrast": m.contrast}
                          for m in results],
        }, indent=2) + "\n")
        write_report(folder, cfg, results, seconds, chosen)
    final = Path(output)
    for m in results:
        m.measured_path = final / m.measured_path.name
    return DemoResult(folder=final, report=final / "report.html", config=cfg, materials=results,
                      seconds=seconds, timings_s=timings)
