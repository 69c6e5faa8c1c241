"""Weave patterns and the yarn micro-geometry of a woven cloth.

A weave is a binary matrix ``P`` of shape ``(n_weft, n_warp)``: ``P[i, j] = 1``
where warp yarn ``j`` passes *over* weft yarn ``i`` (the warp is seen at that
crossing), 0 where the weft is on top. The matrix is one repeat of the
pattern; the cloth repeats it periodically in both directions.

The geometry follows the yarn-level picture of Irawan & Marschner (2012):
every yarn is a tube of elliptical cross-section (width ``2a``, height ``2b``)
whose centre line undulates over and under the crossing yarns (the *crimp*),
with fibres wound around it at the twist angle. The visible cloth surface is
the upper envelope of all yarn tubes over a backing plane (what is seen
through holes), sampled as a periodic height field with, per texel, the
surface normal, the fibre tangent and the yarn it belongs to.

Bending (:mod:`cdbrdf.synth.bending`) changes the crimp amplitudes and
stretches the layout along x; :func:`build_heightfield` takes the result.

References
----------
P. Irawan and S. Marschner, "Specular reflection from woven cloth",
ACM Transactions on Graphics 31(1), 2012.
I. Sadeghi, O. Bisker, J. De Deken, H. W. Jensen, "A practical microcylinder
appearance model for cloth rendering", ACM Transactions on Graphics 32(2), 2013.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import OptionError

__all__ = [
    "WEAVES",
    "weave_matrix",
    "weave_names",
    "YarnGeometry",
    "Heightfield",
    "build_heightfield",
    "x_of_xi",
    "WARP",
    "WEFT",
    "BACKING",
]

#: Texel classes of a :class:`Heightfield`.
WARP, WEFT, BACKING = 0, 1, 2

#: Named weave repeats (rows = weft yarns, columns = warp yarns, 1 = warp on top).
WEAVES: Mapping[str, tuple[tuple[int, ...], ...]] = MappingProxyType(
    {
        "plain": ((1, 0), (0, 1)),
        # 2/1 warp-faced twill.
        "twill_2_1": ((1, 1, 0), (0, 1, 1), (1, 0, 1)),
        # 3/1 warp-faced twill (denim): each warp floats over three wefts.
        "twill_3_1": ((1, 1, 1, 0), (0, 1, 1, 1), (1, 0, 1, 1), (1, 1, 0, 1)),
        "twill_2_2": ((1, 1, 0, 0), (0, 1, 1, 0), (0, 0, 1, 1), (1, 0, 0, 1)),
        # 5-end warp-faced satin (move 2).
        "satin_5": (
            (1, 1, 1, 1, 0),
            (1, 1, 0, 1, 1),
            (0, 1, 1, 1, 1),
            (1, 1, 1, 0, 1),
            (1, 0, 1, 1, 1),
        ),
    }
)


def weave_names() -> list[str]:
    """Names of the registered weave patterns."""
    return sorted(WEAVES)


def weave_matrix(weave: str | ArrayLike) -> NDArray[np.int8]:
    """A validated weave matrix from a registered name or a 0/1 matrix.

    Parameters
    ----------
    weave
        A name from :data:`WEAVES` or a 2-D array of 0/1, shape
        ``(n_weft, n_warp)``, 1 where the warp passes over the weft.

    Returns
    -------
    numpy.ndarray
        int8 matrix, shape ``(n_weft, n_warp)``.

    Raises
    ------
    ValueError
        For an unknown name (listing the valid ones) or a matrix that is not a
        woven repeat: not 2-D, not 0/1, smaller than 2 x 2, or a row or column
        without both a 0 and a 1 (that yarn would never interlace).
    """
    if isinstance(weave, str):
        if weave not in WEAVES:
            raise OptionError(
                f"weave: unknown pattern {weave!r}; valid names: {', '.join(weave_names())}"
            )
        return np.array(WEAVES[weave], dtype=np.int8)
    try:
        m = np.asarray(weave)
    except (TypeError, ValueError) as exc:  # ragged lists
        raise OptionError(f"weave: cannot be read as a matrix ({exc})") from None
    if m.ndim != 2:
        raise OptionError(f"weave: expected a 2-D 0/1 matrix (weft x warp), got shape {m.shape}")
    if m.shape[0] < 2 or m.shape[1] < 2:
        raise OptionError(f"weave: a repeat needs at least 2 x 2 crossings, got shape {m.shape}")
    if not (np.issubdtype(m.dtype, np.number) or m.dtype == bool) or not np.isin(m, (0, 1)).all():
        raise OptionError("weave: entries must be 0 (weft on top) or 1 (warp on top)")
    m = m.astype(np.int8)
    for axis, what in ((1, "weft (row)"), (0, "warp (column)")):
        s = m.sum(axis=axis)
        bad = np.flatnonzero((s == 0) | (s == m.shape[axis]))
        if bad.size:
            raise OptionError(
                f"weave: {what} {int(bad[0])} never changes sides, so it does not interlace; "
                "every row and column needs both a 0 and a 1"
            )
    return m


@dataclass(frozen=True)
class YarnGeometry:
    """Geometry of one yarn family (warp or weft), lengths in mm.

    Attributes
    ----------
    pitch_mm
        Distance between neighbouring yarn centres (1 / yarn count).
    width_mm, height_mm
        Cross-section width ``2a`` and height ``2b`` (an ellipse).
    crimp_mm
        Crimp amplitude: the centre line lies ``+crimp`` above the mid-plane
        where the yarn passes over a crossing yarn, ``-crimp`` below where it
        passes under; in between it follows a half cosine.
    twist_deg
        Angle between the surface fibres and the yarn axis (Z twist > 0).
    transition
        Fraction (0, 1] of the distance between two crossings over which the
        centre line changes level (1: a full half cosine; smaller: level
        floats with steeper dives).
    """

    pitch_mm: float
    width_mm: float
    height_mm: float
    crimp_mm: float
    twist_deg: float
    transition: float = 1.0


@dataclass(frozen=True, eq=False)
class Heightfield:
    """One periodic repeat of the cloth surface, sampled on texel centres.

    Attributes
    ----------
    height
        ``(ny, nx)`` surface height in mm at texel centres
        ``((i + 0.5) dx, (j + 0.5) dy)``.
    normal, tangent
        ``(ny, nx, 3)`` unit surface normal and unit fibre direction (in the
        tangent plane of the normal) in the local frame (z up).
    kind
        ``(ny, nx)`` int8: :data:`WARP`, :data:`WEFT` or :data:`BACKING`.
    size_mm
        ``(Lx, Ly)``: the repeat's size.
    x_mm, texel_width_mm
        ``(nx,)`` texel centres and widths along x: texels are uniform along
        y but, along x, cut at the edges of the yarns spaced along x (see
        :func:`x_of_xi`).
    xmap
        The texel layout along x (``_x_mapping``).
    """

    height: NDArray[np.float64]
    normal: NDArray[np.float64]
    tangent: NDArray[np.float64]
    kind: NDArray[np.int8]
    size_mm: tuple[float, float]
    x_mm: NDArray[np.float64]
    texel_width_mm: NDArray[np.float64]
    xmap: NDArray[np.float64]

    @property
    def shape(self) -> tuple[int, int]:
        """``(ny, nx)``."""
        ny, nx = self.height.shape
        return ny, nx

    def coverage(self) -> dict[str, float]:
        """Fraction of the repeat's area (seen from above) covered by each kind."""
        k = self.kind
        w = np.broadcast_to(self.texel_width_mm / self.size_mm[0] / k.shape[0], k.shape)
        return {
            "warp": float(np.sum(w * (k == WARP))),
            "weft": float(np.sum(w * (k == WEFT))),
            "backing": float(np.sum(w * (k == BACKING))),
        }


