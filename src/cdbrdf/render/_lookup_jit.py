"""The lookup rule of :mod:`cdbrdf.interp` written in Dr.Jit, for the renderer.

The plug-in (:mod:`cdbrdf.render._bsdf`) calls :func:`lookup_jit` inside its
``eval``: in ``llvm_ad_rgb`` Dr.Jit traces it once per render into
straight-line vector code (compares, selects and 32 gathers of a packed RGB
sample), never a Python call per ray.

It follows the rule of :mod:`cdbrdf.interp` on the same
:class:`~cdbrdf.interp.LookupGrid` (pole-applied values, axes, inverse
spacings, azimuth origins and inverse steps) with interp's constants:
curvature and elevations linear and clamped at both ends, azimuths linear and
periodic, every weight snapped to exactly 0 or 1 within
``interp.snap_tolerance`` of the variant's precision (1e-6 in float32), and
the pole rule (at elevation node 0 with weight 0 the azimuth weight is 0)
and, on isotropic tables, the rotation of the query (the view azimuth axis
holds ``phi_v - phi_l``).
It differs from the float64 lookup in two documented ways only:

- arithmetic in the variant's precision (float32 in ``llvm_ad_rgb``) and RGB
  samples packed into 21-bit fixed point (:func:`pack_table`), so it agrees
  with :func:`cdbrdf.interp.evaluate` to about 3e-5 of the table's range;
- no exact ``fmod`` reduction of huge azimuths (the plug-in's azimuths come
  from ``atan2``, within [-180, 180]): a lane whose wrapped index is not a
  number in range (a non-finite azimuth, or one whose float32 floor does not
  wrap exactly) uses node 0 with weight 0, so no gather ever leaves the table.

Invalid queries are not turned into NaN here: an elevation outside [0, 90] is
clamped, a NaN elevation or curvature gives NaN; the caller masks invalid
directions (the plug-in returns 0 for them).
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

from ..colour import LUMINANCE_WEIGHTS
from ..errors import TableError
from ..interp import LookupGrid, snap_tolerance
from ..table import MAX_ABS_VALUE as TABLE_MAX_ABS_VALUE

__all__ = [
    "LAYOUTS",
    "MAX_ABS_VALUE",
    "PACK_BITS",
    "PACK_MAX_RELATIVE_STEP",
    "RECORDS",
    "TableUpload",
    "Corners",
    "check_range",
    "corners_jit",
    "float_table",
    "gather_jit",
    "linear_upload",
    "lookup_jit",
    "pack_table",
    "record_table",
    "packet_index",
    "packing_is_fine",
    "packet_maps",
    "apply_maps",
    "records",
]

#: Largest table value (in magnitude) the renderer accepts: the table's own bound
#: (:data:`cdbrdf.table.MAX_ABS_VALUE`); its arithmetic is float32 (largest 3.4e38),
#: with headroom for the weighted sums and ``scale``. Checked again on values given
#: through ``mi.traverse``.
MAX_ABS_VALUE = TABLE_MAX_ABS_VALUE

#: Bits per channel of the packed RGB table (3 x 21 bits in one 64-bit word).
PACK_BITS = 21
_PACK_MAX = (1 << PACK_BITS) - 1
#: Samples packed per block by :func:`pack_table`.
_PACK_CHUNK = 1 << 18


def _tolerance(dr: Any, Float: Any) -> float:
    """The snap tolerance of the variant's precision (float32 or float64)."""
    return snap_tolerance("float64" if dr.type_v(Float) == dr.VarType.Float64 else "float32")


def _snap(dr: Any, w: Any, tol: float) -> Any:
    """interp's snapping rule: a weight within ``tol`` of 0 or 1 becomes exactly 0 or 1."""
    w = dr.select(w < tol, 0.0, w)
    return dr.select(w > 1.0 - tol, 1.0, w)


