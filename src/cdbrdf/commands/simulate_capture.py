"""``cdbrdf simulate-capture MATERIAL -o DIR``: photographs from the simulated rig."""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from ..rig import NoiseModel

from ._text import say

__all__ = ["register", "run"]


def _noise(text: str) -> NoiseModel:
    """``none`` or ``FULL_WELL[,READ]`` electrons (:meth:`cdbrdf.rig.NoiseModel.parse`)."""
    from ..rig import NoiseModel

    try:
        return NoiseModel.parse(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc).removeprefix("noise: ")) from None


def _material(text: str) -> str:
    """A preset name or an existing CDBRDF file."""
    from ..materials import names
    from ._args import existing_file

    if text in names():
        return text
    try:
        return existing_file()(text)
    except argparse.ArgumentTypeError:
        raise argparse.ArgumentTypeError(
            f"{text}: neither a material preset ({', '.join(names())}) nor an existing file") from None


def register(sub: argparse._SubParsersAction) -> None:
    from ..rig.sensor import IMAGE_KINDS
    from ._args import existing_file, finite_float, float_list, int_range, output_folder, seed, square_size, with_role

    p = sub.add_parser(
        "simulate-capture",
        help="render a capture folder of a material with the simulated rig (Mitsuba 3)",
        description="Render one photograph per row of a capture plan: the fabric (the cdbrdf "
        "BSDF at the stand's curvature) on a convex cylinder, flat face or concave trough "
        "with white walls, an orthographic camera and a directional light per row, photon "
        "and read noise, plus white references. The folder can then be measured with "
        "`cdbrdf measure`. See docs/capture.md.",
    )
    p.add_argument("material", type=with_role(_material, "input"),
                   help="preset name (see cdbrdf.materials), a CDBRDF file or a CD-BTF file (laid on the "
                   "stands in mm, its registration written to stands.json)")
    p.add_argument("-o", "--output", required=True, metavar="DIR", type=output_folder(replaced=False),
                   help="capture folder to write (new, empty, or an earlier simulated capture, replaced "
                   "whole unless files were added to it since)")
    p.add_argument("--plan", type=existing_file(".csv"), default=None,
                   help="capture.csv to render (default: the material's grid, the paper's stands, white references)")
    p.add_argument("--size", type=square_size(lo=8, hi=8192), default=None,
                   help="image size in pixels, 8 to 8192 (64; a CD-BTF: from --px-per-texel)")
    p.add_argument("--field", type=finite_float(0, 1e4, lo_open=True, unit="mm"), default=None,
                   help="camera field width at the stand, mm (2; a CD-BTF: 1.5 repeat diagonals)")
    p.add_argument("--px-per-texel", type=finite_float(0.5, 64), default=3.0,
                   help="a CD-BTF without --size: pixels per texel, 0.5 to 64 (3)")
    p.add_argument("--shifts", type=int_range(1, 64), default=1,
                   help="a CD-BTF without --plan: photograph every sample with the fabric at S positions along u, "
                   "a repeat / S apart (a scan; 1 to 64, default 1)")
    p.add_argument("--spp", type=int_range(1, 65536), default=4, help="samples per pixel (4)")
    p.add_argument("--noise", type=_noise, default="20000,3",
                   help="'none' or FULL_WELL[,READ] electrons (default 20000,3)")
    p.add_argument("--gain", type=finite_float(0, 1e12, lo_open=True), default=2.0,
                   help="pixel value per unit radiance (2)")
    p.add_argument("--exposures", type=float_list(0, 1e6, lo_open=True, max_len=16), default=[1.0],
                   help="exposure brackets of each sample photograph, e.g. 1,0.25 (default 1)")
    p.add_argument("--image", choices=tuple(IMAGE_KINDS), default="png16",
                   help="image kind: " + "; ".join(f"{k} {v}" for k, v in IMAGE_KINDS.items()) + " (png16)")
    p.add_argument("--white-albedo", type=finite_float(0, 1, lo_open=True), default=0.99,
                   help="white reference albedo, in (0, 1] (0.99)")
    p.add_argument("--seed", type=seed(), default=0, help="noise seed, 0 to 2**32-1 (0)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ..rig import simulate_capture
    from ._progress import ProgressBars

    with ProgressBars(quiet=args.quiet, unit="img") as bars:
        rep = simulate_capture(
            args.material, args.output, plan=args.plan, size=args.size, field_mm=args.field,
            px_per_texel=args.px_per_texel, shifts=args.shifts,
            spp=args.spp, noise=args.noise, gain=args.gain,
            exposures=args.exposures, image_kind=args.image, white_albedo=args.white_albedo,
            seed=args.seed, progress=bars.callback("render"),
        )
    if not args.quiet:
        say(rep.summary())
    return 0
