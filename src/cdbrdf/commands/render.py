"""``cdbrdf render FILE (--scene sine | --mesh MESH) -o OUT`` or ``cdbrdf render SCENE.xml -o OUT``.

Render with Mitsuba 3.

A Mitsuba XML scene (``SCENE.xml``, using ``<bsdf type="cdbrdf">``) is
loaded by :func:`cdbrdf.render.load_file` (the plug-in registered, files
found next to the scene, curvature units and the scene checks) with the
``mitsuba`` command's options: ``-D name=value`` for the scene's parameters,
``--spp`` (the sensor's count unless given), the variant, ``--seed``; the
scene defines camera, film, lights and integrator. ``--units`` is the
scene's unit there (mm per scene unit).

PNG output is tone-mapped by an exposure and sRGB-encoded:
``png = srgb(clip(radiance * 2**exposure, 0, 1))`` with ``--exposure`` in EV,
by default chosen from the render (``auto``: the 99th percentile of the
object's luminance maps to 0.85 of white,
:func:`cdbrdf.render.scenes.exposure_from_render`). With the default light
irradiance (pi) a white Lambertian surface facing the light has radiance 1,
i.e. just white at 0 EV. EXR output is the linear radiance (no exposure
applied; black where the built-in studio sky is hidden); both are written by
:func:`cdbrdf.render.output.write_render`. ``--compare`` renders the plain
BRDF and the CDBRDF and writes one figure: BRDF | CDBRDF | difference (heat
map of the per-pixel RGB distance in linear radiance, with a colour bar), as
the paper's Figs. 9-10 (:func:`cdbrdf.plot.plot_render_comparison`).

``--mesh`` takes any mesh cdbrdf reads, repairs it and says what it repaired,
computes its curvature in mm^-1 with ``--units`` (or the unit the file
records) unless the file already holds one computed so, detects the up axis
(``--up``), frames the camera on it and lights it with a studio set-up
(``--lighting studio``: an environment and a key light) or the paper's one
directional light (``--lighting paper``); see :mod:`cdbrdf.render.scenes`.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

from ..errors import OptionError
from ..limits import MAX_SPP
from ._text import say

__all__ = ["register", "run"]

#: Default image size of the built-in scenes.
_SIZE = (512, 384)

#: The passes of a render use seeds ``seed .. seed + spp // 16``.
_SEED_MAX = 2**32 - 1 - MAX_SPP

#: Options of the built-in scenes that a scene file defines itself (refused with SCENE.xml when changed).
_SCENE_FILE_IGNORES = ("light", "irradiance", "no_light", "envmap", "amplitude", "wavelength", "sheet_size",
                       "max_depth", "view", "size", "brdf", "compare", "lighting", "curvature", "up",
                       "neighbourhood", "frame")


def register(sub: argparse._SubParsersAction) -> None:
    from ..mesh import CURVATURE_MODES, MESH_FORMATS, UP_AXES
    from ..render import VARIANTS
    from ..render.scenes import LIGHTINGS
    from ._args import (
        existing_file,
        finite_float,
        float_list,
        input_path,
        int_range,
        key_value,
        keyword,
        output_file,
        seed,
        size_wxh,
    )
    from .curvature import mesh_options

    p = sub.add_parser(
        "render",
        help="render a CDBRDF with Mitsuba 3 (the paper's sine sheet or any mesh)",
        description="Render a CDBRDF file with Mitsuba 3 (llvm_ad_rgb) on the paper's sine sheet or on "
        "a mesh (PLY, OBJ, glTF/GLB, STL, OFF; repaired, its curvature computed in 1/mm from --units "
        "unless the file has it). PNG is sRGB-encoded after the exposure (radiance x 2^EV, clipped; "
        "default: chosen from the render); EXR is linear.",
    )
    p.add_argument("file", type=input_path(),
                   help="a CDBRDF file (.h5), or a Mitsuba scene (.xml) using <bsdf type=\"cdbrdf\">")
    what = p.add_mutually_exclusive_group()
    what.add_argument("--scene", choices=["sine"], help="built-in scene: the paper's sine sheet")
    what.add_argument("--mesh", metavar="MESH", type=existing_file(*MESH_FORMATS),
                      help=f"a mesh ({', '.join(MESH_FORMATS)}), lengths in --units")
    mode = p.add_mutually_exclusive_group()
    mode.add_argument("--brdf", action="store_true", help="render the plain BRDF (kappa = 0 slice)")
    mode.add_argument("--compare", action="store_true",
                      help="write a figure BRDF | CDBRDF | difference (PNG/PDF/SVG output)")
    p.add_argument("-o", "--output", required=True, metavar="OUT",
                   type=output_file(),
                   help="output .png or .exr (--compare: .png, .pdf or .svg)")
    p.add_argument("--spp", type=int_range(1, MAX_SPP), default=None,
                   help=f"samples per pixel, 1 to {MAX_SPP} (default: 64; a scene file: its sensor's)")
    p.add_argument("-D", dest="define", action="append", default=[], type=key_value(), metavar="NAME=VALUE",
                   help="a scene file's parameter $NAME (as Mitsuba's -D; repeatable)")
    p.add_argument("--size", type=size_wxh(), default=None, metavar="WxH",
                   help=f"image size (default: {_SIZE[0]}x{_SIZE[1]}; at most CDBRDF_MAX_RENDER_PIXELS pixels; a "
                   "scene file: its film's)")
    p.add_argument("--lighting", choices=LIGHTINGS, default=None,
                   help="studio: an environment and a key light; paper: one directional light "
                   "(default: studio for --mesh, paper for --scene)")
    p.add_argument("--light", type=float_list(-360, 360, min_len=2, max_len=2, example="45,0", unit="deg"),
                   default=None, metavar="THETA,PHI",
                   help="direction towards the directional (key) light, degrees: elevation from the up "
                   "axis, azimuth from +x (the sheet's bending direction) (default: 45,0; studio: 45 "
                   "degrees above and to the camera's left)")
    p.add_argument("--irradiance", type=finite_float(0, 1e9, lo_open=True, unit="W/m^2"), default=math.pi,
                   help="irradiance of the light, W/m^2 (default: pi)")
    p.add_argument("--no-light", action="store_true", help="no directional light (use with --envmap)")
    p.add_argument("--envmap", metavar="FILE", type=existing_file(".exr", ".hdr"),
                   help="environment map (.exr/.hdr) for --mesh (with studio lighting: instead of its sky)")
    mesh_options(p)
    p.add_argument("--curvature", choices=CURVATURE_MODES, default="max",
                   help="the curvature looked up: max (the paper's: principal curvature of larger "
                   "magnitude) or directional (normal curvature along the material's x axis) "
                   "(default: max)")
    p.add_argument("--up", choices=UP_AXES, default="auto",
                   help="up axis of --mesh (default auto: recorded in the file, else the format's usual one)")
    p.add_argument("--exposure", type=keyword(("auto",), finite_float(-64, 64, unit="EV")), default="auto",
                   help="PNG exposure in EV, -64 to 64, or auto: from the render (default: auto)")
    p.add_argument("--amplitude", type=finite_float(0, 1000, lo_open=True, unit="mm"), default=2.0,
                   help="sine sheet amplitude, mm (default: 2)")
    p.add_argument("--wavelength", type=finite_float(0.01, 1e5, unit="mm"), default=20.0,
                   help="sine sheet wavelength, mm (default: 20)")
    p.add_argument("--sheet-size", type=float_list(0, 1e5, lo_open=True, min_len=2, max_len=2, sep="x",
                                                  example="60x60", unit="mm"),
                   default="60x60", metavar="WxD", help="sine sheet size, mm (default: 60x60)")
    p.add_argument("--max-depth", type=int_range(2, 64), default=3,
                   help="Mitsuba path length, 2 to 64: 2 = direct light only (default: 3)")
    p.add_argument("--view", type=float_list(-360, 360, min_len=2, max_len=2, example="40,-90", unit="deg"),
                   default=None, metavar="ELEV,AZIM",
                   help="camera elevation above the ground plane and azimuth, degrees (default: 40,-90 "
                   "for the sheet, 20,-65 for a mesh)")
    p.add_argument("--seed", type=seed(_SEED_MAX), default=0,
                   help=f"random seed, 0 to {_SEED_MAX} (default: 0)")
    p.add_argument("--variant", choices=VARIANTS, default="llvm_ad_rgb",
                   help="Mitsuba variant (default: llvm_ad_rgb; spectral and mono variants too; "
                   "scalar_*: one Python call per ray, debugging only)")
    # the defaults (and the types that parse them), to tell the options a scene file does not use
    defaults = {a.dest: (a.default, a.type) for a in p._actions if a.dest in _SCENE_FILE_IGNORES}
    p.set_defaults(func=run, defaults_=defaults)


def _check_sheet(sheet) -> None:  # noqa: ANN001 - a SineSheet
    """Refuse a sine sheet whose tessellation would exceed the ``mesh_faces`` limit."""
    from ..limits import check

    check("mesh_faces", sheet.face_count, what=f"--wavelength {sheet.wavelength_mm:g} and --sheet-size "
          f"{sheet.width_mm:g}x{sheet.depth_mm:g}: sine sheet mesh")


def run(args: argparse.Namespace) -> int:  # noqa: C901 - one command, step by step
    from .. import render as cr
    from ..mesh import SineSheet, detect_up, prepare_mesh
    from ..plot import FIGURE_FORMATS, plot_render_comparison, save_figure
    from ..render.output import IMAGE_FORMATS, write_render
    from ..render.scenes import (
        DEFAULT_MESH_VIEW,
        DEFAULT_SINE_VIEW,
        composite,
        exposure_from_render,
        mesh_scene,
        render_scene,
        sine_scene,
    )
    from ..table import load
    from ._progress import ProgressBars
    from .curvature import LARGE_MESH_FACES, print_mesh_report

    if Path(args.file).suffix.lower() == ".xml":
        return _run_scene_file(args)
    if args.scene is None and args.mesh is None:
        raise OptionError("give --scene sine or --mesh MESH for a CDBRDF file (or render a scene file SCENE.xml)")
    if args.define:
        raise OptionError("-D: only for a scene file (SCENE.xml)")
    args.spp = 64 if args.spp is None else args.spp
    out = Path(args.output)
    ext = out.suffix.lower()
    if args.compare:
        if ext not in FIGURE_FORMATS:
            raise OptionError(f"{out}: --compare writes a figure; use {', '.join(FIGURE_FORMATS)}")
    elif ext not in IMAGE_FORMATS:
        raise OptionError(f"{out}: unknown image type {ext!r}; use {' or '.join(IMAGE_FORMATS)}")
    width, height = args.size or _SIZE
    is_mesh = args.scene != "sine"
    lighting = args.lighting or ("studio" if is_mesh else "paper")
    elev, azim = args.view if args.view is not None else (DEFAULT_MESH_VIEW if is_mesh else DEFAULT_SINE_VIEW)
    if args.no_light:
        light = None
    elif args.light is not None:
        light = (args.light[0], args.light[1], args.irradiance)
    elif lighting == "paper":
        light = (45.0, 0.0, args.irradiance)
    else:
        from ..render.scenes import STUDIO_KEY

        light = (STUDIO_KEY[0], azim + STUDIO_KEY[1], args.irradiance)
    if not is_mesh:
        if args.envmap:
            raise OptionError("--envmap: only for --mesh scenes")
        if lighting == "studio":
            raise OptionError("--lighting studio: only for --mesh scenes (the sine sheet is the paper's set-up)")
        if light is None:
            raise OptionError("--no-light: the sine sheet needs a light (the paper's directional light)")
        sw, sd = args.sheet_size
        sheet = SineSheet(amplitude_mm=args.amplitude, wavelength_mm=args.wavelength, width_mm=sw, depth_mm=sd)
        _check_sheet(sheet)
    elif light is None and args.envmap is None and lighting == "paper":
        raise OptionError("--no-light: the scene needs a light; give --envmap or use --lighting studio")
    table = load(args.file)
    cr.set_variant(args.variant)
    common = dict(size=(width, height), spp=args.spp, max_depth=args.max_depth,
                  elevation_deg=elev, azimuth_deg=azim, curvature_mode=args.curvature)
    if not is_mesh:

        def build(mode: str) -> object:
            return sine_scene(table, mode=mode, sheet=sheet, light=light, **common)
    else:
        from ..mesh import read_mesh

        source = read_mesh(args.mesh)
        big = source.faces.shape[0] >= LARGE_MESH_FACES
        with ProgressBars(quiet=args.quiet or not big, unit="vtx") as bars:
            mesh = prepare_mesh(source, units=args.units, neighbourhood_mm=args.neighbourhood, frame=args.frame,
                                table=table, progress=bars.callback("curvature"))
        up, why = (args.up, "given") if args.up != "auto" else detect_up(mesh)
        if not args.quiet:
            print_mesh_report(str(args.mesh), mesh)
            say(f"{args.mesh}: up axis: {up} ({why}); lighting: {lighting}", err=True)

        def build(mode: str) -> object:
            return mesh_scene(table, mesh, mode=mode, lighting=lighting, light=light, envmap=args.envmap,
                              up=up, **common)

    modes = ["brdf", "cdbrdf"] if args.compare else ["brdf" if args.brdf else "cdbrdf"]
    images = {}
    with ProgressBars(quiet=args.quiet, unit="spp", leave=True) as bars:
        for mode in modes:
            images[mode] = render_scene(build(mode), spp=args.spp, seed=args.seed, alpha=True,
                                        progress=bars.callback(f"rendering {mode}"))
    shown = images["cdbrdf" if "cdbrdf" in images else modes[0]]
    if args.exposure == "auto":
        ev, how = exposure_from_render(shown, irradiance=args.irradiance), "auto"
    else:
        ev, how = float(args.exposure), "given"
    backdrop = is_mesh and lighting == "studio" and args.envmap is None
    if args.compare:
        pics = {m: composite(im, exposure_ev=ev) if backdrop else im[..., :3] for m, im in images.items()}
        name = table.attrs.get("material") or Path(args.file).stem
        lit = f"light theta={light[0]:g}, phi={light[1]:g} deg" if light is not None else "environment"
        fig = plot_render_comparison(pics["brdf"], pics["cdbrdf"], exposure_ev=ev,
                                     title=f"{name}: {lighting} lighting, {lit}")
        save_figure(fig, out, dpi=150)
    elif ext == ".png":
        write_render(out, composite(shown, exposure_ev=ev) if backdrop else shown[..., :3], exposure_ev=ev)
    else:
        write_render(out, shown[..., :3])
    if not args.quiet:
        expo = f", exposure {ev:+.2f} EV ({how})" if ext != ".exr" or args.compare else ""
        say(f"{out}: written ({width}x{height}, {args.spp} spp{expo})", err=True)
    return 0


def _run_scene_file(args: argparse.Namespace) -> int:
    """``cdbrdf render SCENE.xml``: load with :func:`cdbrdf.render.load_file`, check, render, write."""
    import numpy as np

    from .. import render as cr
    from ..errors import SceneError
    from ..mesh import parse_units
    from ..render.output import IMAGE_FORMATS, write_render
    from ..render.scenes import exposure_from_render, render_scene
    from ._progress import ProgressBars

    if args.scene is not None or args.mesh is not None:
        raise OptionError(f"{args.file}: a scene file brings its own shapes; --scene and --mesh are not used")
    changed = []
    for k, (default, kind) in getattr(args, "defaults_", {}).items():
        if isinstance(default, str) and callable(kind):
            try:
                default = kind(default)
            except (argparse.ArgumentTypeError, ValueError):
                continue  # its default cannot be parsed here (e.g. a limit variable): not comparable
        if getattr(args, k) != default:
            changed.append(k)
    if changed:
        raise OptionError(f"--{changed[0].replace('_', '-')}: not used with a scene file (the scene defines "
                          "camera, film, lights and integrator; use -D for its parameters)")
    out = Path(args.output)
    if out.suffix.lower() not in IMAGE_FORMATS:
        raise OptionError(f"{out}: unknown image type {out.suffix.lower()!r}; use {' or '.join(IMAGE_FORMATS)}")
    unit_mm = 1.0 if args.units is None else parse_units(args.units).mm_per_unit
    cr.set_variant(args.variant)
    import mitsuba as mi

    from ..fsutil import check_not_input
    from ..render.scenefile import LoadReport

    report = LoadReport()
    scene = cr.load_file(args.file, variables=dict(args.define), unit_mm=float(unit_mm), report=report)
    check_not_input([(out, False)], report.files)  # e.g. -o over the scene's environment map
    if not isinstance(scene, mi.Scene):
        raise SceneError(f"{args.file}: holds a {type(scene).__name__}, not a scene")
    if not scene.sensors():
        raise SceneError(f"{args.file}: the scene has no sensor to render from")
    if scene.integrator() is None:
        raise SceneError(f"{args.file}: the scene has no integrator (add one, e.g. <integrator type=\"path\"/>)")
    with ProgressBars(quiet=args.quiet, unit="spp", leave=True) as bars:
        image = render_scene(scene, spp=args.spp, seed=args.seed, progress=bars.callback("rendering"))
    if out.suffix.lower() == ".exr":
        write_render(out, image)  # grey (one channel) in mono variants
        expo = ""
    else:
        rgb = np.repeat(image, 3, axis=-1) if image.shape[-1] == 1 else image[..., :3]
        ev = exposure_from_render(rgb) if args.exposure == "auto" else float(args.exposure)
        write_render(out, rgb, exposure_ev=ev)
        expo = f", exposure {ev:+.2f} EV ({'auto' if args.exposure == 'auto' else 'given'})"
    if not args.quiet:
        h, w = image.shape[:2]
        say(f"{out}: written ({w}x{h}, {args.spp or scene.sensors()[0].sampler().sample_count()} spp, "
              f"{args.variant}{expo})", err=True)
    return 0