def _crimp(
    u: NDArray[np.float64], h: NDArray[np.float64], pitch: float, transition: float
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Centre-line height and slope of a yarn whose crossings are at (k + 0.5) pitch.

    Between two crossings the height changes along a half cosine over the
    middle ``transition`` fraction of the distance and is level elsewhere.
    """
    n = h.size
    f = u / pitch - 0.5
    k = np.floor(f)
    tau = f - k
    k = k.astype(np.int64) % n
    h0 = h[k]
    h1 = h[(k + 1) % n]
    s = np.clip((tau - 0.5 * (1.0 - transition)) / transition, 0.0, 1.0)
    inside = (s > 0.0) & (s < 1.0)
    w = 0.5 * (1.0 - np.cos(np.pi * s))
    dw = np.where(inside, 0.5 * np.pi * np.sin(np.pi * s) / (pitch * transition), 0.0)
    return h0 + (h1 - h0) * w, (h1 - h0) * dw


def build_heightfield(
    weave: NDArray[np.int8],
    warp: YarnGeometry,
    weft: YarnGeometry,
    *,
    warp_along: str,
    stretch_x: float,
    texels: int,
    backing_z_mm: float | None = None,
    gap_texels: int = 2,
) -> Heightfield:
    """Sample the surface of one weave repeat as a height field.

    Parameters
    ----------
    weave
        Validated weave matrix ``(n_weft, n_warp)`` (see :func:`weave_matrix`).
    warp, weft
        Yarn geometries.
    warp_along
        ``"x"`` or ``"y"``: the local axis the warp runs along (x is the
        bending direction).
    stretch_x
        Stretch of the yarn layout along x (the bent cloth's
        :attr:`~cdbrdf.synth.bending.Bend.stretch_x`); 1 = flat. Yarn
        cross-sections are not stretched.
    texels
        Texels along the longer side of the repeat (the other side gets as many
        as keep texels about square).
    backing_z_mm
        Height of the backing plane; default just below the lowest yarn.
    gap_texels
        Texels across each half of the gap between the yarns spaced along x
        (whatever its width; 0 = uniform texels). Their width follows the gap
        as it opens, so visibility changes smoothly with the bend.

    Returns
    -------
    Heightfield
    """
    if warp_along == "y":
        # Family A runs along y (spaced along x) = warp; B along x = weft.
        a_geom, b_geom = warp, weft
        over_a = weave.astype(bool)  # [b, a]: A on top at crossing
        kind_a, kind_b = WARP, WEFT
    elif warp_along == "x":
        a_geom, b_geom = weft, warp
        over_a = (1 - weave).astype(bool).T  # weft (A) on top, indexed [warp, weft]
        kind_a, kind_b = WEFT, WARP
    else:
        raise OptionError(f"warp_along: expected 'x' or 'y', got {warp_along!r}")
    n_b, n_a = over_a.shape
    p_a = a_geom.pitch_mm * stretch_x  # A centres spaced along x, stretched
    p_b = b_geom.pitch_mm  # B centres spaced along y
    lx, ly = n_a * p_a, n_b * p_b
    if lx >= ly:
        nx = int(texels)
        ny = max(4, int(round(texels * ly / lx)))
    else:
        ny = int(texels)
        nx = max(4, int(round(texels * lx / ly)))
    # Texel size from the unstretched repeat, so texel counts do not change with the bend.
    xmap = _x_mapping(p_a, a_geom.width_mm / 2, lx / nx / stretch_x, gap_texels)
    m = int(xmap[8])
    nx = n_a * m
    dy = ly / ny
    x = x_of_xi(np.arange(nx) + 0.5, xmap)
    edges = x_of_xi(np.arange(nx + 1, dtype=np.float64), xmap)
    y = (np.arange(ny) + 0.5) * dy
    X, Y = np.meshgrid(x, y)  # (ny, nx)

    lowest = min(-a_geom.crimp_mm - a_geom.height_mm / 2, -b_geom.crimp_mm - b_geom.height_mm / 2)
    z_floor = lowest - 1e-3 if backing_z_mm is None else float(backing_z_mm)
    height = np.full(X.shape, z_floor)
    normal = np.zeros(X.shape + (3,))
    normal[..., 2] = 1.0
    tangent = np.zeros(X.shape + (3,))
    tangent[..., 0] = 1.0
    kind = np.full(X.shape, BACKING, dtype=np.int8)

    def add(
        along_coord: NDArray[np.float64],
        across_coord: NDArray[np.float64],
        centre: float,
        period: float,
        half_w: float,
        half_h: float,
        zc: NDArray[np.float64],
        dzc: NDArray[np.float64],
        twist: float,
        k: int,
        along_is_y: bool,
    ) -> None:
        d = (across_coord - centre + period / 2) % period - period / 2
        inside = np.abs(d) < half_w
        if not inside.any():
            return
        q = np.maximum(1.0 - (d / half_w) ** 2, 1e-6)
        z = zc + half_h * np.sqrt(q)
        upd = inside & (z > height)
        if not upd.any():
            return
        dz_across = -half_h * d / (half_w**2 * np.sqrt(q))
        if along_is_y:
            gx, gy = dz_across, dzc
            t = np.stack([np.zeros_like(dzc), np.ones_like(dzc), dzc], axis=-1)
        else:
            gx, gy = dzc, dz_across
            t = np.stack([np.ones_like(dzc), np.zeros_like(dzc), dzc], axis=-1)
        n = np.stack([-gx, -gy, np.ones_like(gx)], axis=-1)
        n /= np.linalg.norm(n, axis=-1, keepdims=True)
        t /= np.linalg.norm(t, axis=-1, keepdims=True)
        if twist != 0.0:
            a = np.radians(twist)
            b = np.cross(n, t)
            t = np.cos(a) * t + np.sin(a) * b
            t -= np.sum(t * n, axis=-1, keepdims=True) * n
            t /= np.linalg.norm(t, axis=-1, keepdims=True)
        height[upd] = z[upd]
        normal[upd] = n[upd]
        tangent[upd] = t[upd]
        kind[upd] = k

    # Family A: along y, centres at x = (a + 0.5) p_a, crossings at y = (b + 0.5) p_b.
    for ia in range(n_a):
        h = np.where(over_a[:, ia], a_geom.crimp_mm, -a_geom.crimp_mm)
        zc, dzc = _crimp(Y, h, p_b, a_geom.transition)
        add(Y, X, (ia + 0.5) * p_a, lx, a_geom.width_mm / 2, a_geom.height_mm / 2,
            zc, dzc, a_geom.twist_deg, kind_a, True)
    # Family B: along x, centres at y = (b + 0.5) p_b, crossings at x = (a + 0.5) p_a.
    for ib in range(n_b):
        h = np.where(over_a[ib, :], -b_geom.crimp_mm, b_geom.crimp_mm)
        zc, dzc = _crimp(X, h, p_a, b_geom.transition)
        add(X, Y, (ib + 0.5) * p_b, ly, b_geom.width_mm / 2, b_geom.height_mm / 2,
            zc, dzc, b_geom.twist_deg, kind_b, False)
    width = np.diff(edges)
    for arr in (height, normal, tangent, kind, x, width, xmap):
        arr.setflags(write=False)
    return Heightfield(
        height=height, normal=normal, tangent=tangent, kind=kind, size_mm=(lx, ly),
        x_mm=x, texel_width_mm=width, xmap=xmap,
    )


def _x_mapping(pitch: float, half_width: float, dx: float, gap_texels: int) -> NDArray[np.float64]:
    """Texel layout along x of one cell of the yarns spaced along x.

    ``[pitch, x0, x1, x2, x3, n0, n1, n2, n3, 0]``: the cell ``[0, pitch)``
    (yarn centre at ``pitch / 2``) is cut at the knots ``x0..x3`` into the
    half-gap (or half-overlap of the neighbouring yarns) at each end and the
    middle, holding ``n1 - n0``, ``n2 - n1``, ``n3 - n2`` texels. Each end
    keeps ``gap_texels`` texels however narrow it is, so a gap that opens (or
    an overlap that grows) with the bend widens its texels instead of popping
    in whole texels; the counts do not depend on the bend.
    """
    half = 0.5 * abs(pitch - 2.0 * half_width)
    g = float(gap_texels)
    my = float(max(4, int(round(min(2.0 * half_width, pitch) / dx))))
    if gap_texels <= 0:
        half = 0.0
        g = 0.0
        my = float(max(4, int(round(pitch / dx))))
    half = min(half, 0.5 * pitch)
    return np.array([pitch, 0.0, half, pitch - half, pitch, 0.0, g, g + my, 2 * g + my])


def x_of_xi(xi: ArrayLike, xmap: NDArray[np.float64]) -> NDArray[np.float64]:
    """Physical x (mm) of texel coordinates ``xi`` (texel i spans [i, i + 1))."""
    xi = np.asarray(xi, dtype=np.float64)
    m = xmap[8]
    c = np.floor(xi / m)
    u = xi - c * m
    out = np.empty_like(xi)
    done = np.zeros(xi.shape, dtype=bool)
    for k in range(3):
        n0, n1 = xmap[5 + k], xmap[6 + k]
        if n1 <= n0:
            continue
        sel = ~done & (u < n1) if k < 2 else ~done
        out[sel] = xmap[1 + k] + (u[sel] - n0) / (n1 - n0) * (xmap[2 + k] - xmap[1 + k])
        done |= sel
    return c * xmap[0] + out
