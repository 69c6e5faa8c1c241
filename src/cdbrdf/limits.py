"""Resource limits on untrusted input, from configuration.

A file or an option can ask for any amount of work or memory: a 20 KB HDF5
file may declare a 36 GiB dataset, an 800 KB PNG a 12000 x 12000 image.
cdbrdf checks such requests against the limits below *before* allocating, and
refuses with a :class:`~cdbrdf.errors.LimitError` that names the limit and the
environment variable that raises it.

Each limit is read from its environment variable at the moment it is checked
(no state is kept at import), so a user or a test raises it with e.g.
``CDBRDF_MAX_IMAGE_PIXELS=400000000 cdbrdf measure ...``.

=========================  ===============================  ==================
limit                      environment variable             default
=========================  ===============================  ==================
``image_pixels``           ``CDBRDF_MAX_IMAGE_PIXELS``      100,000,000 pixels
``table_samples``          ``CDBRDF_MAX_TABLE_SAMPLES``     500,000,000 values
``render_pixels``          ``CDBRDF_MAX_RENDER_PIXELS``     67,108,864 pixels
``capture_rows``           ``CDBRDF_MAX_CAPTURE_ROWS``      10,000,000 rows
``mesh_faces``             ``CDBRDF_MAX_MESH_FACES``        50,000,000 faces
``json_bytes``             ``CDBRDF_MAX_JSON_BYTES``        16,777,216 bytes
=========================  ===============================  ==================
"""

from __future__ import annotations

import os
from dataclasses import dataclass

from .errors import LimitError

__all__ = ["Limit", "LIMITS", "limit", "check"]


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
        """The limit in force now (the environment variable, else the default)."""
        raw = os.environ.get(self.env)
        if raw is None or not raw.strip():
            return self.default
        try:
            v = int(float(raw))
        except ValueError:
            raise LimitError(f"{self.env}={raw!r}: not a number") from None
        if v <= 0:
            raise LimitError(f"{self.env}={raw!r}: must be a positive number of {self.unit}")
        return v


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
