"""Writing a render to a file chosen by its suffix: PNG for viewing, OpenEXR linear.

- ``.png``: 8-bit sRGB after a fixed exposure,
  ``srgb(clip(radiance * 2**exposure_ev, 0, 1))``
  (:func:`cdbrdf.colour.tonemap_srgb8`). With the default light irradiance
  (pi) a white Lambertian surface facing the light has radiance 1, i.e. just
  white at 0 EV.
- ``.exr``: the linear radiance as float32 (no exposure applied).

Both are written atomically by the image writers of
:mod:`cdbrdf.images`.
"""

from __future__ import annotations

from collections.abc import Mapping
from os import PathLike
from pathlib import Path
from types import MappingProxyType

from numpy.typing import ArrayLike

from ..colour import tonemap_srgb8
from ..errors import OptionError

__all__ = ["IMAGE_FORMATS", "write_render"]

#: Output formats of :func:`write_render`, chosen by the file's suffix.
IMAGE_FORMATS: Mapping[str, str] = MappingProxyType({".png": "png", ".exr": "exr"})


def write_render(path: str | PathLike[str], image: ArrayLike, *, exposure_ev: float = 0.0) -> Path:
    """Write a linear render: ``.exr`` linear float32, ``.png`` 8-bit sRGB (atomically).

    Parameters
    ----------
    path
        Output file, ``.png`` or ``.exr``; replaced if it exists.
    image
        Linear RGB radiance ``(H, W, 3)`` (or grey ``(H, W)``).
    exposure_ev
        PNG only: exposure in stops applied before encoding.

    Returns
    -------
    pathlib.Path
        ``path``.

    Raises
    ------
    ValueError
        For another suffix (nothing is written) or an unusable image shape.
    """
    from ..images import write_exr, write_png

    out = Path(path)
    fmt = IMAGE_FORMATS.get(out.suffix.lower())
    if fmt == "exr":
        write_exr(out, image)
    elif fmt == "png":
        write_png(out, tonemap_srgb8(image, exposure_ev=exposure_ev))
    else:
        raise OptionError(f"{out}: unknown image type {out.suffix.lower()!r}; use {' or '.join(IMAGE_FORMATS)}")
    return out
