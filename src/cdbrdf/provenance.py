"""The provenance of a table's samples: which were measured, how each filled one was filled.

The rules a table's provenance arrays obey (``docs/format.md``), checked by
:class:`cdbrdf.table.CDBRDF` when it is made or read, and the one place
that states them; :mod:`cdbrdf.measure.fill` (which fills samples and
writes this provenance) relies on them:

- ``measured``: booleans (or 0/1) over the sample grid;
- ``fill_source``: -1 where measured; on a filled sample the flat index of
  the measured sample it was filled from, or -2 (not recorded);
- ``fill_sources`` / ``fill_weights``: every source of a filled sample and
  its weight, used slots first, slot 0 being ``fill_source``;
- ``fill_method``: a code of :data:`cdbrdf.schema.FILL_METHOD_CODES` per
  sample, 0 (measured) exactly where the sample is measured.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .errors import TableError
from .grid import read_array
from .schema import FILL_METHOD_CODES

__all__ = ["PROVENANCE_FIELDS", "Provenance", "check_measured", "check_fill_source", "read_fill_sources",
           "check_fill_sources", "check_fill_method_codes"]


@dataclass(frozen=True, eq=False)
class Provenance:
    """Where each sample's value comes from: measured, or filled and how (checked by :class:`cdbrdf.CDBRDF`).

    Every array is indexed like the table's samples (``values.shape[:-1]``; the
    per-source arrays add a slot axis; ``fill_std`` is shaped like the
    values); None: not recorded (the table's defaults, :class:`cdbrdf.CDBRDF`).

    Attributes
    ----------
    measured
        Boolean mask, True where the sample was measured.
    fill_source
        Flat index of the measured sample a filled value was copied from (-1 measured, -2 unknown).
    fill_method
        Codes of :data:`cdbrdf.schema.FILL_METHOD_CODES`.
    fill_sources, fill_weights
        The measured samples each filled value was computed from and their weights.
    fill_std
        Estimated standard deviation of each filled value's error (0 where measured).
    """

    measured: ArrayLike | None = None
    fill_source: ArrayLike | None = None
    fill_method: ArrayLike | None = None
    fill_sources: ArrayLike | None = None
    fill_weights: ArrayLike | None = None
    fill_std: ArrayLike | None = None


#: The fields of :class:`Provenance` (the former keywords of :class:`cdbrdf.CDBRDF`).
PROVENANCE_FIELDS: tuple[str, ...] = tuple(f.name for f in fields(Provenance))


def check_measured(measured: ArrayLike | None, shape: tuple[int, ...]) -> NDArray[np.bool_]:
    """The measured mask as read-only booleans of the sample grid's shape (all True when None)."""
    if measured is None:
        m = np.ones(shape, dtype=bool)
    else:
        m = read_array("measured", measured, kinds="biu", what="booleans")
        if m.shape != shape:
            raise TableError(f"measured: shape {m.shape} differs from the sample grid {shape}")
        if m.dtype != bool:
            if not np.isin(m, (0, 1)).all():
                raise TableError(f"measured: expected booleans (or 0/1), got other values of dtype {m.dtype}")
            m = m.astype(bool)
        m = m.copy()
    m.setflags(write=False)
    return m


def check_fill_source(fill: ArrayLike | None, measured: NDArray[np.bool_]) -> NDArray[np.int64]:
    """Fill sources: -1 on measured samples; a measured sample's flat index or -2 on filled ones."""
    if fill is None:
        f = np.full(measured.shape, -1, dtype=np.int64)
        # Unknown sources: mark with -2 ("filled, source not recorded").
        f[~measured] = -2
    else:
        f = read_array("fill_source", fill, kinds="iu", what="integers")
        if f.shape != measured.shape:
            raise TableError(
                f"fill_source: shape {f.shape} differs from the sample grid {measured.shape}"
            )
        if f.size and (f.min() < -2 or f.max() >= measured.size):
            raise TableError(
                f"fill_source: indices must be in [0, {measured.size}) (or -2 = unknown, -1 = measured)"
            )
        f = f.astype(np.int64)
        if np.any(f[measured] != -1):
            raise TableError("fill_source: must be -1 wherever the sample is measured")
        src = f[~measured]
        n_minus1 = int(np.count_nonzero(src == -1))
        if n_minus1:
            raise TableError(
                f"fill_source: {n_minus1} filled sample(s) have -1 (measured); give the flat index "
                "of the measured sample they were filled from, or -2 = unknown"
            )
        known = src[src >= 0]
        if known.size and not measured.reshape(-1)[known].all():
            raise TableError("fill_source: a filled sample points at a sample that is not measured")
    f.setflags(write=False)
    return f


def read_fill_sources(sources: ArrayLike, measured: NDArray[np.bool_]) -> NDArray[np.int64]:
    """``fill_sources`` as int64 of shape ``grid + (n_slot,)`` with valid indices (checked further later)."""
    f = read_array("fill_sources", sources, kinds="iu", what="integers")
    if f.ndim != measured.ndim + 1 or f.shape[:-1] != measured.shape or f.shape[-1] < 1:
        raise TableError(
            f"fill_sources: shape {f.shape} is not the sample grid {measured.shape} plus one slot axis"
        )
    if f.size and (f.min() < -1 or f.max() >= measured.size):
        raise TableError(f"fill_sources: indices must be in [0, {measured.size}) (or -1 = unused slot)")
    return f.astype(np.int64)


def check_fill_sources(
    sources: NDArray[np.int64] | None,
    weights: ArrayLike | None,
    fill: NDArray[np.int64],
    measured: NDArray[np.bool_],
) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
    """All sources and their weights; slot 0 is ``fill_source`` (-1 there for -2)."""
    if sources is None:
        if weights is not None:
            raise TableError("fill_weights: given without fill_sources")
        sources = np.where(fill >= 0, fill, -1)[..., None].astype(np.int64)
    else:
        used = sources >= 0
        if np.any(used[measured]):
            raise TableError("fill_sources: must be -1 (unused) wherever the sample is measured")
        if np.any(~used[..., :-1] & used[..., 1:]):
            raise TableError("fill_sources: used slots must come first (-1 only after the last source)")
        first = sources[..., 0]
        if np.any((first != np.where(fill >= 0, fill, -1))[~measured]):
            raise TableError("fill_sources: the first slot must be fill_source (-1 where that is -2)")
        known = sources[used]
        if known.size and not measured.reshape(-1)[known].all():
            raise TableError("fill_sources: a filled sample points at a sample that is not measured")
    used = sources >= 0
    if weights is None:
        if np.any(used[..., 1:]):
            raise TableError("fill_weights: needed when a filled sample has more than one source")
        w = used.astype(np.float64)
    else:
        w = read_array("fill_weights", weights, kinds="iuf", what="numbers").astype(np.float64)
        if w.shape != sources.shape:
            raise TableError(f"fill_weights: shape {w.shape} differs from fill_sources {sources.shape}")
        if not np.all(np.isfinite(w)):
            raise TableError("fill_weights: must be finite")
        if np.any(w[~used] != 0):
            raise TableError("fill_weights: must be 0 in unused slots")
        w = w.copy()
    sources = sources.copy()
    sources.setflags(write=False)
    w.setflags(write=False)
    return sources, w


def check_fill_method_codes(
    method: ArrayLike | None, fill: NDArray[np.int64], measured: NDArray[np.bool_]
) -> NDArray[np.uint8]:
    """Per-sample fill method codes: 0 exactly where measured."""
    codes = FILL_METHOD_CODES
    if method is None:
        m = np.where(fill >= 0, codes["nearest"], codes["unknown"]).astype(np.uint8)
        m[measured] = codes["measured"]
    else:
        a = read_array("fill_method", method, kinds="iu", what="integers")
        if a.shape != measured.shape:
            raise TableError(f"fill_method: shape {a.shape} differs from the sample grid {measured.shape}")
        if not np.isin(a, list(codes.values())).all():
            valid = ", ".join(f"{v} ({k})" for k, v in codes.items())
            raise TableError(f"fill_method: codes must be one of {valid}")
        m = a.astype(np.uint8)
        if np.any((m == codes["measured"]) != measured):
            raise TableError("fill_method: must be 0 (measured) exactly where the sample is measured")
    m.setflags(write=False)
    return m
