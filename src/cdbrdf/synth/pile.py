"""The curvature-dependent BRDF of a pile fabric (velvet, towelling) from its fibres.

A pile fabric is a ground weave with fibres (velvet: short cut fibres
standing near the normal) or yarn loops (terry towelling) standing on it.
:class:`PileParams` describes one (pile height, fibre or yarn diameter,
density, lean, orientation spread, colours, fibre gloss); :class:`PileModel`
evaluates its reflectance ``f(theta_v, phi_v, theta_l, phi_l, kappa)`` (BRDF
in sr^-1, cosine of the light direction not included, linear Rec. 709 RGB)
and tabulates it onto any :class:`cdbrdf.Grid`.

How a value is computed (``docs/fabric-model.md`` has the details):

1. *Geometry.* The pile is a layer of height ``H`` cut into ``layers`` slabs;
   a quadrature of fibre directions ``t_m`` (around the normal with a
   Gaussian spread, tilted by the lean towards the brush azimuth; for loops,
   the tangents along semi-elliptic arches in random vertical planes) gives,
   per slab, the fibre length per unit volume of each direction.
2. *Bending.* On a cylinder of curvature ``kappa`` the fibres stand along the
   radii: at height ``z`` above the ground the same fibres spread over
   ``1 + kappa z`` times the ground's length, so each slab's density is
   divided by ``1 + kappa z`` (neighbouring tips separate by ``h kappa`` per
   unit spacing on a convex bend, the ground shows; they crowd on a concave
   one). In the local frame the fibres keep their directions.
3. *Extinction.* A fibre of diameter ``d`` shadows ``d |w x t|`` per unit
   length from direction ``w`` (Zhao et al. 2011's fibre medium, the
   microflake model's projected area of Jakob et al. 2010).
4. *Scattering.* Single scattering in the pile, each fibre a diffuse,
   coloured cylinder plus the white specular ``R`` lobe of Marschner et al.
   (2003) (:mod:`cdbrdf.synth._pile`), integrated over depth with the
   transmissions towards the light and the viewer; the ground, a Lambertian
   surface of its own colour, is seen through the pile.
5. *Shadowing and masking.* The view and light paths through the pile are
   correlated where they are closer than ``correlation_mm`` (the gaps between
   tufts): their joint transmission is ``exp(-(max + (1 - c) min))`` of the
   two optical depths, ``c = exp(-separation / correlation_mm)`` (the hot
   spot of Kuusk 1991's canopy model).

Energy: each fibre's albedo is at most 1 (numerically normalised) and only
single scattering and one ground bounce are counted, so the directional
albedo is at most 1 (tested numerically). Reciprocity: every term is
symmetric in the view and the light, so the model is reciprocal to rounding.
Multiple scattering between fibres is not included (the values are a lower
bound for bright fibres).

References
----------
J. Lu, J. J. Koenderink, A. M. L. Kappers, "Optical properties (bidirectional
reflection distribution functions) of velvet", Applied Optics 37(25), 1998.
S. Zhao, W. Jakob, S. Marschner, K. Bala, "Building volumetric appearance
models of fabric using micro CT imaging", ACM Transactions on Graphics 30(4), 2011.
Z. Velinov, M. B. Hullin, "An interactive appearance model for microscopic
fiber surfaces", Vision, Modeling and Visualization, 2016.
W. Jakob, A. Arbree, J. T. Moon, K. Bala, S. Marschner, "A radiative transfer
framework for rendering materials with anisotropic structure", ACM
Transactions on Graphics 29(4), 2010.
S. R. Marschner, H. W. Jensen, M. Cammarano, S. Worley, P. Hanrahan, "Light
scattering from human hair fibers", ACM Transactions on Graphics 22(3), 2003.
A. Kuusk, "The hot spot effect in plant canopy reflectance", in Photon-Vegetation
Interactions, Springer, 1991.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._jit import run_split
from ..errors import OptionError
from . import _pile
from ._model import SampledModel
from ._params import ModelParams, is_real
from .multiple import (
    PILE_AZIMUTHS,
    PILE_RINGS,
    SCATTERING,
    HemisphereGrid,
    PileMedium,
    hemisphere_grid,
    interpolate_pairs,
    pile_multiple,
    pile_reflectance,
)

__all__ = ["PILE_KINDS", "PILE_RANGES", "PileParams", "PileModel", "PILE_MODEL_NAME", "PILE_MODEL_VERSION",
           "strand_albedo"]

log = logging.getLogger(__name__)

PILE_MODEL_NAME = "cdbrdf.synth.pile"
#: Bump when a change alters any computed value.
PILE_MODEL_VERSION = "2.0"

#: Kinds of pile: straight cut fibres (velvet, plush) or yarn loops (terry).
PILE_KINDS: Mapping[str, str] = MappingProxyType({
    "cut": "straight cut fibres rooted in the ground (velvet, velveteen, plush)",
    "loop": "yarn loops, semi-elliptic arches in random vertical planes (terry towelling)",
})

#: Largest ``-kappa z`` a concave bend may reach at the pile's top (the pile
#: would otherwise meet itself at the cylinder's axis).
_MAX_CROWDING = 0.9
_ALBEDO_THETAS = 46
_ALBEDO_N_THETA = 90
_ALBEDO_N_PHI = 180
_NORM_MARGIN = 1.01

RGB = tuple[float, float, float]


#: The physical range of each length and lobe width of :class:`PileParams` (closed): a micrometre to centimetres,
#: a lobe of a tenth of a degree to a hemisphere. Below the lower ends the model's integrals underflow (a gloss
#: of 1e-300 degrees gave NaN reflectance); a pile that vanishes (``strands_per_mm2``) or gaps without correlation
#: (``correlation_mm``) keep their limits of 1e-9.
PILE_RANGES: dict[str, tuple[float, float]] = {
    "pile_height_mm": (1e-3, 50.0), "strand_diameter_mm": (1e-4, 5.0), "strands_per_mm2": (1e-9, 1e5),
    "loop_width_mm": (1e-3, 50.0), "fibre_gloss_deg": (0.1, 90.0), "correlation_mm": (1e-9, 50.0),
}


@dataclass(frozen=True)
class PileParams(ModelParams):
    """Parameters of a pile fabric. Lengths in mm, angles in degrees.

    Attributes
    ----------
    name
        Material name written into tables.
    kind
        ``"cut"`` or ``"loop"`` (:data:`PILE_KINDS`).
    pile_height_mm
        Fibre length (cut) or loop height (loop), ``h``.
    strand_diameter_mm
        Diameter ``d`` of the scattering cylinders: a fibre (cut) or the
        loop yarn (loop).
    strands_per_mm2
        Fibres (cut) or loops (loop) per mm^2 of ground.
    loop_width_mm
        Base width of a loop (loop only).
    lean_deg
        Tilt of the whole pile from the normal, towards ``brush_deg``.
    brush_deg
        Azimuth the pile leans towards (the brush direction), from x.
    spread_deg
        Standard deviation of the fibres' (cut) or loop planes' (loop) tilt
        around the lean.
    fibre_rgb
        Albedo of the fibres' diffuse scattering (linear Rec. 709, [0, 1]).
    ground_rgb
        Lambertian albedo of the ground weave.
    fibre_specular
        Weight ``w_s`` in [0, 1] of the fibres' white specular lobe (1 = Fresnel).
    fibre_gloss_deg
        Width ``beta`` of the specular lobe (fibre surface roughness).
    ior
        Refractive index of the fibres.
    correlation_mm
        Horizontal size of the gaps in the pile: the view and light paths see
        the same gaps when closer than this (the hot spot).
    scattering
        ``"multiple"`` (every order of scattering: the single scattering
        exactly, the further orders by the adding-doubling solution of the
        pile's radiative transfer, :mod:`cdbrdf.synth.multiple`) or
        ``"single"`` (single scattering and one ground bounce only).
    layers
        Slabs the pile is integrated over.
    azimuths
        Azimuthal samples of the orientation quadrature.
    rings
        Tilt samples of the orientation quadrature.
    """

    _KIND = "pile"

    name: str = "pile"
    kind: str = "cut"
    pile_height_mm: float = 1.5
    strand_diameter_mm: float = 0.015
    strands_per_mm2: float = 300.0
    loop_width_mm: float = 1.0
    lean_deg: float = 0.0
    brush_deg: float = 90.0
    spread_deg: float = 10.0
    fibre_rgb: RGB = (0.5, 0.5, 0.5)
    ground_rgb: RGB = (0.5, 0.5, 0.5)
    fibre_specular: float = 1.0
    fibre_gloss_deg: float = 8.0
    ior: float = 1.53
    correlation_mm: float = 0.1
    scattering: str = "multiple"
    layers: int = 16
    azimuths: int = 12
    rings: int = 6

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name:
            raise OptionError("name: must be a non-empty string")
        if self.kind not in PILE_KINDS:
            raise OptionError(f"kind: unknown pile kind {self.kind!r}; valid kinds: {', '.join(PILE_KINDS)}")
        if self.scattering not in SCATTERING:
            raise OptionError(f"scattering: unknown {self.scattering!r}; valid values: {', '.join(SCATTERING)}")
        for f in ("fibre_rgb", "ground_rgb"):
            v = getattr(self, f)
            try:
                a = np.asarray(v, dtype=np.float64)
            except (TypeError, ValueError):
                raise OptionError(f"{f}: expected three numbers, got {v!r}") from None
            if a.shape != (3,) or not np.all(np.isfinite(a)) or np.any(a < 0) or np.any(a > 1):
                raise OptionError(f"{f}: expected three albedos in [0, 1], got {v!r}")
            object.__setattr__(self, f, tuple(float(x) for x in a))
        for f, (lo, hi) in PILE_RANGES.items():
            v = getattr(self, f)
            if not is_real(v) or not lo <= v <= hi:
                raise OptionError(f"{f}: must be a number in [{lo:g}, {hi:g}], got {v!r}")
            object.__setattr__(self, f, float(v))
        for f, lo, hi in (("lean_deg", 0.0, 80.0), ("spread_deg", 0.0, 60.0), ("fibre_specular", 0.0, 1.0),
                          ("brush_deg", -360.0, 360.0), ("ior", 1.0, 3.0)):
            v = getattr(self, f)
            if not is_real(v) or not lo <= v <= hi:
                raise OptionError(f"{f}: must lie in [{lo:g}, {hi:g}], got {v!r}")
            object.__setattr__(self, f, float(v))
        for f, lo, hi in (("layers", 2, 256), ("azimuths", 1, 256), ("rings", 1, 64)):
            v = getattr(self, f)
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or not lo <= v <= hi:
                raise OptionError(f"{f}: must be an integer in [{lo}, {hi}], got {v!r}")
            object.__setattr__(self, f, int(v))


def _lean_matrix(p: PileParams) -> NDArray[np.float64]:
    """Rotation tilting z by ``lean_deg`` towards azimuth ``brush_deg``."""
    a, b = math.radians(p.lean_deg), math.radians(p.brush_deg)
    u = np.array([-math.sin(b), math.cos(b), 0.0])  # rotation axis, horizontal, normal to the brush
    k = np.array([[0, -u[2], u[1]], [u[2], 0, -u[0]], [-u[1], u[0], 0]])
    return np.eye(3) + math.sin(a) * k + (1 - math.cos(a)) * k @ k


def _tilts(p: PileParams) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Tilt nodes (radians, midpoints over +-3 sigma or [0, 3 sigma]) and their weights."""
    s = math.radians(p.spread_deg)
    if s == 0.0:
        return np.zeros(1), np.ones(1)
    n = p.rings
    if p.kind == "cut":  # polar angle of a 2-D Gaussian: weight exp(-a^2 / 2 s^2) sin a
        a = (np.arange(n) + 0.5) / n * min(3.0 * s, math.radians(85.0))
        w = np.exp(-0.5 * (a / s) ** 2) * np.sin(a)
    else:  # signed tilt of a loop's plane about its base
        a = ((np.arange(n) + 0.5) / n * 2.0 - 1.0) * min(3.0 * s, math.radians(85.0))
        w = np.exp(-0.5 * (a / s) ** 2)
    return a, w / w.sum()


def _segments(p: PileParams) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64],
                                      NDArray[np.float64]]:
    """Straight pieces of pile per mm^2 of flat ground.

    Returns ``(tangent (M, 3), z_low (M,), z_high (M,), length (M,))``:
    direction, heights of the ends (mm) and fibre length per mm^2 (mm).
    """
    tilt, tw = _tilts(p)
    naz = p.azimuths
    az = (np.arange(naz) + 0.5) / naz * 2.0 * math.pi
    R = _lean_matrix(p)
    if p.kind == "cut":
        T, A = np.meshgrid(tilt, az, indexing="ij")
        W = np.repeat(tw[:, None], naz, axis=1) / naz
        t = np.stack([np.sin(T) * np.cos(A), np.sin(T) * np.sin(A), np.cos(T)], -1).reshape(-1, 3) @ R.T
        w = W.reshape(-1)
        keep = t[:, 2] > 0.05
        t, w = t[keep], w[keep] / w[keep].sum()
        h = p.pile_height_mm
        return t, np.zeros(len(t)), h * t[:, 2], p.strands_per_mm2 * w * h
    ns = 24
    s = np.linspace(0.0, math.pi, ns + 1)
    arch = np.stack([-0.5 * p.loop_width_mm * np.cos(s), np.zeros_like(s), p.pile_height_mm * np.sin(s)], -1)
    tangents, zlo, zhi, length = [], [], [], []
    for ti, wi in zip(tilt, tw):
        ct, st = math.cos(ti), math.sin(ti)
        rx = np.array([[1, 0, 0], [0, ct, -st], [0, st, ct]])
        for a in az:
            ca, sa = math.cos(a), math.sin(a)
            rz = np.array([[ca, -sa, 0], [sa, ca, 0], [0, 0, 1]])
            pts = arch @ (R @ rz @ rx).T
            d = np.diff(pts, axis=0)
            seg = np.linalg.norm(d, axis=1)
            tangents.append(d / seg[:, None])
            zlo.append(np.minimum(pts[:-1, 2], pts[1:, 2]))
            zhi.append(np.maximum(pts[:-1, 2], pts[1:, 2]))
            length.append(seg * wi / naz * p.strands_per_mm2)
    zl = np.maximum(np.concatenate(zlo), 0.0)
    return np.concatenate(tangents), zl, np.maximum(np.concatenate(zhi), zl), np.concatenate(length)


