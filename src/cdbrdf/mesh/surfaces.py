"""The analytic surfaces the package renders, with their sizes defined here once, in millimetres.

:class:`SineSheet` / :func:`sine_sheet_mesh` is the paper's test surface
(Figs. 9-10): ``z = A sin(2 pi x / L)`` swept along y. The bending direction
is x, which is also the direction of the UV coordinate u (so the material
frame's x follows the bending, as on the measurement stands). Its curvature
is analytic (:func:`sine_sheet_curvature`) and stored per vertex.

:func:`draped_cloth_mesh` is a square cloth draped over a round object: a
smooth convex dome in the middle and radial folds, alternately convex ridges
and concave valleys, growing towards the hem. It exercises both signs of
curvature over the range of the paper's stands (|kappa| up to about
0.2 mm^-1) on one surface, with a planar UV map (u along x, v along y), so
the material's reference tangent x is the same everywhere seen from above.

:func:`skirt_mesh` is a garment as a fashion CAD tool exports it: Y-up, in
millimetres, two panels (front and back) sewn along the side seams with
*opposite* winding (each panel wound as it was drawn), vertical folds growing
towards the hem, one UV chart per panel (u around the body, across the
folds), and a sash hanging at the front that is a *double-sided* panel: the
same triangles twice, once with each winding.

:class:`Swatch` / :func:`swatch_mesh` is a cloth swatch laid in folds of
known radii (20, 10, 5 and 3 mm by default), each fold made of circular arcs
so that its curvature is exact (:func:`swatch_curvature`), convex on the
crests and concave at the feet: a material's look at every bend radius on
one picture (``cdbrdf render --scene swatch``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import OptionError
from ..ranges import Range
from .attributes import CURVATURE_MODES
from .core import Mesh

__all__ = ["SineSheet", "SHEET_RANGES_MM", "sine_sheet_mesh", "sine_sheet_height", "sine_sheet_curvature",
           "DrapedCloth", "draped_cloth_height", "draped_cloth_mesh", "Skirt", "skirt_mesh", "Swatch", "swatch_mesh",
           "swatch_curvature", "SWATCH_MIN_RADIUS_MM", "SWATCH_MAX_RADIUS_MM", "SWATCH_MAX_FOLDS"]


#: Accepted lengths of a :class:`SineSheet`, mm.
SHEET_RANGES_MM: dict[str, Range] = {
    "amplitude_mm": Range(0.0, 1000.0, lo_open=True, unit="mm"),
    "wavelength_mm": Range(0.01, 1e5, unit="mm"),
    "width_mm": Range(0.0, 1e5, lo_open=True, unit="mm"),
    "depth_mm": Range(0.0, 1e5, lo_open=True, unit="mm"),
}


def _both_modes(kappa: NDArray[np.float64]) -> dict[str, NDArray[np.float64]]:
    """The attributes of a surface whose x is a principal direction: both curvature modes are ``kappa``."""
    return {m.attribute: kappa.copy() if i else kappa for i, m in enumerate(CURVATURE_MODES.values())}


def sine_sheet_height(x_mm: ArrayLike, *, amplitude_mm: float, wavelength_mm: float) -> NDArray[np.float64]:
    """Height ``z = A sin(2 pi x / L)`` of the sine sheet.

    Parameters
    ----------
    x_mm
        Positions across the sheet, mm.
    amplitude_mm, wavelength_mm
        ``A`` and ``L``, mm.

    Returns
    -------
    numpy.ndarray
        Heights, mm.
    """
    x = np.asarray(x_mm, dtype=np.float64)
    return amplitude_mm * np.sin(2.0 * np.pi * x / wavelength_mm)


def sine_sheet_curvature(x_mm: ArrayLike, *, amplitude_mm: float, wavelength_mm: float) -> NDArray[np.float64]:
    """Signed curvature (mm^-1) of the sine sheet seen from +z.

    For ``z = A sin(k x)``, ``k = 2 pi / L``, with the normal towards +z the
    curvature across the sheet is ``-z'' / (1 + z'^2)^(3/2)`` (> 0 at crests,
    convex; < 0 in troughs); along the sweep it is 0, so this is also the
    principal curvature of larger magnitude.

    Parameters
    ----------
    x_mm
        Positions across the sheet, mm.
    amplitude_mm, wavelength_mm
        ``A`` and ``L``, mm.

    Returns
    -------
    numpy.ndarray
        Curvatures, mm^-1.
    """
    x = np.asarray(x_mm, dtype=np.float64)
    k = 2.0 * np.pi / wavelength_mm
    d1 = amplitude_mm * k * np.cos(k * x)
    d2 = -amplitude_mm * k * k * np.sin(k * x)
    return -d2 / (1.0 + d1 * d1) ** 1.5


@dataclass(frozen=True)
class SineSheet:
    """Geometry of the sine sheet (mm).

    Parameters
    ----------
    amplitude_mm, wavelength_mm
        ``z = amplitude sin(2 pi x / wavelength)``; the crest curvature is
        ``amplitude (2 pi / wavelength)^2`` (0.197 mm^-1 by default, inside
        the paper's +-0.22 mm^-1).
    width_mm, depth_mm
        Extent across (x) and along (y) the sweep, centred on the origin.
    vertices_per_wavelength
        Tessellation across; along y the sheet is tessellated to keep
        triangles near-square.
    """

    amplitude_mm: float = 2.0
    wavelength_mm: float = 20.0
    width_mm: float = 60.0
    depth_mm: float = 60.0
    vertices_per_wavelength: int = 64

    def __post_init__(self) -> None:
        for name, rng in SHEET_RANGES_MM.items():
            object.__setattr__(self, name, rng.check(name, getattr(self, name)))
        if self.vertices_per_wavelength < 8:
            raise OptionError("vertices_per_wavelength: at least 8 are needed")

    @property
    def crest_curvature_mm(self) -> float:
        """Curvature at a crest (mm^-1)."""
        return self.amplitude_mm * (2 * math.pi / self.wavelength_mm) ** 2

    @property
    def grid_shape(self) -> tuple[int, int]:
        """Vertices across (x) and along (y) the sweep of :func:`sine_sheet_mesh`."""
        nx = max(2, int(round(self.width_mm / self.wavelength_mm * self.vertices_per_wavelength)) + 1)
        dx = self.width_mm / (nx - 1)
        ny = max(2, int(round(self.depth_mm / dx)) + 1)
        return nx, min(ny, 4 * nx)

    @property
    def face_count(self) -> int:
        """Triangles of :func:`sine_sheet_mesh` (known before the mesh is built, for the size limits)."""
        nx, ny = self.grid_shape
        return 2 * (nx - 1) * (ny - 1)


def sine_sheet_mesh(sheet: SineSheet = SineSheet()) -> Mesh:
    """The sine sheet as a mesh with UVs, analytic normals and curvature.

    The mesh's attributes ``"curvature"`` and ``"curvature_dir"`` hold the
    analytic signed curvature (mm^-1) of every vertex (x, the bending
    direction, is a principal direction, so both modes agree); faces wind
    counter-clockwise seen from +z.

    Parameters
    ----------
    sheet
        The sheet's geometry.

    Returns
    -------
    Mesh
        The mesh, in mm, z up.
    """
    nx, ny = sheet.grid_shape
    x = np.linspace(-sheet.width_mm / 2, sheet.width_mm / 2, nx)
    y = np.linspace(-sheet.depth_mm / 2, sheet.depth_mm / 2, ny)
    X, Y = np.meshgrid(x, y, indexing="ij")
    A, L = sheet.amplitude_mm, sheet.wavelength_mm
    Z = sine_sheet_height(X, amplitude_mm=A, wavelength_mm=L)
    V = np.stack([X.ravel(), Y.ravel(), Z.ravel()], axis=1)
    dz = A * 2 * np.pi / L * np.cos(2 * np.pi * X.ravel() / L)
    N = np.stack([-dz, np.zeros_like(dz), np.ones_like(dz)], axis=1)
    N /= np.linalg.norm(N, axis=1, keepdims=True)
    U = np.stack([(X.ravel() + sheet.width_mm / 2) / sheet.width_mm,
                  (Y.ravel() + sheet.depth_mm / 2) / sheet.depth_mm], axis=1)
    i, j = np.meshgrid(np.arange(nx - 1), np.arange(ny - 1), indexing="ij")
    a = (i * ny + j).ravel()
    b = a + ny  # +x
    c = b + 1   # +x +y
    d = a + 1   # +y
    F = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])
    k = sine_sheet_curvature(X.ravel(), amplitude_mm=A, wavelength_mm=L)
    # x (= dP/du) is the bending direction, a principal direction: the directional curvature is kappa
    return Mesh(V, F.astype(np.int64), N, U, _both_modes(k),
                metadata={"units": "mm", "up": "z", "curvature_units": "1/mm", "frame": "uv"})


@dataclass(frozen=True)
class DrapedCloth:
    """Parameters of :func:`draped_cloth_mesh` (lengths in mm).

    Attributes
    ----------
    size_mm
        Side of the square cloth seen from above.
    height_mm
        Height of the dome under the cloth.
    sigma_mm
        Radius (Gaussian sigma) of the dome.
    folds
        Number of radial folds around the dome.
    fold_amplitude_mm
        Amplitude of the folds far from the dome.
    resolution
        Vertices along each side.
    """

    size_mm: float = 100.0
    height_mm: float = 22.0
    sigma_mm: float = 17.0
    folds: int = 8
    fold_amplitude_mm: float = 5.0
    resolution: int = 161

    def __post_init__(self) -> None:
        for name in ("size_mm", "height_mm", "sigma_mm", "fold_amplitude_mm"):
            v = getattr(self, name)
            if not (np.isfinite(v) and v > 0):
                raise OptionError(f"{name}: must be a positive length in mm, got {v!r}")
        if int(self.folds) != self.folds or self.folds < 1:
            raise OptionError(f"folds: must be a positive integer, got {self.folds!r}")
        if int(self.resolution) != self.resolution or self.resolution < 8:
            raise OptionError(f"resolution: must be an integer >= 8, got {self.resolution!r}")


def draped_cloth_height(x_mm: ArrayLike, y_mm: ArrayLike, cloth: DrapedCloth = DrapedCloth()) -> NDArray[np.float64]:
    """Height of the draped cloth.

    Parameters
    ----------
    x_mm, y_mm
        Positions seen from above, mm (broadcast).
    cloth
        The cloth's parameters.

    Returns
    -------
    numpy.ndarray
        Heights, mm.
    """
    x = np.asarray(x_mm, dtype=np.float64)
    y = np.asarray(y_mm, dtype=np.float64)
    r2 = x * x + y * y
    g = np.exp(-r2 / (2.0 * cloth.sigma_mm**2))
    theta = np.arctan2(y, x)
    # the folds grow from nothing on the dome to full amplitude at the hem
    grow = (1.0 - g) ** 2
    return cloth.height_mm * g + cloth.fold_amplitude_mm * grow * np.sin(cloth.folds * theta)


def draped_cloth_mesh(cloth: DrapedCloth = DrapedCloth()) -> Mesh:
    """The draped cloth as a triangle mesh with UVs and vertex normals.

    Faces wind counter-clockwise seen from above (+z): the outward normal
    points up, so the dome is convex (kappa > 0) and the fold valleys are
    concave (kappa < 0). Curvature is not stored: the renderer computes it
    from the mesh (:func:`cdbrdf.mesh.max_curvature`), as for a user's
    mesh.

    Parameters
    ----------
    cloth
        The cloth's parameters.

    Returns
    -------
    Mesh
        The mesh, in mm, z up.
    """
    n = int(cloth.resolution)
    s = cloth.size_mm
    x = np.linspace(-s / 2, s / 2, n)
    X, Y = np.meshgrid(x, x, indexing="ij")
    Z = draped_cloth_height(X, Y, cloth)
    h = x[1] - x[0]
    dzdx, dzdy = np.gradient(Z, h, h)
    N = np.stack([-dzdx, -dzdy, np.ones_like(Z)], axis=-1)
    N /= np.linalg.norm(N, axis=-1, keepdims=True)
    V = np.stack([X, Y, Z], axis=-1).reshape(-1, 3)
    U = np.stack([(X + s / 2) / s, (Y + s / 2) / s], axis=-1).reshape(-1, 2)
    i, j = np.meshgrid(np.arange(n - 1), np.arange(n - 1), indexing="ij")
    a = (i * n + j).ravel()
    b = a + n  # +x
    c = b + 1  # +x +y
    d = a + 1  # +y
    F = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)]).astype(np.int64)
    return Mesh(V, F, N.reshape(-1, 3), U, {}, metadata={"units": "mm", "up": "z"})


@dataclass(frozen=True)
class Skirt:
    """Parameters of :func:`skirt_mesh` (lengths in mm).

    Attributes
    ----------
    length_mm
        Height from the hem (y = 0) to the waist.
    waist_radius_mm, hem_radius_mm
        Radius of the body at the waist and at the hem (a flared cone between).
    folds
        Number of vertical folds around the body.
    fold_amplitude_mm
        Radial amplitude of the folds at the hem (0 at the waist).
    sash
        Whether to add the double-sided sash at the front.
    around, down
        Vertices around each panel and from the waist to the hem.
    """

    length_mm: float = 560.0
    waist_radius_mm: float = 130.0
    hem_radius_mm: float = 300.0
    folds: int = 22
    fold_amplitude_mm: float = 22.0
    sash: bool = True
    around: int = 161
    down: int = 121

    def __post_init__(self) -> None:
        for name in ("length_mm", "waist_radius_mm", "hem_radius_mm"):
            v = getattr(self, name)
            if not (np.isfinite(v) and v > 0):
                raise OptionError(f"{name}: must be a positive length in mm, got {v!r}")
        if not (np.isfinite(self.fold_amplitude_mm) and 0 <= self.fold_amplitude_mm < self.waist_radius_mm):
            raise OptionError(f"fold_amplitude_mm: must be in [0, waist_radius_mm), got {self.fold_amplitude_mm!r}")
        if int(self.folds) != self.folds or self.folds < 0:
            raise OptionError(f"folds: must be an integer >= 0, got {self.folds!r}")
        for name in ("around", "down"):
            v = getattr(self, name)
            if int(v) != v or v < 4:
                raise OptionError(f"{name}: must be an integer >= 4, got {v!r}")


def _skirt_radius(theta: NDArray[np.float64], y: NDArray[np.float64], sk: Skirt) -> NDArray[np.float64]:
    t = 1.0 - y / sk.length_mm  # 0 at the waist, 1 at the hem
    r = sk.waist_radius_mm + (sk.hem_radius_mm - sk.waist_radius_mm) * t
    return r + sk.fold_amplitude_mm * t**1.5 * np.cos(sk.folds * theta)


def _grid_faces(n_a: int, n_d: int, offset: int, outward: bool) -> NDArray[np.int64]:
    i, j = np.meshgrid(np.arange(n_a - 1), np.arange(n_d - 1), indexing="ij")
    a = (i * n_d + j).ravel() + offset
    b = a + n_d  # next around
    c = b + 1  # next around, next down
    d = a + 1  # next down
    f = np.concatenate([np.stack([a, c, b], 1), np.stack([a, d, c], 1)]).astype(np.int64)
    return f if outward else f[:, ::-1]


def skirt_mesh(skirt: Skirt = Skirt()) -> Mesh:
    """The skirt of :class:`Skirt` as a mesh with per-panel UVs (see the module's description).

    Vertices are Y-up in mm (the body's axis is y; the front faces +z); the
    front panel winds counter-clockwise seen from outside, the back panel
    the other way; the sash's two layers share positions and have their
    own vertices, UVs and opposite windings. No normals are given (as in
    many exports): which side is the front follows from the repair.

    Parameters
    ----------
    skirt
        The skirt's parameters.

    Returns
    -------
    Mesh
        The mesh, in mm, y up.
    """
    sk = skirt
    y = np.linspace(sk.length_mm, 0.0, sk.down)
    parts_v, parts_uv, parts_f = [], [], []
    offset = 0
    for k, (t0, t1) in enumerate(((-np.pi / 2, np.pi / 2), (np.pi / 2, 3 * np.pi / 2))):
        th = np.linspace(t0, t1, sk.around)
        T, Y = np.meshgrid(th, y, indexing="ij")
        R = _skirt_radius(T, Y, sk)
        V = np.stack([R * np.sin(T), Y, R * np.cos(T)], axis=-1).reshape(-1, 3)
        U = np.stack([(T - t0) / (t1 - t0), Y / sk.length_mm], axis=-1).reshape(-1, 2)
        parts_v.append(V)
        parts_uv.append(U)
        parts_f.append(_grid_faces(sk.around, sk.down, offset, outward=(k == 0)))
        offset += V.shape[0]
    if sk.sash:
        n_a, n_d = 13, 61
        th = np.linspace(-0.12, 0.12, n_a)
        ys = np.linspace(sk.length_mm - 15.0, 0.55 * sk.length_mm, n_d)
        T, Y = np.meshgrid(th, ys, indexing="ij")
        R = _skirt_radius(T, Y, sk) + 12.0 + 4.0 * np.sin(np.pi * (sk.length_mm - Y) / (0.45 * sk.length_mm))
        V = np.stack([R * np.sin(T), Y, R * np.cos(T)], axis=-1).reshape(-1, 3)
        U = np.stack([(T - th[0]) / (th[-1] - th[0]), (Y - ys[-1]) / (ys[0] - ys[-1])], axis=-1).reshape(-1, 2)
        for outward in (True, False):
            parts_v.append(V)
            parts_uv.append(U)
            parts_f.append(_grid_faces(n_a, n_d, offset, outward=outward))
            offset += V.shape[0]
    return Mesh(np.concatenate(parts_v), np.concatenate(parts_f), None, np.concatenate(parts_uv), {},
                metadata={"units": "mm", "up": "y", "format": "obj"})


# -- the swatch: folds of known radii --------------------------------------------------------
#: Radii a swatch's fold may have, mm.
SWATCH_MIN_RADIUS_MM = 0.5
SWATCH_MAX_RADIUS_MM = 1000.0
#: Most folds on one swatch.
SWATCH_MAX_FOLDS = 32


@dataclass(frozen=True)
class Swatch:
    """A cloth swatch laid in folds of known radii (lengths in mm); see :func:`swatch_mesh`.

    Its profile across the folds (x) is made of circular arcs and straight
    pieces joined without a kink, swept along y. Each fold, left to right
    in the order of ``radii_mm``, rises from the flat cloth, turns over and
    comes back down, every arc of the fold's radius: a **ridge** (a
    positive radius) has a convex crest (kappa = +1/R, turning through twice
    the slope) between two concave feet (kappa = -1/R, each through the
    slope); a **groove** (a negative radius) is the ridge upside down. Every
    fold turns through the same angles, so under a plain BRDF each shows
    the same colours (over a width in proportion to its radius) and what
    differs from fold to fold is the curvature's doing. Flat cloth
    (kappa = 0) lies between the folds and at both ends.

    Attributes
    ----------
    radii_mm
        Signed radius of each fold (ridge > 0, groove < 0), at least
        :data:`SWATCH_MIN_RADIUS_MM` in magnitude. The default spans 20 mm
        (kappa 0.05 mm^-1) to 3 mm (0.33 mm^-1, beyond the paper's
        +-0.22 mm^-1: clamped to it, as the lookup rule says).
    slope_deg
        Steepest slope of every fold, degrees in (0, 80].
    flank_mm
        Straight piece on each flank, between a foot and the crest.
    gap_mm
        Flat cloth between two folds and at both ends.
    depth_mm
        Length along the folds (y).
    step_mm
        Largest spacing of the vertices across the folds (every arc gets at
        least 8 segments).
    row_mm
        Spacing of the vertices along the folds, where the cloth is straight.
    """

    radii_mm: tuple[float, ...] = (20.0, 10.0, 5.0, 3.0)
    slope_deg: float = 35.0
    flank_mm: float = 2.0
    gap_mm: float = 6.0
    depth_mm: float = 80.0
    step_mm: float = 0.25
    row_mm: float = 1.0

    def __post_init__(self) -> None:
        try:
            if isinstance(self.radii_mm, (str, bytes)):
                raise TypeError
            radii = tuple(float(r) for r in self.radii_mm)
        except (TypeError, ValueError):
            raise OptionError(f"radii_mm: expected signed radii in mm, got {self.radii_mm!r:.60}") from None
        if not radii or len(radii) > SWATCH_MAX_FOLDS:
            raise OptionError(f"radii_mm: give 1 to {SWATCH_MAX_FOLDS} folds, got {len(radii)}")
        for r in radii:
            if not (math.isfinite(r) and SWATCH_MIN_RADIUS_MM <= abs(r) <= SWATCH_MAX_RADIUS_MM):
                raise OptionError(f"radii_mm: {r:g} mm is not a radius between {SWATCH_MIN_RADIUS_MM:g} and "
                                  f"{SWATCH_MAX_RADIUS_MM:g} mm in magnitude (> 0 ridge, < 0 groove)")
        object.__setattr__(self, "radii_mm", radii)
        if not (math.isfinite(self.slope_deg) and 0.0 < self.slope_deg <= 80.0):
            raise OptionError(f"slope_deg: expected (0, 80] degrees, got {self.slope_deg!r}")
        for name, positive in (("flank_mm", False), ("gap_mm", False), ("depth_mm", True), ("step_mm", True),
                               ("row_mm", True)):
            v = getattr(self, name)
            if not (math.isfinite(v) and (v > 0 if positive else v >= 0)):
                raise OptionError(f"{name}: must be a {'positive' if positive else 'non-negative'} length in mm, "
                                  f"got {v!r}")

    @property
    def width_mm(self) -> float:
        """Extent across the folds (x), mm."""
        return float(sum(_piece_width(*p) for p in _swatch_pieces(self)))

    @property
    def length_mm(self) -> float:
        """Length of the cloth across the folds (its profile's arc length: u spans it), mm."""
        return float(sum(length for _, length, _ in _swatch_pieces(self)))

    @property
    def grid_shape(self) -> tuple[int, int]:
        """Vertices across (x) and along (y) the folds of :func:`swatch_mesh`."""
        across = 1 + sum(_piece_segments(self, c, length) for c, length, _ in _swatch_pieces(self))
        return across, max(2, int(math.ceil(self.depth_mm / self.row_mm)) + 1)

    @property
    def face_count(self) -> int:
        """Triangles of :func:`swatch_mesh`."""
        nx, ny = self.grid_shape
        return 2 * (nx - 1) * (ny - 1)


def _swatch_pieces(sw: Swatch) -> list[tuple[float, float, float]]:
    """The profile's pieces: ``(dpsi/ds in mm^-1, length mm, heading at the start rad)``, left to right.

    ``dpsi/ds > 0`` turns counter-clockwise seen from -y (up, concave with
    the normal up); the curvature (convex > 0) is its negative.
    """
    a = math.radians(sw.slope_deg)
    out: list[tuple[float, float, float]] = [(0.0, sw.gap_mm, 0.0)]
    for r in sw.radii_mm:
        c = 1.0 / r  # a ridge (r > 0) first turns up: concave foot
        up = math.copysign(a, r)
        out += [(c, a * abs(r), 0.0), (0.0, sw.flank_mm, up), (-c, 2 * a * abs(r), up),
                (0.0, sw.flank_mm, -up), (c, a * abs(r), -up), (0.0, sw.gap_mm, 0.0)]
    return [p for p in out if p[1] > 0]


def _piece_width(c: float, length: float, psi: float) -> float:
    """Extent along x of a piece of the profile."""
    return length * math.cos(psi) if c == 0 else (math.sin(psi + c * length) - math.sin(psi)) / c


def _piece_segments(sw: Swatch, c: float, length: float) -> int:
    return max(8 if c != 0 else 1, int(math.ceil(length / sw.step_mm)))


def _swatch_profile(sw: Swatch) -> tuple[NDArray[np.float64], ...]:
    """Vertices of the profile: arc length, x (centred), z, heading and curvature (mm^-1)."""
    s_all, x_all, z_all, psi_all, k_all = [np.zeros(1)], [np.zeros(1)], [np.zeros(1)], [np.zeros(1)], []
    x0 = z0 = s0 = 0.0
    for c, length, psi0 in _swatch_pieces(sw):
        t = np.linspace(0.0, length, _piece_segments(sw, c, length) + 1)[1:]
        psi = psi0 + c * t
        if c == 0:
            x, z = x0 + t * math.cos(psi0), z0 + t * math.sin(psi0)
        else:
            x = x0 + (np.sin(psi) - math.sin(psi0)) / c
            z = z0 - (np.cos(psi) - math.cos(psi0)) / c
        s_all.append(s0 + t)
        x_all.append(x)
        z_all.append(z)
        psi_all.append(psi)
        k_all.append(np.full(len(t), -c))
        x0, z0, s0 = float(x[-1]), float(z[-1]), s0 + length
    k_seg = np.concatenate(k_all)  # the curvature of the segment ending at each vertex
    k = np.empty(len(k_seg) + 1)
    k[0], k[-1] = k_seg[0], k_seg[-1]
    k[1:-1] = 0.5 * (k_seg[:-1] + k_seg[1:])  # a vertex where two pieces meet: the mean of both sides
    x = np.concatenate(x_all)
    return np.concatenate(s_all), x - 0.5 * x[-1], np.concatenate(z_all), np.concatenate(psi_all), k


def swatch_curvature(x_mm: ArrayLike, swatch: Swatch = Swatch()) -> NDArray[np.float64]:
    """Signed curvature (mm^-1) of the swatch across its folds, seen from +z.

    Constant on each piece of the profile: +1/R on a convex arc (a ridge's
    crest, a groove's shoulders), -1/R on a concave one, 0 on the flanks and
    the flat cloth; at a point where two pieces meet, the mean of both. Along
    the folds the curvature is 0, so this is also the principal curvature of
    larger magnitude and the normal curvature along x (u).

    Parameters
    ----------
    x_mm
        Positions across the swatch (x, centred on 0), mm.
    swatch
        The swatch.

    Returns
    -------
    numpy.ndarray
        Curvatures, mm^-1 (0 beyond the swatch's ends).
    """
    x = np.asarray(x_mm, dtype=np.float64)
    pieces = _swatch_pieces(swatch)
    ends = np.r_[0.0, np.cumsum([_piece_width(*p) for p in pieces])]
    edges = ends - 0.5 * ends[-1]
    kappa = np.array([-c for c, _, _ in pieces])
    i = np.clip(np.searchsorted(edges, x, side="right") - 1, 0, len(pieces) - 1)
    out = np.where((x < edges[0]) | (x > edges[-1]), 0.0, kappa[i])
    tie = np.isclose(x, edges[i], rtol=0.0, atol=1e-9 * max(1.0, float(ends[-1]))) & (i > 0)
    return np.where(tie, 0.5 * (kappa[i] + kappa[np.maximum(i - 1, 0)]), out)


def swatch_mesh(swatch: Swatch = Swatch()) -> Mesh:
    """The swatch as a mesh with UVs, analytic normals and curvature (see :class:`Swatch`).

    The attributes ``"curvature"`` and ``"curvature_dir"`` hold the analytic
    signed curvature (mm^-1) of every vertex (:func:`swatch_curvature`; x,
    across the folds, is a principal direction, so both modes agree). u is
    the arc length across the folds over the profile's length (the
    material's x follows the bending, as on the measurement stands), v runs
    along y; faces wind counter-clockwise seen from +z.

    Parameters
    ----------
    swatch
        The swatch.

    Returns
    -------
    Mesh
        The mesh, in mm, z up, centred on the origin in x and y, the flat cloth at z = 0.
    """
    s, x, z, psi, k = _swatch_profile(swatch)
    nx, ny = len(x), swatch.grid_shape[1]
    y = np.linspace(-swatch.depth_mm / 2, swatch.depth_mm / 2, ny)
    V = np.stack([np.repeat(x, ny), np.tile(y, nx), np.repeat(z, ny)], axis=1)
    N = np.stack([np.repeat(-np.sin(psi), ny), np.zeros(nx * ny), np.repeat(np.cos(psi), ny)], axis=1)
    U = np.stack([np.repeat(s / s[-1], ny), np.tile((y - y[0]) / swatch.depth_mm, nx)], axis=1)
    i, j = np.meshgrid(np.arange(nx - 1), np.arange(ny - 1), indexing="ij")
    a = (i * ny + j).ravel()
    b = a + ny  # +x
    c = b + 1   # +x +y
    d = a + 1   # +y
    F = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)]).astype(np.int64)
    kk = np.repeat(k, ny)
    return Mesh(V, F, N, U, _both_modes(kk),
                metadata={"units": "mm", "up": "z", "curvature_units": "1/mm", "frame": "uv", "source": "swatch"})
