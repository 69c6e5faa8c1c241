"""The curvature-dependent BRDF of a woven cloth, from its micro-structure.

:class:`ClothParams` describes a cloth (weave, yarns, fibres, colours,
thickness); :class:`ClothModel` evaluates its reflectance
``f(theta_v, phi_v, theta_l, phi_l, kappa)`` (BRDF in sr^-1, cosine of the
light direction not included, linear Rec. 709 RGB) and tabulates it onto any
:class:`cdbrdf.Grid`.

How a value is computed (``docs/fabric-model.md`` has the details):

1. *Geometry.* :func:`cdbrdf.synth.bending.bend` finds the yarns' geometry on
   a cylinder of curvature ``kappa`` (the spacing of the yarns along the
   axis, the crimp of the yarns around it); one repeat of the weave is built
   from it as a periodic height field
   (:func:`cdbrdf.synth.weave.build_heightfield`). The micro-surface is the
   bilinear interpolation of its texel-centre heights.
2. *Integration points* spread over that surface in proportion to its area
   (:func:`cdbrdf.synth.surface.surface_points`), each with the surface's own
   normal and the fibre direction of its yarn.
3. *Visibility.* From each point a ray is marched towards the viewer and one
   towards the light: ``V(p, w) = 1`` if it leaves the cloth (masking and
   shadowing, by one rule).
4. *Scattering.* ``f_p`` is the fibre BRDF of :mod:`cdbrdf.synth.fibre` with
   the yarn's colour, fibre direction and normal at ``p``.
5. The flat BRDF is the micro-surface integral
   ``f(v, l) = int f_p (n_p . v)+ (n_p . l)+ V(p, v) V(p, l) dA / (A cos theta_v cos theta_l)``
   (``A`` the repeat's area seen from above; Heitz 2014, eq. 6 and 10).
6. *Footprint.* On the cylinder the macro-normal turns by ``kappa x`` across
   the measured spot of diameter ``footprint_mm``; the value is the average
   over ``tilt_samples`` patches across it, each seen in its own frame and
   weighted by its projected area towards the viewer.

Energy: every local BRDF has directional albedo <= 1, the visible surface
seen from a direction projects onto the repeat's area (the integral of
``(n_p . v)+ V(p, v)`` is ``A cos theta_v``), shadowing only removes light and
the footprint weights sum to 1, so the directional albedo of the cloth is
<= 1 for every view direction and curvature (tested numerically).

Reciprocity: ``f_p`` is symmetric in v and l, and so is every term of the
integral (one visibility rule for both directions, at the same points), so
the computed values are reciprocal to rounding; the footprint average is
reciprocal while no patch turns away from the viewer or the light.

References
----------
P. Irawan and S. Marschner, "Specular reflection from woven cloth",
ACM Transactions on Graphics 31(1), 2012.
I. Sadeghi, O. Bisker, J. De Deken, H. W. Jensen, "A practical microcylinder
appearance model for cloth rendering", ACM Transactions on Graphics 32(2), 2013.
E. Heitz, "Understanding the masking-shadowing function in microfacet-based
BRDFs", Journal of Computer Graphics Techniques 3(2), 2014.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._jit import run_split
from ..errors import OptionError
from . import _trace
from ._model import SampledModel
from ._params import NOT_SPECIAL, ModelParams, is_real
from .bending import Bend, bend
from .fibre import P_B, P_R, FibreLobes
from .multiple import SCATTERING, Compensation, compensation, hemisphere_grid
from .surface import SurfacePoints, surface_points
from .weave import (
    Heightfield,
    YarnGeometry,
    build_heightfield,
    weave_matrix,
)

__all__ = ["CLOTH_RANGES", "ClothParams", "ClothModel", "MODEL_NAME", "MODEL_VERSION"]

log = logging.getLogger(__name__)

MODEL_NAME = "cdbrdf.synth.cloth"
#: Bump when a change alters any computed value.
MODEL_VERSION = "3.0"

#: Largest visibility table (directions x points) held at once, bytes.
_VIS_BYTES = 64 * 2**20
#: The white cloth's directional albedo (the compensation's ``E``) is computed on views of
#: this many rings x azimuths (and the pole), by a light quadrature of this many rings x azimuths.
_E_VIEWS = (6, 8)
_E_LIGHTS = (8, 16)
#: Share of the white cloth's missing energy the compensation returns: all of it but the
#: quadrature error of ``E`` (about 1 %), so that the albedo stays <= 1.
_E_FRACTION = 0.98

RGB = tuple[float, float, float]


#: The physical range of each length, refractive index and lobe width of :class:`ClothParams` (closed): yarns of
#: a micrometre to centimetres, lobes of a tenth of a degree to a hemisphere (below, the model's integrals
#: underflow to NaN, naming no parameter).
CLOTH_RANGES: dict[str, tuple[float, float]] = {
    **{f"{y}_pitch_mm": (1e-3, 100.0) for y in ("warp", "weft")},
    **{f"{y}_width_mm": (1e-3, 100.0) for y in ("warp", "weft")},
    **{f"{y}_height_mm": (1e-4, 100.0) for y in ("warp", "weft")},
    "thickness_mm": (1e-3, 100.0), "ior": (1.0, 3.0),
    **{f"{y}_{lobe}_deg": (0.1, 90.0) for y in ("warp", "weft") for lobe in ("gloss", "sheen")},
}


@dataclass(frozen=True)
class ClothParams(ModelParams):
    """Parameters of a woven cloth. Lengths in mm, angles in degrees.

    Attributes
    ----------
    name
        Material name written into tables.
    weave
        A registered weave name (:data:`cdbrdf.synth.weave.WEAVES`) or a 0/1
        matrix ``(n_weft, n_warp)``, 1 where the warp is on top.
    warp_along
        Local axis the warp runs along, ``"x"`` (the bending direction) or
        ``"y"`` (the cylinder's axis). Gaps open between the yarns that run
        along y.
    warp_rgb, weft_rgb
        Fibre volume-scattering albedo of each yarn (linear Rec. 709, [0, 1]).
    backing_rgb
        Lambertian albedo of what is seen through holes between the yarns.
    warp_pitch_mm, weft_pitch_mm
        Distance between neighbouring yarn centres.
    warp_width_mm, weft_width_mm, warp_height_mm, weft_height_mm
        Elliptical yarn cross-section (full width and height).
    crimp_share_warp
        In [0, 1]: how much of the crimp the warp takes (0.5 balanced).
    warp_twist_deg, weft_twist_deg
        Angle of the surface fibres to the yarn axis.
    crimp_transition
        In (0, 1]: fraction of the distance between crossings over which a
        yarn dives from one side to the other (1 = smooth cosine crimp).
    thickness_mm
        Cloth thickness ``t`` (the yarns are centred in it).
    neutral_fraction
        In [0, 1]: height of the zero-strain surface above the back, as a
        fraction of the thickness (0: a cloth bonded to its stand, whose back
        keeps its length; 1/2: a cloth bent freely). See
        :mod:`cdbrdf.synth.bending`.
    footprint_mm
        Diameter (along x) of the spot whose reflectance a sample averages;
        on a bent cloth the normal turns by ``kappa * footprint`` across it.
    ior
        Refractive index of the fibres.
    warp_specular, weft_specular
        Weight of the white surface reflection (1 = Fresnel).
    warp_gloss_deg, weft_gloss_deg
        Width ``gamma_s`` of the surface-reflection lobe.
    warp_sheen_deg, weft_sheen_deg
        Width ``gamma_v`` of the coloured forward-scattering lobe.
    warp_isotropic, weft_isotropic
        ``k_d`` in [0, 1]: isotropic fraction of the volume scattering.
    scattering
        ``"multiple"`` (the single scattering of the micro-surface plus the
        light it loses, returned by an energy-compensation term:
        :mod:`cdbrdf.synth.multiple`) or ``"single"`` (single scattering
        only, the model before 3.0).
    texels
        Height-field texels along the longer side of the repeat.
    points
        Integration points on the micro-surface of the repeat.
    tilt_samples
        Patches across the footprint on a bent cloth.
    """

    _KIND = "cloth"

    name: str = "cloth"
    weave: str | tuple[tuple[int, ...], ...] = "plain"
    warp_along: str = "y"
    warp_rgb: RGB = (0.5, 0.5, 0.5)
    weft_rgb: RGB = (0.5, 0.5, 0.5)
    backing_rgb: RGB = (0.1, 0.1, 0.1)
    warp_pitch_mm: float = 0.3
    weft_pitch_mm: float = 0.3
    warp_width_mm: float = 0.3
    weft_width_mm: float = 0.3
    warp_height_mm: float = 0.15
    weft_height_mm: float = 0.15
    crimp_share_warp: float = 0.5
    warp_twist_deg: float = 15.0
    weft_twist_deg: float = 15.0
    crimp_transition: float = 1.0
    thickness_mm: float = 0.5
    neutral_fraction: float = 0.0
    footprint_mm: float = 1.0
    ior: float = 1.53
    warp_specular: float = 1.0
    weft_specular: float = 1.0
    warp_gloss_deg: float = 10.0
    weft_gloss_deg: float = 10.0
    warp_sheen_deg: float = 20.0
    weft_sheen_deg: float = 20.0
    warp_isotropic: float = 0.7
    weft_isotropic: float = 0.7
    scattering: str = "multiple"
    texels: int = 192
    points: int = 4181
    tilt_samples: int = 5

    def __post_init__(self) -> None:
        w = self.weave
        if not isinstance(w, str):
            m = weave_matrix(w)
            object.__setattr__(self, "weave", tuple(tuple(int(x) for x in row) for row in m))
        else:
            weave_matrix(w)
        if self.warp_along not in ("x", "y"):
            raise OptionError(f"warp_along: expected 'x' or 'y', got {self.warp_along!r}")
        if self.scattering not in SCATTERING:
            raise OptionError(f"scattering: unknown {self.scattering!r}; valid values: {', '.join(SCATTERING)}")
        if not isinstance(self.name, str) or not self.name:
            raise OptionError("name: must be a non-empty string")
        for f in ("warp_rgb", "weft_rgb", "backing_rgb"):
            v = getattr(self, f)
            try:
                a = np.asarray(v, dtype=np.float64)
            except (TypeError, ValueError):
                raise OptionError(f"{f}: expected three numbers, got {v!r}") from None
            if a.shape != (3,) or not np.all(np.isfinite(a)) or np.any(a < 0) or np.any(a > 1):
                raise OptionError(f"{f}: expected three albedos in [0, 1], got {v!r}")
            object.__setattr__(self, f, tuple(float(x) for x in a))
        for f, (lo, hi) in CLOTH_RANGES.items():
            v = getattr(self, f)
            if not is_real(v) or not lo <= v <= hi:
                raise OptionError(f"{f}: must be a number in [{lo:g}, {hi:g}], got {v!r}")
            object.__setattr__(self, f, float(v))
        for f in ("crimp_share_warp", "neutral_fraction", "warp_isotropic", "weft_isotropic"):
            v = getattr(self, f)
            if not is_real(v) or not 0 <= v <= 1:
                raise OptionError(f"{f}: must lie in [0, 1], got {v!r}")
            object.__setattr__(self, f, float(v))
        v = self.crimp_transition
        if not is_real(v) or not 0.05 <= v <= 1:
            raise OptionError(f"crimp_transition: must lie in [0.05, 1], got {v!r}")
        object.__setattr__(self, "crimp_transition", float(v))
        for f in ("footprint_mm", "warp_specular", "weft_specular"):
            v = getattr(self, f)
            if not is_real(v) or not v >= 0:
                raise OptionError(f"{f}: must be a non-negative number, got {v!r}")
            object.__setattr__(self, f, float(v))
        for f in ("warp_twist_deg", "weft_twist_deg"):
            v = getattr(self, f)
            if not is_real(v) or not -60 <= v <= 60:
                raise OptionError(f"{f}: must lie in [-60, 60] degrees, got {v!r}")
            object.__setattr__(self, f, float(v))
        for f, lo in (("texels", 8), ("points", 16), ("tilt_samples", 1)):
            v = getattr(self, f)
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < lo:
                raise OptionError(f"{f}: must be an integer >= {lo}, got {v!r}")
            object.__setattr__(self, f, int(v))

    @classmethod
    def _parse_special(cls, name: str, text: str) -> Any:
        """A weave is a registered name or rows of 0/1 separated by commas or semicolons (``1110,0111,...``)."""
        if name != "weave":
            return NOT_SPECIAL
        if text.replace(",", "").replace(";", "").replace(" ", "").isdigit():
            rows = [r.strip() for r in text.replace(";", ",").split(",") if r.strip()]
            return tuple(tuple(int(c) for c in r) for r in rows)
        return text

    @property
    def weave_matrix(self) -> NDArray[np.int8]:
        """The weave repeat as a matrix ``(n_weft, n_warp)``."""
        return weave_matrix(self.weave if isinstance(self.weave, str) else np.array(self.weave))

    def yarns(self) -> tuple[YarnGeometry, YarnGeometry]:
        """Warp and weft geometry (crimp split by :attr:`crimp_share_warp`)."""
        total = 0.5 * (self.warp_height_mm + self.weft_height_mm)
        warp = YarnGeometry(
            pitch_mm=self.warp_pitch_mm,
            width_mm=self.warp_width_mm,
            height_mm=self.warp_height_mm,
            crimp_mm=self.crimp_share_warp * total,
            twist_deg=self.warp_twist_deg,
            transition=self.crimp_transition,
        )
        weft = YarnGeometry(
            pitch_mm=self.weft_pitch_mm,
            width_mm=self.weft_width_mm,
            height_mm=self.weft_height_mm,
            crimp_mm=(1.0 - self.crimp_share_warp) * total,
            twist_deg=self.weft_twist_deg,
            transition=self.crimp_transition,
        )
        return warp, weft


class ClothModel(SampledModel):
    """Reflectance of a woven cloth as a function of directions and curvature.

    Parameters
    ----------
    params
        The cloth (:class:`ClothParams`).

    Examples
    --------
    >>> from cdbrdf.synth import presets
    >>> m = presets.model("denim")
    >>> m.evaluate(30.0, 0.0, 30.0, 180.0, kappa=0.22).shape
    (3,)
    """

    def __init__(self, params: ClothParams) -> None:
        if not isinstance(params, ClothParams):
            raise TypeError(f"params: expected ClothParams, got {type(params).__name__}")
        self.params = params
        p = params
        warp = FibreLobes(
            p.warp_rgb, specular=p.warp_specular, gloss_width_deg=p.warp_gloss_deg,
            sheen_width_deg=p.warp_sheen_deg, isotropic=p.warp_isotropic, ior=p.ior,
        )
        weft = FibreLobes(
            p.weft_rgb, specular=p.weft_specular, gloss_width_deg=p.weft_gloss_deg,
            sheen_width_deg=p.weft_sheen_deg, isotropic=p.weft_isotropic, ior=p.ior,
        )
        rows = np.stack([warp.row, weft.row, FibreLobes.lambertian(p.backing_rgb)])
        rows.setflags(write=False)
        self._kernel_params = rows
        self._weave = p.weave_matrix
        self._geometry: dict[float, tuple[Bend, Heightfield, SurfacePoints]] = {}
        self._white_albedo: dict[float, NDArray[np.float64]] = {}
        self._compensation: dict[float, Compensation] = {}

    def recoloured(self, *, warp_rgb: RGB | None = None, weft_rgb: RGB | None = None, backing_rgb: RGB | None = None,
                   scattering: str | None = None) -> ClothModel:
        """The same cloth with other colours (or scattering), sharing this model's geometry and lobes.

        The geometry, the fibre lobes' normalisation and the white cloth's
        albedo do not depend on the colours, so the copy computes none of
        them again (a fit of the colours evaluates many such copies).

        Parameters
        ----------
        warp_rgb, weft_rgb, backing_rgb, scattering
            New values (None: unchanged).

        Returns
        -------
        ClothModel
            The model with ``params`` changed accordingly.
        """
        changes = {k: v for k, v in (("warp_rgb", warp_rgb), ("weft_rgb", weft_rgb), ("backing_rgb", backing_rgb),
                                     ("scattering", scattering)) if v is not None}
        p = self.params.replace(**changes)
        new = ClothModel.__new__(ClothModel)
        new.params = p
        rows = self._kernel_params.copy()
        for i, rgb in enumerate((p.warp_rgb, p.weft_rgb, p.backing_rgb)):
            rows[i, P_R:P_B + 1] = rgb
        rows.setflags(write=False)
        new._kernel_params = rows
        new._weave = self._weave
        new._geometry = self._geometry
        new._white_albedo = self._white_albedo
        new._compensation = {}
        return new

    # -- geometry -------------------------------------------------------------------
    def bend(self, kappa: float) -> Bend:
        """The yarn geometry on a cylinder of curvature ``kappa`` (:func:`cdbrdf.synth.bending.bend`).

        Parameters
        ----------
        kappa
            Curvature, mm^-1 (> 0 convex).

        Returns
        -------
        Bend
            The bent yarns and the stretch of the spacing.
        """
        warp, weft = self.params.yarns()
        return bend(self._weave, warp, weft, warp_along=self.params.warp_along, kappa_per_mm=kappa,
                    thickness_mm=self.params.thickness_mm, neutral_fraction=self.params.neutral_fraction)

    def stretch(self, kappa: float) -> float:
        """Stretch along x of the spacing of the yarns that run along y (1 when flat)."""
        return self.bend(kappa).stretch_x

    def _geometry_at(self, kappa: float) -> tuple[Bend, Heightfield, SurfacePoints]:
        k = float(kappa)
        geo = self._geometry.get(k)
        if geo is None:
            b = self.bend(k)
            hf = build_heightfield(self._weave, b.warp, b.weft, warp_along=self.params.warp_along,
                                   stretch_x=b.stretch_x, texels=self.params.texels)
            geo = (b, hf, surface_points(hf, self.params.points))
            if len(self._geometry) > 16:
                self._geometry.clear()
            self._geometry[k] = geo
        return geo

    def heightfield(self, kappa: float = 0.0) -> Heightfield:
        """The micro-geometry of one repeat on a cylinder of curvature ``kappa``."""
        return self._geometry_at(kappa)[1]

    def surface_points(self, kappa: float = 0.0) -> SurfacePoints:
        """The integration points on the micro-surface at curvature ``kappa``.

        Parameters
        ----------
        kappa
            Curvature, mm^-1.

        Returns
        -------
        SurfacePoints
            Positions, normals, fibre directions and area weights.
        """
        return self._geometry_at(kappa)[2]

    def tilts_rad(self, kappa: float) -> NDArray[np.float64]:
        """Macro-normal tilt of each footprint patch (midpoints across the spot)."""
        k = int(self.params.tilt_samples)
        if kappa == 0.0 or self.params.footprint_mm == 0.0 or k == 1:
            return np.zeros(1)
        x = ((np.arange(k) + 0.5) / k - 0.5) * self.params.footprint_mm
        return kappa * x

    # -- multiple scattering ----------------------------------------------------------
    def compensation(self, kappa: float = 0.0) -> Compensation | None:
        """The energy-compensation term at curvature ``kappa`` (None with ``scattering = "single"``).

        ``E`` is the directional albedo of the same cloth with every albedo 1
        and single scattering, on the bent micro-surface in the flat frame
        (:data:`_E_VIEWS` views, :data:`_E_LIGHTS` light directions, Gauss-
        Legendre in cos theta); the bounce colour ``a`` is the yarns' and the
        backing's colours weighted by their share of the micro-surface's area.

        Parameters
        ----------
        kappa
            Curvature, mm^-1.

        Returns
        -------
        Compensation or None
            The term (:func:`cdbrdf.synth.multiple.compensation`).
        """
        if self.params.scattering != "multiple":
            return None
        k = float(kappa)
        got = self._compensation.get(k)
        if got is None:
            got = self._make_compensation(k)
            if len(self._compensation) > 16:
                self._compensation.clear()
            self._compensation[k] = got
        return got

    def _make_compensation(self, kappa: float) -> Compensation:
        views = hemisphere_grid(*_E_VIEWS)
        albedo = self._white_albedo.get(kappa)
        if albedo is None:
            white = self.recoloured(warp_rgb=(1.0, 1.0, 1.0), weft_rgb=(1.0, 1.0, 1.0), backing_rgb=(1.0, 1.0, 1.0),
                                    scattering="single")
            lights = hemisphere_grid(*_E_LIGHTS)
            vdirs = np.concatenate([views.dirs, [[0.0, 0.0, 1.0]]])
            nv, nl = vdirs.shape[0], lights.size
            v = np.repeat(vdirs, nl, axis=0)
            l = np.tile(lights.dirs, (nv, 1))
            g = white._flat(v, l, kappa)[:, 0].reshape(nv, nl)  # f cos theta_v cos theta_l
            albedo = (g @ lights.weights) / vdirs[:, 2]
            if len(self._white_albedo) > 16:
                self._white_albedo.clear()
            self._white_albedo[kappa] = albedo
        pts = self.surface_points(kappa)
        area = np.bincount(pts.kind, weights=pts.weight, minlength=3)[:3]
        colours = self._kernel_params[:, P_R:P_B + 1]
        bounce = area @ colours / area.sum()
        return compensation(albedo, views, bounce, fraction=_E_FRACTION)

    # -- evaluation -------------------------------------------------------------------
    def _flat(self, v: NDArray[np.float64], l: NDArray[np.float64], kappa: float,
              texels: tuple[int, int] | None = None) -> NDArray[np.float64]:
        """``f cos(theta_v) cos(theta_l)`` in the flat frame, (n, 3): the micro-surface
        integral over the repeat's area seen from above (symmetric in v and l).

        With ``texels = (n_u, n_v)``, (n, n_u * n_v, 3): per texel, the integral
        over the points seen in it (the line from the point along ``v`` crosses
        the repeat's mean height in the texel) over the texel's area; their
        mean is the value without ``texels``.
        """
        nbin = 1 if texels is None else texels[0] * texels[1]
        out = np.zeros((v.shape[0], nbin, 3))
        if v.shape[0] == 0:
            return out if texels is not None else out[:, 0]
        _, hf, pts = self._geometry_at(kappa)
        ny, nx = hf.shape
        dy = hf.size_mm[1] / ny
        xmap = np.ascontiguousarray(hf.xmap)
        # Half the typical texel: the gap texels may be narrower (a thin gap
        # can be stepped over by an oblique ray, as it is hidden then anyway).
        step = 0.5 * min(float(np.median(hf.texel_width_mm)), dy)
        H = np.ascontiguousarray(hf.height)
        n_pts = pts.weight.size
        area = hf.size_mm[0] * hf.size_mm[1]
        # The mean height over the repeat's area seen from above, the repeat, the texels.
        z_mean = float(np.average(hf.height.mean(axis=0), weights=hf.texel_width_mm))
        texel_grid = np.array([z_mean, hf.size_mm[0], hf.size_mm[1]] + list(texels or (1, 1)), dtype=np.float64)
        # Pairs in chunks whose distinct directions' visibility table fits _VIS_BYTES
        # (one chunk when all of them fit, as on a grid: its directions repeat).
        n_dirs = np.unique(np.concatenate([v, l]), axis=0).shape[0]
        per_chunk = v.shape[0] if n_dirs * n_pts <= _VIS_BYTES else max(1, _VIS_BYTES // (2 * n_pts))
        for c0 in range(0, v.shape[0], per_chunk):
            c1 = min(c0 + per_chunk, v.shape[0])
            dirs, inv = np.unique(np.concatenate([v[c0:c1], l[c0:c1]]), axis=0, return_inverse=True)
            inv = inv.reshape(-1).astype(np.int64)
            vis = np.zeros((dirs.shape[0], n_pts), dtype=np.uint8)
            dirs = np.ascontiguousarray(dirs)
            run_split(_trace.visibility, dirs.shape[0], H, xmap, dy, step, pts.position, pts.normal, dirs, vis)
            part = np.zeros((c1 - c0, nbin, 3))
            run_split(_trace.integrate, c1 - c0, inv[: c1 - c0], inv[c1 - c0 :], dirs, vis, pts.position,
                      pts.normal, pts.tangent, pts.kind, pts.weight, self._kernel_params, texel_grid, part,
                      grain=16)
            out[c0:c1] = part / (area / nbin)
        comp = self.compensation(kappa)
        if comp is not None:  # the same diffuse term for every texel: their mean keeps it
            out += (comp(v, l) * (v[:, 2] * l[:, 2])[:, None])[:, None, :]
        return out if texels is not None else out[:, 0]

    def _pairs(self, v: NDArray[np.float64], l: NDArray[np.float64], kappa: float,
               texels: tuple[int, int] | None = None) -> NDArray[np.float64]:
        """BRDF (n, 3) for unit direction pairs at one curvature; per texel (n, n_u * n_v, 3) with
        ``texels = (n_u, n_v)`` (:meth:`_flat`; the mean over the texels is the value without)."""
        tilts = self.tilts_rad(kappa)
        n = v.shape[0]
        num = np.zeros((n, 3) if texels is None else (n, texels[0] * texels[1], 3))
        den = np.zeros(n)
        vs, ls, idx = [], [], []
        for a in tilts:
            ca, sa = math.cos(a), math.sin(a)
            # Patch frame: normal (sin a, 0, cos a), tangent (cos a, 0, -sin a).
            vp = np.stack([v[:, 0] * ca - v[:, 2] * sa, v[:, 1], v[:, 0] * sa + v[:, 2] * ca], -1)
            lp = np.stack([l[:, 0] * ca - l[:, 2] * sa, l[:, 1], l[:, 0] * sa + l[:, 2] * ca], -1)
            cv = np.maximum(vp[:, 2], 0.0)
            den += cv
            ok = (vp[:, 2] > 0) & (lp[:, 2] > 0) & (l[:, 2] > 0)
            vs.append(vp[ok])
            ls.append(lp[ok])
            idx.append(np.flatnonzero(ok))
        # Each patch: its projected area towards the viewer (cos theta_v') times the
        # radiance it sends per unit irradiance (f cos theta_l'); g = f cos theta_v' cos theta_l'.
        g = self._flat(np.concatenate(vs), np.concatenate(ls), kappa, texels)
        start = 0
        for i in idx:
            num[i] += g[start : start + i.size]
            start += i.size
        denom = den * l[:, 2]
        good = denom > 1e-12
        out = np.zeros(num.shape)
        out[good] = num[good] / denom[good].reshape((-1,) + (1,) * (num.ndim - 1))
        return out

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
            Curvature in mm^-1 (> 0 convex), ``|kappa| < 1 / thickness``.

        Returns
        -------
        numpy.ndarray
            ``broadcast shape + (3,)``, float64, >= 0.

        Raises
        ------
        QueryError
            For an elevation outside [0, 90] degrees or a non-finite argument.
        ValueError
            For a curvature tighter than the cloth's thickness allows.
        """
        return self._by_kappa(self._pairs, 3, theta_v, phi_v, theta_l, phi_l, kappa)

    def _sample(self, v: NDArray[np.float64], l: NDArray[np.float64], kappa: float) -> NDArray[np.float64]:
        return self._pairs(v, l, kappa)

    def attrs(self) -> dict[str, Any]:
        """Table metadata: quantity, material, model and parameters (provenance)."""
        return {
            "quantity": "brdf",
            "material": self.params.name,
            "model": MODEL_NAME,
            "model_version": MODEL_VERSION,
            "provenance": {
                "kind": "synthesised",
                "model": MODEL_NAME,
                "model_version": MODEL_VERSION,
                "parameters": self.params.to_dict(),
                "weave_matrix": self.params.weave_matrix.tolist(),
                "references": [
                    "Sadeghi et al. 2013, A practical microcylinder appearance model for cloth rendering",
                    "Irawan & Marschner 2012, Specular reflection from woven cloth",
                ],
            },
        }
