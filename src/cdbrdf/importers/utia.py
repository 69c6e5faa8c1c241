"""UTIA BRDF database ``.bin`` files (Filip & Vavra 2014, 150 anisotropic materials).

A file is raw little-endian float64 without a header: ``3 x 6 x 48 x 6 x 48``
values (1 990 656 bytes), indexed ``[channel][theta_i][phi_i][theta_v][phi_v]``
as the database's reader (by J. Filip) indexes them: ``channel`` R, G, B;
``theta_i`` (illumination) and ``theta_v`` (view) elevations 0..75 degrees in
15-degree steps (exactly the paper's elevations); ``phi_i`` and ``phi_v``
azimuths 0..352.5 degrees in 7.5-degree steps, from x towards y. The readers
interpolate the samples quadrilinearly (azimuths periodic), as the table
lookup does.

The values carry no absolute scale (``quantity = "relative"``) and are stored
sRGB-encoded: the database's Python reader (A. Fichet) decodes them with the
sRGB transfer function by default, and so does this one (``encoding="srgb"``;
``encoding="linear"`` takes them as they are). Negative values, which some
materials hold, are set to 0 and count as not measured.
"""

from __future__ import annotations

from os import PathLike
from pathlib import Path
from typing import Any

import numpy as np

from ..colour import linear_to_srgb, srgb_to_linear
from ..errors import FormatError
from ..grid import Grid
from .source import MAX_PLAUSIBLE_BRDF, Source, check_plausible, file_sha256, read_bytes, table_on

__all__ = ["SHAPE", "FILE_BYTES", "THETA_DEG", "PHI_DEG", "ENCODINGS", "read", "write", "native_grid"]

#: Layout of the values: (channel, theta_i, phi_i, theta_v, phi_v).
SHAPE = (3, 6, 48, 6, 48)
#: Bytes of a file.
FILE_BYTES = 8 * int(np.prod(SHAPE))
#: Elevations of the samples, degrees.
THETA_DEG = np.arange(6, dtype=np.float64) * 15.0
#: Azimuths of the samples, degrees.
PHI_DEG = np.arange(48, dtype=np.float64) * 7.5
#: How the stored values are encoded: choices of ``read(..., encoding=)``.
ENCODINGS: tuple[str, ...] = ("srgb", "linear")


def native_grid(kappa: float = 0.0) -> Grid:
    """The file's own sampling as a one-curvature grid (theta 15, phi 7.5 degrees)."""
    return Grid(kappa=np.array([kappa], dtype=np.float64), theta_l=THETA_DEG, phi_l=PHI_DEG, theta_v=THETA_DEG,
                phi_v=PHI_DEG)


def read(path: str | PathLike[str], *, material: str | None = None, encoding: str = "srgb") -> Source:
    """A UTIA ``.bin`` file as a :class:`~cdbrdf.importers.source.Source` (anisotropic, relative).

    Raises
    ------
    FormatError
        For a file of the wrong size or with non-finite values, or an unknown ``encoding``.
    """
    if encoding not in ENCODINGS:
        raise FormatError(f"encoding: {encoding!r} is not one of {', '.join(ENCODINGS)}")
    p, data = read_bytes(path, what="a UTIA .bin file")
    if len(data) != FILE_BYTES:
        raise FormatError(f"{p}: a UTIA BRDF file of the wrong size: {len(data)} bytes, expected {FILE_BYTES} "
                          "(3 x 6 x 48 x 6 x 48 float64, no header): truncated or not a UTIA file")
    raw = np.frombuffer(data, dtype="<f8").reshape(SHAPE)
    bad = int(np.count_nonzero(~np.isfinite(raw)))
    if bad:
        raise FormatError(f"{p}: holds {bad} NaN or infinite value(s)")
    # the shared plausibility bound, on the stored values first (decoding an absurd one would overflow)
    bound = MAX_PLAUSIBLE_BRDF if encoding == "linear" else float(linear_to_srgb(MAX_PLAUSIBLE_BRDF))
    top = float(np.abs(raw).max())
    if top > bound:
        raise FormatError(f"{p}: holds values up to {top:.3g}, beyond {bound:.4g} ({MAX_PLAUSIBLE_BRDF:.0e} decoded; "
                          "the database's are near 1): damaged or not a UTIA file")
    # (c, ti, pi, tv, pv) -> (kappa = 1, phi_l, theta_l, phi_v, theta_v, c)
    v = np.transpose(raw, (2, 1, 4, 3, 0))[None]
    measured = np.all(v >= 0.0, axis=-1)
    if not measured.any():
        raise FormatError(f"{p}: holds no measured sample (every value is negative)")
    v = np.maximum(v, 0.0)
    if encoding == "srgb":
        v = srgb_to_linear(v)
    check_plausible(p, v[measured], what="decoded values")
    g = native_grid()
    table = table_on(g, v, measured=measured, attrs={"quantity": "relative"})

    mask = None if measured.all() else table_on(g, measured[..., None].astype(np.float64))

    def evaluate(theta_v: Any, phi_v: Any, theta_l: Any, phi_l: Any) -> tuple[Any, Any]:
        f = table.evaluate(theta_v, phi_v, theta_l, phi_l, 0.0)
        return f, None if mask is None else mask.evaluate(theta_v, phi_v, theta_l, phi_l, 0.0)[:, 0]

    details: dict[str, Any] = {
        "layout": "3 x 6 x 48 x 6 x 48 float64 [channel][theta_i][phi_i][theta_v][phi_v], no header",
        "encoding": encoding,
        "decoding": "sRGB transfer function" if encoding == "srgb" else "none (values taken as linear)",
        "unmeasured_samples": int(measured.size - np.count_nonzero(measured)),
    }
    return Source(
        path=p, format="utia", symmetry="anisotropic", quantity="relative",
        colour_space="linear Rec.709 (sRGB primaries)", material=material or p.stem, description="",
        details=details, evaluate=evaluate, sha256=file_sha256(data), table=table,
    )


def write(path: str | PathLike[str], values: Any, *, encoding: str = "srgb") -> None:
    """Write a UTIA ``.bin`` file from linear values of shape ``(6, 48, 6, 48, 3)``
    ``(theta_i, phi_i, theta_v, phi_v, channel)`` (sRGB-encoded unless ``encoding="linear"``). For tests."""
    from ..colour import linear_to_srgb

    v = np.asarray(values, dtype=np.float64)
    if v.shape != (6, 48, 6, 48, 3):
        raise ValueError(f"values: expected shape (6, 48, 6, 48, 3), got {v.shape}")
    if encoding == "srgb":
        v = np.where(v >= 0, linear_to_srgb(np.maximum(v, 0.0)), v)
    Path(path).write_bytes(np.moveaxis(v, -1, 0).astype("<f8").tobytes())
