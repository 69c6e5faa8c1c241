"""From a photograph to one reflectance value: the N x N patch at the stand's centre.

The paper takes "the mean of the 7 x 7 pixels around the stand's centre".
Here:

- the patch is exactly ``N x N`` pixels; for odd ``N`` it is centred on the
  pixel ``(cx, cy)`` (columns ``cx - N//2 .. cx + N//2``); for even ``N`` the
  centre pixel is the lower-right one of the four middle pixels (columns
  ``cx - N//2 .. cx + N//2 - 1``). The default centre is pixel
  ``(width // 2, height // 2)`` (0-based, rows from the top);
- integer codes are decoded to linear (sRGB unless declared linear) and
  scaled so that the format's maximum code is 1.0; float data is used as is;
- a pixel with any channel at the format's maximum code (or non-finite float)
  is *saturated* and never averaged in;
- exposure brackets (several photographs of one condition with relative
  exposures ``e_i``) are merged per pixel into one linear radiance
  ``sum_i (x_i - d_i) / sum_i e_i`` over the exposures where the pixel is not
  saturated (``d_i``: the dark frame of that exposure, or 0); a pixel
  saturated in every exposure makes the sample invalid;
- the sample's value is the mean of the merged pixels, its spread their
  standard deviation (``ddof=1``).

References
----------
Debevec, Malik, "Recovering high dynamic range radiance maps from
photographs", SIGGRAPH 1997 (weighted merge of exposures; here with linear
data the weight is the exposure itself, the maximum-likelihood estimate under
photon noise).
"""

from __future__ import annotations

from collections.abc import Sequence
from os import PathLike

import numpy as np
from numpy.typing import NDArray

from ..colour import srgb_to_linear
from ..errors import OptionError
from ..images import ImageInfo, read_window

__all__ = [
    "patch_window",
    "decode_codes",
    "read_patch",
    "merge_exposures",
    "patch_statistics",
]


def patch_window(
    info: ImageInfo | tuple[int, int], *, n: int = 7, cx: int | None = None, cy: int | None = None
) -> tuple[int, int, int, int]:
    """The window ``(x0, y0, n, n)`` of the ``n x n`` patch centred at ``(cx, cy)``.

    Parameters
    ----------
    info
        The image's :class:`ImageInfo` or its ``(width, height)``.
    n
        Patch size in pixels (>= 1).
    cx, cy
        Column and row of the centre pixel; default ``width // 2``, ``height // 2``.
    """
    if isinstance(info, ImageInfo):
        width, height = info.width, info.height
    else:
        width, height = info
    if int(n) != n or n < 1:
        raise OptionError(f"patch size: expected a positive integer, got {n!r}")
    n = int(n)
    cx = width // 2 if cx is None else int(cx)
    cy = height // 2 if cy is None else int(cy)
    return cx - n // 2, cy - n // 2, n, n


def decode_codes(
    raw: NDArray, info: ImageInfo, *, linear: bool = False
) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """Linear values and the saturation mask of raw codes.

    Parameters
    ----------
    raw
        Codes ``(rows, cols, channels)`` as returned by the readers.
    info
        The image's :class:`ImageInfo`.
    linear
        Integer codes are linear (not sRGB-encoded). Ignored for float data
        (always linear).

    Returns
    -------
    values : numpy.ndarray
        Linear float64, 1.0 = the format's maximum code (float data as is).
    saturated : numpy.ndarray
        ``(rows, cols)``: True where any channel is at the maximum code
        (integer data) or not finite (float data).
    """
    if info.max_code is None:
        v = raw.astype(np.float64)
        sat = ~np.all(np.isfinite(v), axis=-1)
        v = np.where(np.isfinite(v), v, 0.0)
        return v, sat
    sat = np.any(raw >= info.max_code, axis=-1)
    v = raw.astype(np.float64) / float(info.max_code)
    if not (linear or info.linear):
        v = srgb_to_linear(v)
    return v, sat


def read_patch(
    path: str | PathLike[str],
    *,
    n: int = 7,
    cx: int | None = None,
    cy: int | None = None,
    linear: bool = False,
) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """Read and decode the ``n x n`` patch of one photograph.

    Reads only what the format allows (see :func:`cdbrdf.images.read_window`).

    Returns
    -------
    values : numpy.ndarray
        ``(n, n, channels)`` linear values.
    saturated : numpy.ndarray
        ``(n, n)`` saturation mask.
    """
    raw, info = read_window(path, lambda inf: patch_window(inf, n=n, cx=cx, cy=cy))
    return decode_codes(raw, info, linear=linear)


def merge_exposures(
    values: Sequence[NDArray[np.float64]],
    saturated: Sequence[NDArray[np.bool_]],
    exposures: Sequence[float],
    dark: Sequence[NDArray[np.float64] | None] | None = None,
) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """Merge bracketed patches into one linear radiance per pixel.

    Parameters
    ----------
    values, saturated
        Per exposure: linear patch ``(n, n, C)`` and its saturation mask ``(n, n)``.
    exposures
        Relative exposure of each (> 0).
    dark
        Per exposure: the dark frame's linear patch to subtract, or None.

    Returns
    -------
    radiance : numpy.ndarray
        ``(n, n, C)``: ``sum_i (x_i - d_i) / sum_i e_i`` over the unsaturated
        exposures of each pixel (0 where none).
    valid : numpy.ndarray
        ``(n, n)``: True where at least one exposure is unsaturated.
    """
    if not (len(values) == len(saturated) == len(exposures)) or not values:
        raise OptionError("merge_exposures: need the same (non-zero) number of patches, masks and exposures")
    num = np.zeros_like(values[0], dtype=np.float64)
    den = np.zeros(values[0].shape[:2], dtype=np.float64)
    for i, (v, s, e) in enumerate(zip(values, saturated, exposures)):
        if not e > 0:
            raise OptionError(f"exposure: must be positive, got {e!r}")
        ok = ~s
        d = None if dark is None else dark[i]
        x = v if d is None else v - d
        num += np.where(ok[..., None], x, 0.0)
        den += np.where(ok, float(e), 0.0)
    valid = den > 0
    radiance = np.where(valid[..., None], num / np.where(valid, den, 1.0)[..., None], 0.0)
    return radiance, valid


def patch_statistics(
    radiance: NDArray[np.float64], valid: NDArray[np.bool_]
) -> tuple[NDArray[np.float64], NDArray[np.float64], bool]:
    """Mean and standard deviation (``ddof=1``; 0 for a single pixel) over the patch.

    Returns ``(mean, std, ok)``; ``ok`` is False (and mean/std NaN) when any
    pixel is invalid (saturated in every exposure).
    """
    c = radiance.shape[-1]
    if not np.all(valid):
        nan = np.full(c, np.nan)
        return nan, nan.copy(), False
    px = radiance.reshape(-1, c)
    mean = px.mean(axis=0)
    std = px.std(axis=0, ddof=1) if px.shape[0] > 1 else np.zeros(c)
    return mean, std, True
