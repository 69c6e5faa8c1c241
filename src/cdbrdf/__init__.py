"""cdbrdf: measure and render curvature-dependent BRDFs of fabrics.

The public surface is small:

- :class:`CDBRDF` the table, :class:`Grid` its axes;
- :func:`load` / :meth:`CDBRDF.save` the HDF5 file (``docs/format.md``);
- :meth:`CDBRDF.evaluate` the 5-D lookup;
- submodules for each stage: :mod:`cdbrdf.interp`, :mod:`cdbrdf.io`,
  :mod:`cdbrdf.plot`, :mod:`cdbrdf.curvature`, :mod:`cdbrdf.synth`,
  :mod:`cdbrdf.measure`, :mod:`cdbrdf.render` (imported on demand).
"""

from __future__ import annotations

from importlib.metadata import PackageNotFoundError, version as _version

from .errors import CDBRDFError, FormatError, QueryError, TableError
from .io import load
from .table import CDBRDF, Grid

try:
    __version__ = _version("cdbrdf")
except PackageNotFoundError:  # pragma: no cover - running from a source tree
    __version__ = "0.0.0+unknown"

__all__ = [
    "CDBRDF",
    "Grid",
    "load",
    "CDBRDFError",
    "FormatError",
    "QueryError",
    "TableError",
    "__version__",
]
