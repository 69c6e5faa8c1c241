"""``cdbrdf render FILE (--scene sine|swatch | --mesh MESH) -o OUT`` or ``cdbrdf render SCENE.xml -o OUT``.

Render with Mitsuba 3.

A Mitsuba XML scene (``SCENE.xml``, using ``<bsdf type="cdbrdf">``) is
loaded by :func:`cdbrdf.render.load_file` (the plug-in registered, files
found next to the scene, curvature units and the scene checks) with the
``mitsuba`` command's options: ``-D name=value`` for the scene's parameters,
``--spp`` (the sensor's count unless given), the variant, ``--seed``; the
scene defines camera, film, lights and integrator. ``--units`` is the
scene's unit there (mm per scene unit; default the ``cdbrdf`` BSDF's
``unit``, which ``-D`` can set through a ``$unit`` parameter, else mm).

PNG output is tone-mapped by an exposure and sRGB-encoded:
``png = srgb(clip(radiance * 2**exposure, 0, 1))`` with ``--exposure`` in EV,
or by default (``card``) the exposure at which an 18 % grey card facing the
key light shows as mid-grey, so that every fabric shows at its own
reflectance (:mod:`cdbrdf.render.picture`); ``auto`` chooses it from the
render (the 99th percentile of the object's luminance maps to 0.85 of
white, :func:`cdbrdf.render.picture.exposure_from_render`; the default for
a scene file, whose lights cdbrdf does not know). With the default light
irradiance (pi) a white Lambertian surface facing the light has radiance 1,
i.e. just white at 0 EV. EXR output is the linear radiance (no exposure
applied; black where the built-in studio sky is hidden); both are written by
:func:`cdbrdf.render.output.write_render`. ``--compare`` renders the plain
BRDF and the CDBRDF and writes one figure: BRDF | CDBRDF | difference (heat
map of the colour difference of the two pictures as shown, CIEDE2000 by
default or ``--delta-e ab``, with a colour bar naming the metric), as the
paper's Figs. 9-10 (:func:`cdbrdf.plot.plot_render_comparison`).

``--scene`` is a built-in scene (:data:`cdbrdf.render.scenes.SCENES`): the
paper's sine sheet or a swatch laid in folds of known radii (``--fold-radii``).
``--view``, ``--zoom``, ``--fov`` and ``--look-at`` make the camera
(:class:`cdbrdf.render.camera.Camera`): a close-up of a fold is
``--look-at X,Y,Z --zoom 6`` (the mesh's own coordinates and unit) or
``--look-at fold --zoom 6``.

``--mesh`` takes any mesh cdbrdf reads, repairs it and says what it repaired,
computes its curvature in mm^-1 with ``--units`` (or the unit the file
records) unless the file already holds one computed so, detects the up axis
(``--up``), frames the camera on it and lights it with a studio set-up
(``--lighting studio``: an environment and a key light) or the paper's one
directional light (``--lighting paper``); see :mod:`cdbrdf.render.scenes`.
"""

from __future__ import annotations

import argparse
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from ..errors import OptionError
from ._maps import MAP_OPTIONS
from ._text import say

__all__ = ["register", "run"]


