"""``cdbrdf info FILE``: what a CDBRDF file holds."""

from __future__ import annotations

import argparse
import json
import math
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from ..table import CDBRDF

from ._text import printable, say

__all__ = ["register", "run", "describe"]


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "info",
        help="show a CDBRDF file's grid, quantity, material, provenance and value range",
        description="Show what a CDBRDF file holds: grid, quantity, material, "
        "provenance, measured fraction and the value range per channel.",
    )
    from ._args import input_path

    p.add_argument("file", type=input_path(), help="a CDBRDF file (.h5)")
    p.add_argument("--json", action="store_true", help="print the information as JSON")
    p.set_defaults(func=run)


def _axis(a: np.ndarray, unit: str) -> str:
    vals = ", ".join(f"{x:g}" for x in a) if a.size <= 8 else f"{a[0]:g} .. {a[-1]:g}"
    step = ""
    if a.size > 2 and np.allclose(np.diff(a), a[1] - a[0]):
        step = f" step {a[1] - a[0]:g}"
    return f"{a.size:3d} [{vals}]{step} {unit}"


def describe(table: CDBRDF) -> dict[str, Any]:
    """The information ``cdbrdf info`` shows, as a JSON-ready dict."""
    v = table.values
    ranges = {
        name: {"min": float(v[..., i].min()), "max": float(v[..., i].max()), "mean": float(v[..., i].mean())}
        for i, name in enumerate(table.channels)
    }
    per_kappa = {
        f"{k:g}": float(table.measured[i].mean()) for i, k in enumerate(table.kappa)
    }
    return {
        "material": table.attrs.get("material"),
        "quantity": table.quantity,
        "symmetry": table.symmetry,
        "colour_space": table.attrs.get("colour_space"),
        "shape": list(table.shape),
        "axes": {name: axis.tolist() for name, axis in table.grid.axes().items()},
        "measured_fraction": float(table.measured.mean()),
        "measured_fraction_per_kappa": per_kappa,
        "channels": ranges,
        "provenance": table.attrs.get("provenance"),
        "attrs": {k: v for k, v in table.attrs.items() if k not in ("provenance",)},
    }


def run(args: argparse.Namespace) -> int:
    from ..sources import open_source

    source = open_source(args.file)
    btf, table = source.btf, source.flat
    info = describe(table)
    if btf is not None:
        info["btf"] = {"texels": list(btf.texels), "repeat_mm": list(btf.repeat_mm), **btf.compression}
    if args.json:
        say(json.dumps(info, indent=2, sort_keys=True))
        return 0
    g = table.grid
    lines = [  # the file's own text (material, colour space, channels, provenance) with control characters escaped
        f"file          {printable(args.file)}",
        f"material      {printable(info['material'] or '(not recorded)')}",
        f"quantity      {table.quantity}"
        + ("  (BRDF, sr^-1)" if table.quantity == "brdf" else "  (BRDF up to an unknown scale)"),
        f"colour space  {printable(info['colour_space'])}",
        f"symmetry      {table.symmetry}"
        + ("  (phi_l = 0; phi_v holds the azimuth difference phi_v - phi_l)" if table.isotropic else ""),
        f"values        {table.shape} {table.values.dtype}"
        f"  (kappa, phi_l, theta_l, phi_v, theta_v, channel)",
        f"kappa       {_axis(g.kappa, '1/mm')}",
        f"theta_l     {_axis(g.theta_l, 'deg')}",
        f"phi_l       {_axis(g.phi_l, 'deg')}",
        f"theta_v     {_axis(g.theta_v, 'deg')}",
        f"phi_v       {_axis(g.phi_v, 'deg')}",
        f"measured      {100 * info['measured_fraction']:.1f}% of samples"
        + "  (per kappa: "
        + ", ".join(f"{k}: {100 * f:.1f}%" for k, f in info["measured_fraction_per_kappa"].items())
        + ")",
        f"std           {'stored' if table.std is not None else 'none'}",
    ]
    if btf is not None:
        c = btf.compression
        per_k = ", ".join(f"{100 * e:.2f}" for e in c.get("relative_rms_error_per_kappa", []))
        err = c.get("relative_rms_error")
        lines.append(f"CD-BTF        {btf.texels[0]} x {btf.texels[1]} texels over {btf.repeat_mm[0]:.4g} x "
                     f"{btf.repeat_mm[1]:.4g} mm; values above are the tile mean")
        lines.append(f"compression   {printable(str(c.get('method', '?')))} rank {btf.rank}, relative RMS error "
                     + ("?" if err is None else f"{100 * err:.2f} %") + f" (per kappa {per_k} %), "
                     f"{btf.nbytes_ratio():.1f}:1 against float32")
    gx = table.attrs.get("gltf_export")
    if isinstance(gx, dict):
        enc, fb = gx.get("encoding") or {}, gx.get("fallback") or {}
        lines.append(f"glTF export   {printable(str(gx.get('extension')))} {printable(str(gx.get('version')))}: "
                     f"16-bit lookup texture (largest error {float(enc.get('maxAbsoluteOverRange', math.nan)):.2g} "
                     f"of each channel's range, median relative {float(enc.get('medianRelative', math.nan)):.2g}); "
                     f"fallback material's relative RMS error {float(fb.get('relativeRmsError', math.nan)):.1%}")
    for name, r in info["channels"].items():
        lines.append(f"channel {printable(name):5s} min {r['min']:.4g}  mean {r['mean']:.4g}  max {r['max']:.4g}")
    prov = info["provenance"]
    if prov is not None:
        text = json.dumps(prov, indent=2, sort_keys=True) if not isinstance(prov, str) else printable(prov)
        lines.append("provenance    " + text.replace("\n", "\n              "))
    say("\n".join(lines))
    return 0
