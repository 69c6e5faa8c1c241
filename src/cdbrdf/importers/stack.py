"""A CDBRDF from plain BRDFs measured on stands of known curvature: one slice per file, along kappa.

A lab with a gonioreflectometer (or a measurement service) measures the
fabric on each stand and gets one plain BRDF file per stand; :func:`stack`
resamples every file onto one grid (:func:`cdbrdf.importers.convert.table_from`)
and stacks the slices in order of curvature. One-curvature CDBRDF files on
the target grid are copied exactly, with their measured/filled masks and fill
sources; other files carry the measured share their format records (RGL
``valid`` bits, MERL and UTIA negative samples).

The files must agree: the same quantity (and so the same units), colour
space and material name (``material=`` names a stack of files that name
their material differently), three channels, distinct curvatures; CDBRDF
files must share one grid unless a target grid is given. Every refusal is one
line naming the file and the disagreement.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from os import PathLike
from typing import Any

import numpy as np

from ..errors import TableError
from ..grid import Grid
from ..provenance import Provenance
from ..schema import reflectance_units
from .convert import SYMMETRY_CHOICES, table_from, target_grid
from .resample import DEFAULT_SPACING_DEG, MAX_EVALUATIONS
from .source import Source

__all__ = ["stack"]


def _same_directions(a: Grid, b: Grid) -> bool:
    return a.symmetry == b.symmetry and all(
        np.array_equal(getattr(a, n), getattr(b, n)) for n in ("theta_l", "phi_l", "theta_v", "phi_v"))


def _describe(g: Grid) -> str:
    return (f"{g.symmetry} {g.shape[1]}x{g.shape[2]}x{g.shape[3]}x{g.shape[4]} "
            f"(phi_l x theta_l x phi_v x theta_v)")


def _check_agreement(sources: list[Source], material: str | None) -> None:
    first = sources[0]
    for s in sources[1:]:
        if s.quantity != first.quantity:
            raise TableError(
                f"{s.path}: quantity {s.quantity!r} ({reflectance_units(s.quantity)}) differs from {first.path}'s "
                f"{first.quantity!r} ({reflectance_units(first.quantity)}); stacked files must share one quantity "
                "and unit")
        if s.colour_space != first.colour_space:
            raise TableError(f"{s.path}: colour space {s.colour_space!r} differs from {first.path}'s "
                             f"{first.colour_space!r}")
        if material is None and s.material.strip() != first.material.strip():
            raise TableError(f"{s.path}: material {s.material!r} differs from {first.path}'s {first.material!r}; "
                             "stacked files must be one material (name the stack with material=/--material to "
                             "stack them anyway)")


def _common_grid(sources: list[Source], grid: str | Grid | None, symmetry: str, kappa0: float) -> Grid:
    tables = [s for s in sources if s.table is not None]
    if grid is not None:
        return target_grid(grid, sources[0], kappa=kappa0, symmetry=symmetry)
    if tables:
        g0 = tables[0].table.grid  # type: ignore[union-attr]
        for s in tables[1:]:
            g = s.table.grid  # type: ignore[union-attr]
            if not _same_directions(g, g0):
                raise TableError(
                    f"{s.path}: its grid, {_describe(g)}, differs from {tables[0].path}'s, {_describe(g0)}; "
                    "give a target grid (--grid) to resample every file onto one")
        if symmetry == "anisotropic" and g0.isotropic:
            raise TableError(f"{tables[0].path}: its grid is isotropic but the stack is anisotropic; give a target "
                             "grid (--grid)")
        return target_grid(g0, sources[0], kappa=kappa0, symmetry=symmetry)
    return target_grid("default", sources[0], kappa=kappa0, symmetry=symmetry)


def stack(
    entries: Sequence[tuple[float, str | PathLike[str]]],
    *,
    format: str = "auto",
    grid: str | Grid | None = None,
    symmetry: str = "auto",
    material: str | None = None,
    spacing_deg: float = DEFAULT_SPACING_DEG,
    max_evaluations: int = MAX_EVALUATIONS,
    method: str = "cell",
    correction: str = "deblur",
    dtype: Any = None,
    estimate: bool = True,
    progress: Callable[[int, int], None] | None = None,
    **options: Any,
) -> Any:
    """A CDBRDF from plain BRDF files, one per curvature (see the module docstring).

    Parameters
    ----------
    entries
        ``(kappa, file)`` pairs: the stand's curvature (mm^-1, > 0 convex) and
        its plain BRDF (any importable format or a one-curvature CDBRDF file).
    format
        ``"auto"`` or one format for every file.
    grid
        Target grid (as :func:`cdbrdf.importers.import_brdf`); default: the
        CDBRDF files' common grid, else the default grid of the sources' symmetry.
    symmetry
        ``"auto"``: isotropic when every source is, else anisotropic.
    material
        Name of the stacked material (needed when the files name theirs differently).
    spacing_deg, max_evaluations, method, correction, dtype, estimate
        As for :func:`cdbrdf.importers.import_brdf` (``estimate``: per slice).
    progress
        ``progress(done, total)`` over the files.
    **options
        Reader options, as for :func:`cdbrdf.importers.import_brdf`.

    Returns
    -------
    CDBRDF
        Curvatures in increasing order; ``attrs["provenance"]`` lists every
        slice's source, resampling and error estimate.

    Raises
    ------
    TableError
        For fewer than two files, a curvature that is not finite or repeats,
        or files that disagree (one line naming the file and the problem).
    FormatError
        For a file its reader refuses.
    """
    from .._version import __version__
    from ..table import CDBRDF
    from .convert import read_source

    if len(entries) < 2:
        raise TableError(f"a stack needs at least two (kappa, file) pairs, got {len(entries)} "
                         "(import a single file with cdbrdf import)")
    if symmetry not in SYMMETRY_CHOICES:
        raise TableError(f"symmetry: {symmetry!r} is not one of {', '.join(SYMMETRY_CHOICES)}")
    seen: dict[float, Any] = {}
    for k, path in entries:
        if not isinstance(k, (int, float, np.integer, np.floating)) or isinstance(k, bool) or not math.isfinite(k):
            raise TableError(f"{path}: kappa {k!r} is not a finite curvature in 1/mm")
        if float(k) in seen:
            raise TableError(f"{path}: kappa {float(k):g} 1/mm is also given to {seen[float(k)]}; "
                             "each stand needs its own curvature")
        seen[float(k)] = path
    order = sorted(range(len(entries)), key=lambda i: float(entries[i][0]))
    kappas = [float(entries[i][0]) for i in order]
    sources = [read_source(entries[i][1], format=format, material=material, **options) for i in order]
    _check_agreement(sources, material)
    sym = symmetry
    if sym == "auto":
        sym = "isotropic" if all(s.isotropic for s in sources) else "anisotropic"
    base = _common_grid(sources, grid, sym, kappas[0])
    slices = []
    for j, (k, s) in enumerate(zip(kappas, sources)):
        gk = target_grid(base, s, kappa=k, symmetry=sym)
        slices.append(table_from(s, gk, spacing_deg=spacing_deg, max_evaluations=max_evaluations, method=method,
                                 correction=correction, dtype=dtype, estimate=estimate))
        if progress is not None:
            progress(j + 1, len(sources))
    per = int(np.prod(base.shape[1:]))
    fill = np.concatenate([np.where(t.fill_source >= 0, t.fill_source + j * per, t.fill_source)
                           for j, t in enumerate(slices)])
    std = None
    if all(t.std is not None for t in slices):
        std = np.concatenate([t.std for t in slices])
    attrs: dict[str, Any] = {
        "quantity": sources[0].quantity,
        "colour_space": sources[0].colour_space,
        "material": material or sources[0].material,
        "provenance": {
            "kind": "stacked",
            "software": f"cdbrdf {__version__}",
            "grid": slices[0].attrs["provenance"]["grid"],
            "slices": [{"kappa": k, **{key: t.attrs["provenance"].get(key)
                                       for key in ("source", "resampling", "expected_error")}}
                       for k, t in zip(kappas, slices)],
        },
    }
    grid = Grid(kappa=kappas, theta_l=base.theta_l, phi_l=base.phi_l, theta_v=base.theta_v, phi_v=base.phi_v,
                symmetry=base.symmetry)
    return CDBRDF(np.concatenate([t.values for t in slices]), grid, std=std, attrs=attrs,
                  provenance=Provenance(measured=np.concatenate([t.measured for t in slices]), fill_source=fill))
