"""cdbrdf: measure and render curvature-dependent BRDFs of fabrics.

The public surface is small:

- :class:`CDBRDF` the table, :class:`Grid` its axes;
- :func:`load` / :meth:`CDBRDF.save` the HDF5 file (``docs/format.md``);
- :meth:`CDBRDF.evaluate` the 5-D lookup;
- :class:`CDBTF` the curvature-dependent BTF (a CDBRDF per texel, :mod:`cdbrdf.btf`);
- submodules for each stage, imported on demand: :mod:`cdbrdf.interp` (the
  lookup), :mod:`cdbrdf.io` (the file), :mod:`cdbrdf.schema` (the names of
  the file and xarray layout), :mod:`cdbrdf.materials` (bundled fabrics),
  :mod:`cdbrdf.synth` (fabric model), :mod:`cdbrdf.rig` (simulated capture
  rig), :mod:`cdbrdf.importers` (RGL, MERL, UTIA files; stacking per-stand
  files), :mod:`cdbrdf.measure` (photographs to a table), :mod:`cdbrdf.mesh`,
  :mod:`cdbrdf.render` (Mitsuba 3 plug-in and scenes), :mod:`cdbrdf.plot`,
  :mod:`cdbrdf.report` and :mod:`cdbrdf.demo` (the paper end to end).
"""

from __future__ import annotations

from ._version import __version__
from .btf import CDBTF
from .errors import CDBRDFError, FormatError, QueryError, TableError
from .table import CDBRDF, Grid, load

__all__ = [
    "CDBRDF",
    "CDBTF",
    "Grid",
    "load",
    "CDBRDFError",
    "FormatError",
    "QueryError",
    "TableError",
    "__version__",
]
