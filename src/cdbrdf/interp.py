"""5-D multilinear lookup of a :class:`~cdbrdf.table.CDBRDF`: the rule and its owner.

This module states the lookup rule once; every implementation (the numba
kernels in :mod:`cdbrdf._kernels`, the Dr.Jit lookup of the renderer in
:mod:`cdbrdf.render._lookup_jit`, the GLSL lookup of the browser pages in
``cdbrdf/view/assets/lookup.js`` (float32, texelFetch on the grid's values
packed by :mod:`cdbrdf.view.asset` or decoded from a glTF asset's texture,
:mod:`cdbrdf.gltf_table`; shared by the viewer and the glTF renderer, tested
against :func:`evaluate` in ``tests/test_viewer.py`` and by the conformance
suite), and :func:`evaluate_reference`, the slow
readable statement) consumes the same :class:`LookupGrid` built by
:func:`prepare` and the constants below.

The rule, fixed by the project's conventions:

- **curvature**: linear between samples of any spacing, clamped to the ends;
- **elevation**: linear between samples, clamped beyond the last one (and to
  the pole node at 0);
- **azimuth**: linear and periodic on the evenly spaced circle; an azimuth
  outside (-360, 360) is first reduced exactly with ``fmod(phi, 360)``
  (:func:`wrap_azimuth`), so a huge finite azimuth keeps its true place;
- **snapping**: a weight within :data:`SNAP_TOLERANCE` of 0 or of 1 is set to
  exactly 0 or 1, on every axis and on both sides, so that every sample is
  reproduced exactly despite the rounding of the index arithmetic. The
  tolerance belongs to the precision of that arithmetic: ``1e-9`` in float64
  (the numba kernels and the reference, whatever the table's dtype), ``1e-6``
  in float32 (the renderer), where one rounding of ``x / step`` is already
  about 1e-7;
- **pole rule**: at theta = 0 every azimuth is the same direction. The lookup
  grid's first elevation node is theta = 0 and holds, for every azimuth, the
  *mean of the stored ring at theta = 0* (or, when the table's first elevation
  is above 0, a virtual pole node holding the mean of that first ring). Between
  the pole and the next elevation the value is blended linearly; at the pole
  itself (elevation node 0, weight 0 after snapping) the azimuth weight is 0.
  The result is continuous, independent of the azimuth at theta = 0 (bit for
  bit), and exactly equal to the table at every sample with both elevations
  above 0;
- **isotropic tables** (``symmetry = "isotropic"``: ``phi_l`` is ``[0]`` and
  ``phi_v`` the azimuth difference): every query is first rotated about the
  normal so that its light azimuth is 0, i.e. it is looked up at the azimuth
  difference ``wrap(wrap(phi_v) - wrap(phi_l))`` (``wrap`` =
  :func:`wrap_azimuth`; the difference is reduced again when it leaves
  (-360, 360)). The stored azimuth then depends on *both* directions, so the
  pole rule holds for both elevation axes on that one azimuth axis: the light
  pole node (theta_l = 0) holds, for each view elevation, the mean of the
  stored difference ring, exactly as the view pole node (theta_v = 0) does
  for each light elevation; at either pole (elevation weight 0 on node 0) the
  weight of the azimuth difference is 0. A query with the light or the view
  along the normal is then independent of both azimuths, bit for bit.

Non-finite query components give a NaN output row; an elevation outside
[0, 90] degrees raises :class:`~cdbrdf.errors.QueryError` naming the argument
(``on_invalid="nan"`` gives NaN rows instead).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from types import MappingProxyType
from typing import Any, NamedTuple, Protocol

import numpy as np
from numpy.typing import ArrayLike, DTypeLike, NDArray

from .errors import QueryError
from .grid import Grid

__all__ = [
    "KERNELS",
    "KernelGrid",
    "MAX_ELEVATION_DEG",
    "PERIOD_DEG",
    "RGB_MAX_KAPPA",
    "SNAP_TOLERANCE",
    "LookupGrid",
    "evaluate",
    "evaluate_reference",
    "prepare",
    "apply_pole_rule",
    "snap_tolerance",
    "wrap_azimuth",
]

#: Weights this close to 0 or 1 are set to exactly 0 or 1, per precision of
#: the index arithmetic (see the module docstring).
SNAP_TOLERANCE: Mapping[str, float] = MappingProxyType({"float64": 1e-9, "float32": 1e-6})

#: Period of both azimuth axes, degrees.
PERIOD_DEG = 360.0

#: Largest valid elevation, degrees (directions below the surface have no reflectance).
MAX_ELEVATION_DEG = 90.0

#: Most curvature samples of the RGB kernel (:func:`cdbrdf._kernels.lookup_rgb`):
#: the length of :attr:`LookupGrid.kappa_node` and its siblings, which that
#: kernel unpacks into scalars (so a different length fails to compile there).
RGB_MAX_KAPPA = 8

#: Kernels :func:`evaluate` can use: ``"auto"`` takes ``"rgb"`` where the grid
#: allows it (:attr:`LookupGrid.rgb_kernel`) and ``"generic"`` elsewhere.
KERNELS: tuple[str, ...] = ("auto", "rgb", "generic")

#: Valid values of ``on_invalid``.
_ON_INVALID: tuple[str, ...] = ("raise", "nan")

#: Queries handled per kernel call when inputs need broadcasting copies.
_CHUNK = 1 << 16

#: Fewest queries worth a thread of their own (a thread costs about 0.1 ms).
_MIN_QUERIES_PER_THREAD = 1 << 14


def snap_tolerance(precision: DTypeLike) -> float:
    """The weight snap tolerance of index arithmetic in ``precision``.

    Parameters
    ----------
    precision
        ``"float64"`` or ``"float32"`` (or the NumPy dtype).

    Returns
    -------
    float
        :data:`SNAP_TOLERANCE` of that precision.

    Raises
    ------
    QueryError
        For any other precision.
    """
    try:
        name = np.dtype(precision).name
    except TypeError:
        name = str(precision)
    if name not in SNAP_TOLERANCE:
        raise QueryError(f"precision: {precision!r} is not one of {', '.join(SNAP_TOLERANCE)}")
    return SNAP_TOLERANCE[name]


def wrap_azimuth(phi_deg: float) -> float:
    """``phi_deg`` reduced exactly into (-360, 360) when it lies outside.

    ``fmod`` is exact for every finite float, so a huge azimuth (1e30, 1e308)
    keeps its true place on the circle.

    Parameters
    ----------
    phi_deg
        An azimuth, degrees.

    Returns
    -------
    float
        The azimuth in (-360, 360): unchanged when already inside; NaN for
        infinities and NaN.
    """
    x = float(phi_deg)
    if -PERIOD_DEG < x < PERIOD_DEG:
        return x
    return math.fmod(x, PERIOD_DEG) if math.isfinite(x) else math.nan


class KernelGrid(NamedTuple):
    """A prepared table's lookup fields: what the compiled kernels of :mod:`cdbrdf._kernels` read.

    Numba compiles each kernel once for float32 tables and once for float64
    tables: ``flat`` keeps the table's dtype (a float32 table read as float64
    would double the memory the gathers touch, 20 % slower; the kernels
    compute in float64 either way). :class:`LookupGrid` holds one and reads
    its fields as its own.

    Attributes
    ----------
    flat
        The table raveled in C order with ``stride`` values per sample: RGB
        tables are padded to 4 (the padding is 0) so that a sample is one
        aligned 16-byte (float32) or 32-byte (float64) block.
    stride
        Values per sample in ``flat`` (4 for RGB, else the channel count).
    shape
        ``(n_kappa, n_phi_l, n_theta_l, n_phi_v, n_theta_v, channel)`` as integers.
    kappa, kappa_inv_d
        Curvature axis (mm^-1) and ``1 / (kappa[i + 1] - kappa[i])`` (mm);
        a single-sample axis has ``kappa_inv_d == [0]``.
    theta_l, theta_l_inv_d, theta_l_inv_step
        Light elevation axis (degrees, ``theta_l[0] == 0``), its inverse
        spacings (1/degree) and ``1 / step`` when it is evenly spaced with at
        least 3 nodes, else 0.0.
    theta_v, theta_v_inv_d, theta_v_inv_step
        The same for the view elevation.
    phi_l0, phi_l_inv_step
        First light azimuth (degrees) and ``n_phi_l / 360``.
    phi_v0, phi_v_inv_step
        The same for the view azimuth.
    kappa_node, kappa_scan, kappa_slot_inv_d
        The curvature axis in :data:`RGB_MAX_KAPPA` slots for the RGB kernel:
        the nodes padded with the last one; the interior nodes ``1 .. n - 2``
        at their places, +inf elsewhere (a scan counts those at or below the
        query); the inverse spacings padded with 0.
    isotropic
        True for an isotropic table: queries are rotated to light azimuth 0
        (the view azimuth axis holds ``phi_v - phi_l``) and the light pole
        node holds the mean over that axis (see the module docstring).
    """

    flat: NDArray[np.floating]
    stride: int
    shape: tuple[int, int, int, int, int, int]
    kappa: NDArray[np.float64]
    kappa_inv_d: NDArray[np.float64]
    theta_l: NDArray[np.float64]
    theta_l_inv_d: NDArray[np.float64]
    theta_l_inv_step: float
    theta_v: NDArray[np.float64]
    theta_v_inv_d: NDArray[np.float64]
    theta_v_inv_step: float
    phi_l0: float
    phi_l_inv_step: float
    phi_v0: float
    phi_v_inv_step: float
    kappa_node: tuple[float, ...]
    kappa_scan: tuple[float, ...]
    kappa_slot_inv_d: tuple[float, ...]
    isotropic: bool


class LookupGrid(NamedTuple):
    """A table prepared for lookup: pole rule applied, its lookup fields one :class:`KernelGrid`.

    Built once per table by :func:`prepare` (and cached by the table,
    :meth:`cdbrdf.table.CDBRDF.lookup_grid`); immutable, arrays read-only.
    The kernel's fields read as the grid's own (``grid.kappa`` is
    ``grid.kernel.kappa``): one record of them, not two.

    Attributes
    ----------
    values
        ``(n_kappa, n_phi_l, n_theta_l, n_phi_v, n_theta_v, channel)``,
        C-contiguous, the table's dtype (float32 or float64); node 0 of both
        elevation axes is theta = 0 and holds the ring mean.
    kernel
        The lookup fields (:class:`KernelGrid`: ``flat``, ``stride``, the
        axes and their inverse spacings, the curvature slots, ``isotropic``).
    phi_l_step, phi_v_step
        The azimuths' spacings, degrees (360 / n).
    rgb_kernel
        True when the RGB kernel applies: 3 channels, both elevation axes
        evenly spaced, at most :data:`RGB_MAX_KAPPA` curvatures.
    """

    values: NDArray[np.floating]
    kernel: KernelGrid
    phi_l_step: float
    phi_v_step: float
    rgb_kernel: bool

    def __getattr__(self, name: str) -> Any:
        if name.startswith("_"):
            raise AttributeError(name)
        return getattr(self.kernel, name)

    def __repr__(self) -> str:
        return (f"LookupGrid(shape={self.shape}, dtype={self.values.dtype}, stride={self.stride}, "
                f"rgb_kernel={self.rgb_kernel}, isotropic={self.isotropic})")

    @property
    def shape(self) -> tuple[int, ...]:
        """Shape of :attr:`values` (the pole node included)."""
        return tuple(self.values.shape)

    @property
    def n_channels(self) -> int:
        """Number of channels."""
        return int(self.values.shape[-1])

    @property
    def theta_l_even(self) -> bool:
        """Whether the light elevation axis is evenly spaced (index by multiplication)."""
        return self.theta_l_inv_step > 0.0

    @property
    def theta_v_even(self) -> bool:
        """Whether the view elevation axis is evenly spaced."""
        return self.theta_v_inv_step > 0.0


class _Table(Protocol):
    """What :func:`evaluate` needs of a table: its prepared grid (:meth:`cdbrdf.table.CDBRDF.lookup_grid`)."""

    def lookup_grid(self) -> LookupGrid: ...


def _pole(
    values: NDArray[np.floating], theta: NDArray[np.float64], t_axis: int, p_axis: int
) -> tuple[NDArray[np.floating], NDArray[np.float64]]:
    """Apply the pole rule along one (theta, phi) axis pair: node 0 at theta = 0 holds the ring mean."""
    ring_mean = values.mean(axis=p_axis, keepdims=True, dtype=np.float64)
    idx: list[slice] = [slice(None)] * values.ndim
    idx[t_axis] = slice(0, 1)
    ring_mean = np.take(ring_mean, [0], axis=t_axis).astype(values.dtype)
    pole = np.broadcast_to(ring_mean, values[tuple(idx)].shape)
    if theta[0] == 0.0:
        out = values.copy()
        out[tuple(idx)] = pole
        return out, theta
    return np.concatenate([pole, values], axis=t_axis), np.concatenate([[0.0], theta])


def _frozen(a: ArrayLike, dtype: DTypeLike = np.float64, *, copy: bool = True) -> NDArray[Any]:
    """``a`` as a C-contiguous read-only array: a copy, or (``copy=False``) ``a`` itself when it is one."""
    out = np.array(a, dtype=dtype, order="C", copy=True if copy else None)
    out.setflags(write=False)
    return out


def _inv_spacing(axis: NDArray[np.float64]) -> NDArray[np.float64]:
    """``1 / (axis[i + 1] - axis[i])`` (one zero for a single-sample axis)."""
    if axis.size < 2:
        return _frozen(np.zeros(1))
    return _frozen(1.0 / np.diff(axis))


def _inv_step(axis: NDArray[np.float64]) -> float:
    """1 / spacing of an evenly spaced axis of at least 3 nodes, or 0.0 when the spacing varies."""
    if axis.size < 3:
        return 0.0
    d = np.diff(axis)
    if np.allclose(d, d[0], rtol=1e-12, atol=0.0):
        return float(1.0 / d[0])
    return 0.0


def _kappa_slots(kappa: NDArray[np.float64]) -> tuple[tuple[float, ...], tuple[float, ...], tuple[float, ...]]:
    """The curvature axis in :data:`RGB_MAX_KAPPA` slots (see :class:`LookupGrid`)."""
    n = min(kappa.size, RGB_MAX_KAPPA)
    node = np.full(RGB_MAX_KAPPA, kappa[n - 1])
    node[:n] = kappa[:n]
    scan = np.full(RGB_MAX_KAPPA, np.inf)
    scan[1:n - 1] = kappa[1:n - 1]
    inv = np.zeros(RGB_MAX_KAPPA)
    inv[:max(n - 1, 1)] = _inv_spacing(kappa[:n])
    return tuple(map(float, node)), tuple(map(float, scan)), tuple(map(float, inv))


def apply_pole_rule(
    values: ArrayLike, theta_l: ArrayLike, theta_v: ArrayLike, *, isotropic: bool
) -> tuple[NDArray[np.floating], NDArray[np.float64], NDArray[np.float64]]:
    """The samples and elevation axes as the lookups hold them: the pole rule applied (module docstring).

    ``values`` is ``(..., n_phi_l, n_theta_l, n_phi_v, n_theta_v, channel)``
    in the table's layout (any leading axes). Node 0 of each returned
    elevation axis is theta = 0 and holds the mean of the stored ring there
    (a virtual pole node is added when the axis starts above 0); isotropic:
    the light pole averages the azimuth difference axis.

    Parameters
    ----------
    values
        The samples, ``(..., n_phi_l, n_theta_l, n_phi_v, n_theta_v, channel)``.
    theta_l, theta_v
        The table's elevation axes, degrees.
    isotropic
        Whether the table is isotropic (``phi_v`` the azimuth difference).

    Returns
    -------
    values : numpy.ndarray
        The samples with the pole rule applied (a new array).
    theta_l, theta_v : numpy.ndarray
        The elevation axes with their pole nodes.
    """
    v = np.asarray(values)
    if v.ndim < 5:
        raise QueryError(f"values: expected at least 5 axes (phi_l, theta_l, phi_v, theta_v, channel), got {v.ndim}")
    off = v.ndim - 5  # leading axes before phi_l
    # light pole: the mean over the light azimuth ring, or (isotropic) over the azimuth difference
    v, thl = _pole(v, np.asarray(theta_l, dtype=np.float64), off + 1, off + 2 if isotropic else off)
    v, thv = _pole(v, np.asarray(theta_v, dtype=np.float64), off + 3, off + 2)
    return v, thl, thv


def prepare(grid: Grid, values: NDArray[np.floating]) -> LookupGrid:
    """Build the :class:`LookupGrid` of a table's samples (apply the pole rule, lay out every kernel's fields).

    Builds a new grid on every call; :meth:`cdbrdf.table.CDBRDF.lookup_grid`
    calls it once per table and keeps the result, and the lookups use that.

    Parameters
    ----------
    grid
        The sample axes.
    values
        ``grid.shape + (channels,)`` samples (float32 or float64).

    Returns
    -------
    LookupGrid
        The prepared grid (read-only arrays).
    """
    g = grid
    iso = g.isotropic
    v, thl, thv = apply_pole_rule(values, g.theta_l, g.theta_v, isotropic=iso)
    values = _frozen(v, v.dtype, copy=False)  # apply_pole_rule made a new array
    nc = values.shape[-1]
    if nc == 3:
        padded = np.zeros(values.shape[:-1] + (4,), dtype=values.dtype)
        padded[..., :3] = values
        flat, stride = _frozen(padded.reshape(-1), values.dtype, copy=False), 4
    else:
        flat, stride = values.reshape(-1), nc  # a read-only view
    kappa = _frozen(g.kappa)
    theta_l, theta_v = _frozen(thl), _frozen(thv)
    inv_tl, inv_tv = _inv_step(theta_l), _inv_step(theta_v)
    n_pl, n_pv = int(np.size(g.phi_l)), int(np.size(g.phi_v))
    k_node, k_scan, k_inv = _kappa_slots(kappa)
    axes: dict[str, Any] = {
        "kappa": kappa, "kappa_inv_d": _inv_spacing(kappa),
        "theta_l": theta_l, "theta_l_inv_d": _inv_spacing(theta_l), "theta_l_inv_step": inv_tl,
        "theta_v": theta_v, "theta_v_inv_d": _inv_spacing(theta_v), "theta_v_inv_step": inv_tv,
        "phi_l0": float(g.phi_l[0]), "phi_l_inv_step": n_pl / PERIOD_DEG,
        "phi_v0": float(g.phi_v[0]), "phi_v_inv_step": n_pv / PERIOD_DEG,
        "kappa_node": k_node, "kappa_scan": k_scan, "kappa_slot_inv_d": k_inv, "isotropic": iso,
    }
    kernel = KernelGrid(flat=flat, stride=stride,
                        shape=tuple(int(n) for n in values.shape), **axes)  # type: ignore[arg-type]
    return LookupGrid(values=values, kernel=kernel, phi_l_step=PERIOD_DEG / n_pl, phi_v_step=PERIOD_DEG / n_pv,
                      rgb_kernel=bool(nc == 3 and inv_tl > 0.0 and inv_tv > 0.0 and kappa.size <= RGB_MAX_KAPPA))


def _as_query(name: str, x: ArrayLike) -> NDArray[np.floating]:
    if np.ma.is_masked(x):  # np.asarray would drop the mask: masked entries would be looked up as numbers
        raise QueryError(f"{name}: a masked array with masked entries; fill them (e.g. .filled(np.nan): NaN rows)")
    try:
        a = np.asarray(x)
    except (TypeError, ValueError) as exc:
        raise QueryError(f"{name}: cannot be read as numbers ({exc})") from None
    if a.dtype not in (np.float64, np.float32):
        if not (np.issubdtype(a.dtype, np.number) or a.dtype == bool):
            raise QueryError(f"{name}: expected numbers, got dtype {a.dtype}")
        if np.iscomplexobj(a):
            raise QueryError(f"{name}: complex values are not angles or curvatures")
        a = a.astype(np.float64)
    return a


def _kernel_array(a: NDArray[Any]) -> NDArray[np.float64]:
    """A read-only view of a 1-D float64 query array: the kernels see one array type (no recompiling)."""
    v = a.view()
    v.flags.writeable = False
    return v


def _run(run: Any, grid: KernelGrid, tol: float, queries: list[Any], n: int, out: NDArray[np.float64],
         offset: int) -> tuple[int, int]:
    """Run a lookup kernel over ``n`` queries into ``out[offset:offset + n]``, in threads when large.

    Returns the counts of bad view and light elevations.
    """
    from ._jit import run_split

    got = run_split(lambda start, stop: run(grid, tol, *queries, start, stop, out, offset), n,
                    grain=_MIN_QUERIES_PER_THREAD)
    return sum(g[0] for g in got), sum(g[1] for g in got)


def evaluate(
    table: _Table,
    theta_v: ArrayLike,
    phi_v: ArrayLike,
    theta_l: ArrayLike,
    phi_l: ArrayLike,
    kappa: ArrayLike = 0.0,
    *,
    on_invalid: str = "raise",
    kernel: str = "auto",
) -> NDArray[np.float64]:
    """Interpolate ``table`` at continuous directions (degrees) and curvature (mm^-1).

    Arguments broadcast against each other (NumPy rules); the result has shape
    ``broadcast_shape + (n_channels,)``, float64. See the module docstring for
    the interpolation and pole rules.

    Parameters
    ----------
    table
        A :class:`~cdbrdf.table.CDBRDF`.
    theta_v, phi_v, theta_l, phi_l
        View and light elevation (in [0, 90]) and azimuth (any real), degrees.
    kappa
        Curvature, mm^-1 (clamped to the table's range).
    on_invalid
        ``"raise"`` (default): an elevation outside [0, 90] raises
        :class:`QueryError`; ``"nan"``: such rows are NaN.
    kernel
        One of :data:`KERNELS` (for tests and benchmarks; the results agree
        to rounding): ``"auto"`` (default), ``"rgb"`` (only where
        :attr:`LookupGrid.rgb_kernel`), ``"generic"``.

    Returns
    -------
    numpy.ndarray
        Interpolated values; rows with a non-finite input are NaN.

    Raises
    ------
    QueryError
        For an elevation outside [0, 90] (with ``on_invalid="raise"``),
        arguments that are not numbers or do not broadcast, and an unknown
        ``on_invalid`` or ``kernel``.
    """
    from . import _kernels

    if on_invalid not in _ON_INVALID:
        raise QueryError(f"on_invalid: {on_invalid!r} is not one of {', '.join(_ON_INVALID)}")
    if kernel not in KERNELS:
        raise QueryError(f"kernel: {kernel!r} is not one of {', '.join(KERNELS)}")
    names = ("theta_v", "phi_v", "theta_l", "phi_l", "kappa")
    qs = [_as_query(n, x) for n, x in zip(names, (theta_v, phi_v, theta_l, phi_l, kappa))]
    try:
        shape = np.broadcast_shapes(*(q.shape for q in qs))
    except ValueError:
        raise QueryError(
            "theta_v, phi_v, theta_l, phi_l, kappa: shapes "
            + ", ".join(str(q.shape) for q in qs)
            + " do not broadcast together"
        ) from None
    lg = table.lookup_grid()
    if kernel == "rgb" and not lg.rgb_kernel:
        raise QueryError(
            "kernel: 'rgb' needs 3 channels, evenly spaced elevations and at most "
            f"{RGB_MAX_KAPPA} curvatures; this table has shape {lg.shape}"
        )
    run = _kernels.lookup_rgb if (kernel == "rgb" or (kernel == "auto" and lg.rgb_kernel)) else _kernels.lookup_generic
    tol = SNAP_TOLERANCE["float64"]  # the kernels compute in float64
    nc = lg.n_channels
    n = int(np.prod(shape, dtype=np.int64))
    out = np.empty((n, nc), dtype=np.float64)

    direct: list[NDArray[np.float64] | None] = []
    for q in qs:
        if q.size == 1:
            direct.append(_kernel_array(q.reshape(1).astype(np.float64)))
        elif q.shape == shape and q.flags.c_contiguous and q.dtype == np.float64:
            direct.append(_kernel_array(q.reshape(-1)))
        else:
            direct.append(None)
    bad_v = bad_l = 0
    if n == 0:
        pass
    elif all(d is not None for d in direct):
        bad_v, bad_l = _run(run, lg.kernel, tol, direct, n, out, 0)
    else:
        views = [np.broadcast_to(q, shape) if d is None else None for q, d in zip(qs, direct)]
        for s in range(0, n, _CHUNK):
            e = min(n, s + _CHUNK)
            args = [d if d is not None else _kernel_array(v.flat[s:e].astype(np.float64))  # type: ignore[union-attr]
                    for d, v in zip(direct, views)]
            a, b = _run(run, lg.kernel, tol, args, e - s, out, s)
            bad_v += a
            bad_l += b
    if on_invalid == "raise" and (bad_v or bad_l):
        which = [f"theta_v ({bad_v} queries)"] * bool(bad_v) + [f"theta_l ({bad_l} queries)"] * bool(bad_l)
        raise QueryError(
            "elevation outside [0, 90] degrees in " + " and ".join(which)
            + "; directions below the surface have no reflectance"
        )
    return out.reshape(shape + (nc,))


# -- the rule, written out slowly ----------------------------------------------------------
def _snap(w: float, tol: float) -> float:
    """The snapping rule: a weight within ``tol`` of 0 or 1 becomes exactly 0 or 1."""
    if w < tol:
        return 0.0
    if w > 1.0 - tol:
        return 1.0
    return w


def _linear(axis: NDArray[np.float64], x: float, tol: float) -> list[tuple[int, float]]:
    """The two nodes of ``x`` on a sorted axis and their weights (clamped at both ends)."""
    n = axis.size
    if n == 1:
        return [(0, 1.0)]
    x = min(max(x, float(axis[0])), float(axis[-1]))
    i = min(int(np.searchsorted(axis, x, side="right")) - 1, n - 2)
    w = _snap((x - axis[i]) / (axis[i + 1] - axis[i]), tol)
    return [(i, 1.0 - w), (i + 1, w)]


def _periodic(phi0: float, step: float, n: int, x: float, tol: float) -> list[tuple[int, float]]:
    """The two nodes of azimuth ``x`` on an evenly spaced circle and their weights."""
    if n == 1:
        return [(0, 1.0)]
    u = (wrap_azimuth(x) - phi0) / step
    f = math.floor(u)
    w = _snap(u - f, tol)
    return [(f % n, 1.0 - w), ((f + 1) % n, w)]


def _at_pole(nodes: list[tuple[int, float]]) -> bool:
    """Whether elevation ``nodes`` sit exactly on node 0 (theta = 0)."""
    return nodes[0] == (0, 1.0)


def evaluate_reference(
    table: _Table, theta_v: float, phi_v: float, theta_l: float, phi_l: float, kappa: float = 0.0
) -> NDArray[np.float64]:
    """Slow, readable pure-Python lookup of one query: the rule of this module, step by step.

    Uses the table's :class:`LookupGrid` and the float64
    :data:`SNAP_TOLERANCE`, like :func:`evaluate` (which agrees to rounding).

    Parameters
    ----------
    table
        A :class:`~cdbrdf.table.CDBRDF`.
    theta_v, phi_v, theta_l, phi_l
        Elevations and azimuths, degrees.
    kappa
        Curvature, mm^-1.

    Returns
    -------
    numpy.ndarray
        ``(n_channels,)`` float64; NaN when a component is not finite or an
        elevation lies outside [0, 90] (as ``evaluate(..., on_invalid="nan")``).
    """
    lg = table.lookup_grid()
    tol = snap_tolerance(np.float64)
    q = [float(x) for x in (theta_v, phi_v, theta_l, phi_l, kappa)]
    tv, pv, tl, pl, k = q
    if not all(math.isfinite(x) for x in q) or not (
        0.0 <= tv <= MAX_ELEVATION_DEG and 0.0 <= tl <= MAX_ELEVATION_DEG
    ):
        return np.full(lg.n_channels, np.nan)
    _, n_pl, _, n_pv, _, _ = lg.shape
    if lg.isotropic:
        # rotate the query about the normal to light azimuth 0: look up the azimuth difference
        pv = wrap_azimuth(wrap_azimuth(pv) - wrap_azimuth(pl))
        pl = 0.0
    k_nodes = _linear(lg.kappa, k, tol)
    tl_nodes = _linear(lg.theta_l, tl, tol)
    tv_nodes = _linear(lg.theta_v, tv, tol)
    pl_nodes = _periodic(lg.phi_l0, lg.phi_l_step, n_pl, pl, tol)
    pv_nodes = _periodic(lg.phi_v0, lg.phi_v_step, n_pv, pv, tol)
    # pole rule: at theta = 0 the ring holds one value; the azimuth must not matter
    if _at_pole(tl_nodes):
        pl_nodes = [(pl_nodes[0][0], 1.0)]
        if lg.isotropic:  # the stored azimuth is the difference: it depends on the light too
            pv_nodes = [(pv_nodes[0][0], 1.0)]
    if _at_pole(tv_nodes):
        pv_nodes = [(pv_nodes[0][0], 1.0)]
    # the (up to) 32 corners of the cell and their weights, the products of the axes' weights
    corners = [((ik, ipl, itl, ipv, itv), wk * wpl * wtl * wpv * wtv)
               for ik, wk in k_nodes for ipl, wpl in pl_nodes for itl, wtl in tl_nodes
               for ipv, wpv in pv_nodes for itv, wtv in tv_nodes]
    weights = np.array([w for _, w in corners])
    v = np.array([lg.values[c] for c, _ in corners], dtype=np.float64)  # float32 tables: summed in float64
    return np.sum(weights[:, None] * v, axis=0)
