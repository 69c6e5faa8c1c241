"""MERL-MIT BRDF database ``.binary`` files (Matusik et al. 2003).

Layout (little-endian), as the database's reader ``BRDFRead.cpp`` reads it:
three int32 ``(90, 90, 180)`` = the sample counts of theta_h, theta_d and
phi_d, then ``3 x 90 x 90 x 180`` float64: the red block, then green, then
blue, each with phi_d fastest, then theta_d, then theta_h. The half/difference
angles of a direction pair (Rusinkiewicz 1998): ``h = normalize(l + v)``;
theta_h, phi_h its angles; the difference vector is ``l`` turned by -phi_h
about the normal and by -theta_h about the binormal; theta_d, phi_d its angles.
Index of a sample: theta_h is sampled non-linearly, ``floor(sqrt(theta_h /
90 deg) * 90)``; theta_d linearly, ``floor(theta_d / 90 deg * 90)``; phi_d over
[0, 180) degrees, ``floor(phi_d / 180 deg * 180)`` after adding 180 degrees to
a negative phi_d (the data assume reciprocity). Channel scales of the reader:
red 1/1500, green 1.15/1500, blue 1.66/1500, which give the BRDF in sr^-1.
Negative values mark samples that were not measured (below the horizon).

Here the samples are taken at the centres of those index cells (index + 0.5)
and interpolated linearly in index space (theta_h, theta_d clamped at their
ends, phi_d periodic over 180 degrees) instead of the reader's nearest-cell
lookup; samples marked negative are left out of the interpolation (the others
are renormalised) and count as not measured. The data are isotropic, RGB,
treated as linear Rec. 709, and absolute (``quantity = "brdf"``).
"""

from __future__ import annotations

from os import PathLike
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..errors import FormatError
from .source import Source, check_plausible, file_sha256, read_bytes

__all__ = ["DIMS", "SCALES", "HEADER_BYTES", "FILE_BYTES", "read", "write", "half_diff"]

#: Sample counts of (theta_h, theta_d, phi_d).
DIMS = (90, 90, 180)
#: Channel scales of the MERL reader (red, green, blue): stored value x scale = BRDF in sr^-1.
SCALES = (1.0 / 1500.0, 1.15 / 1500.0, 1.66 / 1500.0)
#: Bytes of the header (three int32).
HEADER_BYTES = 12
#: Bytes of a whole file.
FILE_BYTES = HEADER_BYTES + 3 * DIMS[0] * DIMS[1] * DIMS[2] * 8


def _fail(path: Path, problem: str) -> FormatError:
    return FormatError(f"{path}: {problem}")


def half_diff(theta_v: NDArray[np.float64], phi_v: NDArray[np.float64], theta_l: NDArray[np.float64],
              phi_l: NDArray[np.float64]) -> tuple[NDArray[np.float64], ...]:
    """``(theta_h, theta_d, phi_d)`` in radians of direction pairs given in degrees (MERL's convention, l = "in")."""
    def vec(t: NDArray[np.float64], p: NDArray[np.float64]) -> NDArray[np.float64]:
        t, p = np.radians(t), np.radians(p)
        return np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)])

    li, vo = vec(theta_l, phi_l), vec(theta_v, phi_v)
    h = li + vo
    h /= np.linalg.norm(h, axis=0)
    theta_h = np.arccos(np.clip(h[2], -1.0, 1.0))
    phi_h = np.arctan2(h[1], h[0])
    # the light direction turned by -phi_h about z, then by -theta_h about y
    c, s = np.cos(-phi_h), np.sin(-phi_h)
    x, y, z = c * li[0] - s * li[1], s * li[0] + c * li[1], li[2]
    c, s = np.cos(-theta_h), np.sin(-theta_h)
    dx, dy, dz = c * x + s * z, y, -s * x + c * z
    theta_d = np.arccos(np.clip(dz, -1.0, 1.0))
    phi_d = np.arctan2(dy, dx)
    return theta_h, theta_d, phi_d


def _positions(theta_h: NDArray[np.float64], theta_d: NDArray[np.float64],
               phi_d: NDArray[np.float64]) -> tuple[NDArray[np.float64], ...]:
    """Continuous sample positions (index space, sample centres at integers)."""
    nh, nd, np_ = DIMS
    uh = np.sqrt(np.clip(theta_h / (np.pi / 2), 0.0, 1.0)) * nh - 0.5
    ud = np.clip(theta_d / (np.pi / 2), 0.0, 1.0) * nd - 0.5
    pd = np.where(phi_d < 0.0, phi_d + np.pi, phi_d)
    up = pd / np.pi * np_ - 0.5
    return np.clip(uh, 0.0, nh - 1.0), np.clip(ud, 0.0, nd - 1.0), up


