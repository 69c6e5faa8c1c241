"""Import plain BRDFs from the formats of the public databases, and stack them along kappa.

Readers, one module per format, each returning a
:class:`~cdbrdf.importers.source.Source` (a vectorised evaluator in the
project's conventions plus metadata):

- :mod:`cdbrdf.importers.rgl`: RGL material database ``.bsdf`` tensor files
  (RGB and spectral, isotropic and anisotropic), evaluated by Mitsuba 3's
  own ``measured`` plug-in;
- :mod:`cdbrdf.importers.merl`: MERL-MIT ``.binary`` files (isotropic);
- :mod:`cdbrdf.importers.utia`: UTIA BRDF ``.bin`` files (anisotropic);
- :mod:`cdbrdf.importers.tablefile`: one-curvature CDBRDF files;
- :mod:`cdbrdf.importers.mitsuba`: any Mitsuba 3 BSDF (an analytic material
  with a known answer, e.g. for the reference renders).

:mod:`cdbrdf.importers.resample` turns a source into table samples that each
represent their cell (hat-weighted means over the projected solid angle) and
estimates the error; :mod:`cdbrdf.importers.convert` is the import
(:func:`import_brdf`), :mod:`cdbrdf.importers.stack` builds a CDBRDF from
per-stand files (:func:`stack`), and :mod:`cdbrdf.importers.reference`
renders an imported RGL material beside Mitsuba's ``measured`` plug-in.
Conventions of each format: ``docs/import.md``.

Importing this package imports NumPy only; Mitsuba is imported by the RGL
reader and the reference renders when they run.
"""

from __future__ import annotations

from .convert import (
    DEFAULT_ISOTROPIC_GRID,
    FORMATS,
    GRIDS,
    SYMMETRY_CHOICES,
    detect_format,
    import_brdf,
    read_source,
    table_from,
    target_grid,
)
from .resample import estimate_error, resample
from .source import Source
from .stack import stack

__all__ = [
    "DEFAULT_ISOTROPIC_GRID",
    "FORMATS",
    "GRIDS",
    "SYMMETRY_CHOICES",
    "Source",
    "detect_format",
    "estimate_error",
    "import_brdf",
    "read_source",
    "resample",
    "stack",
    "table_from",
    "target_grid",
]
