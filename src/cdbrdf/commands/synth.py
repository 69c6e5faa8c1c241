"""``cdbrdf synth PRESET [--set name=value ...] [--grid ...] [--btf TEXELS [--points-per-texel N]
[--max-error E]] -o FILE``."""

from __future__ import annotations

import argparse
import math
import time
from collections.abc import Sequence
from typing import Any

import numpy as np

from ..errors import OptionError
from ._text import say

__all__ = ["register", "run", "parse_grid", "parse_sets"]

_GRIDS = "paper | regular:THETA_STEP,PHI_STEP"


def _grid(text: str) -> str:
    """A ``--grid`` spec, checked (``paper`` or ``regular:THETA_STEP,PHI_STEP``)."""
    _parse_grid_spec(text)
    return text


def _parse_grid_spec(spec: str) -> tuple[float, float] | None:
    """None for ``paper``, else the two steps of ``regular:T,P`` (degrees)."""
    from ._args import float_list

    s = spec.strip()
    if s == "paper":
        return None
    if s.startswith("regular:"):
        try:
            t, p = float_list(0, 360, lo_open=True, min_len=2, max_len=2, example="15,30",
                              unit="deg")(s.split(":", 1)[1])
        except argparse.ArgumentTypeError as exc:
            raise argparse.ArgumentTypeError(f"regular:THETA_STEP,PHI_STEP: {exc}") from None
        if t > 90:
            raise argparse.ArgumentTypeError(f"regular: THETA_STEP must be at most 90, got {t:g}")
        return t, p
    raise argparse.ArgumentTypeError(f"unknown grid {spec!r}; valid: {_GRIDS}")


def register(sub: argparse._SubParsersAction) -> None:
    from ..btf import DEFAULT_MAX_ERROR
    from ..synth.presets import names
    from ..synth.texels import MAX_TEXELS, POINTS_PER_TEXEL
    from ._args import finite_float, float_list, int_range, output_file

    p = sub.add_parser(
        "synth",
        help="tabulate a synthetic fabric (woven: denim, shot; pile: velvet, towel) into a CDBRDF file",
        description="Tabulate the fabric model of a preset (woven cloth or pile) onto a grid and write "
        "the CDBRDF file. Parameters of the preset can be overridden with --set "
        "(see docs/fabric-model.md for their meaning).",
    )
    p.add_argument("preset", choices=names(), help="the material preset")
    p.add_argument(
        "--set",
        dest="sets",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="override a parameter, e.g. --set thickness_mm=0.8 --set warp_rgb=0.1,0.1,0.4 "
        "(repeatable)",
    )
    p.add_argument("--grid", type=_grid, default="paper", help=f"sample grid: {_GRIDS} (default paper)")
    p.add_argument(
        "--kappa",
        type=float_list(-100, 100, unique=True, unit="1/mm"),
        help="curvatures in 1/mm, comma-separated (default the paper's -0.22,-0.13,0,0.13,0.22)",
    )
    p.add_argument(
        "--btf",
        type=int_range(1, MAX_TEXELS),
        metavar="TEXELS",
        help="tabulate per texel: a CD-BTF of TEXELS x TEXELS texels per weave repeat, compressed "
        "(docs/btf.md); the file's reflectance is the tile mean",
    )
    p.add_argument(
        "--points-per-texel",
        type=int_range(1, 4096),
        default=None,
        metavar="N",
        help=f"with --btf, woven presets: surface points per texel (default {POINTS_PER_TEXEL}; the per-texel noise "
        "falls about as 1/N, docs/btf.md)",
    )
    p.add_argument(
        "--max-error",
        type=finite_float(0, 1, hi_open=True),
        default=None,
        help=f"with --btf: the compression's relative RMS error target (default {DEFAULT_MAX_ERROR:g})",
    )
    p.add_argument("-o", "--output", required=True, type=output_file(), help="output file (.h5)")
    p.set_defaults(func=run)


def parse_sets(items: list[str], *, preset: str = "denim") -> dict:
    """``["name=value", ...]`` -> typed overrides (validated names, finite numbers).

    Checked when the command runs, before anything is computed or written
    (the values depend on the parameter types of the preset's model:
    :func:`cdbrdf.synth.presets.params_class`).
    """
    from ..synth.presets import params_class

    cls = params_class(preset)
    out = {}
    for item in items:
        if "=" not in item:
            raise OptionError(f"--set: expected NAME=VALUE, got {item!r}")
        name, value = item.split("=", 1)
        name = name.strip()
        parsed = cls.parse_value(name, value)
        numbers = parsed if isinstance(parsed, tuple) else (parsed,)
        if any(isinstance(x, float) and not math.isfinite(x) for x in numbers):
            raise OptionError(f"--set: {name}: expected finite numbers, got {value!r}")
        out[name] = parsed
    return out


