"""Plain BRDF files -> one-curvature CDBRDF tables: format detection, target grids, the import.

:func:`import_brdf` reads a file with the reader of its format
(:data:`FORMATS`), resamples it onto the target grid so that each sample is
the mean of its cell (:mod:`cdbrdf.importers.resample`), measures the error
that costs (:func:`cdbrdf.importers.resample.estimate_error`) and returns the
table with its provenance: the source file (name, SHA-256, format, its own
description), the grid, the resampling and the error estimate.

Target grids (:data:`GRIDS`, ``grid=``): ``"default"`` is :data:`DEFAULT_ISOTROPIC_GRID`
for isotropic sources (the isotropic layout, fine enough for glossy
materials) and the paper's grid for anisotropic ones; ``"paper"``;
``"native"`` (the source's own grid, copied exactly: UTIA files, CDBRDF
files); ``"regular:THETA_STEP,PHI_STEP[,THETA_MAX]"``; or a
:class:`~cdbrdf.grid.Grid`.
"""

from __future__ import annotations

import logging
import math
import re
from collections.abc import Callable, Mapping
from os import PathLike
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import FormatError, TableError
from ..grid import Grid
from ..schema import SYMMETRIES
from .resample import CORRECTIONS, DEFAULT_SPACING_DEG, MAX_EVALUATIONS, METHODS, estimate_error, resample
from .source import Source

__all__ = [
    "FORMATS",
    "GRIDS",
    "SYMMETRY_CHOICES",
    "DEFAULT_ISOTROPIC_GRID",
    "detect_format",
    "read_source",
    "target_grid",
    "import_brdf",
    "table_from",
]

_LOG = logging.getLogger(__name__)

#: Readers by format name, with the file suffixes they usually carry.
FORMATS: Mapping[str, tuple[str, ...]] = {
    "rgl": (".bsdf",),
    "merl": (".binary",),
    "utia": (".bin",),
    "nbrdf": (".json",),
    "cdbrdf": (".h5", ".nc", ".hdf5"),
}
#: Grid names ``grid=`` takes besides ``regular:THETA_STEP,PHI_STEP[,THETA_MAX]`` and a Grid.
GRIDS: tuple[str, ...] = ("default", "paper", "native")
#: Choices of ``symmetry=``.
SYMMETRY_CHOICES: tuple[str, ...] = ("auto", *SYMMETRIES)
#: The default target grid of isotropic sources: ``(theta_step, phi_step, theta_max)`` in degrees
#: (elevations 0..88 every 2 degrees, azimuth differences every 2 degrees: 45 x 180 x 45 samples).
DEFAULT_ISOTROPIC_GRID = (2.0, 2.0, 88.0)

_HDF5 = b"\x89HDF\r\n\x1a\n"


def detect_format(path: str | PathLike[str]) -> str:
    """The format of a file from its first bytes and size, else its suffix.

    Parameters
    ----------
    path
        The file.

    Returns
    -------
    str
        One of :data:`FORMATS`.

    Raises
    ------
    FileNotFoundError
        When the file does not exist.
    FormatError
        When neither the content nor the suffix tells.
    """
    from ..fsutil import check_regular
    from .merl import DIMS
    from .nbrdf import looks_like
    from .rgl import MAGIC
    from .utia import FILE_BYTES

    p = Path(path)
    try:
        check_regular(p)  # a FIFO would block the read below, a device never end a later one
    except FileNotFoundError:
        raise FileNotFoundError(f"{p}: no such file") from None
    except IsADirectoryError:
        raise FormatError(f"{p}: is a folder, not a BRDF file") from None
    except OSError as exc:
        raise FormatError(f"{exc}; not a BRDF file") from None
    try:
        with open(p, "rb") as f:
            head = f.read(12)
        size = p.stat().st_size
    except OSError as exc:
        raise FormatError(f"{p}: cannot be read ({exc.strerror or exc})") from None
    if head == MAGIC:
        return "rgl"
    if looks_like(head, p):  # a Keras network's weights (HDF5) or architecture (JSON)
        return "nbrdf"
    if head[:8] == _HDF5:
        return "cdbrdf"
    if len(head) == 12 and tuple(int(x) for x in np.frombuffer(head, dtype="<i4")) == DIMS:
        return "merl"
    if size == FILE_BYTES:
        return "utia"
    suffix = p.suffix.lower()
    for name, suffixes in FORMATS.items():
        if suffix in suffixes:
            return name
    raise FormatError(
        f"{p}: cannot tell its format (not an RGL tensor file, HDF5, a Keras network, a MERL header or the size "
        f"of a UTIA file, and the suffix {suffix or '(none)'!r} names none); give the format ({', '.join(FORMATS)})")


