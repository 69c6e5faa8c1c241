"""How photographs are measured: the options the CDBRDF and the CD-BTF paths share, checked once.

:class:`MeasureOptions` is what :func:`cdbrdf.measure.measure` builds from
its keywords and :func:`cdbrdf.measure.btf.measure_btf` takes whole; the
command line takes its ranges (:data:`PATCH_RANGE_PX`, the capture format's
:data:`~cdbrdf.measure.capture.WHITE_ALBEDO_RANGE`) from here.
"""

from __future__ import annotations

import numbers
from dataclasses import dataclass

from ..errors import OptionError
from ..ranges import Range
from .capture import WHITE_ALBEDO_RANGE

__all__ = ["PATCH_RANGE_PX", "MeasureOptions"]

#: Side of the square patch averaged in each photograph, pixels.
PATCH_RANGE_PX = Range(1, 999, integer=True)


def _positive_int(name: str, value: object, *, none_ok: bool = False) -> None:
    if value is None and none_ok:
        return
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or value < 1:
        raise OptionError(f"{name}: expected a positive whole number{' or None' if none_ok else ''}, "
                          f"got {value!r:.40}")


@dataclass(frozen=True)
class MeasureOptions:
    """The options of a measurement shared by the CDBRDF and the CD-BTF paths (checked when made).

    Attributes
    ----------
    patch
        Side of the patch averaged at each sample's pixel, pixels (:data:`PATCH_RANGE_PX`).
    linear
        Integer images hold linear values, not sRGB.
    skip_bad
        Fill the samples of unusable photographs instead of stopping.
    white_albedo
        Albedo of the white reference (:data:`~cdbrdf.measure.capture.WHITE_ALBEDO_RANGE`); None:
        ``stands.json``'s, else 1.
    material
        Material name written to the file (printable, 1 to 200 characters); None: none.
    fill
        The fill method (:data:`cdbrdf.measure.fill.FILL_METHODS`); None: the path's default.
    checkpoint
        Keep a resumable checkpoint ``OUTPUT.ckpt/`` beside the output.
    batch_size
        Photographs per checkpoint batch.
    num_workers
        Local threads or processes; None: the scheduler's default.
    overwrite
        Replace an existing output file.
    """

    patch: int = 7
    linear: bool = False
    skip_bad: bool = False
    white_albedo: float | None = None
    material: str | None = None
    fill: str | None = None
    checkpoint: bool = True
    batch_size: int = 1024
    num_workers: int | None = None
    overwrite: bool = True

    def __post_init__(self) -> None:
        _positive_int("patch", self.patch)
        object.__setattr__(self, "patch", PATCH_RANGE_PX.check("patch", self.patch))
        _positive_int("batch_size", self.batch_size)
        _positive_int("num_workers", self.num_workers, none_ok=True)
        if self.white_albedo is not None:
            object.__setattr__(self, "white_albedo", WHITE_ALBEDO_RANGE.check("white_albedo", self.white_albedo))
        m = self.material
        if m is not None and (not isinstance(m, str) or not m.strip() or len(m) > 200 or not m.isprintable()):
            raise OptionError(f"material: expected a printable name (1 to 200 characters) or None, got {m!r:.40}")