def _locate(dr: Any, Float: Any, UInt: Any, axis: np.ndarray, inv_d: np.ndarray, x: Any, tol: float) -> tuple[Any, Any]:
    """Lower index and weight of ``x`` on a sorted axis, clamped at both ends.

    The Dr.Jit form of ``cdbrdf._kernels._locate``: the index is a scan of the
    interior nodes with selects (axes are short), the weight
    ``(x - axis[i]) * inv_d[i]`` clipped to [0, 1] and snapped. The index is
    in ``[0, n - 2]`` for every input, NaN included.
    """
    n = axis.size
    if n == 1:
        return UInt(0), Float(0.0)
    lo = UInt(0)
    a0 = Float(float(axis[0]))
    inv = Float(float(inv_d[0]))
    for j in range(1, n - 1):
        m = x >= float(axis[j])
        lo = dr.select(m, UInt(j), lo)
        a0 = dr.select(m, Float(float(axis[j])), a0)
        inv = dr.select(m, Float(float(inv_d[j])), inv)
    w = dr.clip((x - a0) * inv, 0.0, 1.0)
    return lo, _snap(dr, w, tol)


def _locate_periodic(dr: Any, Float: Any, UInt: Any, phi0: float, inv_step: float, n: int, x: Any,
                     tol: float) -> tuple[Any, Any]:
    """Lower index and weight of an azimuth on an evenly spaced circle.

    A weight within ``tol`` of 0 snaps to this node, within ``tol`` of 1 to
    the next one (index + 1, weight 0), as in ``cdbrdf._kernels``. The index
    is in ``[0, n)`` for every input, NaN and infinities included: a lane
    whose wrapped position is not a number in range gets index 0 and weight 0.
    """
    if n == 1:
        return UInt(0), Float(0.0)
    u = (x - phi0) * inv_step
    f = dr.floor(u)
    w = u - f
    up = w > 1.0 - tol
    f = dr.select(up, f + 1.0, f)
    w = dr.select(up | (w < tol), 0.0, w)
    i = f - n * dr.floor(f / n)
    ok = (i >= 0.0) & (i <= n - 1.0) & (w >= 0.0) & (w < 1.0)  # False for NaN
    i = dr.select(ok, i, 0.0)
    w = dr.select(ok, w, 0.0)
    return UInt(dr.clip(i, 0.0, n - 1.0)), w


# -- uploads ---------------------------------------------------------------------------------------
class TableUpload(NamedTuple):
    """A prepared table on the device, in one of two layouts.

    Attributes
    ----------
    layout
        ``"packed"``: one record per table sample (RGB as three
        :data:`PACK_BITS`-bit fixed-point channels in a 64-bit word, one
        channel as float32); ``"float"``: float32 *packets*, one per sample
        ``(k, pl, tl, pv, tv)`` holding the records of ``(pv, tv)``,
        ``(pv, tv + 1)``, ``(pv + 1, tv)`` and ``(pv + 1, tv + 1)`` (``pv``
        periodic, ``tv + 1`` clamped), so one gather fetches four samples;
        ``"records"``: float32 records, one per sample (:func:`record_table`).
    record
        What a record holds (:data:`RECORDS`): ``"rgb"`` (R, G, B, 0),
        ``"one"`` (one value: a one-channel table, or luminance in mono
        variants) or ``"spectral"`` (Mitsuba's sRGB model coefficients and a
        scale, :func:`cdbrdf.render._spectral.spectral_records`).
    buffer
        The Dr.Jit array.
    offset, step
        The fixed-point code of packed RGB (``value = offset + step * q``);
        0 and 1 otherwise.
    """

    layout: str
    record: str
    buffer: Any
    offset: float = 0.0
    step: float = 1.0

    @property
    def stride(self) -> int:
        """Floats per record in the ``"float"`` layout."""
        return 1 if self.record == "one" else 4


#: Layouts of an upload (``"auto"`` lets the plug-in choose).
LAYOUTS: tuple[str, ...] = ("packed", "float", "records")

#: Kinds of record.
RECORDS: tuple[str, ...] = ("rgb", "one", "spectral")


def check_range(values: NDArray[np.floating]) -> tuple[float, float]:
    """The smallest and largest value; refuse values beyond :data:`MAX_ABS_VALUE`."""
    v = np.asarray(values)
    lo, hi = float(v.min()), float(v.max())
    if max(abs(lo), abs(hi)) > MAX_ABS_VALUE:
        raise TableError(
            f"table values span {lo:g}..{hi:g}: the renderer computes in float32 and needs values "
            f"within +-{MAX_ABS_VALUE:g} (rescale the table, e.g. with the plug-in's 'scale')"
        )
    return lo, hi