def _layer_weights(p: PileParams) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64],
                                           NDArray[np.float64]]:
    """The flat pile per slab.

    Returns ``(tangents (M, 3), weights (L, M), caps (L, M), z_edges (L + 1,))``:
    strand length per unit volume (mm / mm^3), area of cut ends per unit
    volume (mm^2 / mm^3, cut pile only: one disc of the strand's section at
    its top) and the slabs' boundaries (mm).
    """
    t, zlo, zhi, length = _segments(p)
    top = float(zhi.max())
    L = p.layers
    edges = np.linspace(0.0, top, L + 1)
    dz = top / L
    lo, hi = edges[:-1, None], edges[1:, None]
    span = zhi - zlo
    flat = span < 1e-9 * top
    overlap = np.clip(np.minimum(hi, zhi) - np.maximum(lo, zlo), 0.0, None)
    frac = overlap / np.where(flat, 1.0, span)
    # A horizontal piece lies wholly in the slab holding its height.
    j = np.minimum((zlo / dz).astype(np.int64), L - 1)
    frac[:, flat] = 0.0
    frac[j[flat], np.flatnonzero(flat)] = 1.0
    W = frac * length / dz
    C = np.zeros_like(W)
    if p.kind == "cut":
        top_slab = np.minimum((zhi / dz).astype(np.int64), L - 1)
        ends = length / p.pile_height_mm  # strands per mm^2 in each direction
        C[top_slab, np.arange(len(t))] = ends * 0.25 * math.pi * p.strand_diameter_mm**2 / dz
    return np.ascontiguousarray(t), np.ascontiguousarray(W), np.ascontiguousarray(C), edges


