"""The curvature-dependent BTF: a CDBRDF per texel of one weave repeat, stored compressed.

A :class:`CDBTF` holds reflectance over texel position ``(u, v)`` within one
repeat of the fabric (periodic; ``u`` along the material's reference tangent
x, ``v`` along y, both in mm of the flat fabric), the five axes of a
:class:`~cdbrdf.grid.Grid` and the channels. It is stored as its tile mean (a
:class:`~cdbrdf.CDBRDF`: what a patch larger than the repeat reflects) plus a
rank-``r`` factorisation of the texels' deviations from it::

    B(u, v, d) = mean(d) + sum_i w_i(u, v) basis_i(d)

``d`` is (kappa, phi_l, theta_l, phi_v, theta_v, channel). The weights live on
``n_v x n_u`` texel centres; between them they are interpolated bilinearly and
periodically. The mean and the basis are looked up together as one table of
``(1 + r) x channels`` channels by the rule of :mod:`cdbrdf.interp` (the pole
rule and clamping are linear, so looking up the factors and combining them is
looking up the decoded texels). A curved fabric's repeat is stretched on its
face; the texel coordinates are fractions of the repeat at every curvature,
measured in mm of the flat repeat.
"""

from __future__ import annotations

import copy
import logging
from collections.abc import Mapping
from os import PathLike
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import FormatError, QueryError, TableError
from ..grid import Grid, read_array
from ..provenance import Provenance
from ..table import CDBRDF, MAX_ABS_VALUE

if TYPE_CHECKING:
    from ..interp import LookupGrid
    from ._neural import FitOptions, Neural

__all__ = ["CDBTF", "COMPRESSION_ATTRS", "DEFAULT_MAX_ERROR", "DEFAULT_METHOD", "MAX_RANK", "METHODS", "load"]

_LOG = logging.getLogger(__name__)

#: Relative RMS error the compression aims at unless told otherwise.
DEFAULT_MAX_ERROR = 0.03

#: Most components a factorisation may have.
MAX_RANK = 256

#: The entries of :attr:`CDBTF.compression`.
COMPRESSION_ATTRS = ("method", "rank", "max_error", "relative_rms_error", "relative_rms_error_per_kappa",
                     "compression_ratio", "truncated_from", "neural_relative_rms_error", "fit_seconds")

#: Valid values of :meth:`CDBTF.from_values`'s ``method``: the representation of the texels.
METHODS = ("neural", "pca")

#: The representation ``cdbrdf synth --btf`` makes (:func:`cdbrdf.synth.texels.tabulate_btf`);
#: :meth:`CDBTF.from_values` keeps ``"pca"`` unless told (a measured CD-BTF, small tables).
DEFAULT_METHOD = "neural"

#: Queries looked up per chunk (bounds the memory of the ``(1 + rank) x channels`` lookups).
_CHUNK = 1 << 15


def _repeat_pair(name: str, value: Any) -> tuple[float, float]:
    from .file import REPEAT_MM_RANGE

    lo, hi = REPEAT_MM_RANGE
    with np.errstate(all="ignore"):
        a = read_array(name, value).astype(np.float64).reshape(-1)
    if a.size != 2 or not np.all(np.isfinite(a)) or np.any(a < lo) or np.any(a > hi):
        raise TableError(f"{name}: expected two sizes (u, v) from {lo:g} to {hi:g} mm, got {value!r}")
    return float(a[0]), float(a[1])