def register(sub: argparse._SubParsersAction) -> None:
    from ..render import DEFAULT_TEXEL_FILTER, TEXEL_FILTERS, VARIANTS
    from ..render.spec import DEFAULT_SPP, EXPOSURE_RANGE_EV, EXPOSURES, SEED_RANGE, SPP_RANGE
    from ._args import in_range, input_path, key_value, keyword, output_file, seed
    from ._maps import add_map_options
    from .curvature import mesh_options

    p = sub.add_parser(
        "render",
        help="render a CDBRDF with Mitsuba 3 (the paper's sine sheet, a swatch or any mesh), or a Mitsuba scene",
        description="Render a CDBRDF file with Mitsuba 3 (llvm_ad_rgb) on the paper's sine sheet, a swatch "
        "in folds of known radii or a mesh (PLY, OBJ, glTF/GLB, STL, OFF; repaired, its curvature computed in "
        "1/mm from --units unless the file has it), or render a Mitsuba XML scene that uses <bsdf type=\"cdbrdf\">. "
        "PNG is sRGB-encoded after the exposure (radiance x 2^EV, clipped; default: an 18 % grey card "
        "facing the key light shows as mid-grey); EXR is linear.",
    )
    p.add_argument("file", type=input_path(),
                   help="a CDBRDF file (.h5), or a Mitsuba scene (.xml) using <bsdf type=\"cdbrdf\">")
    p.add_argument("-o", "--output", required=True, metavar="OUT", type=output_file(),
                   help="output .png or .exr (--compare: .png, .pdf or .svg)")
    p.add_argument("--spp", type=in_range(SPP_RANGE), default=None,
                   help=f"samples per pixel, {SPP_RANGE.text()} (default: {DEFAULT_SPP}; a scene file: its sensor's)")
    p.add_argument("--exposure", type=keyword(tuple(EXPOSURES), in_range(EXPOSURE_RANGE_EV)), default=None,
                   help=f"PNG exposure in EV, {EXPOSURE_RANGE_EV.text()}; "
                   + "; ".join(f"{k}: {v.split(': ', 1)[-1]}" for k, v in EXPOSURES.items()).replace("%", "%%")
                   + " (default: card; a scene file: auto)")
    p.add_argument("--seed", type=seed(int(SEED_RANGE.hi)), default=0,  # type: ignore[arg-type]
                   help=f"random seed, {SEED_RANGE.text()} (default: 0)")
    p.add_argument("--variant", choices=VARIANTS, default="llvm_ad_rgb",
                   help="Mitsuba variant (default: llvm_ad_rgb; spectral and mono variants too; "
                   "scalar_*: one Python call per ray, debugging only)")
    mesh_options(p, what="of --mesh (mm, cm, dm, m, in or mm per model unit; default: the one the file records or "
                 "states, else the one a garment's or a sheet's size makes plausible, else mm), or of a scene file "
                 "(mm per scene unit; default: the cdbrdf BSDF's 'unit', else mm)", only="units")

    scene_file = p.add_argument_group("a Mitsuba scene file (SCENE.xml)")
    scene_file.add_argument("-D", dest="define", action="append", default=None, type=key_value(),
                            metavar="NAME=VALUE", help="a scene parameter $NAME (as Mitsuba's -D; repeatable)")

    _table_options(p.add_argument_group("a CDBRDF file: the surface, its camera and light (every default below is "
                                         "the table form's; none of these apply to a scene file)"))
    add_map_options(p.add_argument_group("maps laid on --mesh by its UVs (docs/rendering.md, \"Maps\")"))
    btf = p.add_argument_group("a CD-BTF file (docs/btf.md)")
    btf.add_argument("--texel-filter", choices=TEXEL_FILTERS, default=None,
                     help=f"between texels: {', '.join(TEXEL_FILTERS)} (default {DEFAULT_TEXEL_FILTER})")
    p.set_defaults(func=run)