#: Largest fixed-point step of the packed layout, relative to the table's median absolute value,
#: that ``storage="auto"`` accepts (beyond it, the float layout is used).
PACK_MAX_RELATIVE_STEP = 1e-3


def packing_is_fine(values: NDArray[np.floating]) -> bool:
    """Whether the 21-bit step of :func:`pack_table` is at most :data:`PACK_MAX_RELATIVE_STEP` of the median |value|.

    A table with a huge dynamic range (a grazing peak 10^5 times its median)
    would keep only a few fixed-point levels at its median values.
    """
    v = np.asarray(values, dtype=np.float64)
    if v.shape[-1] != 3:
        return True  # one-channel tables are float32 in both layouts
    step = (float(v.max()) - float(v.min())) / _PACK_MAX
    med = float(np.median(np.abs(v)))
    return step <= PACK_MAX_RELATIVE_STEP * med if med > 0 else step == 0.0


def pack_table(mi: Any, grid: LookupGrid, record: str | None = None) -> TableUpload:
    """Upload a prepared table in the ``"packed"`` layout.

    RGB tables are packed as three :data:`PACK_BITS`-bit fixed-point channels
    per 64-bit word (``value = offset + step * q``; ``step`` = range /
    (2^21 - 1), i.e. about 5e-7 of the table's range), so one gather fetches
    a whole sample. ``"one"`` records (a one-channel table, or the luminance
    of an RGB one) are float32.

    Parameters
    ----------
    mi
        The ``mitsuba`` module, with a variant set.
    grid
        The table's prepared grid (``table.lookup_grid()``).
    record
        ``"rgb"`` or ``"one"`` (default: ``"rgb"`` for 3 channels, else ``"one"``).

    Returns
    -------
    TableUpload
    """
    v = np.asarray(grid.values)
    lo, hi = check_range(v)
    record = record or ("rgb" if v.shape[-1] == 3 else "one")
    if record not in ("rgb", "one"):
        raise ValueError(f"record: the packed layout holds 'rgb' or 'one' records, not {record!r}")
    if record == "one":
        return TableUpload("packed", "one", mi.Float(records(v, "one").reshape(-1)))
    step = (hi - lo) / _PACK_MAX if hi > lo else 1.0
    flat = v.reshape(-1, 3)
    word = np.empty(flat.shape[0], dtype=np.uint64)
    for s in range(0, flat.shape[0], _PACK_CHUNK):  # in float64 a block at a time (large uploads: the CD-BTF)
        q = np.rint((flat[s : s + _PACK_CHUNK].astype(np.float64) - lo) / step).astype(np.uint64)
        word[s : s + _PACK_CHUNK] = q[:, 0] | (q[:, 1] << np.uint64(PACK_BITS)) | (q[:, 2] << np.uint64(2 * PACK_BITS))
    import drjit as dr

    UInt64: Any = dr.uint64_array_t(mi.Float)
    return TableUpload("packed", "rgb", UInt64(word), lo, step)


def packet_index(shape5: tuple[int, ...], stride: int) -> NDArray[np.int64]:
    """For every float of the ``"float"`` layout, the index of the record float it copies.

    ``shape5`` is the prepared grid's ``(n_kappa, n_phi_l, n_theta_l,
    n_phi_v, n_theta_v)``; records are stored ``stride`` floats each in that
    C order.
    """
    nk, npl, ntl, npv, ntv = shape5
    s = np.arange(nk * npl * ntl * npv * ntv).reshape(shape5)
    pv1 = np.roll(s, -1, axis=3)
    tv1 = np.concatenate([s[..., 1:], s[..., -1:]], axis=4)
    pvtv1 = np.concatenate([pv1[..., 1:], pv1[..., -1:]], axis=4)
    samples = np.stack([s, tv1, pv1, pvtv1], axis=-1)  # (..., 4)
    return (samples[..., None] * stride + np.arange(stride)).reshape(-1)


def records(values: NDArray[np.floating], record: str) -> NDArray[np.float32]:
    """Records ``(..., stride)`` of prepared values ``(..., channels)``."""
    v = np.asarray(values, dtype=np.float64)
    if record == "one":
        return (v if v.shape[-1] == 1 else (v @ LUMINANCE_WEIGHTS)[..., None]).astype(np.float32)
    if record == "spectral":
        from ._spectral import spectral_records

        if v.shape[-1] == 1:
            raise ValueError("a one-channel table has 'one' records (a flat spectrum)")
        return spectral_records(v)
    out = np.zeros(v.shape[:-1] + (4,), dtype=np.float32)
    out[..., :3] = v
    return out