def read_source(path: str | PathLike[str], *, format: str = "auto", material: str | None = None,
                **options: Any) -> Source:
    """Read a plain BRDF file with the reader of its format.

    Parameters
    ----------
    path
        The file.
    format
        ``"auto"`` (:func:`detect_format`) or one of :data:`FORMATS`.
    material
        Name for the material (default: the file's description, else its name).
    **options
        Reader options (``encoding`` for UTIA files).

    Returns
    -------
    Source
        The BRDF as a function of the directions, with its metadata.

    Raises
    ------
    FormatError
        For an unknown format, or a file its reader refuses.
    """
    fmt = detect_format(path) if format == "auto" else format
    if fmt not in FORMATS:
        raise FormatError(f"format: {fmt!r} is not one of auto, {', '.join(FORMATS)}")
    unknown = set(options) - ({"encoding"} if fmt == "utia" else set())
    if unknown:
        raise TableError(f"{', '.join(sorted(unknown))}: not an option of the {fmt} reader")
    if fmt == "rgl":
        from .rgl import read
    elif fmt == "merl":
        from .merl import read
    elif fmt == "utia":
        from .utia import read
    elif fmt == "nbrdf":
        from .nbrdf import read
    else:
        from .tablefile import read
    return read(path, material=material, **options)


_REGULAR = re.compile(r"regular:(.+)")


def target_grid(spec: str | Grid, source: Source, *, kappa: float = 0.0, symmetry: str = "auto") -> Grid:
    """The grid to import ``source`` onto (see the module docstring).

    Parameters
    ----------
    spec
        ``"default"``, ``"paper"``, ``"native"``,
        ``"regular:THETA_STEP,PHI_STEP[,THETA_MAX]"`` or a Grid.
    source
        The BRDF.
    kappa
        The grid's one curvature, mm^-1.
    symmetry
        ``"auto"`` (the source's), ``"isotropic"`` or ``"anisotropic"``.

    Returns
    -------
    Grid
        The grid.

    Raises
    ------
    TableError
        For an unknown grid or symmetry, ``native`` for a source without a
        grid, or an isotropic grid for an anisotropic source.
    """
    if symmetry not in SYMMETRY_CHOICES:
        raise TableError(f"symmetry: {symmetry!r} is not one of {', '.join(SYMMETRY_CHOICES)}")
    if not math.isfinite(kappa):
        raise TableError(f"kappa: must be a finite curvature in 1/mm, got {kappa}")
    sym = source.symmetry if symmetry == "auto" else symmetry
    if sym == "isotropic" and not source.isotropic:
        raise TableError(f"{source.path}: the source is anisotropic; it cannot be stored isotropic")
    if isinstance(spec, Grid):
        g = spec
    elif spec == "native":
        if source.table is None:
            raise TableError(f"{source.path}: a {source.format} file has no grid of its own; "
                             f"choose one of default, paper, regular:THETA_STEP,PHI_STEP")
        g = source.table.grid
        if symmetry == "anisotropic" and g.isotropic:
            raise TableError(f"{source.path}: its own grid is isotropic; choose another grid for an anisotropic table")
    elif spec == "default":
        if sym == "isotropic":
            t, p, top = DEFAULT_ISOTROPIC_GRID
            g = Grid.regular(theta_step_deg=t, phi_step_deg=p, theta_max_deg=top, kappa=[kappa], symmetry=sym)
        else:
            g = Grid.paper(kappa=[kappa])
    elif spec == "paper":
        g = Grid.paper(kappa=[kappa], symmetry=sym)
    elif isinstance(spec, str) and (m := _REGULAR.fullmatch(spec.strip())):
        try:
            steps = [float(x) for x in m[1].split(",")]
        except ValueError:
            steps = []
        if len(steps) not in (2, 3):
            raise TableError(f"grid: {spec!r}: expected regular:THETA_STEP,PHI_STEP[,THETA_MAX] in degrees")
        top = steps[2] if len(steps) == 3 else 89.0 - (89.0 % steps[0]) if steps[0] > 0 else 0.0
        g = Grid.regular(theta_step_deg=steps[0], phi_step_deg=steps[1], theta_max_deg=top, kappa=[kappa],
                         symmetry=sym)
    else:
        raise TableError(f"grid: {spec!r} is not one of {', '.join(GRIDS)} or regular:THETA_STEP,PHI_STEP[,THETA_MAX]")
    if g.kappa.size != 1 or g.kappa[0] != kappa:
        g = Grid(kappa=np.array([kappa], dtype=np.float64), theta_l=g.theta_l, phi_l=g.phi_l, theta_v=g.theta_v,
                 phi_v=g.phi_v, symmetry=g.symmetry)
    if g.isotropic and not source.isotropic:
        raise TableError(f"{source.path}: the source is anisotropic; it cannot be stored on an isotropic grid")
    return g


def _grid_summary(g: Grid) -> dict[str, Any]:
    def axis(a: Any) -> Any:
        a = np.asarray(a)
        if a.size > 2 and np.allclose(np.diff(a), a[1] - a[0]):
            return {"first": float(a[0]), "last": float(a[-1]), "step": float(a[1] - a[0]), "count": int(a.size)}
        return [float(x) for x in a]

    return {"symmetry": g.symmetry, "shape": list(g.shape), **{n: axis(getattr(g, n))
                                                                for n in ("theta_l", "phi_l", "theta_v", "phi_v")}}


