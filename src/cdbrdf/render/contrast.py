"""What bending does to a picture: the curvature seen in each pixel, and the colour at crests and flats.

:func:`curvature_image` asks Mitsuba which surface point each pixel centre
sees (the scene's first sensor, its rays traced by Mitsuba) and reads the
curvature attribute the ``cdbrdf`` BSDF reads there, interpolated over the
triangle as the plug-in interpolates it (with a curvature map, the
plug-in's own sum of the mesh's and the map's, :mod:`cdbrdf.render._maps_jit`). :func:`crest_contrast` compares two
renders of one scene (the plain BRDF and the CDBRDF, as :func:`render_table`
makes them) where they are seen as a viewer sees them: in sRGB at the
picture's exposure, converted to CIE 1976 L*a*b* (:func:`cdbrdf.colour.linear_to_lab`,
display white = 1) and compared pixel by pixel (Delta E*ab,
:func:`cdbrdf.colour.delta_e_ab`) separately where the surface is strongly
curved (the crests and troughs) and where it is flat (the inflection lines
of the sine sheet). Away from the crests both renders use the table at
kappa = 0, so the flat pixels measure noise and the crest pixels the
effect.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..colour import delta_e_ab, ev_to_factor, linear_to_lab, srgb_encode
from ..errors import OptionError

__all__ = ["curvature_image", "CrestContrast", "crest_contrast"]


def curvature_image(scene: Any, *, attribute: str = "vertex_curvature") -> NDArray[np.float32]:
    """The curvature (mm^-1) seen at each pixel centre of ``scene``'s first sensor; NaN where no surface is seen.

    Parameters
    ----------
    scene
        A loaded Mitsuba scene (of the active variant) whose shapes carry
        ``attribute`` (a one-channel vertex attribute, as
        :func:`cdbrdf.render.scenes.mitsuba_mesh` writes the curvatures);
        shapes without it read as NaN.
    attribute
        The Mitsuba attribute's name (a :class:`cdbrdf.mesh.CurvatureMode`'s ``mitsuba_attribute``).

    Returns
    -------
    numpy.ndarray
        ``(H, W)`` float32, the film's crop size.
    """
    import drjit as dr
    import mitsuba as mi

    sensor = scene.sensors()[0]
    w, h = (int(x) for x in sensor.film().crop_size())
    idx = dr.arange(mi.UInt32, w * h)
    px = mi.Point2f((mi.Float(idx % w) + 0.5) / w, (mi.Float(idx // w) + 0.5) / h)
    ray, _ = sensor.sample_ray(0.0, 0.5, px, mi.Point2f(0.5, 0.5))
    si = scene.ray_intersect(ray)
    out = np.full(w * h, np.nan, dtype=np.float32)
    hit = np.asarray(si.is_valid(), dtype=bool)
    for shape in scene.shapes():
        if not shape.has_attribute(attribute):
            continue
        mine = np.asarray(si.shape == mi.ShapePtr(shape), dtype=bool) & hit
        if mine.any():
            bsdf = shape.bsdf()
            if getattr(bsdf, "surface", None) is not None:  # a curvature map's added, as the plug-in looks it up
                mode = "directional" if attribute.endswith("_dir") else "max"
                k = bsdf.curvature_at(si, mi.Bool(mine), mode)
            else:
                k = shape.eval_attribute_1(attribute, si, mine)
            out[mine] = np.broadcast_to(np.asarray(k, dtype=np.float32), mine.shape)[mine]
    return out.reshape(h, w)


@dataclass(frozen=True)
class CrestContrast:
    """How two renders of one scene differ where the surface bends and where it is flat.

    Attributes
    ----------
    crest_delta_e, trough_delta_e, flat_delta_e
        Median Delta E*ab, pixel by pixel, between the two renders shown in
        sRGB: over the convex crest pixels (``kappa`` at least
        ``crest_fraction`` of the largest ``|kappa|`` seen), the concave
        trough pixels (``-kappa`` at least that) and the flat ones
        (``|kappa|`` at most ``flat_fraction`` of it); NaN where there is none.
    crest_pixels, trough_pixels, flat_pixels
        How many pixels each median is over.
    crest_srgb, flat_srgb
        Mean display colour (sRGB, 0-1) of each render, by mode, at the
        convex crests (``kappa > 0``) and at the flat pixels: swatches.
    kappa_max
        The largest ``|kappa|`` seen, mm^-1.
    crest_fraction, flat_fraction
        The bounds used, as shares of ``kappa_max``.
    """

    crest_delta_e: float
    trough_delta_e: float
    flat_delta_e: float
    crest_pixels: int
    trough_pixels: int
    flat_pixels: int
    crest_srgb: dict[str, tuple[float, float, float]]
    flat_srgb: dict[str, tuple[float, float, float]]
    kappa_max: float
    crest_fraction: float
    flat_fraction: float


def crest_contrast(
    picture: Any,
    *,
    modes: tuple[str, str] = ("brdf", "cdbrdf"),
    crest_fraction: float = 0.8,
    flat_fraction: float = 0.1,
) -> CrestContrast:
    """Compare two modes of a :class:`~cdbrdf.render.Picture` at the crests and where the surface is flat.

    Parameters
    ----------
    picture
        Made by :func:`cdbrdf.render.render_table` with ``curvature=True``
        and both ``modes``.
    modes
        The two renders compared.
    crest_fraction, flat_fraction
        Shares of the largest ``|kappa|`` seen that bound the crest and the
        flat pixels, ``0 <= flat_fraction < crest_fraction <= 1``.

    Returns
    -------
    CrestContrast
        The medians, pixel counts and swatches.

    Raises
    ------
    OptionError
        For a picture without its curvature image or one of the modes, bad
        fractions, or a surface that is nowhere curved.
    """
    if not 0.0 <= flat_fraction < crest_fraction <= 1.0:
        raise OptionError(f"crest_fraction, flat_fraction: need 0 <= flat < crest <= 1, got {crest_fraction!r}, "
                          f"{flat_fraction!r}")
    kappa = getattr(picture, "curvature", None)
    if kappa is None:
        raise OptionError("picture: has no curvature image; render it with RenderSpec(curvature_image=True)")
    missing = [m for m in modes if m not in picture.images]
    if missing:
        raise OptionError(f"picture: has no {' or '.join(missing)} render (it has {', '.join(picture.images)})")
    seen = np.isfinite(kappa)
    k_abs = np.where(seen, np.abs(kappa), 0.0)
    k_max = float(k_abs.max()) if seen.any() else 0.0
    if not k_max > 0:
        raise OptionError("picture: the surface it shows is nowhere curved; no crest to compare")
    bent = seen & (k_abs >= crest_fraction * k_max)
    flat = seen & (k_abs <= flat_fraction * k_max)
    convex = bent & (kappa > 0)
    concave = bent & (kappa < 0)
    factor = ev_to_factor(picture.exposure_ev)
    shown = {m: np.clip(np.nan_to_num(picture.display(m) * factor), 0.0, 1.0) for m in modes}
    # L*a*b* of what the screen shows: the sRGB code values decoded back to linear light
    lab = {m: linear_to_lab(v) for m, v in shown.items()}
    d = delta_e_ab(lab[modes[0]], lab[modes[1]])

    def median(sel: NDArray[np.bool_]) -> float:
        return float(np.median(d[sel])) if sel.any() else float("nan")

    def swatch(sel: NDArray[np.bool_]) -> dict[str, tuple[float, float, float]]:
        if not sel.any():
            return {}
        return {m: tuple(float(x) for x in srgb_encode(shown[m][sel].mean(axis=0))) for m in modes}  # type: ignore[misc]

    return CrestContrast(crest_delta_e=median(convex), trough_delta_e=median(concave), flat_delta_e=median(flat),
                         crest_pixels=int(convex.sum()), trough_pixels=int(concave.sum()),
                         flat_pixels=int(flat.sum()), crest_srgb=swatch(convex), flat_srgb=swatch(flat),
                         kappa_max=k_max, crest_fraction=float(crest_fraction),
                         flat_fraction=float(flat_fraction))