class PileModel(SampledModel):
    """Reflectance of a pile fabric as a function of directions and curvature.

    Parameters
    ----------
    params
        The fabric (:class:`PileParams`).

    Examples
    --------
    >>> from cdbrdf.synth import presets
    >>> m = presets.model("velvet")
    >>> m.evaluate(30.0, 0.0, 30.0, 180.0, kappa=0.22).shape
    (3,)
    """

    def __init__(self, params: PileParams) -> None:
        if not isinstance(params, PileParams):
            raise TypeError(f"params: expected PileParams, got {type(params).__name__}")
        self.params = p = params
        self._tangents, self._weights, self._caps, self._edges = _layer_weights(p)
        row = np.zeros(_pile.N_FIBRE)
        row[_pile.F_R:_pile.F_B + 1] = p.fibre_rgb
        row[_pile.F_KD] = 1.0
        row[_pile.F_WS] = p.fibre_specular
        row[_pile.F_BETA] = math.radians(p.fibre_gloss_deg)
        row[_pile.F_ETA] = p.ior
        row[_pile.F_TINV] = 1.0
        ones = np.ones(_ALBEDO_THETAS)
        row[_pile.F_K] = 1.0 / (_fibre_albedo(row, 0, ones).max() * _NORM_MARGIN)
        # What the specular lobe does not reflect enters the fibre: T(theta) = 1 - a_s(theta).
        spec = row.copy()
        spec[_pile.F_KD] = 0.0
        spec_albedo = _fibre_albedo(spec, 1, ones)
        self._trans = np.clip(1.0 - spec_albedo, 0.0, 1.0)
        self._trans.setflags(write=False)
        th = np.radians(np.linspace(0.0, 89.0, _ALBEDO_THETAS))
        fine = np.linspace(0.0, 0.5 * math.pi, 2001)
        tbar = 4.0 / math.pi * np.trapezoid(np.interp(fine, th, self._trans) * np.cos(fine) ** 2, fine)
        row[_pile.F_TINV] = 1.0 / tbar
        probe = row.copy()
        probe[_pile.F_KD] = max(p.fibre_rgb)
        row[_pile.F_SCALE] = 1.0 / max(1.0, float(_fibre_albedo(probe, 1, self._trans).max()) * _NORM_MARGIN)
        # The mean albedo of the specular lobe (weights cos theta: directions spread evenly over the sphere).
        self._spec_mean = float(np.sum(spec_albedo * np.cos(th)) / np.sum(np.cos(th)))
        row.setflags(write=False)
        self._fibre = row
        self._ground = np.asarray(p.ground_rgb, dtype=np.float64)
        self._medium: PileMedium | None = None
        self._grid: HemisphereGrid | None = None
        if p.scattering == "multiple":
            # In the further orders a strand scatters, like a diffuse cylinder, its whole mean albedo
            # a_s + A (1 - a_s) (normalised exactly on the direction grid: no quadrature margin).
            rgb = np.asarray(p.fibre_rgb, dtype=np.float64)
            self._medium = PileMedium(
                tangents=self._tangents, weights=self._weights, caps=self._caps, z_edges=self._edges,
                diameter_mm=p.strand_diameter_mm,
                diffuse_rgb=np.clip(self._spec_mean + rgb * (1.0 - self._spec_mean), 0.0, 1.0),
                cap_rgb=rgb, ground_rgb=self._ground,
            )
            self._grid = hemisphere_grid(PILE_RINGS, PILE_AZIMUTHS)
        self._multiple: dict[float, tuple[NDArray[np.float64], NDArray[np.float64]]] = {}

    @property
    def top_mm(self) -> float:
        """Height of the pile's top above the ground, mm (flat cloth)."""
        return float(self._edges[-1])

    def layer_scale(self, kappa: float) -> NDArray[np.float64]:
        """Density factor ``1 / (1 + kappa z)`` of each slab (mid-height ``z``) at curvature ``kappa``.

        Parameters
        ----------
        kappa
            Curvature, mm^-1 (> 0 convex).

        Returns
        -------
        numpy.ndarray
            One factor per slab of the pile.

        Raises
        ------
        OptionError
            For a concave bend tighter than the pile allows
            (``kappa * top < -0.9``).
        """
        k = float(kappa)
        if k * self.top_mm < -_MAX_CROWDING:
            raise OptionError(
                f"kappa = {k:g} 1/mm: a concave bend tighter than this pile allows "
                f"(pile top {self.top_mm:.3g} mm; kappa must be > {-_MAX_CROWDING / self.top_mm:.3g})"
            )
        z = 0.5 * (self._edges[:-1] + self._edges[1:])
        return 1.0 / (1.0 + k * z)

    def _pairs(self, v: NDArray[np.float64], l: NDArray[np.float64], kappa: float) -> NDArray[np.float64]:
        """Pile and ground BRDF ``(n, 6)`` for unit direction pairs at one curvature."""
        return self._pairs_slabs(v, l, kappa, slabs=False)[0]

    def _pairs_slabs(self, v: NDArray[np.float64], l: NDArray[np.float64], kappa: float, *,
                     slabs: bool) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """``(out (n, 6), slabs (n, L + 1, 3))`` of :func:`_pile.pile_pairs` (slabs empty unless asked)."""
        n = v.shape[0]
        out = np.zeros((n, 6))
        per_slab = np.zeros((n if slabs else 0, self.params.layers + 1, 3))
        if n == 0:
            return out, per_slab
        run_split(_pile.pile_pairs, n, np.ascontiguousarray(v), np.ascontiguousarray(l),
                  self._tangents, self._weights, self._caps, self._edges, self.layer_scale(kappa),
                  self.params.strand_diameter_mm, self._fibre, self._trans, self._ground, self.params.correlation_mm,
                  out, per_slab, grain=64)
        if self._medium is not None:
            self._add_multiple(v, l, kappa, out, per_slab)
        return out, per_slab

    def multiple_scattering(self, kappa: float) -> tuple[NDArray[np.float64], NDArray[np.float64]] | None:
        """The further orders of scattering at curvature ``kappa`` (None with ``scattering = "single"``).

        Parameters
        ----------
        kappa
            Curvature, mm^-1.

        Returns
        -------
        tuple of numpy.ndarray or None
            The BRDF matrices ``(pile, ground)`` over the model's direction
            grid (:func:`cdbrdf.synth.multiple.pile_multiple`): the light that
            scattered two or more times and never reached the ground, and
            that which reached it at least once (besides the ground's single
            bounce).
        """
        if self._medium is None or self._grid is None:
            return None
        k = float(kappa)
        got = self._multiple.get(k)
        if got is None:
            got = pile_multiple(self._medium, self.layer_scale(k), self._grid)
            if len(self._multiple) > 16:
                self._multiple.clear()
            self._multiple[k] = got
        return got

    def _add_multiple(self, v: NDArray[np.float64], l: NDArray[np.float64], kappa: float,
                      out: NDArray[np.float64], per_slab: NDArray[np.float64]) -> None:
        """Add the further orders to ``out`` (pile, ground); the pile's shared by the slabs as its single scattering."""
        ms = self.multiple_scattering(kappa)
        assert ms is not None and self._grid is not None
        ok = (v[:, 2] > 0.0) & (l[:, 2] > 0.0)
        pile = np.zeros((v.shape[0], 3))
        ground = np.zeros((v.shape[0], 3))
        if ok.any():
            pile[ok] = interpolate_pairs(self._grid, ms[0], v[ok], l[ok])
            ground[ok] = interpolate_pairs(self._grid, ms[1], v[ok], l[ok])
        if per_slab.shape[0]:
            L = self.params.layers
            single = out[:, :3]
            has = single > 0.0
            ratio = np.where(has, (single + pile) / np.where(has, single, 1.0), 1.0)
            per_slab[:, :L, :] *= ratio[:, None, :]
            # where nothing scattered once (it cannot scatter twice either, but to keep the sum) the top slab
            per_slab[:, L - 1, :] += np.where(has, 0.0, pile)
        out[:, :3] += pile
        out[:, 3:] += ground

    @property
    def slab_edges_mm(self) -> NDArray[np.float64]:
        """The slabs' boundaries, mm above the ground (``layers + 1``, increasing; flat cloth)."""
        return self._edges.copy()

    def evaluate_parts(
        self,
        theta_v: ArrayLike,
        phi_v: ArrayLike,
        theta_l: ArrayLike,
        phi_l: ArrayLike,
        kappa: ArrayLike = 0.0,
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The BRDF split into the light scattered by the pile and by the ground.

        Parameters
        ----------
        theta_v, phi_v, theta_l, phi_l, kappa
            As :meth:`evaluate` (degrees, mm^-1; broadcast).

        Returns
        -------
        tuple of numpy.ndarray
            ``(pile, ground)``, each ``broadcast shape + (3,)``, sr^-1; their
            sum is :meth:`evaluate`.
        """
        out = self._by_kappa(self._pairs, 6, theta_v, phi_v, theta_l, phi_l, kappa)
        return out[..., :3], out[..., 3:]

    def evaluate(
        self,
        theta_v: ArrayLike,
        phi_v: ArrayLike,
        theta_l: ArrayLike,
        phi_l: ArrayLike,
        kappa: ArrayLike = 0.0,
    ) -> NDArray[np.float64]:
        """The BRDF (sr^-1, RGB) at any directions and curvatures.

        Parameters
        ----------
        theta_v, phi_v, theta_l, phi_l
            View and light elevation in [0, 90] and azimuth, degrees
            (broadcast together).
        kappa
            Curvature in mm^-1 (> 0 convex).

        Returns
        -------
        numpy.ndarray
            ``broadcast shape + (3,)``, float64, >= 0.

        Raises
        ------
        QueryError
            For an elevation outside [0, 90] degrees or a non-finite argument.
        OptionError
            For a concave bend tighter than the pile allows (:meth:`layer_scale`).
        """
        pile, ground = self.evaluate_parts(theta_v, phi_v, theta_l, phi_l, kappa)
        return pile + ground

    def _sample(self, v: NDArray[np.float64], l: NDArray[np.float64], kappa: float) -> NDArray[np.float64]:
        parts = self._pairs(v, l, kappa)
        return parts[:, :3] + parts[:, 3:]

    def _check_kappa(self, kappa: float) -> None:
        self.layer_scale(kappa)

    def attrs(self) -> dict[str, Any]:
        """Table metadata.

        Returns
        -------
        dict
            Quantity, material, model and parameters (provenance).
        """
        return {
            "quantity": "brdf",
            "material": self.params.name,
            "model": PILE_MODEL_NAME,
            "model_version": PILE_MODEL_VERSION,
            "provenance": {
                "kind": "synthesised",
                "model": PILE_MODEL_NAME,
                "model_version": PILE_MODEL_VERSION,
                "parameters": self.params.to_dict(),
                "references": [
                    "Lu, Koenderink & Kappers 1998, Optical properties (BRDFs) of velvet",
                    "Zhao et al. 2011, Building volumetric appearance models of fabric using micro CT imaging",
                    "Velinov & Hullin 2016, An interactive appearance model for microscopic fiber surfaces",
                    "Marschner et al. 2003, Light scattering from human hair fibers",
                ],
            },
        }


def strand_albedo(params: PileParams, reflectance_rgb: ArrayLike, *, stacked: int = 16,
                  tolerance: float = 1e-5) -> RGB:
    """The strand colour ``fibre_rgb`` for which a thick layer of the pile's strands reflects ``reflectance_rgb``.

    A material's published reflectance is that of an optically thick sample
    (``R_inf``, e.g. a pad of the fibre or a folded fabric), the result of
    many scattering events among its fibres; a strand of the pile model is
    one such scatterer. This finds, channel by channel (bisection), the
    strand albedo ``A`` whose pile, ``stacked`` layers deep over nothing,
    reflects ``R_inf`` under diffuse light in the model's own multiple
    scattering (:func:`cdbrdf.synth.multiple.pile_reflectance`).

    Parameters
    ----------
    params
        The pile (its strands' geometry, gloss and density; its colours are ignored).
    reflectance_rgb
        ``R_inf`` of the strands' material, linear Rec. 709, each in [0, 1).
    stacked
        Layers of the pile stacked to make it optically thick.
    tolerance
        On ``A``.

    Returns
    -------
    tuple of float
        ``fibre_rgb``.
    """
    target = np.asarray(reflectance_rgb, dtype=np.float64)
    if target.shape != (3,) or np.any(~np.isfinite(target)) or np.any(target < 0) or np.any(target >= 1):
        raise OptionError(f"reflectance_rgb: expected three reflectances in [0, 1), got {reflectance_rgb!r}")
    model = PileModel(params.replace(fibre_rgb=(1.0, 1.0, 1.0), scattering="multiple"))
    med, grid, s = model._medium, model._grid, model._spec_mean
    assert med is not None and grid is not None
    def excess(a: NDArray[np.float64]) -> NDArray[np.float64]:
        m = PileMedium(tangents=med.tangents, weights=med.weights, caps=med.caps, z_edges=med.z_edges,
                       diameter_mm=med.diameter_mm, diffuse_rgb=s + a * (1.0 - s), cap_rgb=a,
                       ground_rgb=np.zeros(3))
        return pile_reflectance(m, grid, stacked=stacked) - target

    # Regula falsi (Illinois) on [0, 1], channel by channel: R_inf grows with A.
    lo, hi = np.zeros(3), np.ones(3)
    f_lo, f_hi = excess(lo), excess(hi)
    if np.any(f_hi < 0):
        raise OptionError(f"reflectance_rgb: {reflectance_rgb!r} is more than a layer of white strands reflects")
    a = lo.copy()
    side = np.zeros(3)
    for _ in range(60):
        a = np.where(f_hi != f_lo, (lo * f_hi - hi * f_lo) / np.where(f_hi != f_lo, f_hi - f_lo, 1.0), 0.5 * (lo + hi))
        a = np.clip(a, lo, hi)
        f = excess(a)
        right = f > 0
        hi, f_hi = np.where(right, a, hi), np.where(right, f, f_hi)
        lo, f_lo = np.where(right, lo, a), np.where(right, f_lo, f)
        f_lo = np.where(right & (side > 0), 0.5 * f_lo, f_lo)
        f_hi = np.where(~right & (side < 0), 0.5 * f_hi, f_hi)
        side = np.where(right, 1.0, -1.0)
        if float(np.max(np.abs(f))) < tolerance * 0.1 or float(np.max(hi - lo)) < tolerance:
            break
    return float(a[0]), float(a[1]), float(a[2])


def _fibre_albedo(row: NDArray[np.float64], mode: int, trans: NDArray[np.float64]) -> NDArray[np.float64]:
    """Fibre albedo over longitudinal light angles 0..89 degrees (:func:`_pile.fibre_albedo`)."""
    th = np.radians(np.linspace(0.0, 89.0, _ALBEDO_THETAS))
    out = np.zeros(th.size)
    run_split(_pile.fibre_albedo, th.size, th, row, trans, mode, _ALBEDO_N_THETA, _ALBEDO_N_PHI, out, grain=4)
    return out
