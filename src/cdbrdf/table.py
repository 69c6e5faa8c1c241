"""The curvature-dependent BRDF table.

A :class:`CDBRDF` holds reflectance samples over five axes (a
:class:`~cdbrdf.grid.Grid`: kappa in mm^-1, azimuths and elevations in
degrees), in the order fixed by the project's conventions
(``docs/conventions.md``)::

    values[kappa, phi_l, theta_l, phi_v, theta_v, channel]

``channel`` is linear RGB (Rec. 709 primaries) unless ``attrs`` say otherwise.

Values are the BRDF in sr^-1 with the cosine of the light direction *not*
included (``quantity = "brdf"``), or the same up to an unknown scale
(``quantity = "relative"``). Reshaped to ``(n_kappa, n_phi_l * n_theta_l,
n_phi_v * n_theta_v, channel)`` the table is the paper's Fig. 7 layout.

References
----------
Matsufuji, Kawai, "Measurement and Rendering of Curvature Dependent BRDF".
"""

from __future__ import annotations

import copy
from collections.abc import Mapping
from dataclasses import replace
from os import PathLike
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from . import io as _io
from . import limits
from .errors import FormatError, TableError
from .gltf_table import is_gltf, read_gltf
from .grid import MAX_ABS_KAPPA, MIN_AXIS_STEP, PAPER_KAPPA, PAPER_PHI, PAPER_THETA, Grid, read_array
from .provenance import (
    PROVENANCE_FIELDS,
    Provenance,
    check_fill_method_codes,
    check_fill_source,
    check_fill_sources,
    check_measured,
    read_fill_sources,
)
from .schema import (
    AXES,
    FILL_METHOD_CODES,
    QUANTITIES,
    SAMPLE_AXES,
    SYMMETRY_ATTR,
    TableParts,
    channel_names,
    check_symmetry,
)

if TYPE_CHECKING:
    from .interp import LookupGrid

__all__ = [
    "Grid",
    "CDBRDF",
    "load",
    "load_parts",
    "MAX_ABS_VALUE",
    "AXES",
    "QUANTITIES",
    "PAPER_KAPPA",
    "PAPER_THETA",
    "PAPER_PHI",
    "MAX_ABS_KAPPA",
    "MIN_AXIS_STEP",
]

#: Largest magnitude of a table value. Far beyond any reflectance (measured BRDFs stay below about 1e5
#: sr^-1, :data:`cdbrdf.importers.source.MAX_PLAUSIBLE_BRDF`), and small enough that every sum the lookup,
#: its pole rule and the renderer (float32) make of the values stays finite: a float64 table of 1e307
#: would give NaN for finite queries (its ring means overflow).
MAX_ABS_VALUE = 1e30