def _table_options(table: Any) -> None:
    """The options of the table form: the surface, its modes, light, camera and film (ranges from the records)."""
    from ..colour import DELTA_E_METRICS
    from ..mesh import CURVATURE_MODES, MESH_FORMATS, SineSheet
    from ..mesh.surfaces import SHEET_RANGES_MM, SWATCH_MAX_FOLDS, SWATCH_MAX_RADIUS_MM
    from ..render.camera import FOV_RANGE_DEG, LOOK_AT_ANCHORS, ZOOM_RANGE
    from ..render.lighting import IRRADIANCE_RANGE, LIGHTINGS
    from ..render.spec import DEFAULT_MAX_DEPTH, DEFAULT_SIZE, MAX_DEPTH_RANGE, SCENES, SIZE_RANGE
    from ._args import existing_file, finite_float, float_list, in_range, keyword, mesh_file, size_wxh
    from .curvature import mesh_options

    sheet = SineSheet()
    what = table.add_mutually_exclusive_group()
    what.add_argument("--scene", choices=tuple(SCENES), default=None,
                      help="built-in scene: " + "; ".join(f"{k}: {v}" for k, v in SCENES.items()))
    what.add_argument("--mesh", metavar="MESH", type=mesh_file(),
                      help=f"a mesh ({', '.join(MESH_FORMATS)}), lengths in --units")
    mode = table.add_mutually_exclusive_group()
    mode.add_argument("--brdf", action="store_true", default=None, help="render the plain BRDF (kappa = 0 slice)")
    mode.add_argument("--compare", action="store_true", default=None,
                      help="write a figure BRDF | CDBRDF | colour difference as shown (PNG/PDF/SVG output)")
    table.add_argument("--delta-e", choices=tuple(DELTA_E_METRICS), default=None,
                       help="the colour difference of --compare's heat map, between the pictures as shown "
                       "(sRGB -> CIELAB D65): 2000: CIEDE2000 (default); 2000-textiles: CIEDE2000 with kL = 2; "
                       "ab: CIE 1976 Delta E*ab")
    table.add_argument("--size", type=size_wxh(lo=int(SIZE_RANGE.lo), hi=int(SIZE_RANGE.hi)),  # type: ignore[arg-type]
                       default=None, metavar="WxH",
                       help=f"image size (default: {DEFAULT_SIZE[0]}x{DEFAULT_SIZE[1]}; at most "
                       "CDBRDF_MAX_RENDER_PIXELS pixels)")
    table.add_argument("--lighting", choices=LIGHTINGS, default=None,
                       help="studio: an environment and a key light; paper: one directional light "
                       "(default: studio for --mesh and --scene swatch, paper for --scene sine)")
    table.add_argument("--light", type=float_list(min_len=2, max_len=2, example="45,0", unit="deg"),
                       default=None, metavar="THETA,PHI",
                       help="direction towards the directional (key) light, degrees: elevation from the up "
                       "axis, 0 to 90 (exclusive), azimuth from +x (the sheet's bending direction) (default: 45,0; "
                       "studio: 45 degrees above and to the camera's left)")
    table.add_argument("--irradiance", type=in_range(IRRADIANCE_RANGE), default=None,
                       help=f"irradiance of the light, {IRRADIANCE_RANGE.text()} (default: pi)")
    table.add_argument("--no-light", action="store_true", default=None,
                       help="no directional light (use with --envmap)")
    table.add_argument("--envmap", metavar="FILE", type=existing_file(".exr", ".hdr"),
                       help="environment map (.exr/.hdr) for --mesh (with studio lighting: instead of its sky)")
    mesh_options(table, only=("neighbourhood", "frame", "up"))
    table.add_argument("--curvature", choices=tuple(CURVATURE_MODES), default=None,
                       help="the curvature looked up: " + "; ".join(f"{m.name}: {m.description}"
                                                                    for m in CURVATURE_MODES.values())
                       + " (default: max)")
    amp, wave, width = SHEET_RANGES_MM["amplitude_mm"], SHEET_RANGES_MM["wavelength_mm"], SHEET_RANGES_MM["width_mm"]
    table.add_argument("--amplitude", type=in_range(amp), default=None,
                       help=f"sine sheet amplitude, {amp.text()} (default: {sheet.amplitude_mm:g})")
    table.add_argument("--wavelength", type=in_range(wave), default=None,
                       help=f"sine sheet wavelength, {wave.text()} (default: {sheet.wavelength_mm:g})")
    table.add_argument("--sheet-size", type=float_list(width.lo, width.hi, lo_open=True, min_len=2, max_len=2,
                                                      sep="x", example="60x60", unit="mm"),
                       default=None, metavar="WxD",
                       help=f"sine sheet size, mm (default: {sheet.width_mm:g}x{sheet.depth_mm:g})")
    table.add_argument("--fold-radii", type=float_list(-SWATCH_MAX_RADIUS_MM, SWATCH_MAX_RADIUS_MM, min_len=1,
                                                      max_len=SWATCH_MAX_FOLDS, example="20,10,5,3", unit="mm"),
                       default=None, metavar="R1,R2,...",
                       help="the swatch's folds, left to right: radius in mm, > 0 a ridge, < 0 a groove "
                       "(default: 20,10,5,3)")
    table.add_argument("--max-depth", type=in_range(MAX_DEPTH_RANGE), default=None,
                       help=f"Mitsuba path length, {MAX_DEPTH_RANGE.text()}: 2 = direct light only "
                       f"(default: {DEFAULT_MAX_DEPTH})")
    table.add_argument("--view", type=float_list(min_len=2, max_len=2, example="40,-90", unit="deg"),
                       default=None, metavar="ELEV,AZIM",
                       help="camera elevation above the ground plane (-90 to 90) and azimuth, degrees "
                       "(default: 40,-90 for the sheet, 45,-75 for the swatch, 20,-65 for a mesh)")
    table.add_argument("--zoom", type=finite_float(*ZOOM_RANGE, unit="x"), default=None, metavar="F",
                       help=f"magnification about the framed view, {ZOOM_RANGE[0]:g} to {ZOOM_RANGE[1]:g}: 2 halves "
                       "the visible extent, the camera stays where it frames the whole object (default: 1)")
    table.add_argument("--fov", type=finite_float(*FOV_RANGE_DEG, lo_open=True, unit="deg"), default=None,
                       metavar="DEG", help="the lens's field of view along the picture's smaller side, degrees: "
                       "the object is framed the same, the perspective changes (default: 40 for the sheet and "
                       "the swatch, 30 for a mesh)")
    table.add_argument("--look-at", type=keyword(tuple(LOOK_AT_ANCHORS),
                                                 float_list(min_len=3, max_len=3, example="0,10,-5")),
                       default=None, metavar="X,Y,Z|ANCHOR",
                       help="the point at the picture's centre: X,Y,Z in the mesh's own coordinates and unit (as "
                       "in its file; the sheet and the swatch: mm, centred on the origin; a negative first "
                       "number as --look-at=-5,0,2), or " + "; ".join(f"{k}: {v}" for k, v in LOOK_AT_ANCHORS.items())
                       + " (default: the framed object's centre)")


