"""The rig's sensor: photon and read noise, quantisation, and the photographs written.

The linear pixel value ``x = gain * exposure * L`` is turned into electrons
``x * full_well``, gets photon (Poisson) and read (Gaussian) noise
(:class:`NoiseModel`), is clipped to [0, 1], sRGB-encoded and quantised
(:func:`encode`): 16-bit PNG by default; 8-bit PNG, 16-bit TIFF, or linear
float OpenEXR without clipping (:data:`IMAGE_KINDS`). The files are written
with the readers' own writers (:mod:`cdbrdf.images`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from ..colour import linear_to_srgb
from ..errors import OptionError
from ..images import write_exr, write_png, write_tiff

__all__ = ["IMAGE_KINDS", "NoiseModel", "POISSON_NORMAL_ELECTRONS", "encode", "extension", "write_photograph"]

#: Largest full well or read noise :meth:`NoiseModel.parse` accepts, electrons.
_MAX_ELECTRONS = 1e12

#: Electron count from which photon noise is drawn from its normal limit (:meth:`NoiseModel.apply`).
POISSON_NORMAL_ELECTRONS = 1000.0

#: Image kinds the rig writes: kind -> description.
IMAGE_KINDS: dict[str, str] = {
    "png16": "16-bit sRGB PNG",
    "png8": "8-bit sRGB PNG",
    "tif16": "16-bit sRGB TIFF (uncompressed)",
    "exr": "linear float32 OpenEXR",
}


@dataclass(frozen=True)
class NoiseModel:
    """Sensor noise: photon (Poisson) noise of ``full_well`` electrons at full scale, plus read noise.

    Parameters
    ----------
    full_well
        Electrons at the largest code (linear value 1.0); ``0`` disables noise.
    read_e
        Standard deviation of the read noise, electrons.
    """

    full_well: float = 20000.0
    read_e: float = 3.0

    @classmethod
    def parse(cls, text: str) -> NoiseModel:
        """A noise model from its command-line text.

        Parameters
        ----------
        text
            ``"none"`` or ``"FULL_WELL[,READ]"`` (electrons), e.g. ``"20000,3"``.

        Returns
        -------
        NoiseModel
            The model.
        """
        t = text.strip().lower()
        if t in ("none", "off", "0"):
            return cls(0.0, 0.0)
        try:
            vals = [float(p) for p in t.split(",")]
        except ValueError:
            vals = []
        ok = (
            1 <= len(vals) <= 2
            and all(math.isfinite(v) and 0.0 <= v <= _MAX_ELECTRONS for v in vals)
            and vals[0] > 0
        )
        if not ok:
            raise OptionError(
                f"noise: expected 'none' or FULL_WELL[,READ] electrons (full well in (0, {_MAX_ELECTRONS:g}], "
                f"read noise in [0, {_MAX_ELECTRONS:g}]), got {text!r}"
            )
        return cls(vals[0], vals[1] if len(vals) == 2 else cls.read_e)

    @property
    def enabled(self) -> bool:
        """False when the images are noise-free."""
        return self.full_well > 0

    def apply(self, x: NDArray[np.float64], rng: np.random.Generator) -> NDArray[np.float64]:
        """Noisy linear values (not clipped), any shape.

        Photon noise is Poisson in the electron count ``e``; from
        :data:`POISSON_NORMAL_ELECTRONS` electrons on it is drawn from its
        normal limit (mean and variance ``e``; the skewness ``1 / sqrt(e)``
        left out is under 3 %), four times cheaper to draw than Poisson. Read
        noise is normal with standard deviation ``read_e``.

        Parameters
        ----------
        x
            Noise-free linear values, 1 = full well (any shape).
        rng
            The random generator.

        Returns
        -------
        numpy.ndarray
            Noisy linear values (not clipped), the shape of ``x``.
        """
        if not self.enabled:
            return x
        e = np.maximum(x, 0.0) * self.full_well
        few = e < POISSON_NORMAL_ELECTRONS
        noisy = e + np.sqrt(np.where(few, 0.0, e) + self.read_e ** 2) * rng.standard_normal(e.shape)
        if few.any():
            noisy[few] += rng.poisson(e[few]) - e[few]
        return noisy / self.full_well


def encode(x: NDArray[np.float64], kind: str) -> tuple[NDArray, int]:
    """Codes of linear values for an image kind (:data:`IMAGE_KINDS`) and the number of saturated pixels.

    Integer kinds clip to [0, 1], sRGB-encode and quantise; a pixel with any
    channel at the largest code counts as saturated. ``exr`` keeps the linear
    values (float32, unclipped). ``x`` is ``(..., h, w, 3)``: one photograph or
    a stack of them.
    """
    if kind == "exr":
        return x.astype(np.float32), 0
    top = 65535 if kind in ("png16", "tif16") else 255
    c = np.clip(x, 0.0, 1.0)
    codes = np.round(linear_to_srgb(c) * top)
    sat = int(np.count_nonzero(np.any(codes >= top, axis=-1)))
    return codes.astype(np.uint16 if top == 65535 else np.uint8), sat


def write_photograph(path: Path, codes: NDArray, kind: str) -> None:
    """Write the codes of :func:`encode` as a new image of ``kind`` into an existing folder.

    The rig writes into the partial folder that :func:`cdbrdf.outputs.output_folder`
    has just made, which is published whole once the capture is complete, so each
    photograph is written in place (``atomic=False``: no temporary, no sweep of a
    folder of 26,000 photographs, no fsync each). PNGs are stored without
    compression (zlib level 0): four times faster to write than level 1, and
    the capture folder of the rig is a test bench, not an archive.
    """
    if kind in ("png16", "png8"):
        write_png(path, codes, level=0, atomic=False)
    elif kind == "tif16":
        write_tiff(path, codes, atomic=False)
    else:
        write_exr(path, codes, atomic=False)


def extension(kind: str) -> str:
    """The file extension (no dot) of an image kind."""
    return {"png16": "png", "png8": "png", "tif16": "tif", "exr": "exr"}[kind]
