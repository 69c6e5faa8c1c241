"""A plain BRDF read from a file: what every reader of :mod:`cdbrdf.importers` returns.

A :class:`Source` holds what the resampler (:mod:`cdbrdf.importers.resample`)
needs of a measured material: a vectorised evaluator of the BRDF in the
project's conventions (``docs/conventions.md``: directions pointing away from
the surface, elevations and azimuths in degrees, the BRDF in sr^-1 *without*
the cosine, linear Rec. 709 RGB), the share of each value that the source says
was measured, and the metadata that goes into the imported table's attributes
and provenance.
"""

from __future__ import annotations

import hashlib
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from os import PathLike
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

if TYPE_CHECKING:
    from ..table import CDBRDF

__all__ = ["Evaluator", "Source", "MAX_PLAUSIBLE_BRDF", "check_plausible", "file_sha256", "read_bytes", "table_on",
           "mitsuba", "mitsuba_brdf"]

#: Largest value, in sr^-1 (or the relative unit of a ``"relative"`` source), that any imported file may
#: hold, for every format alike (RGL, MERL, UTIA, CDBRDF): 1e5. A BRDF value f over the solid angle it
#: stands for, w, reflects f cos(theta) w of the light; energy conservation (at most all of it) bounds
#: f <= 1 / (cos(theta) w). The finest angular resolution of the public databases' instruments is
#: about a tenth of a degree (a cone of 1e-5 sr), so no measured value can exceed about 1e5: a mirror-
#: like peak reads at most that, the glossiest RGL materials about 1e3. A larger value is damage or a
#: file in another unit, and a single one of them dominates every mean of the table (a UTIA value of 9e5,
#: decoded, turned a table's mean from 0.3 into 4.2e8). The sRGB-encoded UTIA values are checked decoded.
MAX_PLAUSIBLE_BRDF = 1e5

#: ``evaluate(theta_v, phi_v, theta_l, phi_l)`` (degrees, 1-D float64 arrays of one length n) ->
#: ``(values (n, 3) sr^-1 or relative, measured (n,) in [0, 1] or None = all measured)``.
Evaluator = Callable[
    [NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]],
    tuple[NDArray[np.float64], NDArray[np.float64] | None],
]


@dataclass(frozen=True, eq=False)
class Source:
    """A plain (one-curvature) BRDF read from a file, ready to be resampled onto a grid.

    Attributes
    ----------
    path
        The file it was read from.
    format
        The reader's name (a key of :data:`cdbrdf.importers.FORMATS`).
    symmetry
        ``"isotropic"`` when the data depend on the azimuth difference only
        (MERL, isotropic RGL files), else ``"anisotropic"``.
    quantity
        ``"brdf"`` (sr^-1) or ``"relative"`` (unknown scale), as in a table.
    colour_space
        The colour space of :attr:`evaluate`'s values (always linear Rec. 709 here).
    material
        Material name (the file's own description when it has one, else its name).
    description
        The file's own description text ("" when it has none).
    details
        Format-specific facts for the provenance (JSON-ready): resolution,
        scales, encodings, conversions applied.
    evaluate
        The vectorised evaluator (:data:`Evaluator`).
    sha256
        SHA-256 of the file's bytes (hex).
    table
        When the source is itself a table on a grid (UTIA, CDBRDF files): that
        table (one curvature). The resampler copies it exactly when the target
        grid is its own.
    """

    path: Path
    format: str
    symmetry: str
    quantity: str
    colour_space: str
    material: str
    description: str
    details: Mapping[str, Any]
    evaluate: Evaluator
    sha256: str
    table: CDBRDF | None = field(default=None)

    @property
    def isotropic(self) -> bool:
        """Whether the source is isotropic."""
        return self.symmetry == "isotropic"

    def provenance(self) -> dict[str, Any]:
        """Where the data came from, for a table's ``provenance``.

        Returns
        -------
        dict
            JSON-ready: the file, its format, digest and details.
        """
        return {
            "file": str(self.path),
            "file_name": self.path.name,
            "sha256": self.sha256,
            "format": self.format,
            "description": self.description,
            "symmetry": self.symmetry,
            "quantity": self.quantity,
            "details": dict(self.details),
        }


def table_on(grid: Any, values: Any, *, std: Any = None, attrs: Any = None, **provenance: Any) -> CDBRDF:
    """A :class:`~cdbrdf.table.CDBRDF` on ``grid`` with ``values``; ``provenance``: the fields of its record."""
    from ..provenance import Provenance
    from ..table import CDBRDF

    return CDBRDF(values, grid, std=std, attrs=attrs, provenance=Provenance(**provenance))


