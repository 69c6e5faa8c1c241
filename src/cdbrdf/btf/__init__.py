"""The curvature-dependent BTF (CD-BTF): a CDBRDF per texel of one weave repeat.

- :class:`CDBTF`: the tile mean (a :class:`~cdbrdf.CDBRDF`) and the
  factorised texel deviations; :meth:`CDBTF.evaluate` at texel positions
  (mm, periodic), directions and curvatures; :meth:`CDBTF.from_values`
  compresses dense texels to an error target;
- :func:`load` / :meth:`CDBTF.save`: the file, a CDBRDF file whose
  ``reflectance`` is the tile mean (``docs/format.md``; ``docs/btf.md``).
"""

from __future__ import annotations

from .file import is_btf
from .table import CDBTF, COMPRESSION_ATTRS, DEFAULT_MAX_ERROR, DEFAULT_METHOD, MAX_RANK, METHODS, load

__all__ = ["CDBTF", "COMPRESSION_ATTRS", "DEFAULT_MAX_ERROR", "DEFAULT_METHOD", "MAX_RANK", "METHODS", "is_btf", "load"]