def table_from(source: Source, grid: Grid, *, spacing_deg: float = DEFAULT_SPACING_DEG,
               max_evaluations: int = MAX_EVALUATIONS, method: str = "cell", correction: str = "deblur",
               dtype: Any = None, estimate: bool = True,
               progress: Callable[[int, int], None] | None = None) -> Any:
    """The table of ``source`` on ``grid`` (one curvature), with its provenance.

    Parameters
    ----------
    source
        The BRDF (:func:`read_source`).
    grid
        The target grid (:func:`target_grid`).
    spacing_deg, max_evaluations, method, correction, dtype, estimate, progress
        As for :func:`import_brdf`.

    Returns
    -------
    CDBRDF
        The table.
    """
    from .._version import __version__
    from .source import table_on

    res = resample(source, grid, spacing_deg=spacing_deg, max_evaluations=max_evaluations, method=method,
                   correction=correction, progress=progress)
    if res.exact and source.table is not None:
        t0 = source.table
        values, measured, fill, std = t0.values, t0.measured, t0.fill_source, t0.std
    else:
        values = res.values[None]
        measured = (res.measured >= 0.5)[None]
        fill, std = None, None
    if res.negative:
        level = logging.WARNING if res.negative_share > 1e-3 else logging.INFO
        _LOG.log(level, "%s: %d of %d table values below 0 (negative source values, or the deblurring step at a "
                 "sharp edge) set to 0; they held %.3g %% of the table's magnitude", source.path, res.negative,
                 res.values.size, 100 * res.negative_share)
    attrs: dict[str, Any] = {
        "quantity": source.quantity,
        "colour_space": source.colour_space,
        "material": source.material,
        "provenance": {
            "kind": "imported",
            "software": f"cdbrdf {__version__}",
            "source": source.provenance(),
            "grid": _grid_summary(grid),
            "resampling": res.details(),
        },
    }
    if dtype is None:  # exact copies keep the source's dtype; resampled values are float32
        dtype = np.asarray(values).dtype if res.exact else np.float32
    table = table_on(grid, np.asarray(values).astype(dtype), measured=measured, fill_source=fill, std=std,
                     attrs=attrs)
    if estimate and not res.exact:  # an exact copy is the source itself
        est = estimate_error(source, table, peak=res.peak)
        prov = dict(attrs["provenance"])
        prov["expected_error"] = est
        table = table.with_attrs(provenance=prov)
    return table


def import_brdf(
    path: str | PathLike[str],
    *,
    format: str = "auto",
    grid: str | Grid = "default",
    symmetry: str = "auto",
    kappa: float = 0.0,
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
    """Read a plain BRDF file and return it as a one-curvature :class:`~cdbrdf.table.CDBRDF`.

    Parameters
    ----------
    path
        An RGL ``.bsdf``, MERL ``.binary``, UTIA ``.bin``, Neural-BRDF (``NAME.h5`` or ``NAME.json`` of the
        pair) or one-curvature CDBRDF file.
    format
        ``"auto"`` (from the content, then the suffix) or one of :data:`FORMATS`.
    grid
        The target grid (module docstring): ``"default"``, ``"paper"``,
        ``"native"``, ``"regular:THETA_STEP,PHI_STEP[,THETA_MAX]"`` or a Grid.
    symmetry
        ``"auto"`` (the source's), ``"isotropic"`` (isotropic sources only) or ``"anisotropic"``.
    kappa
        The curvature the table is given (mm^-1; the stand it was measured on).
    material
        Name for the table (default: the file's description, else its name).
    spacing_deg, max_evaluations
        Quadrature of the cell means (:func:`cdbrdf.importers.resample.resample`).
    method
        ``"cell"`` (cell means, default) or ``"point"`` (the source at the nodes; for comparisons),
        :data:`~cdbrdf.importers.resample.METHODS`.
    correction
        ``"deblur"`` (default), ``"mean"`` or ``"projection"``
        (:data:`~cdbrdf.importers.resample.CORRECTIONS`).
    dtype
        Storage of the values: float32 or float64; default float32, or the
        source table's own dtype when it is copied exactly.
    estimate
        Measure the error of the table against the source (a fraction of a second).
    progress
        ``progress(done, total)`` over the source evaluations.
    **options
        Reader options (``encoding="srgb" | "linear"`` for UTIA files).

    Returns
    -------
    CDBRDF
        The table; ``attrs["provenance"]`` holds the source, the grid, the
        resampling and (with ``estimate``) ``expected_error``.

    Raises
    ------
    FileNotFoundError, FormatError, TableError
        One line naming the file or argument and the problem.
    """
    source = read_source(path, format=format, material=material, **options)
    g = target_grid(grid, source, kappa=float(kappa), symmetry=symmetry)
    if dtype is not None and np.dtype(dtype) not in (np.float32, np.float64):
        raise TableError(f"dtype: {dtype!r} is not float32 or float64")
    if method not in METHODS or correction not in CORRECTIONS:
        raise TableError(f"method, correction: {method!r}, {correction!r} are not among {', '.join(METHODS)} and "
                         f"{', '.join(CORRECTIONS)}")
    return table_from(source, g, spacing_deg=spacing_deg, max_evaluations=max_evaluations, method=method,
                      correction=correction, dtype=dtype, estimate=estimate, progress=progress)