def mitsuba() -> tuple[Any, Any]:
    """``(mitsuba, drjit)``, imported on demand, typed as Any (their stubs do not follow variants)."""
    import drjit as dr
    import mitsuba as mi

    return mi, dr


def mitsuba_brdf(bsdf: Any, theta_v: NDArray[np.float64], phi_v: NDArray[np.float64],
                 theta_l: NDArray[np.float64], phi_l: NDArray[np.float64]) -> tuple[Any, Any, Any]:
    """A loaded Mitsuba BSDF's BRDF (sr^-1, no cosine) at directions given in degrees, in its local frame.

    ``si.wi`` is the view and ``wo`` the light, both pointing away from the surface;
    ``eval`` (which includes the light's cosine) is divided by ``cos(theta_l)``.
    Returns the Dr.Jit values with ``wi`` and ``wo`` (for callers that need more at
    the same directions). Call it in the variant the BSDF was loaded in.
    """
    mi, dr = mitsuba()
    deg = float(np.pi / 180.0)

    def direction(t: NDArray[np.float64], p: NDArray[np.float64]) -> Any:
        st, ct = dr.sincos(mi.Float(np.asarray(t, dtype=np.float32)) * deg)
        sp, cp = dr.sincos(mi.Float(np.asarray(p, dtype=np.float32)) * deg)
        return mi.Vector3f(st * cp, st * sp, ct)

    wi, wo = direction(theta_v, phi_v), direction(theta_l, phi_l)
    si = dr.zeros(mi.SurfaceInteraction3f, dr.width(wi))
    si.wi = wi
    return bsdf.eval(mi.BSDFContext(), si, wo) / dr.maximum(wo.z, 1e-6), wi, wo


def check_plausible(path: Path, values: NDArray[np.floating], *, what: str = "values") -> None:
    """Refuse NaN or infinite ``values``, or any beyond :data:`MAX_PLAUSIBLE_BRDF` (one line naming the file).

    The one value check of every reader, applied to the values as the table
    will hold them (decoded, scaled to sr^-1), measured ones only.

    Raises
    ------
    FormatError
        ``"f.bin: holds values up to 1.6e+14, beyond 1e+05 (no measured BRDF reaches it): damaged, or not in
        sr^-1"``.
    """
    from ..errors import FormatError

    v = np.asarray(values)
    if not v.size:
        return
    bad = int(np.count_nonzero(~np.isfinite(v)))
    if bad:
        raise FormatError(f"{path}: {what} hold {bad} NaN or infinite value(s)")
    top = float(np.max(np.abs(v)))
    if top > MAX_PLAUSIBLE_BRDF:
        raise FormatError(f"{path}: {what} up to {top:.3g}, beyond {MAX_PLAUSIBLE_BRDF:.0e} (no measured BRDF reaches "
                          "it): damaged, or not in sr^-1")


def file_sha256(data: bytes) -> str:
    """SHA-256 of ``data`` as hex."""
    return hashlib.sha256(data).hexdigest()


def read_bytes(path: str | PathLike[str], *, what: str) -> tuple[Path, bytes]:
    """The bytes of a source file, with one-line errors naming it.

    Raises
    ------
    FileNotFoundError
        When ``path`` does not exist.
    FormatError
        When it is a folder, not a regular file (a FIFO, a device: refused
        before it is opened) or cannot be read.
    LimitError
        When it is larger than 8 bytes per value of the ``table_samples`` limit.
    """
    from .. import limits
    from ..errors import FormatError
    from ..fsutil import check_regular, read_regular

    p = Path(path)
    try:
        check_regular(p)  # a FIFO would block the read, /dev/zero never end it
    except FileNotFoundError:
        raise FileNotFoundError(f"{p}: no such file") from None
    except IsADirectoryError:
        raise FormatError(f"{p}: is a folder, not {what}") from None
    except OSError as exc:
        raise FormatError(f"{exc}; not {what}") from None
    cap = int(limits.limit("table_samples").value()) * 8
    try:
        size = p.stat().st_size
        limits.check("table_samples", size / 8.0, what=f"{p}: a file of {size} bytes")
        data = read_regular(p, max_bytes=cap)
    except OSError as exc:
        raise FormatError(f"{p}: cannot be read ({exc.strerror or exc})") from None
    limits.check("table_samples", len(data) / 8.0, what=f"{p}: a file of at least {len(data)} bytes")
    return p, data
