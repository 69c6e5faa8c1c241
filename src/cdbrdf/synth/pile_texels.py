"""The pile model per texel: a CD-BTF of one repeat of tufts (cut pile) or loops (terry).

The pile model (:mod:`cdbrdf.synth.pile`) is a homogeneous layer: its
fibres' density does not depend on the position on the fabric. Real pile
stands in tufts, one per pile end and a few picks, with gaps between them
through which the ground shows; that is the texture of velvet and towelling
close up, and a convex bend opens it. This module lays the pile's density
out over the fabric and shares the model's light among the texels, so that
the tile mean is *exactly* the model's CDBRDF (:meth:`PileModel.tabulate`):

1. *Layout* (:func:`tuft_layout`). Tufts (a V-tuft of two cut strands, or
   one loop) at ``n = strands_per_mm2 / 2`` (cut) or ``strands_per_mm2``
   (loop) per mm^2, in rows along x staggered by half a pitch (as pile ends
   interlace with the ground's picks): pitch ``a = 1 / sqrt(n)``, a repeat of
   ``a x 2a`` mm holding two tufts. Each tuft is a round Gaussian bundle
   whose full width at half maximum is the pitch less the gaps between
   tufts (``correlation_mm``, the model's gap size), at least a quarter of
   the pitch.
2. *Bending.* On a cylinder of curvature ``kappa`` the tufts stand along
   the radii and stay bundles: at height ``z`` the pitch grows by
   ``1 + kappa z`` while a tuft keeps its width, so in the repeat's
   coordinates (fractions of the repeat, measured in mm of the flat repeat)
   a tuft at height ``z`` is ``1 + kappa z`` times narrower: the gaps open
   on a convex bend and close on a concave one. A leaning pile's tuft at
   height ``z`` is shifted by ``z tan(lean)`` towards the brush azimuth.
3. *Texels.* A texel is what an orthographic camera rectified to the plane
   of the pile's top sees (the parallax of the CD-BTF's texels): the light
   that slab ``j`` of the model scatters towards ``v`` is shared among the
   texels in proportion to the tufts' density where the line from the texel
   along ``v`` crosses the slab; the light the ground reflects is shared in
   proportion to ``exp(-tau rho)``, the transmission of the pile over the
   ground point the texel sees, with ``tau`` the model's joint optical depth
   of the two paths and ``rho`` the relative density the view line crosses.
   Each share has mean one over the texels, so the texels' mean is the
   model's value at every sample. The texel's area is accounted for by
   widening each bundle by the texel's box (variance ``texel^2 / 12`` per
   axis).

Not modelled: the light path's own crossing of tufts (the share uses the
view line only), light passing from one tuft to another, and the loops'
shape from above (a loop is a round bundle at the loop's centre).
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..frames import direction_from_angles
from ..grid import Grid
from ..limits import check
from .pile import PileModel

__all__ = ["TuftLayout", "tuft_layout", "tabulate_pile_texels"]

_LOG = logging.getLogger(__name__)

#: Smallest tuft width as a fraction of the pitch.
_MIN_WIDTH = 0.25

#: Full width at half maximum of a Gaussian over its standard deviation.
_FWHM = 2.0 * math.sqrt(2.0 * math.log(2.0))


@dataclass(frozen=True)
class TuftLayout:
    """Where the tufts of a pile stand on one repeat.

    Attributes
    ----------
    repeat_mm
        ``(size_u, size_v)``: the repeat on the flat fabric, mm (``a x 2a``).
    pitch_mm
        ``a``: the distance between neighbouring tufts in a row, mm.
    centres_mm
        ``(2, 2)``: the tufts' centres on the ground, mm.
    sigma_mm
        The standard deviation of a tuft's round Gaussian bundle, mm.
    """

    repeat_mm: tuple[float, float]
    pitch_mm: float
    centres_mm: NDArray[np.float64]
    sigma_mm: float


def tuft_layout(model: PileModel) -> TuftLayout:
    """The tufts of a pile model on one repeat (step 1 of the module's rule).

    Parameters
    ----------
    model
        The pile.

    Returns
    -------
    TuftLayout
    """
    p = model.params
    per_mm2 = p.strands_per_mm2 / 2.0 if p.kind == "cut" else p.strands_per_mm2
    a = 1.0 / math.sqrt(per_mm2)
    fwhm = max(a - p.correlation_mm, _MIN_WIDTH * a)
    centres = np.array([[0.5 * a, 0.5 * a], [0.0, 1.5 * a]])
    return TuftLayout(repeat_mm=(a, 2.0 * a), pitch_mm=a, centres_mm=centres, sigma_mm=fwhm / _FWHM)


def _density(layout: TuftLayout, fu: NDArray[np.float64], fv: NDArray[np.float64], sigma_u: NDArray[np.float64],
             sigma_v: NDArray[np.float64]) -> NDArray[np.float64]:
    """Relative tuft density (mean 1 over the repeat) at positions ``(fu, fv)`` in mm of the flat repeat.

    ``sigma_u``, ``sigma_v`` broadcast with the positions: each bundle's
    width in the repeat's coordinates (with the texel's box). Periodic
    images within five widths are summed.
    """
    su, sv = layout.repeat_mm
    out = np.zeros(np.broadcast(fu, fv, sigma_u, sigma_v).shape)
    reach_u = int(math.ceil(5.0 * float(np.max(sigma_u)) / su)) + 1
    reach_v = int(math.ceil(5.0 * float(np.max(sigma_v)) / sv)) + 1
    for cu, cv in layout.centres_mm:
        du = np.mod(fu - cu + 0.5 * su, su) - 0.5 * su
        dv = np.mod(fv - cv + 0.5 * sv, sv) - 0.5 * sv
        for i in range(-reach_u, reach_u + 1):
            gu = np.exp(-0.5 * ((du + i * su) / sigma_u) ** 2) / sigma_u
            for j in range(-reach_v, reach_v + 1):
                out += gu * np.exp(-0.5 * ((dv + j * sv) / sigma_v) ** 2) / sigma_v
    # each bundle integrates to 2 pi; two bundles per repeat of area su sv
    return out * (su * sv / (2.0 * 2.0 * math.pi))


def _normalised(w: NDArray[np.float64]) -> NDArray[np.float64]:
    """Shares of mean one over the last axis (the texels); uniform where all are zero."""
    m = w.mean(axis=-1, keepdims=True)
    return np.where(m > 0, w / np.where(m > 0, m, 1.0), 1.0)


def _slab_shares(model: PileModel, layout: TuftLayout, kappa: float, views: NDArray[np.float64],
                 tu: NDArray[np.float64], tv: NDArray[np.float64]) -> NDArray[np.float64]:
    """``(n_views, layers, n_texels)``: each slab's share per texel for each view direction (mean 1)."""
    p = model.params
    su, sv = layout.repeat_mm
    edges = model.slab_edges_mm
    z = 0.5 * (edges[:-1] + edges[1:])  # (L,)
    top = float(edges[-1])
    stretch = 1.0 + kappa * z  # the pitch at height z over the ground's
    lean = math.tan(math.radians(p.lean_deg))
    b = math.radians(p.brush_deg)
    slope = views[:, :2] / views[:, 2:3]  # (V, 2): horizontal mm per mm of height along the view line
    # where the view line from the texel (on the top plane) crosses slab j, in mm of the flat repeat
    off = (top - z)[None, :, None] * slope[:, None, :] / stretch[None, :, None]  # (V, L, 2)
    lean_uv = np.array([math.cos(b), math.sin(b)]) * lean
    shift = z[:, None] * lean_uv[None, :] / stretch[:, None]  # (L, 2) the tuft's centre at height z
    box_u, box_v = (su / len(tu)) ** 2 / 12.0, (sv / len(tv)) ** 2 / 12.0
    sig = layout.sigma_mm / stretch  # (L,)
    sig_u = np.sqrt(sig**2 + box_u)[None, :, None]
    sig_v = np.sqrt(sig**2 + box_v)[None, :, None]
    U, V = np.meshgrid(tu, tv)  # texel centres, (n_v, n_u): texel t = iv * n_u + iu
    fu = U.reshape(1, 1, -1) - off[..., 0:1] - shift[None, :, 0:1]
    fv = V.reshape(1, 1, -1) - off[..., 1:2] - shift[None, :, 1:2]
    return _normalised(_density(layout, fu, fv, sig_u, sig_v))


