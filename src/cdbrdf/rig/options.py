"""How the simulated rig photographs: its camera, sensor, exposures and sampling, as one record.

:class:`RigOptions` is what :func:`cdbrdf.rig.simulate_capture` takes
beside the material, the folder and what to photograph (a plan, or a grid and
stands); it is checked once, when it is made (a field of the wrong kind or
out of its range is one :class:`~cdbrdf.errors.OptionError` line). Every
range is a :class:`~cdbrdf.ranges.Range` here, which ``cdbrdf
simulate-capture`` reads too; the white reference's is the capture format's
(:data:`cdbrdf.measure.capture.WHITE_ALBEDO_RANGE`), since the rig writes it
into ``stands.json``.

.. code-block:: python

    from cdbrdf.rig import NoiseModel, RigOptions, simulate_capture

    simulate_capture("denim", "capture", RigOptions(size=32, spp=8, noise=NoiseModel(0, 0), seed=1))
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from ..errors import OptionError
from ..measure.capture import WHITE_ALBEDO_RANGE
from ..ranges import Range
from .sensor import IMAGE_KINDS, NoiseModel

__all__ = ["RigOptions", "PX_PER_TEXEL", "DEFAULT_SIZE_PX", "DEFAULT_FIELD_MM", "SIZE_RANGE_PX", "FIELD_RANGE_MM",
           "PX_PER_TEXEL_RANGE", "SHIFTS_RANGE", "SPP_RANGE", "GAIN_RANGE", "EXPOSURE_RANGE", "MAX_EXPOSURES",
           "SEED_RANGE", "WHITE_ALBEDO_RANGE"]

#: Pixels per texel (along the texel's shorter side) the rig's camera gives a CD-BTF by default.
PX_PER_TEXEL = 3.0

#: Default image side, pixels (a CD-BTF: from :attr:`RigOptions.px_per_texel`).
DEFAULT_SIZE_PX = 64

#: Default width of the camera's field at the stand, mm (a CD-BTF: 1.5 repeat diagonals).
DEFAULT_FIELD_MM = 2.0

#: Accepted image sides, pixels.
SIZE_RANGE_PX = Range(8, 8192, integer=True, unit="pixels")

#: Accepted fields, mm.
FIELD_RANGE_MM = Range(0.0, 1e4, lo_open=True, unit="mm")

#: Accepted pixels per texel of a CD-BTF.
PX_PER_TEXEL_RANGE = Range(0.5, 64.0)

#: Accepted positions of a CD-BTF's scan along u.
SHIFTS_RANGE = Range(1, 64, integer=True)

#: Accepted samples per pixel.
SPP_RANGE = Range(1, 65536, integer=True)

#: Accepted gains (linear pixel value per unit radiance at exposure 1).
GAIN_RANGE = Range(0.0, 1e12, lo_open=True)

#: Accepted exposures of a photograph (relative).
EXPOSURE_RANGE = Range(0.0, 1e6, lo_open=True)

#: Most exposures (brackets) per sample.
MAX_EXPOSURES = 16

#: Accepted noise seeds (numpy's and Mitsuba's 32-bit seeds).
SEED_RANGE = Range(0, 2**32 - 1, integer=True)


@dataclass(frozen=True)
class RigOptions:
    """How the rig photographs (see the module's description).

    Parameters
    ----------
    size
        Image width and height, pixels, in :data:`SIZE_RANGE_PX`; None:
        :data:`DEFAULT_SIZE_PX`, for a CD-BTF from ``px_per_texel``
        (:func:`cdbrdf.rig.btf_camera`).
    field_mm
        Width of the camera's field at the stand, in :data:`FIELD_RANGE_MM`;
        None: :data:`DEFAULT_FIELD_MM`, for a CD-BTF 1.5 repeat diagonals.
        ``field_mm / size`` (the pixel) is written to ``stands.json`` as
        ``pixel_mm``, so that the measurement discards photographs in which
        a pixel of the patch sees a wall or lies in its shadow.
    px_per_texel
        For a CD-BTF without ``size``: pixels per texel (its shorter side), in
        :data:`PX_PER_TEXEL_RANGE`.
    shifts
        For a CD-BTF without a plan: photograph every sample with the fabric
        at ``shifts`` positions along u, ``size_u / shifts`` apart (a scan),
        in :data:`SHIFTS_RANGE`.
    spp
        Stratified samples per pixel (each pixel's footprint; box filter), in :data:`SPP_RANGE`.
    noise
        Sensor noise (:class:`~cdbrdf.rig.NoiseModel`; ``NoiseModel(0, 0)`` for none).
    gain
        Linear pixel value per unit radiance at exposure 1, in :data:`GAIN_RANGE`.
    exposures
        Without a plan: the exposures of each sample and white photograph, 1
        to :data:`MAX_EXPOSURES` of them, each in :data:`EXPOSURE_RANGE`
        (several make brackets, each rendered once and given its own noise).
    image_kind
        One of :data:`~cdbrdf.rig.sensor.IMAGE_KINDS`.
    white_albedo
        Albedo of the white reference plate (written to ``stands.json``), in
        :data:`~cdbrdf.measure.capture.WHITE_ALBEDO_RANGE`.
    white
        Without a plan: add white-reference rows.
    patch_px
        Without a plan: the patch size the plan's ``hidden`` marks assume.
    seed
        Noise seed, in :data:`SEED_RANGE` (the photographs of one rendering
        draw from ``(seed, its first row)``).

    Raises
    ------
    OptionError
        For a value of the wrong kind or out of its range.
    """

    size: int | None = None
    field_mm: float | None = None
    px_per_texel: float = PX_PER_TEXEL
    shifts: int = 1
    spp: int = 4
    noise: NoiseModel = NoiseModel()
    gain: float = 2.0
    exposures: Sequence[float] = (1.0,)
    image_kind: str = "png16"
    white_albedo: float = 0.99
    white: bool = True
    patch_px: int = 7
    seed: int = 0

    def __post_init__(self) -> None:
        put = object.__setattr__
        if not isinstance(self.image_kind, str) or self.image_kind not in IMAGE_KINDS:
            raise OptionError(f"image_kind: {self.image_kind!r:.40} is not one of {', '.join(IMAGE_KINDS)}")
        if self.size is not None:
            put(self, "size", SIZE_RANGE_PX.check("size", self.size))
        if self.field_mm is not None:
            put(self, "field_mm", FIELD_RANGE_MM.check("field_mm", self.field_mm))
        for name, rng in (("px_per_texel", PX_PER_TEXEL_RANGE), ("shifts", SHIFTS_RANGE), ("spp", SPP_RANGE),
                          ("gain", GAIN_RANGE), ("white_albedo", WHITE_ALBEDO_RANGE), ("seed", SEED_RANGE)):
            put(self, name, rng.check(name, getattr(self, name)))
        if not isinstance(self.noise, NoiseModel):
            raise OptionError(f"noise: expected a cdbrdf.rig.NoiseModel, got {type(self.noise).__name__:.40}")
        try:
            exposures = tuple(self.exposures)
        except TypeError:
            raise OptionError(f"exposures: expected 1 to {MAX_EXPOSURES} numbers, got {self.exposures!r:.40}") from None
        if not 1 <= len(exposures) <= MAX_EXPOSURES:
            raise OptionError(f"exposures: expected 1 to {MAX_EXPOSURES} numbers, got {len(exposures)}")
        put(self, "exposures", tuple(EXPOSURE_RANGE.check("exposures", e) for e in exposures))
        put(self, "white", bool(self.white))
