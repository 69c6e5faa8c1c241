"""Ready-made materials shipped with the package: ``denim``, ``shot``, ``velvet`` and ``towel``.

Each is a table of the corresponding :mod:`cdbrdf.synth.presets` preset
tabulated on the paper's grid (:meth:`cdbrdf.Grid.paper`, float32), stored in
``cdbrdf/data/<name>.h5``. They are regenerated, with the same values, by
:func:`regenerate`, or from a source checkout by::

    python scripts/regenerate_materials.py

(values are identical on the same platform: every sample is computed
independently, without reductions across threads).

Examples
--------
>>> import cdbrdf.materials
>>> cdbrdf.materials.names()
['denim', 'shot', 'velvet', 'towel']
>>> table = cdbrdf.materials.load("denim")   # doctest: +SKIP
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Sequence
from pathlib import Path

from .errors import OptionError
from .table import CDBRDF, Grid

__all__ = ["names", "load", "path", "build", "regenerate"]

_NAMES = ("denim", "shot", "velvet", "towel")
_DATA = Path(__file__).resolve().parent / "data"

log = logging.getLogger(__name__)


def names() -> list[str]:
    """Names of the bundled materials.

    Returns
    -------
    list of str
        The names (``"denim"``, ``"shot"``).
    """
    return list(_NAMES)


def _check(name: str) -> str:
    if not isinstance(name, str) or name not in _NAMES:
        raise OptionError(f"material {name!r:.40}: unknown; valid names: {', '.join(_NAMES)}")
    return name


def path(name: str) -> Path:
    """Where the bundled table of a material lives.

    Parameters
    ----------
    name
        One of :func:`names`.

    Returns
    -------
    pathlib.Path
        The HDF5 file in the package's ``data`` folder.
    """
    return _DATA / f"{_check(name)}.h5"


def load(name: str) -> CDBRDF:
    """The bundled table of a material.

    Parameters
    ----------
    name
        One of :func:`names`.

    Returns
    -------
    CDBRDF
        The table.

    Raises
    ------
    OptionError
        For an unknown name (the message lists the valid ones).
    FileNotFoundError
        When the package was installed without its data files.
    """
    from .table import load as _load

    p = path(name)
    if not p.is_file():
        raise FileNotFoundError(
            f"{p.name}: the bundled table of {name!r} is missing; reinstall cdbrdf "
            "or run `python scripts/regenerate_materials.py` in a source checkout"
        )
    return _load(p)


def build(
    name: str,
    grid: Grid | None = None,
    *,
    progress: Callable[[int, int], None] | None = None,
) -> CDBRDF:
    """Tabulate a fabric preset of :mod:`cdbrdf.synth`.

    Parameters
    ----------
    name
        The preset (:func:`names`).
    grid
        The table's grid; default: the paper's.
    progress
        ``progress(done, total)`` during the tabulation.

    Returns
    -------
    CDBRDF
        The tabulated model.
    """
    from .synth import presets

    return presets.model(_check(name)).tabulate(grid, progress=progress)


def regenerate(
    which: Sequence[str] | None = None,
    *,
    out_dir: str | Path | None = None,
    progress: Callable[[str, int, int], None] | None = None,
) -> list[Path]:
    """Recompute the bundled tables and write them (atomically).

    Parameters
    ----------
    which
        Material names; default all.
    out_dir
        Destination folder; default the package's ``data`` folder.
    progress
        Called as ``progress(name, done, total)`` per curvature slice.

    Returns
    -------
    list of pathlib.Path
        The files written.

    Raises
    ------
    ValueError
        For an unknown name (before anything is computed or written).
    """
    chosen = [_check(n) for n in (which or _NAMES)]
    out = Path(out_dir) if out_dir is not None else _DATA
    out.mkdir(parents=True, exist_ok=True)
    written = []
    for name in chosen:
        cb = None if progress is None else (lambda d, t, _n=name: progress(_n, d, t))
        table = build(name, progress=cb)
        dest = out / f"{name}.h5"
        table.save(dest)
        log.info("wrote %s", dest)
        written.append(dest)
    return written
