"""Measurement stands: their geometry, which directions they hide, and ``stands.json``.

A stand (``docs/capture.md``) carries the fabric on a cylindrical face whose
axis is the local y axis; x is the bending direction, z the normal at the
stand's centre (the measured point, at the origin).

- ``kappa > 0`` (convex): the fabric lies on the outside of a cylinder of
  radius ``R = 1/kappa``. The body lies entirely below the tangent plane at
  the centre, so it hides no direction above it.
- ``kappa = 0``: a flat face; nothing is hidden.
- ``kappa < 0`` (concave): the fabric lines a trough of radius ``R = 1/|kappa|``
  over an arc of length ``face_width_mm`` (half-angle ``alpha = w / 2R``,
  below 90 degrees), whose edges, at ``x_e = +-R sin(alpha)`` and height
  ``z_e = R (1 - cos(alpha))``, carry vertical white walls of height
  ``wall_height_mm``. The stand is long along y, so only the direction's
  projection on the x-z plane matters. The trough's profile is convex seen
  from the centre, so a direction ``(dx, dy, dz)`` is hidden (the ray from
  the centre meets the face or the wall) exactly when
  ``dz < |dx| (z_e + h) / x_e``: when its elevation in the x-z plane lies
  below the wall's top edge. Directions on the boundary count as visible.

The measurement averages an N x N patch, not a point: with the camera's
pixel size at the stand (``pixel_mm`` in ``stands.json``) the test is made
from the point of the face nearest to the wall the direction points to,
``margin = (N/2) sqrt(2) pixel_mm / cos(theta_v)`` from the centre
(:func:`footprint_mm`), so that no pixel of the patch sees the wall or lies
in its shadow.

A hidden *view* means the camera sees the trough or the white wall instead
of the centre; a hidden *light* means the centre is in shadow. Both make the
photograph useless for that sample (the white lines of the paper's Fig. 7b).

The stands are written to and read from the ``stands`` list of the capture
folder's ``stands.json`` (:func:`write_stands`, :func:`read_stands`,
:func:`parse_stands`); the file's other keys are capture settings, read by
:func:`cdbrdf.measure.capture.read_capture`. Both the planner
(:func:`cdbrdf.measure.plan.write_plan`) and the simulated rig
(:mod:`cdbrdf.rig`) take their geometry from here.
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import asdict, dataclass
from os import PathLike
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .. import limits
from ..errors import CaptureError, OptionError
from ..frames import direction_from_angles
from ..fsutil import atomic_path, read_regular
from ..table import Grid

__all__ = [
    "Stand",
    "default_stand",
    "stand_for",
    "hidden_mask",
    "footprint_mm",
    "load_json_object",
    "read_json_object",
    "json_number",
    "read_input",
    "parse_stands",
    "read_stands",
    "write_stands",
    "KAPPA_TOL_PER_MM",
    "DEFAULT_FACE_WIDTH_MM",
    "DEFAULT_WALL_HEIGHT_MM",
    "DEFAULT_LENGTH_MM",
]

DEFAULT_FACE_WIDTH_MM = 6.0
DEFAULT_WALL_HEIGHT_MM = 1.0
DEFAULT_LENGTH_MM = 40.0
#: Two curvatures (mm^-1) closer than this name the same stand.
KAPPA_TOL_PER_MM = 1e-9


@dataclass(frozen=True)
class Stand:
    """One measurement stand.

    Parameters
    ----------
    kappa
        Curvature of the face in mm^-1 (> 0 convex cylinder, < 0 concave trough).
    face_width_mm
        Arc length of the fabric face across the axis (x), mm.
    wall_height_mm
        Concave stands: height of the white walls above the face's edges, mm.
    length_mm
        Length along the axis (y), mm (used by the simulated rig; the
        occlusion test treats the stand as long).
    """

    kappa: float
    face_width_mm: float = DEFAULT_FACE_WIDTH_MM
    wall_height_mm: float = DEFAULT_WALL_HEIGHT_MM
    length_mm: float = DEFAULT_LENGTH_MM

    def __post_init__(self) -> None:
        for name in ("kappa", "face_width_mm", "wall_height_mm", "length_mm"):
            v = getattr(self, name)
            try:
                v = float(v)
            except (TypeError, ValueError):
                raise OptionError(f"stand {name}: expected a number, got {v!r}") from None
            if not math.isfinite(v):
                raise OptionError(f"stand {name}: must be finite, got {v!r}")
            object.__setattr__(self, name, v)
        if self.face_width_mm <= 0 or self.length_mm <= 0 or self.wall_height_mm < 0:
            raise OptionError(
                f"stand kappa={self.kappa:g}: face_width_mm and length_mm must be positive "
                "and wall_height_mm non-negative"
            )
        if self.kappa < 0 and self.half_angle_rad >= math.pi / 2:
            raise OptionError(
                f"stand kappa={self.kappa:g}: a face {self.face_width_mm:g} mm wide spans "
                f"{math.degrees(2 * self.half_angle_rad):.1f} degrees of the trough; it must "
                f"stay below 180 (face_width_mm < {math.pi * self.radius_mm:.3g})"
            )

    @property
    def radius_mm(self) -> float:
        """Radius of the face (``inf`` for a flat stand)."""
        return math.inf if self.kappa == 0 else 1.0 / abs(self.kappa)

    @property
    def half_angle_rad(self) -> float:
        """Half the angle the face spans on its cylinder (0 for a flat stand)."""
        return 0.0 if self.kappa == 0 else 0.5 * self.face_width_mm / self.radius_mm

    @property
    def edge_mm(self) -> tuple[float, float]:
        """``(x_e, z_e)``: the face's edge in the x-z plane (x_e > 0)."""
        if self.kappa == 0:
            return 0.5 * self.face_width_mm, 0.0
        r, a = self.radius_mm, self.half_angle_rad
        z = r * (1 - math.cos(a))
        return r * math.sin(a), (z if self.kappa < 0 else -z)

    def horizon_slope(self, margin_mm: float = 0.0) -> float:
        """``tan`` of the elevation (in the x-z plane) below which directions are hidden.

        Seen from the point of the face ``margin_mm`` (arc length) from the
        centre towards the wall the direction points to: the worst point of
        a patch that reaches ``margin_mm`` from the centre.

        Parameters
        ----------
        margin_mm
            Arc length from the centre, mm.

        Returns
        -------
        float
            The slope; 0 for stands that hide nothing (convex and flat),
            ``inf`` when the margin reaches the face's edge.
        """
        if self.kappa >= 0:
            return 0.0
        x_e, z_e = self.edge_mm
        r = self.radius_mm
        m = min(max(float(margin_mm), 0.0), 0.5 * self.face_width_mm)
        px, pz = r * math.sin(m / r), r * (1.0 - math.cos(m / r))
        if x_e - px <= 1e-12:
            return math.inf
        return (z_e + self.wall_height_mm - pz) / (x_e - px)

    def hides(self, theta_deg: ArrayLike, phi_deg: ArrayLike, *, margin_mm: float = 0.0) -> NDArray[np.bool_]:
        """Where a direction cannot reach the patch (see the module's description).

        Parameters
        ----------
        theta_deg, phi_deg
            Elevation and azimuth of the directions, degrees (broadcast).
        margin_mm
            The patch's half-extent on the face (0 = the centre only).

        Returns
        -------
        numpy.ndarray
            Boolean, True where the direction is hidden.
        """
        d = direction_from_angles(theta_deg, phi_deg)
        s = self.horizon_slope(margin_mm)
        if s == 0.0:
            return np.zeros(d.shape[:-1], dtype=bool)
        if math.isinf(s):
            return np.abs(d[..., 0]) > 1e-12
        return d[..., 2] < np.abs(d[..., 0]) * s - 1e-12

    def to_dict(self) -> dict[str, float]:
        """The stand as written to ``stands.json``.

        Returns
        -------
        dict
            Its dimensions by name.
        """
        return asdict(self)


