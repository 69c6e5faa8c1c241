"""The woven-cloth model per texel: a CD-BTF (:class:`cdbrdf.CDBTF`) of one repeat.

The cloth model's reflectance is an integral over points spread over the
micro-surface of one weave repeat by area (:mod:`cdbrdf.synth.cloth`). Per
texel, for a view direction, a point belongs to the texel where the line from
the point along the view direction crosses the repeat's mean height (what an
orthographic camera rectified to the fabric plane sees there): a texel's
value is the sum over its points over the texel's area, with the same
visibility, footprint tilts and normalisation as the CDBRDF. The mean over
the texels is then exactly the cloth's CDBRDF computed with those points:
:meth:`ClothModel.tabulate` of the model with
``points = points_per_texel * n_u * n_v`` (it differs from the model's own
:attr:`ClothParams.points` by the integration error only). The texel
coordinates are fractions of the repeat at every curvature (the face
stretches on a bent cloth), in mm of the flat repeat.
"""

from __future__ import annotations

import logging
from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from ..btf import CDBTF, DEFAULT_MAX_ERROR, DEFAULT_METHOD, MAX_RANK
from ..errors import OptionError
from ..frames import direction_from_angles
from ..grid import Grid
from ..limits import check
from .cloth import ClothModel
from .pile import PileModel

__all__ = ["tabulate_btf", "tabulate_texels", "texel_model", "MAX_TEXELS", "POINTS_PER_TEXEL"]

_LOG = logging.getLogger(__name__)

#: Most texels along a side of the repeat.
MAX_TEXELS = 256

#: Default surface points per texel (on average: the points are spread by area).
POINTS_PER_TEXEL = 64

#: Per-texel values computed at once (bounds the memory of one chunk of light directions), float64 RGB.
_CHUNK_VALUES = 1 << 23


def _texels(texels: int | tuple[int, int]) -> tuple[int, int]:
    t = (texels, texels) if isinstance(texels, (int, np.integer)) and not isinstance(texels, bool) else texels
    try:
        nu, nv = (int(x) for x in t)  # type: ignore[union-attr]
        ok = all(isinstance(x, (int, np.integer)) and not isinstance(x, bool) for x in t)  # type: ignore[union-attr]
    except (TypeError, ValueError):
        ok = False
    if not ok or not (1 <= nu <= MAX_TEXELS and 1 <= nv <= MAX_TEXELS):
        raise OptionError(f"texels: expected an integer or two in [1, {MAX_TEXELS}], got {texels!r}")
    return nu, nv


def _points_per_texel(n: int) -> int:
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
        raise OptionError(f"points_per_texel: expected a positive integer, got {n!r}")
    return int(n)


def texel_model(model: ClothModel, texels: int | tuple[int, int] = 32, *,
                points_per_texel: int = POINTS_PER_TEXEL) -> ClothModel:
    """The cloth with ``points_per_texel * n_u * n_v`` surface points: the model whose CDBRDF is the tile mean.

    Parameters
    ----------
    model
        The cloth.
    texels, points_per_texel
        As :func:`tabulate_texels`.

    Returns
    -------
    ClothModel
    """
    nu, nv = _texels(texels)
    n = _points_per_texel(points_per_texel) * nu * nv
    return ClothModel(model.params.replace(points=max(16, n)))


