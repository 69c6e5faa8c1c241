"""Scale-aware principal curvatures: a robust surface fit over a neighbourhood given in millimetres.

The curvature that matters for cloth is the bending of the fabric over the
size of the measured patch (a few millimetres), not the noise of a scan's
triangles: a scan with 0.05 mm noise on 0.3 mm edges has "curvatures" of
hundreds of mm^-1 at the scale of one triangle. So each vertex's curvature is
fitted to the surface within a ball whose *diameter* is the neighbourhood,
given in mm and converted to the mesh's unit, whatever the tessellation:

1. samples: the vertices, or, where the mesh is much finer than the
   neighbourhood, the means of the vertices in cells of a grid (about 40 per
   neighbourhood, keyed by the normal's dominant axis so that the two layers
   of a thin shell stay apart); the surface is then fitted at the samples
   and each vertex gets the Gaussian-weighted mean of the shape operators
   (``k1 d1 d1^T + k2 d2 d2^T``) of its 12 nearest fitted samples, projected
   into its tangent plane: the cost is that of the samples, whatever the
   radius;
2. for every vertex (or sample) the 48 nearest samples (scipy's cKDTree), of which those
   of its own connected component (two garments worn one over the other do
   not mix) within the ball whose normal is within 60 degrees of the
   vertex's are used (the other side of a thin garment or of a sharp CAD
   edge is not), or the 10 nearest of them where the mesh is coarser than
   the ball;
3. a weighted (Gaussian, sigma = radius / 2) robust fit (Tukey's biweight)
   of a height quadric, then of the normal-section model, which is exact for
   spheres at any radius (:func:`cdbrdf.mesh._kernels.fit_vertices`);
4. a fit that turns by more than :data:`cdbrdf.mesh._kernels.BEND_MAX`
   radians over its samples' rms distance, which samples within the normal
   cone cannot show, is a spike (on a coarse mesh, the samples along a
   collar's rim, a turned-up cuff or a waistband's ledge fit curvatures of
   10 to 100 mm^-1 at 17 mm edges): it is replaced by the Gaussian-weighted
   mean of the shape operators fitted around it.

Measured (``tests/test_curvature.py``, ``docs/rendering.md``): a cylinder
of radius 1/0.22 mm at the default 5 mm neighbourhood is within 0.86 %
(median), the same with 0.05 mm Gaussian noise on 0.3 mm edges within 1.4 %;
libigl's ``principal_curvature`` (two edge lengths) is off by 65 % there.
Cost: ``benchmarks/bench_curvature.py``.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..errors import MeshError

__all__ = [
    "DEFAULT_NEIGHBOURHOOD_MM",
    "NEIGHBOURHOOD_RANGE_MM",
    "MAX_NEIGHBOURS",
    "MIN_NEIGHBOURS",
    "SAMPLES_PER_NEIGHBOURHOOD",
    "NORMAL_CONE_DEG",
    "PrincipalCurvatures",
    "fit_curvatures",
]

_LOG = logging.getLogger(__name__)

#: Default neighbourhood (diameter of the fitted disc), mm: the scale of the paper's
#: measured patches, larger than scan noise and smaller than the stands' radii (>= 4.5 mm).
DEFAULT_NEIGHBOURHOOD_MM = 5.0

#: Neighbourhoods accepted, mm.
NEIGHBOURHOOD_RANGE_MM: tuple[float, float] = (1e-3, 1e4)

#: Nearest samples looked at per vertex.
MAX_NEIGHBOURS = 48

#: Nearest samples looked at, at most, for a vertex whose nearest are all of other components.
RETRY_NEIGHBOURS = 3072

#: Samples used at least (the neighbourhood grows where the mesh is coarser than it).
MIN_NEIGHBOURS = 10

#: Samples aimed at per neighbourhood when a fine mesh is thinned.
SAMPLES_PER_NEIGHBOURHOOD = 40

#: Fitted samples whose shape operators are averaged at a vertex of a thinned mesh.
TRANSFER_NEIGHBOURS = 12

#: Growth of the radius at a boundary: a half disc of sqrt(2) r holds as much surface as a disc of r.
ONE_SIDED_GROWTH = math.sqrt(2.0)

#: A boundary vertex's refit is a spike when it bends more than this many times as tightly as the fits of
#: the interior vertices beside it; it gets theirs instead.
OPENING_SPIKE = 2.0

#: Largest angle between a sample's normal and the vertex's, degrees.
NORMAL_CONE_DEG = 60.0

#: Vertices per call of the fitting kernel (progress is reported between calls).
CHUNK = 32768


@dataclass(frozen=True)
class PrincipalCurvatures:
    """Per-vertex principal curvatures (1 / length unit) and directions.

    Attributes
    ----------
    k1, k2
        Principal curvatures with ``k1 >= k2``, signed: > 0 where the surface
        bends away from its normal (convex).
    d1, d2
        Unit principal directions ``(n, 3)`` of ``k1`` and ``k2``.
    """

    k1: NDArray[np.float64]
    k2: NDArray[np.float64]
    d1: NDArray[np.float64]
    d2: NDArray[np.float64]

    @property
    def kappa(self) -> NDArray[np.float64]:
        """The principal curvature of larger magnitude, with its sign (the paper's kappa)."""
        return np.where(np.abs(self.k1) >= np.abs(self.k2), self.k1, self.k2)

    @property
    def kappa_direction(self) -> NDArray[np.float64]:
        """Unit direction of :attr:`kappa` (the bending direction)."""
        return np.where((np.abs(self.k1) >= np.abs(self.k2))[:, None], self.d1, self.d2)

    def normal_curvature(self, tangent: NDArray[np.float64]) -> NDArray[np.float64]:
        """Signed normal curvature along ``tangent`` (``(n, 3)``, projected into the tangent plane).

        Euler's formula ``k1 cos^2 + k2 sin^2`` of the angle to ``d1``.

        Parameters
        ----------
        tangent
            ``(n, 3)`` directions, projected into each tangent plane.

        Returns
        -------
        numpy.ndarray
            ``(n,)`` curvatures; NaN where the tangent has no component in
            the tangent plane.
        """
        t = np.asarray(tangent, dtype=np.float64)
        c1 = np.einsum("ij,ij->i", t, self.d1)
        c2 = np.einsum("ij,ij->i", t, self.d2)
        s = c1 * c1 + c2 * c2
        with np.errstate(invalid="ignore", divide="ignore"):
            out = (self.k1 * c1 * c1 + self.k2 * c2 * c2) / s
        return np.where(s > 1e-12, out, np.nan)


def _samples(
    pos: NDArray[np.float64], nrm: NDArray[np.float64], comp: NDArray[np.int64], radius: float, edge: float
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.int64]]:
    """The sample points, normals, weights and components: the vertices, or cell means where the mesh is fine."""
    h = radius * math.sqrt(math.pi / SAMPLES_PER_NEIGHBOURHOOD)
    if not edge < 0.7 * h:
        return pos, nrm, np.ones(pos.shape[0]), comp
    lo = pos.min(axis=0)
    cell = np.floor((pos - lo) / h).astype(np.int64)
    axis = np.argmax(np.abs(nrm), axis=1)
    sign = np.take_along_axis(nrm, axis[:, None], 1)[:, 0] > 0
    bin6 = (2 * axis + sign).astype(np.int64)
    span = cell.max(axis=0) + 1
    n_comp = int(comp.max()) + 1 if comp.size else 1
    if float(span[0]) * float(span[1]) * float(span[2]) * 6.0 * n_comp < 2.0**62:
        key = (((cell[:, 0] * span[1] + cell[:, 1]) * span[2] + cell[:, 2]) * 6 + bin6) * n_comp + comp
        _, inv = np.unique(key, return_inverse=True)
    else:  # an extreme aspect ratio: unique rows instead of one key
        _, inv = np.unique(np.c_[cell, bin6, comp], axis=0, return_inverse=True)
    inv = inv.reshape(-1)
    n = int(inv.max()) + 1
    w = np.bincount(inv, minlength=n).astype(np.float64)
    sp = np.stack([np.bincount(inv, pos[:, c], n) for c in range(3)], 1) / w[:, None]
    sn = np.stack([np.bincount(inv, nrm[:, c], n) for c in range(3)], 1)
    ln = np.linalg.norm(sn, axis=1, keepdims=True)
    sn = np.divide(sn, ln, out=np.zeros_like(sn), where=ln > 0)
    sc = np.zeros(n, np.int64)
    sc[inv] = comp
    return sp, sn, w, sc