#: Options of the table form (default None: not given), each refused with a scene file.
_TABLE_ONLY = ("scene", "mesh", "brdf", "compare", "size", "lighting", "light", "irradiance", "no_light", "envmap",
               "neighbourhood", "frame", "curvature", "up", "amplitude", "wavelength", "sheet_size",
               "max_depth", "view", "zoom", "fov", "look_at", "delta_e", "fold_radii", "texel_filter", *MAP_OPTIONS)

#: Options of one built-in surface, refused with another.
_SURFACE_ONLY = {"amplitude": "sine", "wavelength": "sine", "sheet_size": "sine", "fold_radii": "swatch"}


def run(args: argparse.Namespace) -> int:
    """``cdbrdf render``: a scene file, or a table on the sine sheet or a mesh (:func:`cdbrdf.render.render_table`)."""
    if Path(args.file).suffix.lower() == ".xml":
        given = [k for k in _TABLE_ONLY if getattr(args, k) is not None]
        if given:
            raise OptionError(f"--{given[0].replace('_', '-')}: not used with a scene file (the scene defines "
                              "its shapes, camera, film, lights and integrator; use -D for its parameters)")
        return _run_scene_file(args)
    if args.define is not None:
        raise OptionError("-D: only for a scene file (SCENE.xml)")
    return _run_table(args)


def _check_table_options(args: argparse.Namespace) -> None:
    """Refuse the options the table form's surface or output does not take (before anything is read)."""
    from ..plot import FIGURE_FORMATS
    from ..render.output import IMAGE_FORMATS

    if args.scene is None and args.mesh is None:
        raise OptionError("give --scene sine, --scene swatch or --mesh MESH for a CDBRDF file (or render a scene "
                          "file SCENE.xml)")
    for opt, scene in _SURFACE_ONLY.items():
        if getattr(args, opt) is not None and args.scene != scene:
            raise OptionError(f"--{opt.replace('_', '-')}: only for --scene {scene}")
    if args.delta_e is not None and not args.compare:
        raise OptionError("--delta-e: only with --compare (the metric of its heat map)")
    given = [k for k in MAP_OPTIONS[1:] if getattr(args, k) is not None]
    if given and args.mesh is None:
        raise OptionError(f"--{given[0].replace('_', '-')}: only for --mesh MESH (a built-in scene's folds are its "
                          "geometry)")
    out = Path(args.output)
    ext = out.suffix.lower()
    if args.compare:
        if ext not in FIGURE_FORMATS:
            raise OptionError(f"{out}: --compare writes a figure; use {', '.join(FIGURE_FORMATS)}")
    elif ext not in IMAGE_FORMATS:
        raise OptionError(f"{out}: unknown image type {ext!r}; use {' or '.join(IMAGE_FORMATS)}")


