"""``cdbrdf render FILE (--scene sine | --mesh MESH) -o OUT`` or ``cdbrdf render SCENE.xml -o OUT``.

Render with Mitsuba 3.

A Mitsuba XML scene (``SCENE.xml``, using ``<bsdf type="cdbrdf">``) is
loaded by :func:`cdbrdf.render.load_file` (the plug-in registered, files
found next to the scene, curvature units and the scene checks) with the
``mitsuba`` command's options: ``-D name=value`` for the scene's parameters,
``--spp`` (the sensor's count unless given), the variant, ``--seed``; the
scene defines camera, film, lights and integrator. ``--units`` is the
scene's unit there (mm per scene unit).

PNG output is tone-mapped by a fixed exposure and sRGB-encoded:
``png = srgb(clip(radiance * 2**exposure, 0, 1))`` with ``--exposure`` in EV
(default 0). With the default light irradiance (pi) a white Lambertian surface
facing the light has radiance 1, i.e. just white at 0 EV. EXR output is the
linear radiance (no exposure applied); both are written by
:func:`cdbrdf.render.output.write_render`. ``--compare`` renders the plain BRDF
and the CDBRDF and writes one figure: BRDF | CDBRDF | difference (heat map of
the per-pixel RGB distance in linear radiance, with a colour bar), as the
paper's Figs. 9-10 (:func:`cdbrdf.plot.plot_render_comparison`).
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

__all__ = ["register", "run"]


#: Largest --spp; the passes of a render use seeds ``seed .. seed + spp // 16``.
MAX_SPP = 65536

_SEED_MAX = 2**32 - 1 - MAX_SPP

#: Options of the built-in scenes that a scene file defines itself (refused with SCENE.xml when changed).
_SCENE_FILE_IGNORES = ("light", "irradiance", "no_light", "envmap", "amplitude", "wavelength", "sheet_size",
                       "max_depth", "view", "size", "brdf", "compare")


def register(sub: argparse._SubParsersAction) -> None:
    from ..render import VARIANTS
    from ..render.scenes import UNITS_MM
    from ._args import existing_file, finite_float, float_list, int_range, key_value, output_file, seed, size_wxh

    p = sub.add_parser(
        "render",
        help="render a CDBRDF with Mitsuba 3 (the paper's sine sheet or a UV-mapped mesh)",
        description="Render a CDBRDF file with Mitsuba 3 (llvm_ad_rgb) on the paper's sine sheet "
        "or on a mesh with UVs (curvature computed if the file has none). PNG is sRGB-encoded "
        "after the exposure (radiance x 2^EV, clipped); EXR is linear.",
    )
    p.add_argument("file", help="a CDBRDF file (.h5), or a Mitsuba scene (.xml) using <bsdf type=\"cdbrdf\">")
    what = p.add_mutually_exclusive_group()
    what.add_argument("--scene", choices=["sine"], help="built-in scene: the paper's sine sheet")
    what.add_argument("--mesh", metavar="MESH", type=existing_file(".ply", ".obj"), help="a .ply/.obj mesh with UVs (lengths in --units)")
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
    p.add_argument("--size", type=size_wxh(), default="512x384", metavar="WxH",
                   help="image size (default: 512x384; at most CDBRDF_MAX_RENDER_PIXELS pixels)")
    p.add_argument("--light", type=float_list(-360, 360, min_len=2, max_len=2, example="45,0", unit="deg"),
                   default="45,0", metavar="THETA,PHI",
                   help="direction towards the directional light, degrees: elevation from +z, "
                   "azimuth from +x (the sheet's bending direction) (default: 45,0)")
    p.add_argument("--irradiance", type=finite_float(0, 1e9, lo_open=True, unit="W/m^2"), default=math.pi,
                   help="irradiance of the light, W/m^2 (default: pi)")
    p.add_argument("--no-light", action="store_true", help="no directional light (use with --envmap)")
    p.add_argument("--envmap", metavar="FILE", type=existing_file(".exr", ".hdr"), help="environment map (.exr/.hdr) for --mesh")
    p.add_argument("--units", choices=sorted(UNITS_MM), default="mm", help="length unit of --mesh")
    p.add_argument("--exposure", type=finite_float(-64, 64, unit="EV"), default=0.0,
                   help="PNG exposure in EV, -64 to 64 (default: 0)")
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
                   default="40,-90", metavar="ELEV,AZIM",
                   help="camera elevation and azimuth, degrees (default: 40,-90)")
    p.add_argument("--seed", type=seed(_SEED_MAX), default=0,
                   help=f"random seed, 0 to {_SEED_MAX} (default: 0)")
    p.add_argument("--variant", choices=VARIANTS, default="llvm_ad_rgb",
                   help="Mitsuba variant (default: llvm_ad_rgb; spectral and mono variants too; "
                   "scalar_*: one Python call per ray, debugging only)")
    defaults = {}
    for action in p._actions:  # the parsed defaults, to tell options a scene file does not use
        if action.dest in _SCENE_FILE_IGNORES:
            d = action.default
            defaults[action.dest] = action.type(d) if isinstance(d, str) and callable(action.type) else d
    p.set_defaults(func=run, defaults_=defaults)


def _check_sheet(sheet) -> None:  # noqa: ANN001 - a SineSheet
    """Refuse a sine sheet whose tessellation would exceed the ``mesh_faces`` limit."""
    from ..limits import check

    nx = round(sheet.width_mm / sheet.wavelength_mm * sheet.vertices_per_wavelength) + 1
    dx = sheet.width_mm / max(nx - 1, 1)
    ny = min(round(sheet.depth_mm / dx) + 1, 4 * nx)
    check("mesh_faces", 2 * max(nx - 1, 1) * max(ny - 1, 1),
          what=f"--wavelength {sheet.wavelength_mm:g} and --sheet-size "
          f"{sheet.width_mm:g}x{sheet.depth_mm:g}: sine sheet mesh")


def run(args: argparse.Namespace) -> int:
    from .. import render as cr
    from ..plot import FIGURE_FORMATS, plot_render_comparison, save_figure
    from ..render.output import IMAGE_FORMATS, write_render
    from ..render.scenes import SineSheet, mesh_scene, prepare_mesh, render_scene, sine_scene
    from ..table import load
    from ._progress import ProgressBars

    if Path(args.file).suffix.lower() == ".xml":
        return _run_scene_file(args)
    if args.scene is None and args.mesh is None:
        raise ValueError("give --scene sine or --mesh MESH for a CDBRDF file (or render a scene file SCENE.xml)")
    if args.define:
        raise ValueError("-D: only for a scene file (SCENE.xml)")
    args.spp = 64 if args.spp is None else args.spp
    out = Path(args.output)
    ext = out.suffix.lower()
    if args.compare:
        if ext not in FIGURE_FORMATS:
            raise ValueError(f"{out}: --compare writes a figure; use {', '.join(FIGURE_FORMATS)}")
    elif ext not in IMAGE_FORMATS:
        raise ValueError(f"{out}: unknown image type {ext!r}; use {' or '.join(IMAGE_FORMATS)}")
    width, height = args.size
    theta, phi = args.light
    elev, azim = args.view
    light = None if args.no_light else (theta, phi, args.irradiance)
    if args.scene == "sine":
        if args.envmap:
            raise ValueError("--envmap: only for --mesh scenes")
        sw, sd = args.sheet_size
        sheet = SineSheet(amplitude_mm=args.amplitude, wavelength_mm=args.wavelength, width_mm=sw, depth_mm=sd)
        _check_sheet(sheet)
    table = load(args.file)
    cr.set_variant(args.variant)
    common = dict(light=light, size=(width, height), spp=args.spp, max_depth=args.max_depth,
                  elevation_deg=elev, azimuth_deg=azim)
    if args.scene == "sine":

        def build(mode):
            return sine_scene(table, mode=mode, sheet=sheet, **common)
    else:
        mesh = prepare_mesh(args.mesh, units=args.units)

        def build(mode):
            return mesh_scene(table, mesh, mode=mode, envmap=args.envmap, **common)

    modes = ["brdf", "cdbrdf"] if args.compare else ["brdf" if args.brdf else "cdbrdf"]
    images = {}
    with ProgressBars(quiet=args.quiet, unit="spp", leave=True) as bars:
        for mode in modes:
            images[mode] = render_scene(build(mode), spp=args.spp, seed=args.seed,
                                        progress=bars.callback(f"rendering {mode}"))
    if args.compare:
        name = table.attrs.get("material") or Path(args.file).stem
        fig = plot_render_comparison(images["brdf"], images["cdbrdf"], exposure_ev=args.exposure,
                                     title=f"{name}: light theta={theta:g}, phi={phi:g} deg")
        save_figure(fig, out, dpi=150)
    else:
        write_render(out, images[modes[0]], exposure_ev=args.exposure)
    if not args.quiet:
        print(f"{out}: written ({width}x{height}, {args.spp} spp)", file=sys.stderr)
    return 0


def _run_scene_file(args: argparse.Namespace) -> int:
    """``cdbrdf render SCENE.xml``: load with :func:`cdbrdf.render.load_file`, check, render, write."""
    from .. import render as cr
    from ..errors import SceneError
    from ..render.output import IMAGE_FORMATS, write_render
    from ..render.scenes import UNITS_MM, render_scene
    from ._progress import ProgressBars

    if args.scene is not None or args.mesh is not None:
        raise ValueError(f"{args.file}: a scene file brings its own shapes; --scene and --mesh are not used")
    defaults = getattr(args, "defaults_", {})
    changed = [k for k in _SCENE_FILE_IGNORES if k in defaults and getattr(args, k) != defaults[k]]
    if changed:
        raise ValueError(f"--{changed[0].replace('_', '-')}: not used with a scene file (the scene defines "
                         "camera, film, lights and integrator; use -D for its parameters)")
    out = Path(args.output)
    if out.suffix.lower() not in IMAGE_FORMATS:
        raise ValueError(f"{out}: unknown image type {out.suffix.lower()!r}; use {' or '.join(IMAGE_FORMATS)}")
    units = args.units if isinstance(args.units, (int, float)) else UNITS_MM[args.units]
    cr.set_variant(args.variant)
    import mitsuba as mi

    scene = cr.load_file(args.file, variables=dict(args.define), unit_mm=float(units))
    if not isinstance(scene, mi.Scene):
        raise SceneError(f"{args.file}: holds a {type(scene).__name__}, not a scene")
    if not scene.sensors():
        raise SceneError(f"{args.file}: the scene has no sensor to render from")
    with ProgressBars(quiet=args.quiet, unit="spp", leave=True) as bars:
        image = render_scene(scene, spp=args.spp, seed=args.seed, progress=bars.callback("rendering"))
    write_render(out, image, exposure_ev=args.exposure)
    if not args.quiet:
        h, w = image.shape[:2]
        print(f"{out}: written ({w}x{h}, {args.spp or scene.sensors()[0].sampler().sample_count()} spp, "
              f"{args.variant})", file=sys.stderr)
    return 0
