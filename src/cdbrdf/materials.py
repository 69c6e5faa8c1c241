"""Ready-made materials shipped with the package: ``denim`` and ``shot``.

Each is a table of the corresponding :mod:`cdbrdf.synth.presets` preset
tabulated on the paper's grid (:meth:`cdbrdf.Grid.paper`, float32), stored in
``cdbrdf/data/<name>.h5``. They are regenerated, with the same values, by::

    python -m cdbrdf.materials --regenerate

(values are identical on the same platform: every sample is computed
independently, without reductions across threads).

Examples
--------
>>> import cdbrdf.materials
>>> cdbrdf.materials.names()
['denim', 'shot']
>>> table = cdbrdf.materials.load("denim")   # doctest: +SKIP
"""

from __future__ import annotations

import argparse
import logging
import sys
from collections.abc import Callable, Sequence
from pathlib import Path

from .table import CDBRDF, Grid

__all__ = ["names", "load", "path", "build", "regenerate", "main"]

_NAMES = ("denim", "shot")
_DATA = Path(__file__).resolve().parent / "data"

log = logging.getLogger(__name__)


def names() -> list[str]:
    """Names of the bundled materials."""
    return list(_NAMES)


def _check(name: str) -> str:
    if name not in _NAMES:
        raise ValueError(f"unknown material {name!r}; valid names: {', '.join(_NAMES)}")
    return name


def path(name: str) -> Path:
    """Where the bundled table of ``name`` lives."""
    return _DATA / f"{_check(name)}.h5"


def load(name: str) -> CDBRDF:
    """The bundled table of a material (a :class:`cdbrdf.CDBRDF`).

    Raises
    ------
    ValueError
        For an unknown name (the message lists the valid ones).
    FileNotFoundError
        When the package was installed without its data files.
    """
    from .table import load as _load

    p = path(name)
    if not p.is_file():
        raise FileNotFoundError(
            f"{p.name}: the bundled table of {name!r} is missing; "
            "run `python -m cdbrdf.materials --regenerate`"
        )
    return _load(p)


def build(
    name: str,
    grid: Grid | None = None,
    *,
    progress: Callable[[int, int], None] | None = None,
) -> CDBRDF:
    """Tabulate the preset ``name`` (default: on the paper's grid)."""
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
    """
    out = Path(out_dir) if out_dir is not None else _DATA
    out.mkdir(parents=True, exist_ok=True)
    written = []
    for name in which or _NAMES:
        cb = None if progress is None else (lambda d, t, _n=name: progress(_n, d, t))
        table = build(name, progress=cb)
        dest = out / f"{_check(name)}.h5"
        table.save(dest)
        log.info("wrote %s", dest)
        written.append(dest)
    return written


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m cdbrdf.materials --regenerate [NAME ...] [--out DIR]``."""
    parser = argparse.ArgumentParser(
        prog="python -m cdbrdf.materials", description="List or regenerate the bundled materials."
    )
    parser.add_argument("--regenerate", action="store_true", help="recompute the bundled tables")
    parser.add_argument("names", nargs="*", help=f"materials (default all: {', '.join(_NAMES)})")
    parser.add_argument("--out", help="write into this folder instead of the package's data folder")
    args = parser.parse_args(argv)
    try:
        for n in args.names:
            _check(n)
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    if not args.regenerate:
        for n in names():
            print(n, path(n), "present" if path(n).is_file() else "missing")
        return 0
    from tqdm import tqdm

    bars: dict[str, tqdm] = {}

    def cb(name: str, done: int, total: int) -> None:
        bar = bars.get(name)
        if bar is None:
            bar = bars[name] = tqdm(total=total, desc=name, unit="kappa")
        bar.update(done - bar.n)
        if done == total:
            bar.close()

    for p in regenerate(args.names or None, out_dir=args.out, progress=cb):
        print(p)
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