def tabulate_pile_texels(
    model: PileModel,
    grid: Grid,
    *,
    texels: tuple[int, int],
    progress: Callable[[int, int], None] | None = None,
) -> tuple[NDArray[np.float32], TuftLayout]:
    """The pile model per texel of one repeat of tufts on a grid, uncompressed.

    Parameters
    ----------
    model
        The pile.
    grid
        The sample axes.
    texels
        ``(n_u, n_v)`` texels per repeat.
    progress
        Called as ``progress(done, total)`` after each curvature slice.

    Returns
    -------
    values : numpy.ndarray
        ``(n_v, n_u) + grid.shape + (3,)`` float32, the BRDF in sr^-1; the
        mean over the texels is :meth:`PileModel.tabulate` on ``grid``.
    layout : TuftLayout
        The tufts (the repeat's size).
    """
    nu, nv = texels
    layout = tuft_layout(model)
    check("table_samples", float(np.prod(grid.shape)) * nu * nv * 3,
          what=f"CD-BTF of {nu} x {nv} texels on a grid of shape {grid.shape}")
    su, sv = layout.repeat_mm
    tu, tvc = (np.arange(nu) + 0.5) * su / nu, (np.arange(nv) + 0.5) * sv / nv
    nk, npl, ntl, npv, ntv = grid.shape
    PV, TV = np.meshgrid(grid.phi_v, grid.theta_v, indexing="ij")
    views = direction_from_angles(TV.reshape(-1), PV.reshape(-1))  # (V, 3), V = npv * ntv
    PL, TL = np.meshgrid(grid.phi_l, grid.theta_l, indexing="ij")
    lights = direction_from_angles(TL.reshape(-1), PL.reshape(-1))  # (Lt, 3)
    n_v, n_l, n_t = views.shape[0], lights.shape[0], nu * nv
    values = np.empty((nk, n_l, n_v, n_t, 3), dtype=np.float32)
    L = model.params.layers
    for ik, k in enumerate(grid.kappa):
        _LOG.debug("%s: per-texel kappa = %g (%d x %d texels)", model.params.name, k, nu, nv)
        v = np.tile(views, (n_l, 1))
        l = np.repeat(lights, n_v, axis=0)
        out, slabs = model._pairs_slabs(v, l, float(k), slabs=True)
        out = out.reshape(n_l, n_v, 6)
        slabs = slabs.reshape(n_l, n_v, L + 1, 3)
        share = _slab_shares(model, layout, float(k), views, tu, tvc)  # (V, L, T)
        rho_path = share.mean(axis=1)  # (V, T): the relative density the view line crosses
        for c in range(3):
            # the pile: sum over slabs of the slab's value times its share
            values[ik, ..., c] = np.einsum("lvj,vjt->lvt", slabs[..., :L, c], share, optimize=True)
        tau = slabs[..., L, 0]  # (Lt, V)
        ground = _normalised(np.exp(-tau[..., None] * rho_path[None]))  # (Lt, V, T)
        values[ik] += (out[..., 3:, None] * ground[:, :, None, :]).transpose(0, 1, 3, 2)
        if progress is not None:
            progress(ik + 1, nk)
    # (kappa, phi_l * theta_l, phi_v * theta_v, v * u, c) -> (v, u, kappa, phi_l, theta_l, phi_v, theta_v, c)
    dense = np.moveaxis(values.reshape(nk, npl, ntl, npv, ntv, nv, nu, 3), (5, 6), (0, 1))
    return np.ascontiguousarray(dense), layout