def float_table(mi: Any, grid: LookupGrid, record: str) -> TableUpload:
    """Upload a prepared table in the ``"float"`` (packet) layout with records of kind ``record``."""
    if record not in RECORDS:
        raise ValueError(f"record: {record!r} is not one of {', '.join(RECORDS)}")
    check_range(grid.values)
    rec = records(grid.values, record)
    stride = rec.shape[-1]
    flat = rec.reshape(-1)[packet_index(grid.values.shape[:5], stride)]
    return TableUpload("float", record, mi.Float(np.ascontiguousarray(flat)))


def record_table(mi: Any, grid: LookupGrid, record: str) -> TableUpload:
    """Upload a prepared table in the ``"records"`` layout: one record of kind ``record`` per sample.

    A quarter of the ``"float"`` layout's memory, four times as many gathers
    (of one record each); the lookup sums the same terms in the same order, so
    it gives the same values. Used for the texels of a CD-BTF in spectral
    variants (:mod:`cdbrdf.render._btf_jit`), where the packets would take
    64 bytes per sample.
    """
    if record not in RECORDS:
        raise ValueError(f"record: {record!r} is not one of {', '.join(RECORDS)}")
    check_range(grid.values)
    return TableUpload("records", record, mi.Float(np.ascontiguousarray(records(grid.values, record).reshape(-1))))


# -- the differentiable upload: raw table values -> packets, one sparse linear map -------------------
def _pole_pass(theta: NDArray[np.float64], n_phi: int, light: bool, isotropic: bool = False) -> NDArray[np.float64]:
    """interp's pole rule on one (theta, phi) pair of axes, as a dense matrix.

    Anisotropic light pass: ``(n_phi_l, n_theta_out, n_phi_l * n_theta)`` on
    the (phi_l, theta_l) axes; isotropic light pass: ``(n_theta_out, n_phi_v,
    n_theta * n_phi_v)`` on the (theta_l, phi_v) axes (its light pole averages
    the azimuth difference); view pass: ``(n_phi_v, n_theta_out, n_phi_v *
    n_theta)`` on (phi_v, theta_v). Obtained by running
    :func:`cdbrdf.interp.apply_pole_rule` on the identity, so it is the owner's rule
    by construction.
    """
    from ..interp import apply_pole_rule

    n_theta = theta.size
    m = n_phi * n_theta
    other = np.array([45.0])  # the other elevation axis: one node above 0, untouched by this pass
    if light and isotropic:
        values = np.eye(m).reshape(n_theta, n_phi, m)[None, None, :, :, None, :]
        return np.asarray(apply_pole_rule(values, theta, other, isotropic=True)[0][0, 0, :, :, -1, :], dtype=np.float64)
    eye = np.eye(m).reshape(n_phi, n_theta, m)
    if light:
        values = eye[None, :, :, None, None, :]
        pole = apply_pole_rule(values, theta, other, isotropic=False)[0]
        return np.asarray(pole[0, :, :, 0, -1, :], dtype=np.float64)
    values = eye[None, None, None, :, :, :]
    pole = apply_pole_rule(values, other, theta, isotropic=isotropic)[0]
    return np.asarray(pole[0, 0, -1, :, :, :], dtype=np.float64)


def _factor(dense: NDArray[np.float64]) -> tuple[Any, Any]:
    """``dense = select @ unique``: its distinct rows (sparse) and the selection of each row."""
    import scipy.sparse as sp

    unique, inverse = np.unique(dense, axis=0, return_inverse=True)
    inverse = np.asarray(inverse).reshape(-1)
    select = sp.csr_matrix((np.ones(inverse.size), (np.arange(inverse.size), inverse)),
                           shape=(inverse.size, unique.shape[0]))
    return select, sp.csr_matrix(unique)


