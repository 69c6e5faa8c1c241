"""Measurement: from a folder of photographs to a CDBRDF (``docs/capture.md``).

Modules, one per stage:

- :mod:`~cdbrdf.measure.capture`: the capture folder's format: reading
  ``capture.csv`` (:func:`read_capture`), writing plans, brackets;
- :mod:`~cdbrdf.measure.stands`: stand geometry, occlusion, ``stands.json``'s stands;
- (the photographs are read by :mod:`cdbrdf.images`, whole or a window);
- :mod:`~cdbrdf.measure.patch`: the N x N patch, saturation, brackets, dark frames;
- :mod:`~cdbrdf.measure.preflight`: checks of photographs and outputs before any work;
- :mod:`~cdbrdf.measure.checkpoint`: results kept between runs (resume);
- :mod:`~cdbrdf.measure.calibrate`: dark frames, brackets, white reference, fill: the table;
- :mod:`~cdbrdf.measure.fill`: filling invalid samples (the fill method registry:
  ``kappa-fit`` along the curvature, ``nearest-stand``, the paper's ``nearest``);
- :mod:`~cdbrdf.measure.schedulers`: where the Dask tasks run (both measurements);
- :mod:`~cdbrdf.measure.pipeline`: the Dask pipeline (:func:`measure`);
- :mod:`~cdbrdf.measure.btf` (with :mod:`~cdbrdf.measure.btf_geometry` and
  :mod:`~cdbrdf.measure.btf_batches`): ``measure --btf``, a CD-BTF.

The main entry point is :func:`measure`.
"""

from __future__ import annotations

from ..errors import CaptureError
from .calibrate import MeasureReport
from .capture import read_capture
from .options import MeasureOptions
from .pipeline import MeasurementInterrupted, measure
from .plan import write_plan
from .stands import Stand, hidden_mask

__all__ = [
    "MeasureOptions",
    "measure",
    "read_capture",
    "MeasureReport",
    "CaptureError",
    "MeasurementInterrupted",
    "Stand",
    "hidden_mask",
    "write_plan",
]