def default_stand(kappa: float) -> Stand:
    """A stand of the given curvature with the default face width and wall height."""
    return Stand(kappa=float(kappa))


def stand_for(stands: Mapping[float, Stand] | Sequence[Stand], kappa: float) -> Stand:
    """The stand of curvature ``kappa`` (mm^-1, within :data:`KAPPA_TOL_PER_MM`).

    Raises
    ------
    ValueError
        When no stand has that curvature.
    """
    items = stands.values() if isinstance(stands, Mapping) else stands
    for s in items:
        if abs(s.kappa - kappa) <= KAPPA_TOL_PER_MM:
            return s
    raise OptionError(f"no stand is described for kappa = {kappa:g} 1/mm")


def footprint_mm(theta_v_deg: ArrayLike, *, pixel_mm: float, patch_px: int) -> NDArray[np.float64]:
    """Half-extent on the face of an N x N patch seen from elevation ``theta_v``.

    ``(N / 2) * sqrt(2) * pixel_mm / cos(theta_v)``: the half-diagonal of the
    patch (its orientation in the image is unknown), stretched by the
    foreshortening of an oblique view. ``pixel_mm`` is the size of one pixel
    at the stand's centre for a camera along the normal.
    """
    c = np.cos(np.radians(np.asarray(theta_v_deg, dtype=np.float64)))
    return 0.5 * patch_px * math.sqrt(2.0) * float(pixel_mm) / c