def parse_grid(spec: str, kappa: str | Sequence[float] | None = None):  # noqa: ANN201 - a Grid
    """A :class:`cdbrdf.Grid` from ``--grid`` and ``--kappa`` (text or numbers).

    Raises
    ------
    ValueError
        For an unreadable spec (message naming the option).
    cdbrdf.errors.LimitError
        When the table would exceed the ``table_samples`` limit.
    """
    from ..limits import check
    from ..table import PAPER_KAPPA, Grid
    from ._args import float_list

    try:
        if kappa is None:
            k = PAPER_KAPPA
        elif isinstance(kappa, str):
            k = np.array(float_list(-100, 100, unique=True, unit="1/mm")(kappa))
        else:
            k = np.asarray(kappa, dtype=float)
    except argparse.ArgumentTypeError as exc:
        raise OptionError(f"--kappa: {exc}") from None
    try:
        steps = _parse_grid_spec(spec)
    except argparse.ArgumentTypeError as exc:
        raise OptionError(f"--grid: {exc}") from None
    if steps is None:
        return Grid.paper(kappa=k)
    t, p = steps
    n_theta = int(75.0 // t) + 1
    n_phi = int(round(360.0 / p))
    check("table_samples", k.size * (n_theta * n_phi) ** 2 * 3,
          what=f"--grid {spec.strip()}: {k.size} x {n_theta * n_phi} x {n_theta * n_phi} x 3 table")
    return Grid.regular(theta_step_deg=t, phi_step_deg=p, kappa=k)


def run(args: argparse.Namespace) -> int:
    from ..synth import presets
    from ._progress import ProgressBars

    overrides = parse_sets(args.sets, preset=args.preset)
    if args.max_error is not None and args.btf is None:
        raise OptionError("--max-error: only with --btf (the compression of a CD-BTF)")
    if args.points_per_texel is not None and args.btf is None:
        raise OptionError("--points-per-texel: only with --btf (the integration of a CD-BTF)")
    model = presets.model(args.preset, **overrides)
    grid = parse_grid(args.grid, args.kappa)
    quiet = getattr(args, "quiet", False)
    t0 = time.perf_counter()
    if args.btf is not None:
        return _run_btf(args, model, grid, quiet, t0)
    with ProgressBars(quiet=quiet, unit="kappa") as bars:
        table = model.tabulate(grid, progress=bars.callback(f"synth {args.preset}"))
    table.save(args.output)
    if not quiet:
        say(f"wrote {args.output}: {args.preset}, shape {table.shape}, "
              f"{time.perf_counter() - t0:.1f} s")
    return 0


def _run_btf(args: argparse.Namespace, model: Any, grid: Any, quiet: bool, t0: float) -> int:
    """``--btf``: tabulate per texel, compress, write the CD-BTF file."""
    from ..btf import DEFAULT_MAX_ERROR
    from ..synth.texels import tabulate_btf
    from ._progress import ProgressBars

    target = DEFAULT_MAX_ERROR if args.max_error is None else args.max_error
    with ProgressBars(quiet=quiet, unit="kappa") as bars:
        btf = tabulate_btf(model, grid, texels=args.btf, points_per_texel=args.points_per_texel, max_error=target,
                           progress=bars.callback(f"synth {args.preset} --btf {args.btf}"))
    btf.save(args.output)
    if not quiet:
        c = btf.compression
        per_k = ", ".join(f"{100 * e:.2f}" for e in c["relative_rms_error_per_kappa"])
        say(f"wrote {args.output}: {args.preset} CD-BTF, {args.btf} x {args.btf} texels over "
            f"{btf.repeat_mm[0]:.3g} x {btf.repeat_mm[1]:.3g} mm, rank {btf.rank}, relative RMS error "
            f"{100 * c['relative_rms_error']:.2f} % (per kappa {per_k} %), {c['compression_ratio']:.1f}:1, "
            f"{time.perf_counter() - t0:.1f} s")
    return 0
