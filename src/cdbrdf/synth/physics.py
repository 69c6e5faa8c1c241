"""What bending does to a cloth model, in numbers (the derivation in ``docs/fabric-model.md``).

:func:`bend_summary` reports, for one curvature, the strains, the spacing
and gaps of the yarns along the cylinder's axis, the crimp and largest slope
of the yarns around it, the share of the repeat each yarn covers seen from
above, and the share of each yarn's colour in the light reflected near the
normal (:func:`seen_fractions`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..grid import Grid
from .bending import _hoop_rows, centre_line_length
from .cloth import ClothModel
from .weave import _crimp

__all__ = ["BendSummary", "bend_summary", "seen_fractions"]

#: Elevations (degrees) of the near-normal directions of :func:`seen_fractions`.
_NEAR_NORMAL_THETA = (0.0, 15.0, 30.0)


@dataclass(frozen=True)
class BendSummary:
    """The geometry of a cloth model on a cylinder of curvature ``kappa_per_mm``.

    Attributes
    ----------
    kappa_per_mm
        Curvature, mm^-1 (> 0 convex).
    face_strain, axial_strain
        Strain of the outer face, and of the spacing of the axial yarns (along
        y) at their centres.
    axial_pitch_mm, axial_gap_mm
        Spacing of the axial yarns' centres and the gap between neighbours
        (spacing minus width; < 0 where they overlap).
    hoop_crimp_mm, axial_crimp_mm
        Crimp amplitudes of the hoop yarns (along x) and the axial yarns.
    hoop_crimp_fraction
        The crimp left in the hoop yarns: the excess of their centre line's
        length over the repeat's length, ``L / (n p) - 1``, drawn at the bent
        spacing ``p``.
    hoop_slope_deg
        Largest angle of the hoop yarns' centre line to the cloth's plane.
    cover
        Share of the repeat seen from above, per ``"warp"``, ``"weft"``,
        ``"backing"``.
    seen
        Share of each yarn's colour in the light reflected near the normal
        (:func:`seen_fractions`), or None when not computed.
    """

    kappa_per_mm: float
    face_strain: float
    axial_strain: float
    axial_pitch_mm: float
    axial_gap_mm: float
    hoop_crimp_mm: float
    axial_crimp_mm: float
    hoop_crimp_fraction: float
    hoop_slope_deg: float
    cover: dict[str, float]
    seen: dict[str, float] | None


def seen_fractions(model: ClothModel, kappa: float) -> dict[str, float]:
    """Share of each yarn's colour in the light the cloth reflects near the normal.

    The model is evaluated with white, Lambertian, non-reflecting-surface
    yarns and backing, one at a time (the others black), for view and light
    elevations 0, 15, 30 deg and azimuths every 30 deg; the share of a kind
    is ``pi`` times its mean BRDF: the reflected colour of a cloth of
    Lambertian yarns is ``sum_kind share * albedo``. Shadowing, masking and
    the surfaces' tilt are included; what is hidden or unlit has no share.
    Single scattering only: the light of further bounces mixes the kinds.

    Returns
    -------
    dict
        ``{"warp": ..., "weft": ..., "backing": ...}``.
    """
    p = model.params
    probe = p.replace(
        warp_rgb=(1.0, 0.0, 0.0), weft_rgb=(0.0, 1.0, 0.0), backing_rgb=(0.0, 0.0, 1.0),
        warp_specular=0.0, weft_specular=0.0, warp_isotropic=1.0, weft_isotropic=1.0, ior=1.0,
        scattering="single",
    )
    azimuths = np.arange(0.0, 360.0, 30.0)
    g = Grid(kappa=[float(kappa)], theta_l=_NEAR_NORMAL_THETA, phi_l=azimuths, theta_v=_NEAR_NORMAL_THETA,
             phi_v=azimuths)
    v = ClothModel(probe).tabulate(g).values.reshape(-1, 3).astype(np.float64).mean(axis=0) * math.pi
    return {"warp": float(v[0]), "weft": float(v[1]), "backing": float(v[2])}


def bend_summary(model: ClothModel, kappa: float, *, seen: bool = True) -> BendSummary:
    """The geometry and what is seen of ``model`` at curvature ``kappa`` (mm^-1).

    Parameters
    ----------
    model
        The cloth.
    kappa
        Curvature, mm^-1.
    seen
        Also compute :func:`seen_fractions` (a few seconds).

    Returns
    -------
    BendSummary
    """
    b = model.bend(kappa)
    p = model.params
    rows = _hoop_rows(p.weave_matrix, p.warp_along)
    pitch = b.axial.pitch_mm * b.stretch_x
    n = rows.shape[1]
    length = centre_line_length(rows, b.hoop.crimp_mm, pitch, b.hoop.transition)
    u = (np.arange(n * 512) + 0.5) * pitch / 512
    slope = max(float(np.abs(_crimp(u, r * b.hoop.crimp_mm, pitch, b.hoop.transition)[1]).max()) for r in rows)
    return BendSummary(
        kappa_per_mm=float(kappa),
        face_strain=b.face_strain,
        axial_strain=b.axial_strain,
        axial_pitch_mm=pitch,
        axial_gap_mm=pitch - b.axial.width_mm,
        hoop_crimp_mm=b.hoop.crimp_mm,
        axial_crimp_mm=b.axial.crimp_mm,
        hoop_crimp_fraction=length / (n * pitch) - 1.0,
        hoop_slope_deg=math.degrees(math.atan(slope)),
        cover=model.heightfield(kappa).coverage(),
        seen=seen_fractions(model, kappa) if seen else None,
    )