def hidden_mask(
    grid: Grid,
    stands: Mapping[float, Stand] | Sequence[Stand],
    *,
    pixel_mm: float = 0.0,
    patch_px: int = 7,
) -> NDArray[np.uint8]:
    """Which samples of a grid the stands hide from the camera or the light.

    With ``pixel_mm = 0`` only the centre point is tested. Otherwise a sample
    is hidden when the camera or the light cannot reach any point of the
    patch: the margin is :func:`footprint_mm` at the sample's view elevation.

    Parameters
    ----------
    grid
        The capture's grid.
    stands
        One stand per curvature of the grid (a mapping by curvature, or in
        the grid's order).
    pixel_mm
        Size of a camera pixel on the face, mm (0: the centre point only).
    patch_px
        The patch's side, pixels.

    Returns
    -------
    numpy.ndarray
        ``grid.shape`` uint8: 0 visible, 1 view hidden, 2 light hidden, 3 both.
    """
    out = np.zeros(grid.shape, dtype=np.uint8)
    for k, kappa in enumerate(grid.kappa):
        st = stand_for(stands, float(kappa))
        for j, tv in enumerate(grid.theta_v):
            m = float(footprint_mm(tv, pixel_mm=pixel_mm, patch_px=patch_px)) if pixel_mm else 0.0
            view = st.hides(tv, grid.phi_v, margin_mm=m)  # (n_phi_v,)
            light = st.hides(grid.theta_l[None, :], grid.phi_l[:, None], margin_mm=m)  # (n_phi_l, n_theta_l)
            out[k, :, :, :, j] = view[None, None, :].astype(np.uint8) + 2 * light[:, :, None].astype(np.uint8)
    return out


# --------------------------------------------------------------------------- stands.json
def load_json_object(path: str | PathLike[str]) -> dict[str, Any]:
    """Read a small JSON object file (``stands.json``) defensively.

    The file must be a regular file (a FIFO or a device such as
    ``/dev/zero`` is refused before it is opened, so reading neither blocks
    nor runs without end) and is read with a bounded read: at most the
    ``json_bytes`` limit plus one byte, a larger file being refused. Bytes
    that are not UTF-8, invalid JSON, nesting too deep for the parser,
    integers too long to convert and a top level that is not an object are
    refused.

    Raises
    ------
    CaptureError
        One line naming the file and the problem.
    LimitError
        When the file is larger than the ``json_bytes`` limit.
    """
    return read_json_object(path)[0]


def read_json_object(path: str | PathLike[str]) -> tuple[dict[str, Any], bytes]:
    """:func:`load_json_object` and the bytes it parsed (read once)."""
    p = Path(path)
    raw = read_input(p, "json_bytes", what=f"{p}: JSON file")
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = raw[: exc.start].count(b"\n") + 1
        raise CaptureError(f"{p}: line {line}: not UTF-8 text (byte 0x{raw[exc.start]:02x})") from None
    try:
        doc = json.loads(text, parse_constant=_reject_constant)
    except json.JSONDecodeError as exc:
        raise CaptureError(f"{p}: line {exc.lineno}: not valid JSON ({exc.msg})") from None
    except RecursionError:
        raise CaptureError(f"{p}: not valid JSON (nested too deeply)") from None
    except ValueError as exc:  # NaN/Infinity literals, integers too long to convert
        raise CaptureError(f"{p}: not valid JSON ({str(exc).splitlines()[0]})") from None
    if not isinstance(doc, dict):
        raise CaptureError(f"{p}: expected a JSON object, got {type(doc).__name__}")
    return doc, raw