def _neighbours(tree: Any, q: NDArray[np.float64], k: int, radius: float,
                n_samples: int, coarse: bool = False) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """The ``k`` nearest samples within ``radius`` (a bounded search is fast), topped up where too few.

    Rows with fewer than :data:`MIN_NEIGHBOURS` within the radius (a mesh
    coarser than the neighbourhood) get their ``2 * MIN_NEIGHBOURS`` nearest at any distance.
    Missing neighbours have index ``n_samples`` and distance inf, sorted last.
    With ``coarse`` (the ball holds fewer than that on average) all rows
    take the latter at once.
    """
    if coarse:
        kk = min(k, 2 * MIN_NEIGHBOURS)
        dist, idx = tree.query(q, k=kk, workers=-1)
        return (np.ascontiguousarray(dist.reshape(q.shape[0], kk)),
                np.ascontiguousarray(idx.reshape(q.shape[0], kk), dtype=np.int64))
    dist, idx = tree.query(q, k=k, distance_upper_bound=radius * (1.0 + 1e-9), workers=-1)
    dist, idx = np.atleast_2d(dist), np.atleast_2d(idx)
    if k == 1:
        dist, idx = dist.reshape(-1, 1), idx.reshape(-1, 1)
    few = np.flatnonzero(np.count_nonzero(idx < n_samples, axis=1) < MIN_NEIGHBOURS)
    if few.size:
        kk = min(k, 2 * MIN_NEIGHBOURS)
        d2, i2 = tree.query(q[few], k=kk, workers=-1)
        d2, i2 = d2.reshape(few.size, kk), i2.reshape(few.size, kk)
        dist[few] = np.inf
        idx[few] = n_samples
        dist[few, :kk] = d2
        idx[few, :kk] = i2
    return np.ascontiguousarray(dist), np.ascontiguousarray(idx, dtype=np.int64)