class _Evaluator:
    """Trilinear interpolation of the samples in index space, leaving out the unmeasured ones."""

    def __init__(self, rgb: NDArray[np.float64], valid: NDArray[np.bool_]) -> None:
        self.rgb = np.where(valid[..., None], rgb, 0.0)  # (nh, nd, np, 3)
        self.valid = valid.astype(np.float64)

    def __call__(self, theta_v: NDArray[np.float64], phi_v: NDArray[np.float64], theta_l: NDArray[np.float64],
                 phi_l: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        uh, ud, up = _positions(*half_diff(theta_v, phi_v, theta_l, phi_l))
        nh, nd, np_ = DIMS
        ih = np.minimum(np.floor(uh).astype(np.int64), nh - 2)
        id_ = np.minimum(np.floor(ud).astype(np.int64), nd - 2)
        fp = np.floor(up)
        ip = fp.astype(np.int64) % np_
        wh, wd, wp = uh - ih, ud - id_, up - fp
        acc = np.zeros((uh.size, 3))
        wsum = np.zeros(uh.size)
        for a, wa in ((ih, 1.0 - wh), (ih + 1, wh)):
            for b, wb in ((id_, 1.0 - wd), (id_ + 1, wd)):
                for c, wc in ((ip, 1.0 - wp), ((ip + 1) % np_, wp)):
                    w = wa * wb * wc
                    acc += (w[:, None]) * self.rgb[a, b, c]
                    wsum += w * self.valid[a, b, c]
        with np.errstate(invalid="ignore", divide="ignore"):
            out = np.where(wsum[:, None] > 1e-12, acc / wsum[:, None], 0.0)
        return out, np.clip(wsum, 0.0, 1.0)


def read(path: str | PathLike[str], *, material: str | None = None) -> Source:
    """A MERL ``.binary`` file as a :class:`~cdbrdf.importers.source.Source`.

    Raises
    ------
    FormatError
        For a file of the wrong size, a header other than ``(90, 90, 180)``,
        non-finite values, or no measured sample.
    """
    p, data = read_bytes(path, what="a MERL .binary file")
    if len(data) < HEADER_BYTES:
        raise _fail(p, f"not a MERL .binary file (only {len(data)} bytes)")
    dims = tuple(int(x) for x in np.frombuffer(data, dtype="<i4", count=3))
    if dims != DIMS:
        raise _fail(p, f"not a MERL .binary file: its header gives {dims[0]} x {dims[1]} x {dims[2]} samples, "
                       f"expected {DIMS[0]} x {DIMS[1]} x {DIMS[2]} (theta_h x theta_d x phi_d)")
    if len(data) != FILE_BYTES:
        raise _fail(p, f"a MERL file of the wrong size: {len(data)} bytes, expected {FILE_BYTES} "
                       f"(12-byte header + 3 x {DIMS[0] * DIMS[1] * DIMS[2]} float64): truncated or padded")
    raw = np.frombuffer(data, dtype="<f8", offset=HEADER_BYTES).reshape(3, *DIMS)
    bad = int(np.count_nonzero(~np.isfinite(raw)))
    if bad:
        raise _fail(p, f"holds {bad} NaN or infinite value(s)")
    valid = np.all(raw >= 0.0, axis=0)
    if not valid.any():
        raise _fail(p, "holds no measured sample (every value is negative)")
    rgb = np.moveaxis(raw, 0, -1) * np.asarray(SCALES)
    check_plausible(p, rgb[valid], what="BRDF values (sr^-1, the reader's channel scales applied)")
    n_bad = int(valid.size - np.count_nonzero(valid))
    details: dict[str, Any] = {
        "layout": "3 int32 (90, 90, 180) + 3 x 90 x 90 x 180 float64 (R, G, B; phi_d fastest)",
        "channel_scales": [f"{s * 1500:g}/1500" for s in SCALES],
        "unmeasured_samples": n_bad,
        "interpolation": "linear in index space between cell centres; unmeasured samples left out",
        "colour_space": "the database's RGB, treated as linear Rec.709",
    }
    return Source(
        path=p, format="merl", symmetry="isotropic", quantity="brdf",
        colour_space="linear Rec.709 (sRGB primaries)", material=material or p.stem.split(".")[0],
        description="", details=details, evaluate=_Evaluator(rgb, valid), sha256=file_sha256(data),
    )


def write(path: str | PathLike[str], brdf_rgb: NDArray[np.floating]) -> None:
    """Write a MERL ``.binary`` file from BRDF values (sr^-1) of shape ``(90, 90, 180, 3)``.

    The values are divided by :data:`SCALES` (the inverse of the reader);
    negative values mark unmeasured samples. For tests and conversions.
    """
    v = np.asarray(brdf_rgb, dtype=np.float64)
    if v.shape != (*DIMS, 3):
        raise ValueError(f"brdf_rgb: expected shape {(*DIMS, 3)}, got {v.shape}")
    raw = np.moveaxis(v / np.asarray(SCALES), -1, 0)
    Path(path).write_bytes(np.asarray(DIMS, dtype="<i4").tobytes() + raw.astype("<f8").tobytes())