def read_input(path: str | PathLike[str], limit_name: str, *, what: str) -> bytes:
    """The bytes of a small input file of the capture folder (``stands.json``, ``capture.csv``).

    The file must be a regular file (:func:`cdbrdf.fsutil.read_regular`: a
    FIFO or a device is refused before it is opened) and is read with a
    bounded read of at most the limit ``limit_name`` (bytes) plus one.

    Raises
    ------
    CaptureError
        When it is not a regular file or cannot be read (names the file).
    LimitError
        When it is larger than the limit.
    """
    p = Path(path)
    cap = limits.limit(limit_name).value()
    try:
        raw = read_regular(p, max_bytes=cap)
        size = len(raw) if len(raw) <= cap else max(len(raw), p.stat().st_size)
    except OSError as exc:  # not a regular file (no strerror: the message says what it is), unreadable
        why = f"cannot be read ({exc.strerror})" if exc.strerror else str(exc).removeprefix(f"{p}: ")
        raise CaptureError(f"{p}: {why}") from None
    limits.check(limit_name, size, what=what)
    return raw


def _reject_constant(name: str) -> float:
    raise OptionError(f"{name} is not a number JSON allows")


def json_number(where: str | PathLike[str], key: str, v: object) -> float:
    """A finite JSON number (not a boolean; an integer too big for a float is out of range), else a CaptureError."""
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise CaptureError(f"{where}: {key}: expected a number, got {_short(v)}")
    try:
        f = float(v)
    except OverflowError:
        raise CaptureError(f"{where}: {key}: {_short(v)} is out of range") from None
    if not math.isfinite(f):
        raise CaptureError(f"{where}: {key}: must be finite, got {_short(v)}")
    return f


def _short(v: object) -> str:
    r = repr(v)
    return r if len(r) <= 40 else r[:37] + "..."


def parse_stands(doc: Mapping[str, Any], where: str | PathLike[str]) -> dict[float, Stand]:
    """The ``stands`` list of a parsed ``stands.json``, by curvature.

    Parameters
    ----------
    doc
        The file's top-level object.
    where
        The file, for messages.

    Raises
    ------
    CaptureError
        When ``stands`` is not a non-empty list of stand objects, a key is
        unknown, a value is not a finite number (booleans, NaN and strings
        are refused), a stand is impossible (zero or negative width or
        length, negative wall, a trough spanning 180 degrees or more) or two
        stands share a curvature. The message names the file and the stand.
    """
    items = doc.get("stands")
    if not isinstance(items, list) or not items:
        raise CaptureError(f"{where}: expected an object with a non-empty list 'stands'")
    out: dict[float, Stand] = {}
    fields = ("kappa", "face_width_mm", "wall_height_mm", "length_mm")
    for i, item in enumerate(items):
        if not isinstance(item, dict) or "kappa" not in item:
            raise CaptureError(f"{where}: stand {i} must be an object with at least 'kappa'")
        unknown = set(item) - set(fields)
        if unknown:
            raise CaptureError(
                f"{where}: stand {i} has unknown keys {sorted(unknown)}; valid: {sorted(fields)}"
            )
        vals = {k: json_number(where, f"stand {i} {k}", item[k]) for k in fields if k in item}
        try:
            st = Stand(**vals)
        except ValueError as exc:
            raise CaptureError(f"{where}: stand {i}: {exc}") from None
        if any(abs(st.kappa - k) <= KAPPA_TOL_PER_MM for k in out):
            raise CaptureError(f"{where}: stand {i}: a second stand for kappa {st.kappa:g}")
        out[st.kappa] = st
    return out


def read_stands(path: str | PathLike[str]) -> dict[float, Stand]:
    """Read a stand file; returns the stands by curvature.

    Raises
    ------
    CaptureError
        (a :class:`ValueError`) when the file is not valid JSON or a stand is
        malformed; one line naming the file (:func:`parse_stands`).
    LimitError
        When the file is larger than the ``json_bytes`` limit.
    """
    p = Path(path)
    return parse_stands(load_json_object(p), p)


def write_stands(path: str | PathLike[str], stands: Iterable[Stand], **extra: Any) -> None:
    """Write ``stands.json``: ``{"stands": [...], ...extra}`` (atomically: :func:`cdbrdf.fsutil.atomic_path`)."""
    doc = {"stands": [s.to_dict() for s in stands], **extra}
    with atomic_path(path) as tmp:
        tmp.write_text(json.dumps(doc, indent=2) + "\n", encoding="utf-8")