def packet_maps(raw_shape: tuple[int, ...], theta_l: NDArray[np.float64], theta_v: NDArray[np.float64],
                record: str, *, isotropic: bool = False) -> tuple[Any, ...]:
    """Sparse matrices (scipy CSR) whose product maps the raw values (C order) to the ``"float"`` layout.

    Applied in the order given (``packets = M[-1] @ ... @ M[0] @ raw``), they
    are the light and view pole rules of :func:`cdbrdf.interp.prepare`
    (:func:`_pole_pass`, each split into its distinct rows and a selection,
    so that the ring means are summed once, not once per azimuth), the record
    map (RGB padded to 4, or the luminance for a ``"one"`` record of an RGB
    table) and :func:`packet_index`. Linear in the values, so the renderer
    can differentiate through them.
    """
    import scipy.sparse as sp

    nk, npl, ntl, npv, ntv, nc = raw_shape
    if isotropic:  # the light pole averages the azimuth difference (the phi_v axis)
        lp = _pole_pass(np.asarray(theta_l, dtype=np.float64), npv, light=True, isotropic=True)
        ntl_o = lp.shape[0]
        l_sel, l_uni = _factor(lp.reshape(ntl_o * npv, ntl * npv))
    else:
        lp = _pole_pass(np.asarray(theta_l, dtype=np.float64), npl, light=True)
        ntl_o = lp.shape[1]
        l_sel, l_uni = _factor(lp.reshape(npl * ntl_o, npl * ntl))
    vp = _pole_pass(np.asarray(theta_v, dtype=np.float64), npv, light=False, isotropic=isotropic)
    ntv_o = vp.shape[1]
    v_sel, v_uni = _factor(vp.reshape(npv * ntv_o, npv * ntv))

    def eye(n: int) -> Any:
        return sp.identity(n, format="csr")

    def on(a: int, m: Any, b: int) -> Any:
        return sp.kron(sp.kron(eye(a), m), eye(b), format="csr")

    n_samples = nk * npl * ntl_o * npv * ntv_o
    if record == "rgb":
        if nc != 3:
            raise ValueError("'rgb' records need a 3-channel table")
        per, stride = np.eye(4, 3), 4
    elif record == "one":
        if nc not in (1, 3):
            raise ValueError("'one' records need a 1- or 3-channel table")
        per, stride = (np.atleast_2d(LUMINANCE_WEIGHTS) if nc == 3 else np.ones((1, 1))), 1
    else:
        raise ValueError(f"record {record!r}: only 'rgb' and 'one' records are linear in the table")
    idx = packet_index((nk, npl, ntl_o, npv, ntv_o), stride)
    gather = sp.csr_matrix((np.ones(idx.size), (np.arange(idx.size), idx)), shape=(idx.size, n_samples * stride))
    rec = sp.kron(eye(n_samples), sp.csr_matrix(per), format="csr")
    # the light pass acts on (phi_l, theta_l), or (theta_l, phi_v) when isotropic; the view pass on (phi_v, theta_v)
    before, after = (nk * npl, ntv * nc) if isotropic else (nk, npv * ntv * nc)
    first = on(before, l_uni, after)
    second = on(nk * npl * ntl_o, v_uni, nc) @ on(before, l_sel, after)
    third = gather @ rec @ on(nk * npl * ntl_o, v_sel, nc)
    return first.tocsr(), second.tocsr(), third.tocsr()


def apply_maps(maps: tuple[Any, ...], values: NDArray[np.floating]) -> NDArray[np.float64]:
    """``maps`` applied to flat values in NumPy (the reference of :func:`linear_upload`)."""
    x = np.asarray(values, dtype=np.float64).reshape(-1)
    for m in maps:
        x = m @ x
    return x


def _apply_jit(mi: Any, x: Any, m: Any) -> Any:
    """``m @ x`` in Dr.Jit with gathers only: rows grouped by their number of terms, summed in a fixed order.

    Deterministic (a scatter-add would sum in thread order), so rows with the
    same terms (the pole ring means) are equal bit for bit; differentiable.
    """
    import drjit as dr

    UInt = mi.UInt32
    csr = m.tocsr()
    csr.sort_indices()
    counts = np.diff(csr.indptr)
    out = dr.zeros(mi.Float, csr.shape[0])
    for c in np.unique(counts):
        if c == 0:
            continue
        rows = np.flatnonzero(counts == c)
        pos = csr.indptr[rows][:, None] + np.arange(c)[None, :]
        cols, vals = csr.indices[pos], csr.data[pos]
        acc = dr.gather(mi.Float, x, UInt(cols[:, 0].astype(np.uint32))) * mi.Float(vals[:, 0].astype(np.float32))
        for r in range(1, int(c)):
            acc = dr.fma(dr.gather(mi.Float, x, UInt(cols[:, r].astype(np.uint32))),
                         mi.Float(vals[:, r].astype(np.float32)), acc)
        dr.scatter(out, acc, UInt(rows.astype(np.uint32)))
    return out