def _check_source(args: argparse.Namespace, source: Any) -> None:
    """Refuse the options a CDBRDF file (not a CD-BTF) does not take."""
    if source.is_btf:
        return
    if args.texel_filter is not None:
        raise OptionError(f"--texel-filter: only for a CD-BTF file ({args.file} has no texels)")
    if args.uv_scale is not None and args.mesh is None:
        raise OptionError(f"--uv-scale: for the maps of --mesh MESH or a CD-BTF file ({args.file} has no texels)")


def _surface(args: argparse.Namespace) -> Any:
    """The surface record of ``--scene``/``--mesh`` and their options."""
    from ..mesh import MeshSurface, SineSheet, Swatch

    if args.scene == "swatch":
        with _as_option("fold-radii", "radii_mm"):
            return Swatch() if args.fold_radii is None else Swatch(radii_mm=tuple(args.fold_radii))
    if args.mesh is None:
        defaults = SineSheet()
        width, depth = args.sheet_size or (defaults.width_mm, defaults.depth_mm)
        return SineSheet(amplitude_mm=args.amplitude or defaults.amplitude_mm,
                         wavelength_mm=args.wavelength or defaults.wavelength_mm, width_mm=width, depth_mm=depth)
    return MeshSurface(args.mesh, units=args.units, neighbourhood_mm=args.neighbourhood, frame=args.frame,
                       up=args.up or "auto")


def _spec(args: argparse.Namespace) -> object:
    """The :class:`cdbrdf.render.RenderSpec` of the table form's options."""
    from ..render import Camera, Light, RenderSpec
    from ..render.spec import DEFAULT_MAX_DEPTH, DEFAULT_SIZE, DEFAULT_SPP
    from ._maps import surface_maps

    with _as_option("view", "view"), _as_option("zoom", "zoom"), _as_option("fov", "fov_deg"), \
            _as_option("look-at", "look_at"):
        camera = Camera(view=None if args.view is None else tuple(args.view), zoom=args.zoom or 1.0,
                        fov_deg=args.fov, look_at=args.look_at if args.look_at is None or isinstance(args.look_at, str)
                        else tuple(args.look_at))
    light = Light(lighting=args.lighting,
                  direction=None if args.no_light else (tuple(args.light) if args.light is not None else "auto"),
                  irradiance=args.irradiance or Light().irradiance, envmap=args.envmap)
    modes = ("brdf", "cdbrdf") if args.compare else (("brdf",) if args.brdf else ("cdbrdf",))
    return RenderSpec(surface=_surface(args), modes=modes, camera=camera, light=light, maps=surface_maps(args),
                      exposure=args.exposure or "card", size=args.size or DEFAULT_SIZE,
                      spp=DEFAULT_SPP if args.spp is None else args.spp, seed=args.seed,
                      max_depth=args.max_depth or DEFAULT_MAX_DEPTH, curvature_mode=args.curvature or "max",
                      texel_filter=args.texel_filter, variant=args.variant)