class CDBRDF:
    """A curvature-dependent BRDF sampled on a 5-D grid (RGB or other channels).

    Parameters
    ----------
    values
        Reflectance, shape ``(kappa, phi_l, theta_l, phi_v, theta_v, channel)``;
        sr^-1 for ``quantity="brdf"``. Stored as float32 or float64 (integer
        and other float dtypes are converted to float64; bool, complex, time,
        object and string dtypes and masked arrays with masked entries are
        refused). Must be finite and within +-:data:`MAX_ABS_VALUE`.
    grid
        The sample axes and the symmetry (:class:`Grid`: curvatures in mm^-1,
        strictly increasing; light and view azimuth and elevation in degrees).
    std
        Optional per-sample standard deviation, same shape as ``values``.
    provenance
        Where each sample comes from (:class:`cdbrdf.provenance.Provenance`,
        its fields below); default: every sample measured.
    attrs
        Metadata: ``quantity`` ("brdf" or "relative"), ``colour_space``,
        ``material``, ``provenance`` (any JSON-serialisable value), ``channels``,
        ``symmetry`` (the grid's).
    **keywords
        The former form, kept for reading older code: the axes ``kappa``,
        ``phi_l``, ``theta_l``, ``phi_v``, ``theta_v`` and ``symmetry`` instead
        of ``grid``, the fields of :class:`~cdbrdf.provenance.Provenance` instead of
        ``provenance``.

    Raises
    ------
    TableError
        When the shapes, axes, mask or values are inconsistent. The message
        names the argument.
    LimitError
        When the table has more values than the ``table_samples`` limit.

    Notes
    -----
    The fields of :class:`~cdbrdf.provenance.Provenance`:

    measured
        Boolean mask, shape ``values.shape[:-1]``: True where the sample was
        measured, False where it was filled. Default: all True.
    fill_source
        Integer array, shape ``values.shape[:-1]``: for a filled sample the
        C-order flat index (over the five sample axes) of the measured sample
        its value was copied from, -2 when unknown; -1 for (and only for)
        measured samples. Default: -1 where measured, -2 where filled.
    fill_method
        Codes of :data:`cdbrdf.schema.FILL_METHOD_CODES`, shape ``values.shape[:-1]``:
        how each sample was filled; 0 (``measured``) for, and only for, measured
        samples. Default: ``nearest`` where a fill source is known, else ``unknown``.
    fill_sources
        Integer array ``values.shape[:-1] + (n_slot,)``: the measured samples
        each filled value was computed from (flat indices, used slots first, -1
        unused; all -1 for measured samples and unknown sources). Its first slot
        is ``fill_source`` (-1 where that is -2); either is derived from the
        other when only one is given. Default: the one slot ``fill_source``.
    fill_weights
        Float array like ``fill_sources``: the weight of each source (a filled
        value is the weighted sum of its sources, of their logarithms for
        ``kappa_fit``), 0 in unused slots; default 1 for the one source of a copy.
    fill_std
        Optional estimated standard deviation of the error of each filled
        value, same shape as ``values``; 0 where measured.

    Examples
    --------
    >>> import numpy as np, cdbrdf
    >>> g = cdbrdf.Grid.paper()
    >>> t = cdbrdf.CDBRDF(np.full(g.shape + (3,), 0.2), g)
    >>> t.evaluate(30.0, 45.0, 10.0, 200.0, 0.05).round(3)
    array([0.2, 0.2, 0.2])
    """

    __slots__ = ("_grid", "_values", "_measured", "_fill_source", "_std", "_attrs", "_lookup",
                 "_fill_method", "_fill_sources", "_fill_weights", "_fill_std")

    def __init__(
        self,
        values: ArrayLike,
        grid: Grid | None = None,
        *,
        std: ArrayLike | None = None,
        provenance: Provenance | None = None,
        attrs: Mapping[str, Any] | None = None,
        **keywords: Any,
    ) -> None:
        grid, provenance = self._records(grid, provenance, attrs, keywords)
        self._build(values, grid, std, provenance, attrs)

    @classmethod
    def _records(cls, grid: Grid | None, provenance: Provenance | None, attrs: Mapping[str, Any] | None,
                 keywords: dict[str, Any]) -> tuple[Grid, Provenance]:
        """The grid and provenance records, from themselves or the former keywords (axes, symmetry, arrays)."""
        axes = {k: keywords.pop(k) for k in SAMPLE_AXES if k in keywords}
        symmetry = keywords.pop("symmetry", None)
        arrays = {k: keywords.pop(k) for k in PROVENANCE_FIELDS if k in keywords}
        if keywords:
            raise TypeError(f"CDBRDF() got an unexpected keyword argument {next(iter(keywords))!r}")
        if grid is None:
            missing = [k for k in SAMPLE_AXES if k not in axes]
            if missing:
                raise TypeError(f"CDBRDF() needs a grid (cdbrdf.Grid) or the axes; missing {', '.join(missing)}")
            grid = Grid(**axes, symmetry=cls._check_symmetry(symmetry, attrs))
        elif not isinstance(grid, Grid):
            raise TableError(f"grid: expected a cdbrdf.Grid, got {type(grid).__name__:.40}")
        elif axes or symmetry is not None:
            raise TableError(f"grid: give the axes and symmetry in the Grid, not beside it "
                             f"({next(iter(axes), 'symmetry')})")
        else:
            cls._check_symmetry(grid.symmetry, attrs)
        if provenance is None:
            provenance = Provenance(**arrays)
        elif arrays:
            raise TableError(f"provenance: give {next(iter(arrays))} in the Provenance, not beside it")
        return grid, provenance

    def _build(self, values: ArrayLike, grid: Grid, std: ArrayLike | None, provenance: Provenance,
               attrs: Mapping[str, Any] | None) -> None:
        if not isinstance(provenance, Provenance):
            raise TableError("provenance: expected a cdbrdf.provenance.Provenance, "
                             f"got {type(provenance).__name__:.40}")
        sym = grid.symmetry
        measured, fill_source, fill_sources = provenance.measured, provenance.fill_source, provenance.fill_sources
        fill_method, fill_weights, fill_std = provenance.fill_method, provenance.fill_weights, provenance.fill_std
        self._grid = grid
        self._values = self._check_values("values", values, grid)
        self._std = self._check_std("std", std, grid, self._values.shape)
        self._measured = check_measured(measured, grid.shape)
        sources = None if fill_sources is None else read_fill_sources(fill_sources, self._measured)
        if fill_source is None and sources is not None:
            first = sources[..., 0]
            fill_source = np.where(self._measured, -1, np.where(first >= 0, first, -2))
        self._fill_source = check_fill_source(fill_source, self._measured)
        self._fill_sources, self._fill_weights = check_fill_sources(
            sources, fill_weights, self._fill_source, self._measured
        )
        self._fill_method = check_fill_method_codes(fill_method, self._fill_source, self._measured)
        self._fill_std = self._check_std("fill_std", fill_std, grid, self._values.shape)
        if self._fill_std is not None and np.any(self._fill_std[self._measured] != 0):
            raise TableError("fill_std: must be 0 wherever the sample is measured")
        self._attrs = self._check_attrs(attrs)
        if sym == "isotropic":
            self._attrs[SYMMETRY_ATTR] = sym
        self._lookup: LookupGrid | None = None  # filled by lookup_grid()

    # -- validation -------------------------------------------------------------
    @staticmethod
    def _check_symmetry(symmetry: str | None, attrs: Mapping[str, Any] | None) -> str:
        """The table's symmetry: the argument, else ``attrs["symmetry"]``, else anisotropic; both must agree."""
        stored = attrs.get(SYMMETRY_ATTR) if isinstance(attrs, Mapping) else None
        if stored is not None:
            try:
                check_symmetry(stored)
            except TableError as exc:
                raise TableError(f"attrs[{SYMMETRY_ATTR!r}]: {str(exc).partition(': ')[2]}") from None
        if symmetry is None:
            return "anisotropic" if stored is None else str(stored)
        check_symmetry(symmetry)
        if stored is not None and stored != symmetry:
            raise TableError(f"symmetry: {symmetry!r} disagrees with attrs[{SYMMETRY_ATTR!r}] = {stored!r}")
        return symmetry

    @staticmethod
    def _check_values(name: str, values: ArrayLike, grid: Grid) -> NDArray[np.floating]:
        v = read_array(name, values)
        if v.ndim != 6:
            raise TableError(
                f"{name}: expected 6 dimensions {AXES}, got shape {v.shape}"
            )
        if v.shape[:5] != grid.shape:
            raise TableError(
                f"{name}: shape {v.shape} does not match the axes "
                f"(kappa, phi_l, theta_l, phi_v, theta_v) = {grid.shape}"
            )
        if v.shape[5] < 1:
            raise TableError(f"{name}: needs at least one channel")
        limits.check("table_samples", float(v.size), what=f"{name}: table of shape {v.shape}")
        if v.dtype not in (np.float32, np.float64):
            with np.errstate(all="ignore"):  # out-of-range values become inf: refused below
                v = v.astype(np.float64)
        if not np.all(np.isfinite(v)):
            bad = int(np.count_nonzero(~np.isfinite(v)))
            raise TableError(f"{name}: contains {bad} NaN or infinite value(s)")
        bound = v.dtype.type(MAX_ABS_VALUE)  # at the values' precision: float32(1e30) is the bound itself
        if v.size and np.max(np.abs(v)) > bound:
            bad = int(np.count_nonzero(np.abs(v) > bound))
            top = float(np.max(np.abs(v)))
            raise TableError(f"{name}: {bad} value(s) beyond +-{MAX_ABS_VALUE:g} (up to {top:.3g}): not a "
                             "reflectance, and its sums would overflow")
        v = np.array(v, order="C", copy=True)
        v.setflags(write=False)
        return v

    @classmethod
    def _check_std(
        cls, name: str, std: ArrayLike | None, grid: Grid, shape: tuple[int, ...]
    ) -> NDArray[np.floating] | None:
        if std is None:
            return None
        s = cls._check_values(name, std, grid)
        if s.shape != shape:
            raise TableError(f"{name}: shape {s.shape} differs from values {shape}")
        if np.any(s < 0):
            raise TableError(f"{name}: standard deviations must be non-negative")
        return s

    @staticmethod
    def _check_attrs(attrs: Mapping[str, Any] | None) -> dict[str, Any]:
        a: dict[str, Any] = {"quantity": "relative", "colour_space": "linear Rec.709 (sRGB primaries)"}
        if attrs is not None:
            if not isinstance(attrs, Mapping):
                raise TableError(f"attrs: expected a mapping, got {type(attrs).__name__}")
            for k in attrs:
                if not isinstance(k, str):
                    raise TableError(f"attrs: keys must be strings, got {k!r}")
            a.update(copy.deepcopy(dict(attrs)))
        if a["quantity"] not in QUANTITIES:
            raise TableError(
                f"attrs['quantity']: {a['quantity']!r} is not one of {', '.join(QUANTITIES)}"
            )
        return a

    # -- properties -----------------------------------------------------------------
    @property
    def grid(self) -> Grid:
        """The sample axes."""
        return self._grid

    @property
    def values(self) -> NDArray[np.floating]:
        """Read-only samples, ``(kappa, phi_l, theta_l, phi_v, theta_v, channel)``."""
        return self._values

    @property
    def measured(self) -> NDArray[np.bool_]:
        """Read-only mask: True where measured, False where filled."""
        return self._measured

    @property
    def fill_source(self) -> NDArray[np.int64]:
        """Flat index of each filled sample's source; -1 measured, -2 unknown."""
        return self._fill_source

    @property
    def std(self) -> NDArray[np.floating] | None:
        """Per-sample standard deviation, or None."""
        return self._std

    @property
    def fill_method(self) -> NDArray[np.uint8]:
        """How each sample was filled: codes of :data:`cdbrdf.schema.FILL_METHOD_CODES` (0 measured)."""
        return self._fill_method

    @property
    def fill_sources(self) -> NDArray[np.int64]:
        """Every source of each filled sample, ``(..., n_slot)`` flat indices, -1 unused."""
        return self._fill_sources

    @property
    def fill_weights(self) -> NDArray[np.float64]:
        """The weight of each source in :attr:`fill_sources` (0 in unused slots)."""
        return self._fill_weights

    @property
    def fill_std(self) -> NDArray[np.floating] | None:
        """Estimated standard deviation of each filled value's error (0 measured), or None."""
        return self._fill_std

    @property
    def provenance(self) -> Provenance:
        """Where each sample comes from, as the record :class:`cdbrdf.provenance.Provenance` (checked arrays)."""
        return Provenance(measured=self._measured, fill_source=self._fill_source, fill_method=self._fill_method,
                          fill_sources=self._fill_sources, fill_weights=self._fill_weights, fill_std=self._fill_std)

    def fill_method_names(self) -> NDArray[np.str_]:
        """:attr:`fill_method` as names.

        Returns
        -------
        numpy.ndarray
            Names such as ``"measured"`` or ``"kappa_fit"``, shape ``values.shape[:-1]``.
        """
        names = np.array(list(FILL_METHOD_CODES), dtype=object)
        lut = np.empty(max(FILL_METHOD_CODES.values()) + 1, dtype=object)
        lut[list(FILL_METHOD_CODES.values())] = names
        return lut[self._fill_method].astype(str)

    @property
    def attrs(self) -> dict[str, Any]:
        """Metadata (a dict; changes to it are kept)."""
        return self._attrs

    kappa = property(lambda self: self._grid.kappa, doc="Curvature axis, mm^-1.")
    theta_l = property(lambda self: self._grid.theta_l, doc="Light elevation axis, degrees.")
    phi_l = property(lambda self: self._grid.phi_l, doc="Light azimuth axis, degrees.")
    theta_v = property(lambda self: self._grid.theta_v, doc="View elevation axis, degrees.")
    phi_v = property(lambda self: self._grid.phi_v, doc="View azimuth axis, degrees.")

    @property
    def shape(self) -> tuple[int, ...]:
        """Shape of :attr:`values`."""
        return self._values.shape

    @property
    def n_channels(self) -> int:
        """Number of channels (3 for RGB)."""
        return self._values.shape[-1]

    @property
    def channels(self) -> list[str]:
        """Channel names (``attrs['channels']`` or :func:`cdbrdf.schema.default_channels`: R, G, B)."""
        return channel_names(self._attrs, self.n_channels)

    @property
    def quantity(self) -> str:
        """``"brdf"`` (sr^-1) or ``"relative"`` (unknown scale)."""
        return str(self._attrs["quantity"])

    @property
    def symmetry(self) -> str:
        """``"anisotropic"`` or ``"isotropic"`` (``phi_v`` is the azimuth difference)."""
        return self._grid.symmetry

    @property
    def isotropic(self) -> bool:
        """Whether the table is isotropic (see :attr:`symmetry`)."""
        return self._grid.isotropic

    # -- operations ---------------------------------------------------------------
    def evaluate(
        self,
        theta_v: ArrayLike,
        phi_v: ArrayLike,
        theta_l: ArrayLike,
        phi_l: ArrayLike,
        kappa: ArrayLike = 0.0,
    ) -> NDArray[np.float64]:
        """Interpolate the table at continuous directions and curvature.

        5-D multilinear: azimuths periodic, elevations clamped beyond the last
        sample, curvature clamped to the axis ends. At elevation 0 the azimuth
        has no effect (pole rule, see :func:`cdbrdf.interp.evaluate`).

        Parameters
        ----------
        theta_v, phi_v
            View elevation in [0, 90] and azimuth (any real; periodic), degrees.
        theta_l, phi_l
            Light elevation in [0, 90] and azimuth, degrees.
        kappa
            Curvature, mm^-1.

        Returns
        -------
        numpy.ndarray
            ``broadcast(...).shape + (n_channels,)``, float64; NaN where a query is NaN or infinite.

        Raises
        ------
        QueryError
            When an elevation lies outside [0, 90] degrees.
        """
        from .interp import evaluate

        return evaluate(self, theta_v, phi_v, theta_l, phi_l, kappa)

    def lookup_grid(self) -> LookupGrid:
        """The table prepared for lookup (:class:`cdbrdf.interp.LookupGrid`).

        Built by :func:`cdbrdf.interp.prepare` on first use and kept (the table never
        changes): every lookup of this table, the renderer's included, shares it.

        Returns
        -------
        LookupGrid
            The prepared grid.
        """
        if self._lookup is None:
            from .interp import prepare

            self._lookup = prepare(self._grid, self._values)
        return self._lookup

    def brdf(self, kappa: float = 0.0) -> CDBRDF:
        """The plain BRDF: the table at one curvature as a one-kappa table.

        At a sampled curvature (the flat stand's 0 by default) the slice is copied
        exactly, mask and fill provenance included (sources on other curvatures
        are dropped: ``fill_source`` -2); outside the curvature range the end
        slice is copied (clamped, as in the lookup); between samples it is
        interpolated linearly in kappa, a sample measured only if both
        neighbours were (the others' fill method ``unknown``).

        Parameters
        ----------
        kappa
            The curvature of the slice, mm^-1.

        Returns
        -------
        CDBRDF
            A table with the one curvature ``kappa``.
        """
        if isinstance(kappa, (bool, np.bool_)) or not isinstance(kappa, (int, float, np.integer, np.floating)):
            raise TableError(f"kappa: expected a number (1/mm), got {type(kappa).__name__} {kappa!r}")
        k = float(kappa)
        if not np.isfinite(k):
            raise TableError(f"kappa: must be finite, got {kappa!r}")
        ks = self.kappa
        hit = np.flatnonzero(ks == k)
        if ks.size == 1 or k <= ks[0] or k >= ks[-1] or hit.size:
            # a sampled curvature, or clamped to an end of the axis
            i = int(hit[0]) if hit.size else (0 if k <= ks[0] else ks.size - 1)
            vals = self._values[i : i + 1]
            meas = self._measured[i : i + 1]
            per = int(np.prod(self.grid.shape[1:]))
            std = None if self._std is None else self._std[i : i + 1]
            method = self._fill_method[i : i + 1]
            # sources on other curvatures are not in the one-curvature table: dropped
            src: NDArray[np.int64] | None = self._fill_sources[i : i + 1]
            assert src is not None
            inside = (src >= i * per) & (src < (i + 1) * per)
            wts: NDArray[np.float64] | None = np.where(inside, self._fill_weights[i : i + 1], 0.0)
            order = np.argsort(~inside, axis=-1, kind="stable")  # kept sources first
            src = np.take_along_axis(np.where(inside, src - i * per, -1), order, axis=-1)
            wts = np.take_along_axis(np.asarray(wts), order, axis=-1)
            fill = np.where(meas, -1, np.where(src[..., 0] >= 0, src[..., 0], -2))
            fstd = None if self._fill_std is None else self._fill_std[i : i + 1]
        else:
            j = int(np.searchsorted(ks, k, side="right") - 1)
            w = (k - ks[j]) / (ks[j + 1] - ks[j])
            vals = ((1 - w) * self._values[j] + w * self._values[j + 1])[None].astype(self._values.dtype)
            meas = (self._measured[j] & self._measured[j + 1])[None]
            fill = np.where(meas, -1, -2)
            std = None
            method = np.where(meas, FILL_METHOD_CODES["measured"], FILL_METHOD_CODES["unknown"])
            src = wts = None
            fstd = None
        attrs = copy.deepcopy(self._attrs)
        attrs["plain_brdf_of_kappa"] = k
        return CDBRDF(vals, replace(self._grid, kappa=np.array([k], dtype=np.float64)), std=std, attrs=attrs,
                      provenance=Provenance(measured=meas, fill_source=fill, fill_method=method, fill_sources=src,
                                            fill_weights=wts, fill_std=fstd))

    def expanded(self, *, max_azimuths: int | None = None) -> CDBRDF:
        """The anisotropic table holding an isotropic table's values for every light azimuth.

        Both azimuth axes of the result are (a subset of) the isotropic table's
        azimuth-difference nodes, so every value is an exact copy: light azimuths
        ``0, s, 2 s, ...``, view azimuths ``phi_v[0] + (0, s, 2 s, ...)``, ``s`` the
        difference step times the smallest divisor of ``n_phi_v`` that leaves at
        most ``max_azimuths`` azimuths; ``(phi_l = i s, phi_v = phi_v[0] + j s)``
        is the isotropic sample at the difference ``(j - i) s``.

        Parameters
        ----------
        max_azimuths
            The most azimuths per axis; default: all of ``phi_v``.

        Returns
        -------
        CDBRDF
            The anisotropic table (this table when it is anisotropic).
        """
        if not self.isotropic:
            return self
        n = self.phi_v.size
        if max_azimuths is not None and (isinstance(max_azimuths, bool) or not isinstance(max_azimuths, int)
                                         or max_azimuths < 1):
            raise TableError(f"max_azimuths: expected a positive integer, got {max_azimuths!r}")
        k = 1
        if max_azimuths is not None:
            k = next(d for d in range(1, n + 1) if n % d == 0 and n // d <= max_azimuths)
        m = n // k
        step = 360.0 / m
        idx = (k * (np.arange(m)[None, :] - np.arange(m)[:, None])) % n  # [i_l, j_v] -> difference node

        def expand(a: NDArray[Any]) -> NDArray[Any]:
            # (kappa, 1, theta_l, dphi, theta_v, ...) -> (kappa, phi_l, theta_l, phi_v, theta_v, ...)
            return np.moveaxis(a[:, 0][:, :, idx], 2, 1)

        attrs = copy.deepcopy(self._attrs)
        attrs.pop(SYMMETRY_ATTR, None)
        attrs["expanded_from"] = "isotropic"
        meas = expand(self._measured)
        grid = Grid(kappa=self.kappa, theta_l=self.theta_l, phi_l=np.arange(m) * step, theta_v=self.theta_v,
                    phi_v=self.phi_v[0] + np.arange(m) * step)
        return CDBRDF(expand(self._values), grid, std=None if self._std is None else expand(self._std), attrs=attrs,
                      provenance=Provenance(measured=meas, fill_source=np.where(meas, -1, -2)))

    def save(self, path: str | PathLike[str], *, compression: str | None = "gzip") -> None:
        """Write the table to an HDF5 file, atomically (``docs/format.md``, :func:`cdbrdf.io.write`).

        Parameters
        ----------
        path, compression
            Destination (its folder must exist); HDF5 filter, ``"gzip"`` or None.
        """
        _io.write(TableParts.of(self), path, compression=compression)

    def fig7(self) -> NDArray[np.floating]:
        """The values in the paper's Fig. 7 layout.

        Returns
        -------
        numpy.ndarray
            ``(n_kappa, n_phi_l * n_theta_l, n_phi_v * n_theta_v, channel)``:
            rows are light directions, columns view directions, grouped by
            azimuth with the elevation varying inside a group.
        """
        k, pl, tl, pv, tv, c = self.shape
        return self._values.reshape(k, pl * tl, pv * tv, c)

    def to_xarray(self) -> Any:
        """The table as an :class:`xarray.Dataset` with named dimensions.

        The layout of the file (``docs/format.md``, :mod:`cdbrdf.schema`):
        ``reflectance`` and the provenance variables, coordinates, units and
        the file's global attributes (:func:`cdbrdf.io.global_attrs`), so that
        ``to_xarray().to_netcdf(path)`` writes a file :func:`cdbrdf.load`
        reads back as this table. Needs xarray.

        Returns
        -------
        xarray.Dataset
            The table's arrays, coordinates and attributes.
        """
        return _io.to_dataset(TableParts.of(self))

    @classmethod
    def from_xarray(cls, ds: Any) -> CDBRDF:
        """A table from a :class:`xarray.Dataset` laid out as :meth:`to_xarray` makes.

        Dimensions are transposed into the table's order when needed, the
        attributes and channel names read as :func:`cdbrdf.io.parts_from_dataset`
        reads them, the values validated as by the constructor.

        Parameters
        ----------
        ds : xarray.Dataset
            The dataset.

        Returns
        -------
        CDBRDF
            The table.
        """
        return _of_parts(_io.parts_from_dataset(ds))

    def with_attrs(self, **attrs: Any) -> CDBRDF:
        """A copy with ``attrs`` updated (the symmetry cannot change this way).

        Parameters
        ----------
        **attrs
            Attributes to set.

        Returns
        -------
        CDBRDF
            The copy.
        """
        a = copy.deepcopy(self._attrs)
        a.update(attrs)
        return CDBRDF(self._values, self._grid, std=self._std, provenance=self.provenance, attrs=a)

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, CDBRDF):
            return NotImplemented
        return (
            self._grid == other._grid
            and self._values.dtype == other._values.dtype
            and np.array_equal(self._values, other._values)
            and np.array_equal(self._measured, other._measured)
            and np.array_equal(self._fill_source, other._fill_source)
            and _same_optional(self._std, other._std)
            and np.array_equal(self._fill_method, other._fill_method)
            and np.array_equal(self._fill_sources, other._fill_sources)
            and np.array_equal(self._fill_weights, other._fill_weights)
            and _same_optional(self._fill_std, other._fill_std)
            and self._attrs == other._attrs
        )

    __hash__ = None  # type: ignore[assignment]

    def __repr__(self) -> str:
        meas = self._measured.mean() * 100
        return (
            f"CDBRDF(material={self._attrs.get('material', '?')!r}, quantity={self.quantity!r}, "
            f"shape={self.shape}, measured={meas:.1f}%, {self._grid!r})"
        )