def linear_upload(mi: Any, values: Any, maps: tuple[Any, ...], record: str) -> TableUpload:
    """The ``"float"`` layout as the product of :func:`packet_maps` with ``values``, in Dr.Jit.

    ``values`` is a flat ``mi.Float`` of the raw table (C order), e.g. the
    array of the tensor that ``mi.traverse`` exposes; the result is
    differentiable in it (gathers; their adjoints are scatter-adds).
    """
    x = values
    for m in maps:
        x = _apply_jit(mi, x, m)
    return TableUpload("float", record, x)


# -- the lookup ----------------------------------------------------------------------------------
def _array_x(mi: Any) -> Any:
    """The dynamic-size float array type of the variant's backend (packet gathers)."""
    import importlib

    return importlib.import_module(mi.Float.__module__).ArrayXf


class Corners(NamedTuple):
    """The 5-D cell of a lookup: what :func:`corners_jit` computes once and :func:`gather_jit` reads with.

    Attributes
    ----------
    outer
        The (kappa, phi_l, theta_l) corners: ``(row, weight)``, ``row`` the
        index of the corner's ``(n_phi_v, n_theta_v)`` slice in one table.
    ipv, wpv, itv, wtv
        Lower view azimuth and elevation node and their weights.
    rows
        Slices per table (``n_kappa * n_phi_l * n_theta_l``): a table of
        several (the texels of a CD-BTF) starts at ``block * rows``.
    """

    outer: list[tuple[Any, Any]]
    ipv: Any
    wpv: Any
    itv: Any
    wtv: Any
    rows: int


def corners_jit(mi: Any, grid: LookupGrid, theta_v: Any, phi_v: Any, theta_l: Any, phi_l: Any,
                kappa: Any) -> Corners:
    """The interpolation cell of the queries (indices and weights of the rule; see :func:`lookup_jit`)."""
    import drjit as dr

    Float, UInt = mi.Float, mi.UInt32
    tol = _tolerance(dr, Float)
    nk, npl, ntl, npv, ntv, nc = grid.values.shape
    if grid.isotropic:  # the view azimuth axis holds phi_v - phi_l (interp's rotation)
        phi_v = phi_v - phi_l
    ik, wk = _locate(dr, Float, UInt, grid.kappa, grid.kappa_inv_d, kappa, tol)
    itl, wtl = _locate(dr, Float, UInt, grid.theta_l, grid.theta_l_inv_d, theta_l, tol)
    itv, wtv = _locate(dr, Float, UInt, grid.theta_v, grid.theta_v_inv_d, theta_v, tol)
    ipl, wpl = _locate_periodic(dr, Float, UInt, grid.phi_l0, grid.phi_l_inv_step, npl, phi_l, tol)
    ipv, wpv = _locate_periodic(dr, Float, UInt, grid.phi_v0, grid.phi_v_inv_step, npv, phi_v, tol)
    # Pole: node 0 of an elevation axis is theta = 0 (one value for every azimuth).
    light_pole = (itl == 0) & (wtl == 0.0)
    wpl = dr.select(light_pole, 0.0, wpl)
    view_pole = (itv == 0) & (wtv == 0.0)
    if grid.isotropic:  # the stored azimuth difference depends on the light azimuth too
        view_pole = view_pole | light_pole
    wpv = dr.select(view_pole, 0.0, wpv)
    ipl1 = dr.select(ipl + 1 < npl, ipl + 1, 0)
    k_nodes = [(ik, 1.0 - wk), (ik + 1, wk)] if nk > 1 else [(ik, Float(1.0))]
    pl_nodes = [(ipl, 1.0 - wpl), (ipl1, wpl)] if npl > 1 else [(ipl, Float(1.0))]
    tl_nodes = [(itl, 1.0 - wtl), (itl + 1, wtl)] if ntl > 1 else [(itl, Float(1.0))]
    outer = []
    for ka, wa in k_nodes:
        for pb, wb in pl_nodes:
            wab = wa * wb
            base_b = (ka * npl + pb) * ntl
            for td, wd in tl_nodes:
                outer.append((base_b + td, wab * wd))
    return Corners(outer, ipv, wpv, itv, wtv, nk * npl * ntl)