class CDBTF:
    """A curvature-dependent BTF: tile mean plus factorised texel deviations.

    Usually made by :meth:`from_values` (which compresses dense texels), by
    :meth:`cdbrdf.synth.ClothModel.tabulate_btf` or read by :func:`cdbrdf.btf.load`.

    Parameters
    ----------
    mean
        The tile mean, a :class:`~cdbrdf.CDBRDF` (its grid is the BTF's).
    weights
        ``(n_v, n_u, rank)``: each texel's weight of each component.
    basis
        ``mean.shape[:-1] + (rank, n_channels)``: the components, in the
        table's units.
    repeat_mm
        ``(size_u, size_v)``: the repeat's size on the flat fabric, mm.
    compression
        What the factorisation recorded (:data:`COMPRESSION_ATTRS`).
    neural
        A neural CD-BTF's latent pyramid and decoder (``docs/btf.md``), or None.

    Raises
    ------
    TableError
        When shapes disagree, values are not finite, the repeat is outside 0.01 mm to 10 m, or the
        factors could decode to values beyond the table's bound (1e30).
    """

    __slots__ = ("_mean", "_weights", "_basis", "_repeat", "_compression", "_lookup", "_neural")

    def __init__(self, mean: CDBRDF, weights: ArrayLike, basis: ArrayLike, *, repeat_mm: ArrayLike,
                 compression: Mapping[str, Any] | None = None, neural: Neural | None = None) -> None:
        if not isinstance(mean, CDBRDF):
            raise TableError(f"mean: expected a cdbrdf.CDBRDF, got {type(mean).__name__}")
        w = read_array("weights", weights).astype(np.float32)
        b = read_array("basis", basis).astype(np.float32)
        if w.ndim != 3 or min(w.shape[:2]) < 1:
            raise TableError(f"weights: expected (n_v, n_u, rank), got shape {w.shape}")
        want = mean.shape[:-1] + (w.shape[2], mean.n_channels)
        if b.shape != want:
            raise TableError(f"basis: shape {b.shape} does not match the mean and weights {want}")
        for name, a in (("weights", w), ("basis", b)):
            if not np.all(np.isfinite(a)):
                raise TableError(f"{name}: contains NaN or infinite values")
            a.setflags(write=False)
        from ._neural import check, decoded_bound

        if neural is not None:
            check(neural, texels=(w.shape[1], w.shape[0]), n_channels=mean.n_channels)
        bound = decoded_bound(mean.values, w, b, neural, mean.grid.kappa)
        if not bound <= MAX_ABS_VALUE:
            raise TableError(f"weights, basis{', neural' if neural is not None else ''}: could decode to values up "
                             f"to {bound:.3g}, beyond +-{MAX_ABS_VALUE:g}: not a reflectance")
        self._mean = mean
        self._weights = w
        self._basis = b
        self._repeat = _repeat_pair("repeat_mm", repeat_mm)
        self._compression = copy.deepcopy(dict(compression or {}))
        self._lookup: LookupGrid | None = None
        self._neural = neural

    # -- construction from dense texels ---------------------------------------------
    @classmethod
    def from_values(cls, values: ArrayLike, grid: Grid, *, repeat_mm: ArrayLike,
                    max_error: float = DEFAULT_MAX_ERROR, max_rank: int = MAX_RANK,
                    attrs: Mapping[str, Any] | None = None, provenance: Provenance | None = None,
                    method: str = "pca", fit: FitOptions | None = None) -> CDBTF:
        """Compress dense texels: the tile mean and the smallest representation meeting ``max_error``.

        Parameters
        ----------
        values
            ``(n_v, n_u) + grid.shape + (n_channels,)``, per texel.
        grid
            The sample axes.
        repeat_mm
            ``(size_u, size_v)`` of the repeat, mm.
        max_error
            Target relative RMS error (a fraction, e.g. 0.03), met by the
            whole table and by every curvature slice.
        max_rank
            Most components (a warning is logged when the target needs more).
        attrs
            The tile mean's attributes (material, provenance, quantity).
        provenance
            The tile mean's per-sample provenance
            (:class:`cdbrdf.provenance.Provenance`): the measured mask and the
            fill's sources of a measured CD-BTF (the same for every texel).
        method
            One of :data:`METHODS`: ``"pca"`` (default: components only) or
            ``"neural"`` (per-texel latent codes and a shared decoder
            modulating the tile mean, plus as many residual components as
            ``max_error`` needs; ``docs/btf.md``; what ``cdbrdf synth --btf``
            makes, :data:`DEFAULT_METHOD`). When the decoder misses
            ``max_error`` and a PCA alone meets it in fewer bytes than the
            decoder plus residual components, the PCA is returned (its
            record keeps the decoder's error, ``neural_relative_rms_error``).
        fit
            How the neural part is fitted (``cdbrdf.btf._neural.FitOptions``;
            default: the measured choice).

        Returns
        -------
        CDBTF
            With :attr:`compression` holding the rank, the errors and the ratio.
        """
        from ._factor import factorise

        if not isinstance(grid, Grid):
            raise TableError(f"grid: expected cdbrdf.Grid, got {type(grid).__name__}")
        if isinstance(max_error, bool) or not isinstance(max_error, (int, float)) or not 0.0 <= max_error < 1.0:
            raise TableError(f"max_error: expected a fraction in [0, 1), got {max_error!r}")
        if isinstance(max_rank, bool) or not isinstance(max_rank, int) or not 0 <= max_rank <= MAX_RANK:
            raise TableError(f"max_rank: expected an integer in [0, {MAX_RANK}], got {max_rank!r}")
        if method not in METHODS:
            raise TableError(f"method: {method!r} is not one of {', '.join(METHODS)}")
        v = read_array("values", values)
        if v.ndim != 8 or v.shape[2:7] != grid.shape:
            raise TableError(f"values: expected (n_v, n_u) + {grid.shape} + (channels,), got shape {v.shape}")
        if not np.all(np.isfinite(v)):
            raise TableError("values: contains NaN or infinite values")
        nv, nu = v.shape[:2]
        nc = v.shape[-1]
        dense = v.reshape(nv * nu, -1)
        if method == "neural":
            from ._neural import compress

            m16, net, residual, comp = compress(v, grid, max_error=float(max_error), max_rank=max_rank, options=fit)
            mean = CDBRDF(m16, grid, attrs=attrs, provenance=provenance)
            out = cls(mean, residual.weights.reshape(nv, nu, -1),
                      np.moveaxis(residual.basis.reshape((-1,) + grid.shape + (nc,)), 0, -2),
                      repeat_mm=repeat_mm, compression=comp, neural=net)
            out._compression["compression_ratio"] = out.nbytes_ratio()
            if out.rank == 0:
                return out
            # the decoder missed the target: a PCA alone may need fewer bytes than the decoder plus components
            pca = cls.from_values(v, grid, repeat_mm=repeat_mm, max_error=max_error, max_rank=max_rank, attrs=attrs,
                                  provenance=provenance, method="pca")
            if pca.nbytes_ratio() <= out.nbytes_ratio():
                return out
            for key in ("neural_relative_rms_error", "fit_seconds"):
                pca._compression[key] = comp[key]
            _LOG.info("the error target %g needs residual components after the decoder (%d, %.1f:1); the PCA "
                      "alone is smaller (rank %d, %.1f:1) and is kept", max_error, out.rank, out.nbytes_ratio(),
                      pca.rank, pca.nbytes_ratio())
            return pca
        f = factorise(dense, grid.shape[0], max_error=float(max_error), max_rank=max_rank)
        mean = CDBRDF(f.mean.reshape(grid.shape + (nc,)).astype(np.float32), grid, attrs=attrs,
                      provenance=provenance)
        rank = f.weights.shape[1]
        basis = np.moveaxis(f.basis.reshape((rank,) + grid.shape + (nc,)), 0, -2)
        comp = {"method": "pca", "rank": rank, "max_error": float(max_error),
                "relative_rms_error": f.error, "relative_rms_error_per_kappa": [float(e) for e in f.error_per_kappa]}
        out = cls(mean, f.weights.reshape(nv, nu, rank), basis, repeat_mm=repeat_mm, compression=comp)
        out._compression["compression_ratio"] = out.nbytes_ratio()
        return out

    # -- properties -------------------------------------------------------------------
    @property
    def grid(self) -> Grid:
        """The sample axes of every texel."""
        return self._mean.grid

    @property
    def weights(self) -> NDArray[np.float32]:
        """Read-only ``(n_v, n_u, rank)`` component weights of the texels."""
        return self._weights

    @property
    def basis(self) -> NDArray[np.float32]:
        """Read-only ``(kappa, phi_l, theta_l, phi_v, theta_v, rank, channel)`` components."""
        return self._basis

    @property
    def repeat_mm(self) -> tuple[float, float]:
        """``(size_u, size_v)`` of the repeat on the flat fabric, mm."""
        return self._repeat

    @property
    def texels(self) -> tuple[int, int]:
        """``(n_u, n_v)`` texels per repeat."""
        return int(self._weights.shape[1]), int(self._weights.shape[0])

    @property
    def rank(self) -> int:
        """Number of components."""
        return int(self._weights.shape[2])

    @property
    def n_channels(self) -> int:
        """Number of channels (3 for RGB)."""
        return self._mean.n_channels

    @property
    def attrs(self) -> dict[str, Any]:
        """The tile mean's attributes (material, provenance, quantity)."""
        return self._mean.attrs

    @property
    def compression(self) -> dict[str, Any]:
        """The factorisation's record: :data:`COMPRESSION_ATTRS` (a copy)."""
        return copy.deepcopy(self._compression)

    @property
    def neural(self) -> Neural | None:
        """The neural part (latent pyramid and decoder), or None for a CD-BTF of components only (PCA)."""
        return self._neural

    @property
    def method(self) -> str:
        """``"neural"`` or ``"pca"``: the representation of the texels (:data:`METHODS`)."""
        return "pca" if self._neural is None else "neural"

    def mean(self) -> CDBRDF:
        """The tile mean: what a patch of whole repeats reflects.

        Returns
        -------
        CDBRDF
            The mean over the texels.
        """
        return self._mean

    def texel_centres_mm(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The texel centres.

        Returns
        -------
        tuple of numpy.ndarray
            Centres along u and along v, mm.
        """
        nu, nv = self.texels
        su, sv = self._repeat
        return (np.arange(nu) + 0.5) * su / nu, (np.arange(nv) + 0.5) * sv / nv

    def decode(self) -> NDArray[np.float32]:
        """The decoded texels at the grid's samples (the finest level).

        Returns
        -------
        numpy.ndarray
            ``(n_v, n_u) + grid.shape + (channels,)`` float32.
        """
        nv, nu, r = self._weights.shape
        m = self._mean.values.astype(np.float32)
        basis = np.moveaxis(self._basis, -2, 0).reshape(r, m.size)  # (rank, samples * channels)
        out = (self._weights.reshape(nv * nu, r) @ basis).reshape((nv, nu) + m.shape)
        if self._neural is None:
            out += m
        else:
            from ._neural import decode_grid

            out += decode_grid(self._neural, self.grid, m).reshape(out.shape)
        return out

    def truncated(self, rank: int) -> CDBTF:
        """The CD-BTF of the leading ``rank`` components, with the errors of that truncation.

        Components are ordered by energy, so the leading ones are the best
        approximation of that rank (for the PCA of :meth:`from_values`).
        The errors recorded in :attr:`compression` are updated from the
        components themselves: the energy of the dropped part (exactly, from
        the weights' and the components' Gram matrices) added to the error
        recorded for the full rank (the residual is orthogonal to the
        components, as it is for a PCA; a CD-BTF built from its parts
        without recorded errors is taken as exact at its full rank, so the
        errors are those of the truncation alone). ``max_error`` is kept (the target
        the full rank was chosen for), and ``truncated_from`` records the
        full rank.

        Parameters
        ----------
        rank
            Components to keep, ``0 <= rank <=`` :attr:`rank`.

        Returns
        -------
        CDBTF
            Sharing the tile mean; ``self`` when ``rank`` is the full rank.

        Raises
        ------
        TableError
            For a rank that is not an integer in ``[0, rank]``.
        """
        if isinstance(rank, bool) or not isinstance(rank, (int, np.integer)) or not 0 <= rank <= self.rank:
            raise TableError(f"rank: expected an integer in [0, {self.rank}], got {rank!r}")
        r = int(rank)
        if r == self.rank:
            return self
        nv, nu, full = self._weights.shape
        nk = self.grid.shape[0]
        w = self._weights.reshape(nv * nu, full).astype(np.float64)
        gw = w.T @ w  # (full, full)
        wsum = w.sum(axis=0)
        m = self._mean.values.astype(np.float64).reshape(nk, -1, self.n_channels)
        stored, dropped = np.empty(nk), np.empty(nk)
        for k in range(nk):
            b = np.moveaxis(self._basis[k].reshape(-1, full, self.n_channels), 1, 0).reshape(full, -1)
            b = b.astype(np.float64)
            gb = b @ b.T
            mb = b @ m[k].reshape(-1)
            stored[k] = nv * nu * float(m[k].reshape(-1) @ m[k].reshape(-1)) + 2.0 * float(wsum @ mb) \
                + float(np.sum(gw * gb))
            dropped[k] = float(np.sum(gw[r:, r:] * gb[r:, r:]))
        if self._neural is not None:  # the stored energy of the decoded texels (the neural part is not a mean)
            d = self.decode().astype(np.float64)
            stored = np.array([float(np.sum(d[:, :, k] ** 2)) for k in range(nk)])
        comp = self.compression
        err_k = np.asarray(comp.get("relative_rms_error_per_kappa", np.zeros(nk)), dtype=np.float64)
        if err_k.shape != (nk,) or not np.all((err_k >= 0) & (err_k < 1)):
            err_k = np.zeros(nk)
        truth = stored / (1.0 - err_k**2)  # the uncompressed slices' energy
        residual = err_k**2 * truth
        safe = np.where(truth > 0, truth, 1.0)
        comp["relative_rms_error_per_kappa"] = [float(x) for x in np.sqrt((residual + dropped) / safe)]
        comp["relative_rms_error"] = float(np.sqrt((residual.sum() + dropped.sum()) / (truth.sum() or 1.0)))
        comp["rank"] = r
        comp["truncated_from"] = int(comp.get("truncated_from") or full)
        out = CDBTF(self._mean, self._weights[..., :r], self._basis[..., :r, :], repeat_mm=self._repeat,
                    compression=comp, neural=self._neural)
        comp["compression_ratio"] = out.nbytes_ratio()
        out._compression = comp
        return out

    def nbytes_ratio(self) -> float:
        """The compression ratio against raw float32.

        Returns
        -------
        float
            Bytes of every texel's table in float32 over the bytes of what
            represents them: a PCA CD-BTF's mean, basis and weights in float32;
            a neural one's tile mean and latent codes in float16 (their values
            are float16 numbers), its decoder and residual components in float32.
        """
        nu, nv = self.texels
        raw = 4 * nu * nv * self._mean.values.size
        comps = 4 * (self._basis.size + self._weights.size)
        if self._neural is None:
            return raw / (4 * self._mean.values.size + comps)
        net = self._neural
        return raw / (2 * self._mean.values.size + 2 * net.n_latent_values + 4 * net.n_parameters + comps)

    # -- lookup -----------------------------------------------------------------------
    def lookup_grid(self) -> LookupGrid:
        """The mean and the components as one table of ``(1 + rank) * channels`` channels, prepared for lookup.

        Returns
        -------
        cdbrdf.interp.LookupGrid
            Channel ``i * channels + c`` is component ``i`` (0: the mean) of
            channel ``c``.
        """
        if self._lookup is None:
            from ..interp import prepare

            m = self._mean.values.astype(np.float32)
            stacked = np.concatenate([m[..., None, :], self._basis], axis=-2)
            self._lookup = prepare(self.grid, stacked.reshape(stacked.shape[:-2] + (-1,)))
        return self._lookup

    def texel_weights(self, u_mm: ArrayLike, v_mm: ArrayLike, footprint_mm: ArrayLike = 0.0) -> NDArray[np.float64]:
        """The component weights at positions ``(u, v)`` (periodic bilinear between texel centres).

        Parameters
        ----------
        u_mm, v_mm
            Positions in the repeat, mm (broadcast; any value, wrapped).
        footprint_mm
            The width of the area a lookup stands for (a pixel's footprint on
            the fabric), mm: the weights are those of the texels averaged over
            it (the pyramid of the weights' block means, :func:`texel_level`);
            0 (default): the texels themselves.

        Returns
        -------
        numpy.ndarray
            ``broadcast shape + (rank,)``; NaN rows where a position is not finite.
        """
        from ._neural import bilinear_codes, block_means, level_shapes, level_weights

        u, v, fp = np.broadcast_arrays(*(np.asarray(x, dtype=np.float64) for x in (u_mm, v_mm, footprint_mm)))
        nu, nv = self.texels
        su, sv = self._repeat
        with np.errstate(invalid="ignore"):
            fu, fv = np.mod(u, su) / su, np.mod(v, sv) / sv
        bad = ~(np.isfinite(fu) & np.isfinite(fv))
        fu, fv = np.where(bad, 0.0, fu), np.where(bad, 0.0, fv)
        shapes = level_shapes(nu, nv)
        lev, t, fade = level_weights(self.footprint_texels(fp), len(shapes))
        out = np.zeros(u.shape + (self.rank,))
        for level in np.unique(lev):
            sel = lev == level
            w = bilinear_codes(block_means(self._weights, shapes[level]), fu[sel], fv[sel])
            if level + 1 < len(shapes):
                w1 = bilinear_codes(block_means(self._weights, shapes[level + 1]), fu[sel], fv[sel])
                w = w + t[sel][:, None] * (w1 - w)
            out[sel] = w * fade[sel][:, None]
        out[bad] = np.nan
        return out

    def footprint_texels(self, footprint_mm: ArrayLike) -> NDArray[np.float64]:
        """A footprint on the fabric (mm) in texels: over the larger of the texels' two sides.

        Parameters
        ----------
        footprint_mm
            The footprint's width on the fabric, mm.

        Returns
        -------
        numpy.ndarray
            The width in texels.
        """
        nu, nv = self.texels
        return np.asarray(footprint_mm, np.float64) / max(self._repeat[0] / nu, self._repeat[1] / nv)

    def evaluate(self, u_mm: ArrayLike, v_mm: ArrayLike, theta_v: ArrayLike, phi_v: ArrayLike,
                 theta_l: ArrayLike, phi_l: ArrayLike, kappa: ArrayLike = 0.0, *,
                 footprint_mm: ArrayLike = 0.0) -> NDArray[np.float64]:
        """The reflectance at texel positions, directions (degrees) and curvatures (mm^-1).

        Arguments broadcast together; periodic bilinear in ``(u, v)``, the rule
        of :mod:`cdbrdf.interp` in the other five axes (the tile mean and the
        components), the decoder at the query (a neural CD-BTF).

        Parameters
        ----------
        u_mm, v_mm
            Position on the fabric, mm (periodic over :attr:`repeat_mm`).
        theta_v, phi_v, theta_l, phi_l
            View and light elevation in [0, 90] and azimuth, degrees.
        kappa
            Curvature, mm^-1 (clamped to the grid).
        footprint_mm
            The width of the fabric a lookup stands for (a pixel's footprint),
            mm: the texels filtered over it (the pyramid levels,
            ``docs/btf.md``, "Filtering"); from the size of the repeat on, the
            tile mean. 0 (default): the texels themselves.

        Returns
        -------
        numpy.ndarray
            ``broadcast shape + (n_channels,)``, float64; NaN rows where an
            input is not finite.

        Raises
        ------
        QueryError
            For an elevation outside [0, 90] degrees or arguments that do not broadcast.
        """
        from ..interp import _as_query
        from ..interp import evaluate as lookup

        names = ("u_mm", "v_mm", "theta_v", "phi_v", "theta_l", "phi_l", "kappa", "footprint_mm")
        args = (u_mm, v_mm, theta_v, phi_v, theta_l, phi_l, kappa, footprint_mm)
        # the query rule of CDBRDF.evaluate: numbers only (an integer beyond float64 is refused there)
        as_float = [_as_query(n, a).astype(np.float64) for n, a in zip(names, args)]
        try:
            qs = np.broadcast_arrays(*as_float)
        except ValueError as exc:
            raise QueryError(f"{', '.join(names)}: {exc}") from None
        shape = qs[0].shape
        flat = [q.reshape(-1) for q in qs]
        n = flat[0].size
        nc, r = self.n_channels, self.rank
        out = np.empty((n, nc))
        for s in range(0, n, _CHUNK):
            e = min(n, s + _CHUNK)
            q = [x[s:e] for x in flat]
            comps = lookup(self, *q[2:7]).reshape(e - s, 1 + r, nc)
            base = comps[:, 0]
            if self._neural is not None:
                from ._neural import neural_at

                su, sv = self._repeat
                with np.errstate(invalid="ignore"):
                    fu, fv = np.mod(q[0], su) / su, np.mod(q[1], sv) / sv
                base = neural_at(self._neural, self.grid, fu, fv, self.footprint_texels(q[7]), q[2:7], base)
            w = self.texel_weights(q[0], q[1], q[7])
            out[s:e] = base + np.einsum("nr,nrc->nc", w, comps[:, 1:])
        return out.reshape(shape + (nc,))

    # -- file -------------------------------------------------------------------------
    def save(self, path: str | PathLike[str], *, compression: str | None = "gzip") -> None:
        """Write the BTF to an HDF5 file, atomically (``docs/format.md``, the CD-BTF variables).

        Parameters
        ----------
        path
            The file.
        compression
            HDF5 filter of the variables (``"gzip"`` or None).
        """
        from .file import BTFParts, write

        write(BTFParts(self._mean, self._weights, self._basis, self._repeat, self.compression, self._neural), path,
              compression=compression)

    def __repr__(self) -> str:
        nu, nv = self.texels
        err = self._compression.get("relative_rms_error")
        e = "?" if err is None else f"{100 * err:.2f}%"
        return (f"CDBTF(material={self.attrs.get('material', '?')!r}, texels={nu}x{nv}, "
                f"repeat_mm=({self._repeat[0]:g}, {self._repeat[1]:g}), method={self.method!r}, rank={self.rank}, "
                f"error={e}, "
                f"{self.grid!r})")


def load(path: str | PathLike[str], *, mean: CDBRDF | None = None) -> CDBTF:
    """Read a CD-BTF file written by :meth:`CDBTF.save`.

    The tile mean is read and checked by :func:`cdbrdf.load` (every rule of
    the CDBRDF file), then the CD-BTF variables: their shapes against the
    mean and each other, finite values, every number attribute in its range
    (``docs/format.md``), the digest ``btf_sha256``, and the decoded values
    within the table's bound.

    Parameters
    ----------
    path
        The file.
    mean
        The file's tile mean, when it was read already (:func:`cdbrdf.sources.open_source`).

    Raises
    ------
    FileNotFoundError
        When ``path`` does not exist.
    FormatError
        For a file that is not a CD-BTF file or is inconsistent or damaged
        (the message starts with the path).
    """
    from pathlib import Path

    from .file import read

    p = read(path, mean=mean)
    try:
        return CDBTF(p.mean, p.weights, p.basis, repeat_mm=p.repeat_mm, compression=p.compression, neural=p.neural)
    except TableError as exc:
        raise FormatError(f"{Path(path)}: {exc}") from None
