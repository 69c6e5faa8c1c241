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
    from ..rig import options as o
    from ..rig.sensor import IMAGE_KINDS
    from ._args import (
        existing_file,
        float_list,
        in_range,
        output_folder,
        seed,
        square_size,
        with_role,
    )

    d = o.RigOptions()
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
    p.add_argument("--size", type=square_size(lo=int(o.SIZE_RANGE_PX.lo), hi=int(o.SIZE_RANGE_PX.hi)),  # type: ignore[arg-type]
                   default=None, help=f"image size, {o.SIZE_RANGE_PX.text()} ({o.DEFAULT_SIZE_PX}; "
                   "a CD-BTF: from --px-per-texel)")
    p.add_argument("--field", type=in_range(o.FIELD_RANGE_MM), default=None,
                   help=f"camera field width at the stand, {o.FIELD_RANGE_MM.text()} ({o.DEFAULT_FIELD_MM:g}; "
                   "a CD-BTF: 1.5 repeat diagonals)")
    p.add_argument("--px-per-texel", type=in_range(o.PX_PER_TEXEL_RANGE), default=d.px_per_texel,
                   help=f"a CD-BTF without --size: pixels per texel, {o.PX_PER_TEXEL_RANGE.text()} "
                   f"({d.px_per_texel:g})")
    p.add_argument("--shifts", type=in_range(o.SHIFTS_RANGE), default=d.shifts,
                   help="a CD-BTF without --plan: photograph every sample with the fabric at S positions along u, "
                   f"a repeat / S apart (a scan; {o.SHIFTS_RANGE.text()}, default {d.shifts})")
    p.add_argument("--spp", type=in_range(o.SPP_RANGE), default=d.spp,
                   help=f"samples per pixel, {o.SPP_RANGE.text()} ({d.spp})")
    p.add_argument("--noise", type=_noise, default="20000,3",
                   help="'none' or FULL_WELL[,READ] electrons (default 20000,3)")
    p.add_argument("--gain", type=in_range(o.GAIN_RANGE), default=d.gain,
                   help=f"pixel value per unit radiance, {o.GAIN_RANGE.text()} ({d.gain:g})")
    p.add_argument("--exposures", type=float_list(o.EXPOSURE_RANGE.lo, o.EXPOSURE_RANGE.hi, lo_open=True,
                                                  max_len=o.MAX_EXPOSURES), default=list(d.exposures),
                   help=f"exposure brackets of each sample photograph, e.g. 1,0.25 (1 to {o.MAX_EXPOSURES} values; "
                   "default 1)")
    p.add_argument("--image", choices=tuple(IMAGE_KINDS), default=d.image_kind,
                   help="image kind: " + "; ".join(f"{k} {v}" for k, v in IMAGE_KINDS.items())
                   + f" ({d.image_kind})")
    p.add_argument("--white-albedo", type=in_range(o.WHITE_ALBEDO_RANGE), default=d.white_albedo,
                   help=f"white reference albedo, {o.WHITE_ALBEDO_RANGE.text()} ({d.white_albedo:g})")
    p.add_argument("--seed", type=seed(int(o.SEED_RANGE.hi)), default=d.seed,  # type: ignore[arg-type]
                   help=f"noise seed, {o.SEED_RANGE.text()} ({d.seed})")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ..rig import RigOptions, simulate_capture
    from ._progress import ProgressBars

    options = RigOptions(size=args.size, field_mm=args.field, px_per_texel=args.px_per_texel, shifts=args.shifts,
                         spp=args.spp, noise=args.noise, gain=args.gain, exposures=tuple(args.exposures),
                         image_kind=args.image, white_albedo=args.white_albedo, seed=args.seed)
    with ProgressBars(quiet=args.quiet, unit="img") as bars:
        rep = simulate_capture(args.material, args.output, options, plan=args.plan,
                               progress=bars.callback("render"))
    if not args.quiet:
        say(rep.summary())
    return 0