def lookup_jit(mi: Any, grid: LookupGrid, table: TableUpload, theta_v: Any, phi_v: Any,
               theta_l: Any, phi_l: Any, kappa: Any, active: Any = True, wavelengths: Any = None,
               block: Any = None) -> Any:
    """Interpolate a prepared table in Dr.Jit (see the module docstring).

    Parameters
    ----------
    mi
        The ``mitsuba`` module, with a variant set.
    grid
        The table's prepared grid (``table.lookup_grid()``), 1 or 3 channels.
    table
        :func:`pack_table`, :func:`float_table`, :func:`record_table` or :func:`linear_upload` of ``grid``.
    theta_v, phi_v, theta_l, phi_l
        View and light elevation and azimuth, degrees (``mi.Float``).
    kappa
        Curvature, mm^-1 (``mi.Float``).
    active
        Lanes to gather for (the others read nothing and give 0 * weight).
    wavelengths
        For ``"spectral"`` records: the lanes' wavelengths (nm, ``mi.Spectrum``).
    block
        For an upload of several tables of ``grid``'s shape one after the
        other (the texels of a CD-BTF, :mod:`cdbrdf.render._btf_jit`): the
        table each lane reads (``mi.UInt32``); None: the only one.

    Returns
    -------
    mi.Color3f, mi.Float or mi.Spectrum
        ``"rgb"`` records: the RGB value; ``"one"``: the value in all three
        channels (``mi.Color3f``) or, with ``wavelengths`` given, as
        ``mi.Float``; ``"spectral"``: the spectrum at ``wavelengths``.
    """
    c = corners_jit(mi, grid, theta_v, phi_v, theta_l, phi_l, kappa)
    return gather_jit(mi, grid, table, c, active, wavelengths, block=block)


def gather_jit(mi: Any, grid: LookupGrid, table: TableUpload, c: Corners, active: Any = True,
               wavelengths: Any = None, block: Any = None) -> Any:
    """The table's value in the cell ``c`` (:func:`corners_jit`), of table ``block`` (see :func:`lookup_jit`).

    Several tables of one upload (the texels of a CD-BTF) read with the same
    cell: the weights and indices are computed once, only the gathers repeat.
    """
    import drjit as dr

    Float = mi.Float
    nk, npl, ntl, npv, ntv, nc = grid.values.shape
    outer = c.outer
    if block is not None:  # tables one after the other: table b starts at row b * rows
        start = block * c.rows
        outer = [(b + start, w) for b, w in outer]
    ipv, wpv, itv, wtv = c.ipv, c.wpv, c.itv, c.wtv
    if table.layout == "float":
        return _lookup_packets(mi, table, outer, ipv, wpv, itv, wtv, npv, ntv, active, wavelengths)
    ipv1 = dr.select(ipv + 1 < npv, ipv + 1, 0)
    if table.layout == "records":  # one record per sample, read in the order of the packets
        tv1 = dr.select(itv + 1 < ntv, itv + 1, itv)
        inner = [(ipv, itv, (1.0 - wpv) * (1.0 - wtv)), (ipv, tv1, (1.0 - wpv) * wtv),
                 (ipv1, itv, wpv * (1.0 - wtv)), (ipv1, tv1, wpv * wtv)]
        return _lookup_records(mi, table, outer, inner, npv, ntv, active, wavelengths)
    pv_nodes = [(ipv, 1.0 - wpv), (ipv1, wpv)] if npv > 1 else [(ipv, Float(1.0))]
    tv_nodes = [(itv, 1.0 - wtv), (itv + 1, wtv)] if ntv > 1 else [(itv, Float(1.0))]
    Int32 = dr.int32_array_t(Float)
    rgb = table.record == "rgb"
    buf = table.buffer
    acc = [Float(0.0) for _ in range(3 if rgb else 1)]
    for base_d, wabd in outer:
        base_d = base_d * npv
        for pe, we in pv_nodes:
            wabde = wabd * we
            base_e = (base_d + pe) * ntv
            for tf, wf in tv_nodes:
                w = wabde * wf
                idx = base_e + tf
                if rgb:
                    word = dr.gather(type(buf), buf, idx, active)
                    acc[0] += w * Float(Int32(word & _PACK_MAX))
                    acc[1] += w * Float(Int32((word >> PACK_BITS) & _PACK_MAX))
                    acc[2] += w * Float(Int32(word >> (2 * PACK_BITS)))
                else:
                    acc[0] += w * dr.gather(Float, buf, idx, active)
    if rgb:
        return mi.Color3f(acc[0], acc[1], acc[2]) * table.step + table.offset
    return acc[0] if wavelengths is not None else mi.Color3f(acc[0])


