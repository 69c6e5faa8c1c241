"""Resource limits on untrusted input, from configuration.

A file or an option can ask for any amount of work or memory: a 20 KB HDF5
file may declare a 36 GiB dataset, an 800 KB PNG a 12000 x 12000 image.
cdbrdf checks such requests against the limits below *before* allocating, and
refuses with a :class:`~cdbrdf.errors.LimitError` that names the limit and the
environment variable that raises it.

Each limit is read from its environment variable at the moment it is checked
(no state is kept at import), so a user or a test raises it with e.g.
``CDBRDF_MAX_IMAGE_PIXELS=400000000 cdbrdf measure ...``. A variable must
hold a whole number in decimal digits (:meth:`Limit.value`); the command
line checks every variable before any work (:func:`check_environment`).

=========================  ===============================  ==================
limit                      environment variable             default
=========================  ===============================  ==================
``image_pixels``           ``CDBRDF_MAX_IMAGE_PIXELS``      100,000,000 pixels
``table_samples``          ``CDBRDF_MAX_TABLE_SAMPLES``     500,000,000 values
``render_pixels``          ``CDBRDF_MAX_RENDER_PIXELS``     67,108,864 pixels
``capture_rows``           ``CDBRDF_MAX_CAPTURE_ROWS``      10,000,000 rows
``mesh_faces``             ``CDBRDF_MAX_MESH_FACES``        50,000,000 faces
``json_bytes``             ``CDBRDF_MAX_JSON_BYTES``        16,777,216 bytes
``csv_bytes``              ``CDBRDF_MAX_CSV_BYTES``         2,147,483,648 bytes
=========================  ===============================  ==================

One bound is fixed: :data:`MAX_SPP`, the samples per pixel of one render.
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass

from .errors import LimitError

__all__ = ["Limit", "LIMITS", "MAX_VALUE", "MAX_SPP", "limit", "check", "check_environment"]

#: Most samples per pixel of one render (``--spp``, a scene's sampler, ``-D spp=...``): 65,536 spp of a
#: 512 x 384 image already take hours on a CPU; more is a typo, never a useful render.
MAX_SPP = 65536


@dataclass(frozen=True)
class Limit:
    """One configurable limit.

    Attributes
    ----------
    name
        Registry key, e.g. ``"image_pixels"``.
    env
        Environment variable that overrides ``default``.
    default
        Value used when the variable is unset.
    unit
        What is counted, for messages (``"pixels"``, ``"values"``...).
    """

    name: str
    env: str
    default: int
    unit: str

    def value(self) -> int:
        """The limit in force now (the environment variable, else the default).

        The variable must hold a whole number of the limit's unit, written
        in decimal digits (``1000000``; ``1_000_000`` is accepted too), from 1
        to :data:`MAX_VALUE`. Anything else (``inf``, ``1e400``, ``-5``,
        ``abc``, ``1.5``) is refused with a :class:`LimitError` naming the
        variable, never read as some other limit.
        """
        raw = os.environ.get(self.env)
        if raw is None or not raw.strip():
            return self.default
        text = raw.strip()
        if len(text) > 40 or not _DIGITS.fullmatch(text) or not 1 <= (v := int(text.replace("_", ""))) <= MAX_VALUE:
            raise LimitError(
                f"{self.env}={raw[:40]!r}: expected a whole number of {self.unit} from 1 to "
                f"{MAX_VALUE:,} in decimal digits (e.g. {self.default}), or unset it for the default"
            )
        return v


#: Largest value a limit variable may hold (the largest int64: counts stay exact in NumPy).
MAX_VALUE = 2**63 - 1
_DIGITS = re.compile(r"[0-9]+(?:_[0-9]+)*")


#: Every limit, by name.
LIMITS: dict[str, Limit] = {
    lim.name: lim
    for lim in (
        Limit("image_pixels", "CDBRDF_MAX_IMAGE_PIXELS", 100_000_000, "pixels"),
        Limit("table_samples", "CDBRDF_MAX_TABLE_SAMPLES", 500_000_000, "values"),
        Limit("render_pixels", "CDBRDF_MAX_RENDER_PIXELS", 8192 * 8192, "pixels"),
        Limit("capture_rows", "CDBRDF_MAX_CAPTURE_ROWS", 10_000_000, "rows"),
        Limit("mesh_faces", "CDBRDF_MAX_MESH_FACES", 50_000_000, "faces"),
        Limit("json_bytes", "CDBRDF_MAX_JSON_BYTES", 16 * 1024 * 1024, "bytes"),
        Limit("csv_bytes", "CDBRDF_MAX_CSV_BYTES", 2 * 1024**3, "bytes"),
    )
}


def limit(name: str) -> Limit:
    """The limit called ``name``; :class:`LimitError` listing the valid names otherwise."""
    try:
        return LIMITS[name]
    except KeyError:
        raise LimitError(f"limit {name!r}: unknown; valid limits are {', '.join(LIMITS)}") from None


def check(name: str, amount: int | float, *, what: str) -> None:
    """Refuse ``amount`` when it exceeds the limit ``name``.

    Parameters
    ----------
    name
        A key of :data:`LIMITS`.
    amount
        What the input asks for, in the limit's unit.
    what
        The thing at fault, for the message (e.g. ``"photo.png: 12000 x 12000 image"``).

    Raises
    ------
    LimitError
        ``"<what>: 144,000,000 pixels exceed the limit of 100,000,000
        (raise it with CDBRDF_MAX_IMAGE_PIXELS)"``.
    """
    lim = limit(name)
    cap = lim.value()
    if not amount <= cap:  # also refuses NaN
        raise LimitError(
            f"{what}: {amount:,.0f} {lim.unit} exceed the limit of {cap:,} "
            f"(raise it with {lim.env})"
        )


def check_environment() -> None:
    """Refuse, before any work, a limit variable that is set to something :meth:`Limit.value` refuses.

    The command line calls it first, so that a bad ``CDBRDF_MAX_*`` value is
    one line naming the variable, not a failure of whichever file is read
    first.

    Raises
    ------
    LimitError
        Naming the first bad variable and what it may hold.
    """
    for lim in LIMITS.values():
        lim.value()