def _same_optional(a: NDArray | None, b: NDArray | None) -> bool:
    """Both None, or equal arrays."""
    if a is None or b is None:
        return a is None and b is None
    return bool(np.array_equal(a, b))


def load(path: str | PathLike[str]) -> CDBRDF:
    """Read a CDBRDF file written by :meth:`CDBRDF.save` (any 1.x version), or a glTF export's table.

    A ``.glb``/``.gltf`` of ``cdbrdf export``: :func:`cdbrdf.gltf_table.read_gltf`; else :func:`cdbrdf.io.read`
    (files without HDF5 metadata checksums in a child process stopped after
    :data:`cdbrdf.io.LEGACY_READ_TIMEOUT_S` seconds plus one per 20 MB; re-saving such a file makes it fast).

    Parameters
    ----------
    path
        The file.

    Returns
    -------
    CDBRDF
        The table, equal to the one that was saved.

    Raises
    ------
    FileNotFoundError
        When ``path`` does not exist.
    FormatError
        For any problem with an existing file (not a CDBRDF file, a newer major
        version, missing or inconsistent data, checksum mismatches, damaged HDF5
        structures, unreadable permissions); the message starts with its path.
    LimitError
        When the file declares more samples than the ``table_samples`` limit.
    """
    return _from_parts(read_gltf(path) if is_gltf(path) else _io.read(path), path)


def load_parts(path: str | PathLike[str]) -> tuple[CDBRDF, frozenset[str] | None]:
    """A CDBRDF file read as :func:`load` reads it, with the names of the file's global attributes.

    Parameters
    ----------
    path
        A CDBRDF (or CD-BTF) file.

    Returns
    -------
    tuple
        The table, and the names of the file's global attributes (None when
        it was read in a child process, :func:`cdbrdf.io.read`).
    """
    parts = _io.read(path)
    return _from_parts(parts, path), parts.file_attrs


def _from_parts(parts: Any, path: str | PathLike[str]) -> CDBRDF:
    try:
        return _of_parts(parts)
    except TableError as exc:
        raise FormatError(f"{Path(path)}: {exc}") from None


def _of_parts(parts: TableParts) -> CDBRDF:
    """The table of a file's parts: its grid (the symmetry its attributes record) and provenance records."""
    grid = Grid(**parts.axes, symmetry=CDBRDF._check_symmetry(None, parts.attrs))
    return CDBRDF(parts.values, grid, std=parts.std, attrs=parts.attrs,
                  provenance=Provenance(**{k: getattr(parts, k) for k in PROVENANCE_FIELDS}))