def _lookup_records(mi: Any, table: TableUpload, outer: list[tuple[Any, Any]], inner: list[tuple[Any, Any, Any]],
                    npv: int, ntv: int, active: Any, wavelengths: Any) -> Any:
    """The ``"records"`` layout: one record gather per corner, summed as :func:`_lookup_packets` sums.

    The same terms in the same order as the packet layout of the same
    records, so both give the same value to the last bit.
    """
    import drjit as dr

    ArrayXf = _array_x(mi)
    stride = table.stride
    spectral = table.record == "spectral"
    spec = dr.zeros(mi.Spectrum) if spectral else None
    acc = [mi.Float(0.0) for _ in range(4 * stride)]
    for base, w in outer:
        base = base * npv
        for j, (pe, tf, wi) in enumerate(inner):
            r = dr.gather(ArrayXf, table.buffer, (base + pe) * ntv + tf, active, shape=(stride, 1))
            if spectral:
                col = mi.Vector3f(r[0], r[1], r[2])
                spec += (w * wi * r[3]) * mi.srgb_model_eval(col, wavelengths)
            else:
                for k in range(stride):
                    acc[j * stride + k] = dr.fma(w, r[k], acc[j * stride + k])
    if spectral:
        return spec
    wts = [wi for _, _, wi in inner]
    if table.record == "one":
        v = acc[0] * wts[0] + acc[1] * wts[1] + acc[2] * wts[2] + acc[3] * wts[3]
        return v if wavelengths is not None else mi.Color3f(v)
    return mi.Color3f(*[acc[c] * wts[0] + acc[4 + c] * wts[1] + acc[8 + c] * wts[2] + acc[12 + c] * wts[3]
                        for c in range(3)])


def _lookup_packets(mi: Any, table: TableUpload, outer: list[tuple[Any, Any]], ipv: Any, wpv: Any, itv: Any,
                    wtv: Any, npv: int, ntv: int, active: Any, wavelengths: Any) -> Any:
    """The ``"float"`` layout: one packet gather per (kappa, phi_l, theta_l) corner."""
    import drjit as dr

    Float = mi.Float
    ArrayXf = _array_x(mi)
    stride = table.stride
    size = 4 * stride
    inner = [(1.0 - wpv) * (1.0 - wtv), (1.0 - wpv) * wtv, wpv * (1.0 - wtv), wpv * wtv]
    if table.record == "spectral":
        spec = dr.zeros(mi.Spectrum)
        for base, w in outer:
            pk = dr.gather(ArrayXf, table.buffer, (base * npv + ipv) * ntv + itv, active, shape=(size, 1))
            for j in range(4):
                c = mi.Vector3f(pk[4 * j], pk[4 * j + 1], pk[4 * j + 2])
                spec += (w * inner[j] * pk[4 * j + 3]) * mi.srgb_model_eval(c, wavelengths)
        return spec
    acc = [Float(0.0) for _ in range(size)]
    for base, w in outer:
        pk = dr.gather(ArrayXf, table.buffer, (base * npv + ipv) * ntv + itv, active, shape=(size, 1))
        for j in range(size):
            acc[j] = dr.fma(w, pk[j], acc[j])
    if table.record == "one":
        v = acc[0] * inner[0] + acc[1] * inner[1] + acc[2] * inner[2] + acc[3] * inner[3]
        return v if wavelengths is not None else mi.Color3f(v)
    out = [acc[c] * inner[0] + acc[4 + c] * inner[1] + acc[8 + c] * inner[2] + acc[12 + c] * inner[3]
           for c in range(3)]
    return mi.Color3f(*out)