def tabulate_texels(
    model: ClothModel,
    grid: Grid | None = None,
    *,
    texels: int | tuple[int, int] = 32,
    points_per_texel: int = POINTS_PER_TEXEL,
    progress: Callable[[int, int], None] | None = None,
) -> NDArray[np.float32]:
    """The cloth model per texel of one repeat on a grid, uncompressed.

    Parameters
    ----------
    model
        The cloth.
    grid
        The sample axes; default :meth:`cdbrdf.Grid.paper`.
    texels
        Texels per repeat: ``n`` (n x n) or ``(n_u, n_v)``.
    points_per_texel
        Surface points per texel on average: the tile is integrated with
        ``points_per_texel * n_u * n_v`` points (:func:`texel_model`).
    progress
        Called as ``progress(done, total)`` after each curvature slice.

    Returns
    -------
    numpy.ndarray
        ``(n_v, n_u) + grid.shape + (3,)`` float32, the BRDF in sr^-1.
    """
    g = Grid.paper() if grid is None else grid
    if not isinstance(g, Grid):
        raise TypeError(f"grid: expected cdbrdf.Grid, got {type(g).__name__}")
    nu, nv = _texels(texels)
    n_tex = nu * nv
    fine = texel_model(model, (nu, nv), points_per_texel=points_per_texel)
    check("table_samples", float(np.prod(g.shape)) * n_tex * 3,
          what=f"CD-BTF of {nu} x {nv} texels on a grid of shape {g.shape}")
    nk, npl, ntl, npv, ntv = g.shape
    values = np.empty((nk, npl, ntl, npv * ntv, n_tex, 3), dtype=np.float32)
    PV, TV = np.meshgrid(g.phi_v, g.theta_v, indexing="ij")
    v1 = direction_from_angles(TV.reshape(-1), PV.reshape(-1))
    lights = [(i, j) for i in range(npl) for j in range(ntl)]
    per_chunk = max(1, _CHUNK_VALUES // (v1.shape[0] * n_tex * 3))
    for ik, k in enumerate(g.kappa):
        _LOG.debug("%s: per-texel kappa = %g (%d x %d texels, %d points)", model.params.name, k, nu, nv,
                   fine.params.points)
        for c0 in range(0, len(lights), per_chunk):
            chunk = lights[c0 : c0 + per_chunk]
            l_dirs = direction_from_angles(np.array([g.theta_l[j] for _, j in chunk]),
                                           np.array([g.phi_l[i] for i, _ in chunk]))
            v = np.tile(v1, (len(chunk), 1))
            l = np.repeat(l_dirs, v1.shape[0], axis=0)
            out = fine._pairs(v, l, float(k), (nu, nv)).reshape(len(chunk), v1.shape[0], n_tex, 3)
            for (i, j), block in zip(chunk, out):
                values[ik, i, j] = block
        if progress is not None:
            progress(ik + 1, nk)
    # (kappa, phi_l, theta_l, phi_v * theta_v, v * u, c) -> (v, u, kappa, phi_l, theta_l, phi_v, theta_v, c)
    dense = np.moveaxis(values.reshape(nk, npl, ntl, npv, ntv, nv, nu, 3), (5, 6), (0, 1))
    return np.ascontiguousarray(dense)


def tabulate_btf(
    model: ClothModel | PileModel,
    grid: Grid | None = None,
    *,
    texels: int | tuple[int, int] = 32,
    points_per_texel: int | None = None,
    max_error: float = DEFAULT_MAX_ERROR,
    max_rank: int = MAX_RANK,
    progress: Callable[[int, int], None] | None = None,
    method: str = DEFAULT_METHOD,
) -> CDBTF:
    """Sample a fabric model per texel of one repeat and compress it.

    Woven cloth (:class:`ClothModel`): :func:`tabulate_texels`, one weave
    repeat. Pile (:class:`~cdbrdf.synth.PileModel`):
    :func:`cdbrdf.synth.pile_texels.tabulate_pile_texels`, one repeat of
    tufts or loops.

    Parameters
    ----------
    model, grid, texels, progress
        As :func:`tabulate_texels`.
    points_per_texel
        Woven cloth only (default :data:`POINTS_PER_TEXEL`): as
        :func:`tabulate_texels`.
    max_error, max_rank
        The compression's target relative RMS error and most components
        (:meth:`cdbrdf.CDBTF.from_values`).
    method
        The representation (:data:`cdbrdf.btf.METHODS`; default
        ``"neural"``: latent codes and a decoder, plus residual components
        while ``max_error`` needs them; ``docs/btf.md``).

    Returns
    -------
    CDBTF
        ``quantity = "brdf"``; the tile mean's attributes are the model's
        (for cloth those of :func:`texel_model`, its ``points`` the tile's)
        with ``btf_texels`` and ``btf_points_per_texel`` (cloth) or
        ``btf_tufts`` (pile: pitch and bundle width, mm).

    Raises
    ------
    OptionError
        For bad texel counts, or ``points_per_texel`` with a pile model.
    """
    g = Grid.paper() if grid is None else grid
    if not isinstance(g, Grid):
        raise TypeError(f"grid: expected cdbrdf.Grid, got {type(g).__name__}")
    nu, nv = _texels(texels)
    if isinstance(model, PileModel):
        from .pile_texels import tabulate_pile_texels

        if points_per_texel is not None:
            raise OptionError("points_per_texel: only for woven cloth (a pile model has no integration points)")
        dense, layout = tabulate_pile_texels(model, g, texels=(nu, nv), progress=progress)
        attrs = model.attrs()
        attrs["btf_texels"] = [nu, nv]
        attrs["btf_tufts"] = {"pitch_mm": layout.pitch_mm, "sigma_mm": layout.sigma_mm}
        repeat = layout.repeat_mm
    else:
        ppt = _points_per_texel(POINTS_PER_TEXEL if points_per_texel is None else points_per_texel)
        dense = tabulate_texels(model, g, texels=(nu, nv), points_per_texel=ppt, progress=progress)
        attrs = texel_model(model, (nu, nv), points_per_texel=ppt).attrs()
        attrs["btf_texels"] = [nu, nv]
        attrs["btf_points_per_texel"] = ppt
        repeat = model.heightfield(0.0).size_mm
    return CDBTF.from_values(dense, g, repeat_mm=repeat, max_error=max_error, max_rank=max_rank, attrs=attrs,
                             method=method)
