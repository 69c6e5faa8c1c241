"""Measurement: from a folder of photographs to a CDBRDF (``docs/capture.md``).

Modules, one per stage:

- :mod:`~cdbrdf.measure.plan`: capture plans, stand geometry, occlusion;
- :mod:`~cdbrdf.measure.images`: PNG/TIFF/OpenEXR readers (whole or a window);
- :mod:`~cdbrdf.measure.patch`: the N x N patch, saturation, brackets, dark frames;
- :mod:`~cdbrdf.measure.fill`: filling invalid samples from the nearest measured one;
- :mod:`~cdbrdf.measure.pipeline`: the Dask pipeline with checkpoints.

The main entry point is :func:`measure`.
"""

from __future__ import annotations

from .pipeline import CaptureError, MeasureReport, MeasurementInterrupted, measure, read_capture
from .plan import Stand, hidden_mask, write_plan

__all__ = [
    "measure",
    "read_capture",
    "MeasureReport",
    "CaptureError",
    "MeasurementInterrupted",
    "Stand",
    "hidden_mask",
    "write_plan",
]
