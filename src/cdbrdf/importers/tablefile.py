"""One-curvature CDBRDF files as sources (for stacking per-stand tables along kappa)."""

from __future__ import annotations

from os import PathLike
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import FormatError
from .source import Source, check_plausible, file_sha256, table_on

__all__ = ["read"]


def read(path: str | PathLike[str], *, material: str | None = None) -> Source:
    """A CDBRDF file with one curvature as a :class:`~cdbrdf.importers.source.Source`.

    The values are looked up with the table's own interpolation; on the
    table's own grid they are copied exactly (mask and fill sources too).

    Raises
    ------
    FormatError
        For a file that :func:`cdbrdf.load` refuses, or one with more than one curvature.
    """
    from ..table import load

    p = Path(path)
    table = load(p)
    if table.kappa.size != 1:
        raise FormatError(
            f"{p}: holds {table.kappa.size} curvatures; a plain BRDF (one curvature) is needed "
            "(take one slice with CDBRDF.brdf(kappa) and save it)")
    if table.n_channels != 3:
        raise FormatError(f"{p}: has {table.n_channels} channels; stacking and import need RGB (3)")
    check_plausible(p, table.values[table.measured], what="measured values")
    k = float(table.kappa[0])
    mask = None if table.measured.all() else table_on(table.grid, table.measured[..., None].astype(np.float64))

    def evaluate(theta_v: Any, phi_v: Any, theta_l: Any, phi_l: Any) -> tuple[Any, Any]:
        f = table.evaluate(theta_v, phi_v, theta_l, phi_l, k)
        return f, None if mask is None else mask.evaluate(theta_v, phi_v, theta_l, phi_l, k)[:, 0]

    prov = table.attrs.get("provenance")
    return Source(
        path=p, format="cdbrdf", symmetry=table.symmetry, quantity=table.quantity,
        colour_space=str(table.attrs.get("colour_space", "")),
        material=material or str(table.attrs.get("material", "")),
        description="", details={"kappa_of_file": k, "grid_shape": list(table.shape), "provenance": prov},
        evaluate=evaluate, sha256=file_sha256(p.read_bytes()), table=table,
    )
