"""``cdbrdf simulate-capture MATERIAL -o DIR``: photographs from the simulated rig."""

from __future__ import annotations

import argparse

__all__ = ["register", "run"]


def _floats(text: str) -> list[float]:
    try:
        return [float(x) for x in text.split(",") if x.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected comma-separated numbers, got {text!r}") from None


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "simulate-capture",
        help="render a capture folder of a material with the simulated rig (Mitsuba 3)",
        description="Render one photograph per row of a capture plan: the fabric (the cdbrdf "
        "BSDF at the stand's curvature) on a convex cylinder, flat face or concave trough "
        "with white walls, an orthographic camera and a directional light per row, photon "
        "and read noise, plus white references. The folder can then be measured with "
        "`cdbrdf measure`. See docs/capture.md.",
    )
    p.add_argument("material", help="preset name (see cdbrdf.materials) or a CDBRDF file")
    p.add_argument("-o", "--output", required=True, metavar="DIR", help="capture folder to write")
    p.add_argument("--plan", default=None, help="capture.csv to render (default: the material's grid, "
                   "the paper's stands, white references)")
    p.add_argument("--size", type=int, default=64, help="image size in pixels (64)")
    p.add_argument("--field", type=float, default=2.0, help="camera field width at the stand, mm (2)")
    p.add_argument("--spp", type=int, default=4, help="samples per pixel (4)")
    p.add_argument("--noise", default="20000,3",
                   help="'none' or FULL_WELL[,READ] electrons (default 20000,3)")
    p.add_argument("--gain", type=float, default=2.0, help="pixel value per unit radiance (2)")
    p.add_argument("--exposures", type=_floats, default=[1.0],
                   help="exposure brackets of each sample photograph, e.g. 1,0.25 (default 1)")
    p.add_argument("--image", choices=("exr", "png16", "png8", "tif16"), default="png16",
                   help="image kind (png16)")
    p.add_argument("--white-albedo", type=float, default=0.99, help="white reference albedo (0.99)")
    p.add_argument("--seed", type=int, default=0, help="noise seed (0)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ..synth.rig import NoiseModel, simulate_capture

    bar = None
    if not args.quiet:
        from tqdm import tqdm

        bar = tqdm(total=0, unit="img", desc="render", leave=False, mininterval=0.5)

    def progress(done: int, total: int) -> None:
        if bar is not None:
            bar.total = total
            bar.update(done - bar.n)  # tqdm redraws at most every mininterval

    try:
        rep = simulate_capture(
            args.material, args.output, plan=args.plan, size=args.size, field_mm=args.field,
            spp=args.spp, noise=NoiseModel.parse(args.noise), gain=args.gain,
            exposures=args.exposures, image_kind=args.image, white_albedo=args.white_albedo,
            seed=args.seed, progress=progress,
        )
    finally:
        if bar is not None:
            bar.close()
    if not args.quiet:
        print(rep.summary())
    return 0
