"""``cdbrdf measure CAPTURE_DIR -o FILE``: photographs to a CDBRDF file."""

from __future__ import annotations

import argparse
from pathlib import Path

from ..measure.capture import WHITE_ALBEDO_RANGE
from ..measure.fill import BTF_DEFAULT_FILL, DEFAULT_FILL, FILL_METHODS
from ..measure.options import PATCH_RANGE_PX
from ._args import in_range, int_range, keyword, output_path
from ._text import say

__all__ = ["register", "run"]


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "measure",
        help="measure a capture folder (capture.csv + photographs) into a CDBRDF file",
        description="For every sample, the mean of the N x N patch at the stand's centre, "
        "decoded to linear, saturated pixels excluded, brackets merged, dark frame subtracted, "
        "divided by cos(theta_l), scaled by the white reference (quantity brdf; else relative). "
        "Invalid samples (hidden by the stand, missing, unreadable, saturated) are filled by "
        "--fill: by default from the same direction on the other stands, fitted along the "
        "curvature; --fill nearest is the paper's rule. Every filled sample records its method, "
        "sources and an uncertainty. An interrupted run resumes from FILE.ckpt. See docs/capture.md.",
    )
    p.add_argument("capture", metavar="CAPTURE_DIR", help="capture folder with capture.csv")
    p.add_argument("-o", "--output", required=True, metavar="FILE", type=output_path(),
                   help="CDBRDF file to write (.h5)")
    p.add_argument("--patch", type=in_range(PATCH_RANGE_PX), default=7,
                   help=f"patch size N in pixels, {PATCH_RANGE_PX.text()} (7)")
    p.add_argument("--linear", action="store_true", help="integer images hold linear values, not sRGB")
    p.add_argument("--skip-bad", action="store_true",
                   help="fill the samples of photographs that cannot be used (missing, not a file, "
                   "unreadable, corrupt, of another size) instead of stopping; without it the run "
                   "stops before any work and lists them all in FILE.bad.txt")
    p.add_argument("--scheduler", metavar="ADDRESS", default=None,
                   help="Dask scheduler address (tcp://host:port) or threads/processes/synchronous; "
                   "default: local threads")
    p.add_argument("--white-albedo", type=in_range(WHITE_ALBEDO_RANGE), default=None,
                   help=f"albedo of the white reference, {WHITE_ALBEDO_RANGE.text()} (default: stands.json's, else 1)")
    p.add_argument("--material", default=None, help="material name written to the file")
    p.add_argument("--fill", type=keyword(FILL_METHODS), default=None, metavar="METHOD",
                   help="how invalid samples are filled: "
                   + "; ".join(f"{name}: {text}" for name, text in FILL_METHODS.items())
                   + f" (default {DEFAULT_FILL}; with --btf {BTF_DEFAULT_FILL})")
    p.add_argument("--btf", type=int_range(1, 256), default=None, metavar="N",
                   help="measure a CD-BTF of N x N texels per weave repeat instead (the capture's stands.json "
                   "must register the fabric's (u, v) on the stands): every photograph is rectified onto the "
                   "texels instead of averaged; the same calibration, hidden samples, fill, schedulers and "
                   "resumable checkpoint (OUT.ckpt/). Writes a CD-BTF file")
    p.add_argument("--workers", type=int_range(1, 1024), default=None, help="local threads/processes, 1 to 1024")
    p.add_argument("--force", action="store_true",
                   help="overwrite an existing output file (never one of the capture's own files)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ..measure.pipeline import measure
    from ._progress import ProgressBars

    out = Path(args.output)
    try:
        with ProgressBars(quiet=args.quiet, unit="img") as bars:
            table, report = measure(
                args.capture, out, patch=args.patch, linear=args.linear, skip_bad=args.skip_bad,
                scheduler=args.scheduler, white_albedo=args.white_albedo, material=args.material,
                num_workers=args.workers, progress=bars.callback("measure"), overwrite=args.force,
                fill=args.fill, btf=args.btf,
            )
    except KeyboardInterrupt:

        say(f"cdbrdf measure: progress kept in {out}.ckpt; run the same command again to resume",
              err=True)
        raise
    if not args.quiet:
        say(report.summary())
        say(f"wrote {out}")
    return 0