def _run_table(args: argparse.Namespace) -> int:
    """``cdbrdf render TABLE (--scene sine|swatch | --mesh MESH)``."""
    from ..mesh import Swatch
    from ..plot import plot_render_comparison, save_figure
    from ..render import RenderSpec, render_table
    from ..render.output import write_render
    from ..sources import open_source
    from ._progress import ProgressBars
    from .curvature import LARGE_MESH_FACES, print_mesh_report

    _check_table_options(args)
    source = open_source(args.file)  # the file read once
    _check_source(args, source)
    spec = _spec(args)
    assert isinstance(spec, RenderSpec)
    out = Path(args.output)
    ext = out.suffix.lower()
    with ProgressBars(quiet=args.quiet, unit="spp", leave=True) as bars:
        def progress(stage: str, done: int, total: int) -> None:
            if stage != "curvature" or 2 * total >= LARGE_MESH_FACES:  # a bar for the fit of large meshes
                bars.update(stage, done, total)

        pic = render_table(source.table, spec, progress=progress)
    if pic.mesh is not None and not args.quiet:
        print_mesh_report(str(args.mesh), pic.mesh)
        say(f"{args.mesh}: up axis: {pic.up} ({pic.up_reason}); lighting: {pic.lighting}", err=True)
    if isinstance(spec.surface, Swatch) and not args.quiet:
        folds = ", ".join(f"{'ridge' if r > 0 else 'groove'} {abs(r):g} mm (kappa +-{1 / abs(r):.3g} / mm)"
                          for r in spec.surface.radii_mm)
        say(f"swatch: {folds}; lighting: {pic.lighting}", err=True)
    if args.compare:
        name = source.name
        lit = (f"light theta={pic.light[0]:g}, phi={pic.light[1]:g} deg" if pic.light is not None
               else "environment")
        fig = plot_render_comparison(pic.display("brdf"), pic.display("cdbrdf"), exposure_ev=pic.exposure_ev,
                                     title=f"{name}: {pic.lighting} lighting, {lit}", delta_e=args.delta_e or "2000")
        save_figure(fig, out, dpi=150)
    elif ext == ".png":
        write_render(out, pic.display(spec.modes[0]), exposure_ev=pic.exposure_ev)
    else:
        write_render(out, pic.images[spec.modes[0]][..., :3])
    if not args.quiet:
        expo = f", exposure {pic.exposure_ev:+.2f} EV ({pic.exposure_source})" if ext != ".exr" or args.compare else ""
        say(f"{out}: written ({spec.size[0]}x{spec.size[1]}, {spec.spp} spp{expo})", err=True)
    return 0


@contextmanager
def _as_option(option: str, field: str) -> Iterator[None]:
    """An :class:`OptionError` about the library's ``field`` said about the command's ``--option``."""
    try:
        yield
    except OptionError as exc:
        text = str(exc)
        if text.startswith(f"{field}: "):
            raise OptionError(f"--{option}: {text[len(field) + 2:]}") from None
        raise


def _run_scene_file(args: argparse.Namespace) -> int:
    """``cdbrdf render SCENE.xml``: load with :func:`cdbrdf.render.load_file`, check, render, write."""
    import numpy as np

    from .. import render as cr
    from ..errors import SceneError
    from ..mesh import parse_units
    from ..render.output import IMAGE_FORMATS, write_render
    from ..render.picture import exposure_from_render, render_scene
    from ._progress import ProgressBars

    out = Path(args.output)
    if out.suffix.lower() not in IMAGE_FORMATS:
        raise OptionError(f"{out}: unknown image type {out.suffix.lower()!r}; use {' or '.join(IMAGE_FORMATS)}")
    unit_mm = None if args.units is None else parse_units(args.units).mm_per_unit
    cr.set_variant(args.variant)  # the command is the application: it chooses the variant
    import mitsuba as mi

    from ..outputs import check_not_input
    from ..render.scenefile import LoadReport

    report = LoadReport()
    scene = cr.load_file(args.file, variables=dict(args.define or []), unit_mm=unit_mm, report=report)
    check_not_input([(out, False)], report.files)  # e.g. -o over the scene's environment map
    if not isinstance(scene, mi.Scene):
        raise SceneError(f"{args.file}: holds a {type(scene).__name__}, not a scene")
    if not scene.sensors():
        raise SceneError(f"{args.file}: the scene has no sensor to render from")
    if scene.integrator() is None:
        raise SceneError(f"{args.file}: the scene has no integrator (add one, e.g. <integrator type=\"path\"/>)")
    spp = args.spp or int(scene.sensors()[0].sampler().sample_count())  # before the passes change the sampler's
    with ProgressBars(quiet=args.quiet, unit="spp", leave=True) as bars:
        image = render_scene(scene, spp=spp, seed=args.seed, progress=bars.callback("rendering"))
    if out.suffix.lower() == ".exr":
        write_render(out, image)  # grey (one channel) in mono variants
        expo = ""
    else:
        rgb = np.repeat(image, 3, axis=-1) if image.shape[-1] == 1 else image[..., :3]
        auto = args.exposure in (None, "auto")
        ev = exposure_from_render(rgb) if auto else float(args.exposure)
        write_render(out, rgb, exposure_ev=ev)
        expo = f", exposure {ev:+.2f} EV ({'auto' if auto else 'given'})"
    if not args.quiet:
        h, w = image.shape[:2]
        say(f"{out}: written ({w}x{h}, {spp} spp, {args.variant}{expo})", err=True)
    return 0