def fit_curvatures(
    vertices: NDArray[np.float64],
    normals: NDArray[np.float64],
    *,
    components: NDArray[np.int64] | None = None,
    radius: float,
    edge_length: float,
    one_sided: NDArray[np.bool_] | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> tuple[PrincipalCurvatures, NDArray[np.float64], int]:
    """Principal curvatures at every vertex of an oriented surface, fitted within ``radius``.

    Parameters
    ----------
    vertices, normals
        ``(n, 3)`` positions and unit normals (oriented: the sign of the
        curvature follows them). A vertex with a zero normal gets 0.
    components
        ``(n,)`` connected component of each vertex: only samples of a
        vertex's own component are fitted (two garments worn one over the
        other do not mix); default all one.
    radius
        Radius of the fitted ball, in the vertices' unit (half the neighbourhood).
    edge_length
        The mesh's mean edge length (decides whether it is thinned).
    one_sided
        ``(n,)`` vertices on the surface's open boundaries and cuts: they are
        fitted again over a one-sided neighbourhood as large as a full one
        (the radius grown by :data:`ONE_SIDED_GROWTH`, at least twice
        :data:`MIN_NEIGHBOURS` samples), not over half a neighbourhood (a
        spike on a coarse mesh); a refit that bends more than
        :data:`OPENING_SPIKE` times as tightly as the interior vertices beside
        it (their shape operators, carried over with Gaussian weights) is a
        spike too, and the vertex gets theirs.
    progress
        ``progress(done, total)`` in vertices, after each chunk.

    Returns
    -------
    curvatures, normals, n_unfitted
        The curvatures (1 / the vertices' unit), the fitted normals and the
        number of vertices without enough samples nearby (their curvature is 0).
    """
    from scipy.spatial import cKDTree

    from .._jit import run_split
    from ._kernels import GRAIN, fit_vertices, transfer_tensors

    if not (math.isfinite(radius) and radius > 0):
        raise MeshError(f"neighbourhood: the radius must be positive and finite, got {radius!r}")
    pos = np.ascontiguousarray(vertices, dtype=np.float64)
    nrm = np.ascontiguousarray(normals, dtype=np.float64)
    n = pos.shape[0]
    comp = np.zeros(n, np.int64) if components is None else np.ascontiguousarray(components, dtype=np.int64)
    sp, sn, sw, sc = _samples(pos, nrm, comp, radius, edge_length)
    thinned = sp.shape[0] < n
    # fit at the vertices, or at the samples of a thinned mesh (then carried over to the vertices)
    q_pos, q_nrm, q_comp = (sp, sn, sc) if thinned else (pos, nrm, comp)
    nq = q_pos.shape[0]
    total = nq + (n if thinned else 0)
    k = int(min(MAX_NEIGHBOURS, sp.shape[0]))
    # vertices in the ball on a mesh of mean edge e: pi r^2 / (0.866 e^2)
    coarse = not thinned and math.pi * radius**2 < 1.5 * MIN_NEIGHBOURS * 0.866 * edge_length**2
    tree = cKDTree(sp, balanced_tree=False, compact_nodes=False)
    k1, k2 = np.zeros(nq), np.zeros(nq)
    d1, d2 = np.zeros((nq, 3)), np.zeros((nq, 3))
    fitted_n = np.zeros((nq, 3))
    status = np.zeros(nq, np.int8)
    cos_max = math.cos(math.radians(NORMAL_CONE_DEG))
    if progress is not None:
        progress(0, total)
    for start in range(0, nq, CHUNK):
        stop = min(nq, start + CHUNK)
        dist, idx = _neighbours(tree, q_pos[start:stop], k, radius, sp.shape[0], coarse)
        run_split(fit_vertices, stop - start, q_pos[start:stop], q_nrm[start:stop], q_comp[start:stop], sp, sn,
                  sw, sc, idx, dist, float(radius), MIN_NEIGHBOURS, cos_max,
                  k1[start:stop], k2[start:stop], d1[start:stop], d2[start:stop],
                  fitted_n[start:stop], status[start:stop], grain=GRAIN)
        if progress is not None:
            progress(stop, total)
    # where the nearest samples belong to other components (a sash over a coarse skirt), look further
    kr = k
    while kr < min(RETRY_NEIGHBOURS, sp.shape[0]):
        retry = np.flatnonzero(status == 1)
        if retry.size == 0:
            break
        kr = min(8 * kr, RETRY_NEIGHBOURS, sp.shape[0])
        dist, idx = tree.query(q_pos[retry], k=kr, workers=-1)
        dist, idx = dist.reshape(retry.size, kr), idx.reshape(retry.size, kr)
        r1, r2 = np.zeros(retry.size), np.zeros(retry.size)
        e1, e2, en = np.zeros((retry.size, 3)), np.zeros((retry.size, 3)), np.zeros((retry.size, 3))
        rs = np.zeros(retry.size, np.int8)
        run_split(fit_vertices, retry.size, q_pos[retry], q_nrm[retry], q_comp[retry], sp, sn, sw, sc,
                  np.ascontiguousarray(idx, np.int64), np.ascontiguousarray(dist), float(radius),
                  MIN_NEIGHBOURS, cos_max, r1, r2, e1, e2, en, rs, grain=GRAIN)
        k1[retry], k2[retry], d1[retry], d2[retry], fitted_n[retry], status[retry] = r1, r2, e1, e2, en, rs
    unresolved = np.flatnonzero(status == 3)
    if unresolved.size:  # a spike (no height field the samples resolve): the fits around it, averaged
        ok = status == 0
        kt = int(min(MAX_NEIGHBOURS, sp.shape[0]))  # past a row of unresolved neighbours (a crease's line)
        dist, idx = tree.query(q_pos[unresolved], k=kt, workers=-1)
        dist, idx = dist.reshape(unresolved.size, kt), idx.reshape(unresolved.size, kt)
        spacing = max(float(np.median(dist[:, 1:])) if kt > 1 else radius, 1e-300)
        r1, r2 = np.zeros(unresolved.size), np.zeros(unresolved.size)
        e1, e2 = np.zeros((unresolved.size, 3)), np.zeros((unresolved.size, 3))
        rs = np.zeros(unresolved.size, np.int8)
        # the query points are the samples (the vertices of a mesh fitted at its vertices)
        run_split(transfer_tensors, unresolved.size, np.ascontiguousarray(q_nrm[unresolved]),
                  np.ascontiguousarray(q_comp[unresolved]), sn, sc, ok, fitted_n, k1, k2, d1, d2,
                  np.ascontiguousarray(idx, np.int64), np.ascontiguousarray(dist), spacing, cos_max,
                  r1, r2, e1, e2, rs, grain=GRAIN)
        k1[unresolved], k2[unresolved], d1[unresolved], d2[unresolved] = r1, r2, e1, e2
        status[unresolved] = np.where(rs == 0, 0, 1)
    if thinned:
        spacing = radius * math.sqrt(math.pi / SAMPLES_PER_NEIGHBOURHOOD)
        ok = status == 0
        vk1, vk2 = np.zeros(n), np.zeros(n)
        vd1, vd2 = np.zeros((n, 3)), np.zeros((n, 3))
        vstatus = np.zeros(n, np.int8)
        kt = int(min(TRANSFER_NEIGHBOURS, sp.shape[0]))
        for start in range(0, n, CHUNK):
            stop = min(n, start + CHUNK)
            dist, idx = tree.query(pos[start:stop], k=kt, workers=-1)
            dist, idx = dist.reshape(stop - start, kt), idx.reshape(stop - start, kt)
            run_split(transfer_tensors, stop - start, nrm[start:stop], comp[start:stop], sn, sc, ok, fitted_n,
                      k1, k2, d1, d2, np.ascontiguousarray(idx, dtype=np.int64), np.ascontiguousarray(dist),
                      float(spacing), cos_max, vk1[start:stop], vk2[start:stop], vd1[start:stop],
                      vd2[start:stop], vstatus[start:stop], grain=GRAIN)
            if progress is not None:
                progress(nq + stop, total)
        k1, k2, d1, d2, status = vk1, vk2, vd1, vd2, vstatus
        fitted_n = nrm
    if one_sided is not None and one_sided.any():
        k1, k2, d1, d2, status = _one_sided(pos, nrm, comp, tree, sp, sn, sw, sc, one_sided, k1, k2, d1, d2,
                                            fitted_n, status, radius=radius, cos_max=cos_max)
    bad = int(np.count_nonzero(status == 1))
    return PrincipalCurvatures(k1, k2, d1, d2), fitted_n, bad


def _one_sided(pos: NDArray[np.float64], nrm: NDArray[np.float64], comp: NDArray[np.int64],
               tree: Any, sp: NDArray[np.float64], sn: NDArray[np.float64], sw: NDArray[np.float64],
               sc: NDArray[np.int64], one_sided: NDArray[np.bool_], k1: NDArray[np.float64],
               k2: NDArray[np.float64], d1: NDArray[np.float64], d2: NDArray[np.float64],
               fitted_n: NDArray[np.float64], status: NDArray[np.int8], *, radius: float,
               cos_max: float) -> tuple[Any, ...]:
    """The boundary vertices fitted again over a half disc as large as the full one (see fit_curvatures)."""
    from .._jit import run_split
    from ._kernels import GRAIN, fit_vertices, transfer_tensors

    q = np.flatnonzero(one_sided)
    k = int(min(2 * MAX_NEIGHBOURS, sp.shape[0]))
    dist, idx = tree.query(pos[q], k=k, workers=-1)
    dist, idx = dist.reshape(q.size, k), idx.reshape(q.size, k)
    b1, b2 = np.zeros(q.size), np.zeros(q.size)
    e1, e2, en = np.zeros((q.size, 3)), np.zeros((q.size, 3)), np.zeros((q.size, 3))
    bs = np.zeros(q.size, np.int8)
    run_split(fit_vertices, q.size, np.ascontiguousarray(pos[q]), np.ascontiguousarray(nrm[q]),
              np.ascontiguousarray(comp[q]), sp, sn, sw, sc, np.ascontiguousarray(idx, dtype=np.int64),
              np.ascontiguousarray(dist), float(ONE_SIDED_GROWTH * radius), 2 * MIN_NEIGHBOURS, cos_max,
              b1, b2, e1, e2, en, bs, grain=GRAIN)
    # the surface's side: the fits of the interior vertices nearby, carried over (Gaussian weights)
    from scipy.spatial import cKDTree

    inner = (status == 0) & ~one_sided
    t1, t2 = np.zeros(q.size), np.zeros(q.size)
    f1, f2 = np.zeros((q.size, 3)), np.zeros((q.size, 3))
    ts = np.ones(q.size, np.int8)
    if inner.any():
        kt = int(min(MAX_NEIGHBOURS, int(inner.sum())))
        pi = np.flatnonzero(inner)
        dist, idx = cKDTree(pos[pi]).query(pos[q], k=kt, workers=-1)
        dist, idx = dist.reshape(q.size, kt), idx.reshape(q.size, kt)
        run_split(transfer_tensors, q.size, np.ascontiguousarray(nrm[q]), np.ascontiguousarray(comp[q]),
                  np.ascontiguousarray(nrm[pi]), np.ascontiguousarray(comp[pi]), np.ones(pi.size, np.bool_),
                  np.ascontiguousarray(fitted_n[pi]), k1[pi], k2[pi], d1[pi], d2[pi], np.ascontiguousarray(idx),
                  np.ascontiguousarray(dist), float(radius), cos_max, t1, t2, f1, f2, ts, grain=GRAIN)
    # the refit, unless it bends more than twice as tightly as the surface beside it (a spike at an
    # opening: a sleeve's hem where the bodice's other layer is near); else the surface beside it
    side = np.maximum(np.abs(t1), np.abs(t2))
    done = (bs == 0) & ((ts != 0) | (np.maximum(np.abs(b1), np.abs(b2)) <= OPENING_SPIKE * side + 1e-12))
    carried = ~done & (ts == 0)
    k1, k2, d1, d2, status = k1.copy(), k2.copy(), d1.copy(), d2.copy(), status.copy()
    k1[q[done]], k2[q[done]], d1[q[done]], d2[q[done]] = b1[done], b2[done], e1[done], e2[done]
    k1[q[carried]], k2[q[carried]], d1[q[carried]], d2[q[carried]] = t1[carried], t2[carried], f1[carried], f2[carried]
    status[q[done | carried]] = 0
    return k1, k2, d1, d2, status
