"""Pictures of a table: renders in passes, their exposure, the backdrop, and :func:`render_table`.

:func:`render_table` makes a :class:`Picture` of a table from one
:class:`~cdbrdf.render.spec.RenderSpec`.

**Exposure** (:data:`~cdbrdf.render.spec.EXPOSURES`): ``"card"`` (the default of
:func:`render_table`) is the exposure at which an 18 % grey card facing the
key light, lit by it and the environment, shows as mid-grey
(:func:`cdbrdf.colour.card_exposure_ev`, :func:`cdbrdf.render.lighting.card_irradiance`):
every surface then shows at its own reflectance, so a dark indigo denim
stays indigo, whatever else is in the picture. ``"auto"``
(:func:`exposure_from_render`) maps the 99th percentile of the object's
luminance (pixels it covers) to 0.85 of display white
(:func:`cdbrdf.colour.auto_exposure_ev`), at most :data:`MAX_AUTO_EV` stops
above the physical exposure (a white Lambertian surface facing a key light
of the default irradiance pi is white): bright pictures, for dark scenes
of unknown light.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from os import PathLike
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..errors import OptionError, SceneError
from ..limits import MAX_SPP
from ..limits import check as check_limit
from ..mesh import MeshSurface, SineSheet, Swatch
from ..sources import open_source
from .lighting import DEFAULT_IRRADIANCE
from .spec import RenderSpec

__all__ = [
    "BACKDROP",
    "MAX_AUTO_EV",
    "Picture",
    "render_table",
    "render_scene",
    "render",
    "exposure_from_render",
    "composite",
]

#: Display value (linear, before encoding) of the backdrop behind a studio render.
BACKDROP = 0.5

#: Largest automatic exposure, in stops above the physical one (see the module's description).
MAX_AUTO_EV = 2.0



def render_scene(
    scene: Any,
    *,
    spp: int | None = None,
    seed: int = 0,
    passes: int | None = None,
    progress: Callable[[int, int], None] | None = None,
    alpha: bool = False,
) -> NDArray[np.float32]:
    """Render ``scene`` in passes.

    Parameters
    ----------
    scene : mitsuba.Scene
        The scene.
    spp
        Samples per pixel (default: the sensor's).
    seed
        Seed of the first pass (pass ``i`` uses ``seed + i``).
    passes
        Number of passes (default: about 16 spp each); the image is their mean.
    progress
        Called as ``progress(samples_done, samples_total)`` after each pass.
    alpha
        Also return the coverage (1 where the object is seen; with the
        studio lighting's hidden sky, 0 on the background), as a 4th channel.

    Returns
    -------
    numpy.ndarray
        Linear RGB ``(H, W, 3)`` float32 (RGBA with ``alpha``).

    Raises
    ------
    OptionError
        For ``spp`` (given, or the sensor's) outside 1 to :data:`cdbrdf.limits.MAX_SPP`.
    SceneError
        For a scene without integrator or sensor, or a film of size 0.
    LimitError
        For a film of more pixels than the ``render_pixels`` limit: checked on
        what is rendered, whatever made the scene.
    """
    import mitsuba as mi

    from .. import limits

    if scene.integrator() is None:
        raise SceneError("the scene has no integrator (add one, e.g. <integrator type=\"path\"/>)")
    if not scene.sensors():
        raise SceneError("the scene has no sensor to render from")
    sensor = scene.sensors()[0]
    total = int(spp if spp is not None else sensor.sampler().sample_count())
    if not 1 <= total <= MAX_SPP:
        raise OptionError(f"spp: {total:,} samples per pixel; a render takes 1 to {MAX_SPP:,}")
    w, h = (int(x) for x in sensor.film().crop_size())
    if w < 1 or h < 1:
        raise SceneError(f"the film's size is {w} x {h}; a render needs at least 1 x 1 pixels")
    limits.check("render_pixels", w * h, what=f"a {w} x {h} render")
    n = passes if passes is not None else max(1, math.ceil(total / 16))
    n = min(n, total)
    chunks = [total // n + (1 if i < total % n else 0) for i in range(n)]
    acc = None
    done = 0
    for i, c in enumerate(chunks):
        img = np.asarray(mi.render(scene, spp=c, seed=seed + i), dtype=np.float64)  # type: ignore[arg-type]
        acc = img * c if acc is None else acc + img * c
        done += c
        if progress is not None:
            progress(done, total)
    assert acc is not None
    out = (acc / total).astype(np.float32)
    if alpha:
        if out.shape[-1] >= 4:
            return out[..., :4]
        return np.concatenate([out[..., :3], np.ones(out.shape[:-1] + (1,), np.float32)], axis=-1)
    return out[..., :3]


def exposure_from_render(image: NDArray[np.floating], *, irradiance: float = DEFAULT_IRRADIANCE) -> float:
    """The exposure (EV) of a render: its object's 99th luminance percentile to 0.85 of white.

    ``image`` is RGB or RGBA; with alpha only the pixels the object covers
    (alpha >= 0.5) count. At most :data:`MAX_AUTO_EV` stops above the
    physical exposure for a key light of ``irradiance`` (``log2(pi /
    irradiance)``). See :func:`cdbrdf.colour.auto_exposure_ev`.

    Parameters
    ----------
    image
        Linear RGB or RGBA render.
    irradiance
        The key light's irradiance.

    Returns
    -------
    float
        The exposure, stops.
    """
    from ..colour import auto_exposure_ev

    if not (math.isfinite(irradiance) and irradiance > 0):
        raise OptionError(f"irradiance: must be positive, got {irradiance}")
    top = MAX_AUTO_EV + math.log2(DEFAULT_IRRADIANCE / irradiance)
    img = np.asarray(image, dtype=np.float64)
    if img.shape[-1] >= 4:
        cover = img[..., 3] >= 0.5
        if cover.any():
            return auto_exposure_ev(img[cover][:, :3], max_ev=top)
    return auto_exposure_ev(img[..., :3], max_ev=top)


def composite(image: NDArray[np.floating], *, exposure_ev: float, backdrop: float = BACKDROP) -> NDArray[np.float32]:
    """An RGBA render over a uniform backdrop that shows as ``backdrop`` (display value) at ``exposure_ev``.

    Parameters
    ----------
    image
        ``(H, W, 4)`` linear RGBA, or RGB.
    exposure_ev
        The exposure the picture is shown at, stops.
    backdrop
        The backdrop's display value.

    Returns
    -------
    numpy.ndarray
        Linear RGB ``rgb + (1 - alpha) * backdrop * 2**-exposure_ev``; an RGB
        image as it is.
    """
    img = np.asarray(image, dtype=np.float64)
    if img.shape[-1] < 4:
        return img.astype(np.float32)
    a = np.clip(img[..., 3:4], 0.0, 1.0)
    return (img[..., :3] + (1.0 - a) * backdrop * 2.0 ** (-exposure_ev)).astype(np.float32)


def render(scene: Any, *, spp: int | None = None, seed: int = 0,
           progress: Callable[[int, int], None] | None = None) -> Any:
    """Render a scene after :func:`cdbrdf.render.check_scene`.

    Parameters
    ----------
    scene : mitsuba.Scene
        The scene.
    spp, seed
        As for :func:`render_scene`.
    progress
        ``progress(done, total)``, called per pass.

    Returns
    -------
    numpy.ndarray
        Float32 ``(H, W, C)`` image, linear.
    """
    from .checks import check_scene

    check_scene(scene)
    return render_scene(scene, spp=spp, seed=seed, progress=progress)


# -- one picture of a table ----------------------------------------------------------------------
@dataclass(frozen=True)
class Picture:
    """What :func:`render_table` made.

    Attributes
    ----------
    images
        By mode (``"cdbrdf"``, ``"brdf"``): linear RGBA, float32 ``(H, W, 4)``
        (alpha: where the surface is seen).
    exposure_ev
        The exposure to show them at (the same for every mode).
    exposure_source
        ``"grey card"`` (:func:`cdbrdf.colour.card_exposure_ev`), ``"auto"``
        (:func:`exposure_from_render` of the CDBRDF image) or ``"given"``.
    surface
        What was rendered: ``"sine sheet"``, ``"swatch"`` or the mesh's name.
    lighting
        ``"paper"`` or ``"studio"``.
    light
        ``(theta_deg, phi_deg, irradiance)`` of the directional light, or None.
    backdrop
        Whether the background is the studio's hidden sky, shown as a uniform
        backdrop (:meth:`display`).
    mesh
        The prepared mesh (its metadata says what was repaired, its unit,
        neighbourhood and frame), or None for a built-in scene.
    up, up_reason
        The mesh's up axis and why (None for a built-in scene).
    curvature
        With ``RenderSpec(curvature_image=True)``: the curvature (mm^-1)
        seen at each pixel centre, ``(H, W)`` float32, NaN where no surface
        is seen (:func:`cdbrdf.render.contrast.curvature_image`); else None.
    """

    images: Mapping[str, NDArray[np.float32]]
    exposure_ev: float
    exposure_source: str
    surface: str
    lighting: str
    light: tuple[float, float, float] | None
    backdrop: bool
    mesh: Any = None
    up: str | None = None
    up_reason: str | None = None
    curvature: NDArray[np.float32] | None = None

    def display(self, mode: str = "cdbrdf") -> NDArray[np.float32]:
        """Linear RGB of ``mode`` as shown: over the backdrop where the studio's sky is hidden.

        Parameters
        ----------
        mode
            ``"cdbrdf"`` or ``"brdf"`` (one of :attr:`images`).

        Returns
        -------
        numpy.ndarray
            ``(H, W, 3)`` float32, linear.
        """
        img = self.images[mode]
        return composite(img, exposure_ev=self.exposure_ev) if self.backdrop else img[..., :3]


def render_table(table: Any, spec: RenderSpec | str | PathLike[str] | Any = None, *,
                 progress: Callable[[str, int, int], None] | None = None, **legacy: Any) -> Picture:
    """Render a table on a built-in scene or on a mesh, with the CDBRDF and/or the plain BRDF.

    The one entry point for a picture of a table: ``cdbrdf render``, the demo
    and user scripts call it. It prepares the surface (a mesh is read,
    repaired, given its curvature in mm^-1 and turned upright:
    :func:`cdbrdf.mesh.prepare_mesh`), builds the scene in memory
    (:mod:`cdbrdf.render.scenes`), renders every mode with the same seed and
    picks one exposure for all, under a Mitsuba variant that is restored
    afterwards (:func:`cdbrdf.render.variant`).

    Parameters
    ----------
    table
        A :class:`~cdbrdf.CDBRDF` or a CDBRDF file, or a :class:`~cdbrdf.CDBTF`
        or its file (each texel at the surface's UVs, ``docs/btf.md``).
    spec
        What to render: a :class:`~cdbrdf.render.spec.RenderSpec` (surface,
        camera, light, maps, exposure, film, modes; checked when it was
        made), or a surface alone (``"sine"``, ``"swatch"``, a mesh file, ...)
        for ``RenderSpec(surface=...)``; default ``RenderSpec()``, the sine sheet.
    progress
        ``progress(stage, done, total)``: ``"curvature"`` (vertices) while a
        mesh is prepared, ``"rendering MODE"`` (samples per pixel).
    **legacy
        The former keywords (``modes=``, ``size=``, ``light=``, ...): turned
        into the record by :meth:`RenderSpec.from_options`, with a
        :class:`DeprecationWarning` (``docs/rendering.md``, "Migrating to RenderSpec").

    Returns
    -------
    Picture
        The image of every mode, the exposure to show them at and what was rendered.

    Raises
    ------
    OptionError
        For an invalid option or combination (:class:`~cdbrdf.render.spec.RenderSpec`).
    MeshError, LimitError, SceneError
        For a mesh that cannot be used, a render too large, a damaged
        environment map.
    """
    from .plugin import DEFAULT_VARIANT
    from .plugin import variant as variant_context

    spec = _spec_of(spec, legacy)
    w, h = spec.size
    check_limit("render_pixels", w * h, what=f"a {w} x {h} render")
    source = open_source(table)
    btf, tbl = source.btf, source.flat
    name = spec.name
    spec, mesh, btf, (up, why) = _surface(spec, tbl, btf, progress)
    images: dict[str, NDArray[np.float32]] = {}
    kappa_image = None
    uv_scale = _btf_uv_scale(btf, spec, mesh)
    with variant_context(spec.variant or DEFAULT_VARIANT):
        for mode in spec.modes:
            images[mode], k = _render_mode(tbl, btf, uv_scale, spec, mode, progress,
                                           curvature=spec.curvature_image and kappa_image is None)
            kappa_image = k if kappa_image is None else kappa_image
    ev, how = _exposure(spec, images)
    return Picture(images=images, exposure_ev=ev, exposure_source=how, surface=name,
                   lighting=spec.lighting, light=spec.sun(), backdrop=spec.backdrop, mesh=mesh,
                   up=up, up_reason=why, curvature=kappa_image)


def _spec_of(spec: Any, legacy: dict[str, Any]) -> RenderSpec:
    """The spec of :func:`render_table`'s arguments: the record, a surface alone, or the former keywords."""
    if legacy:
        import warnings

        warnings.warn("render_table(table, surface, **options) is deprecated: pass a cdbrdf.render.RenderSpec "
                      f"(RenderSpec.from_options turns {', '.join(sorted(legacy))} into one)",
                      DeprecationWarning, stacklevel=3)
        if isinstance(spec, RenderSpec):
            raise OptionError(f"render_table: give the options in the RenderSpec, not beside it ({next(iter(legacy))})")
        return RenderSpec.from_options("sine" if spec is None else spec, **legacy)
    if isinstance(spec, RenderSpec):
        return spec
    return RenderSpec() if spec is None else RenderSpec(surface=spec)


def _surface(spec: RenderSpec, tbl: Any, btf: Any,
             progress: Any) -> tuple[RenderSpec, Any, Any, tuple[str | None, str | None]]:
    """The spec on its prepared surface, the prepared mesh (None for a built-in one), the CD-BTF, the up axis and why.

    A built-in surface's size is checked against the ``mesh_faces`` limit; a
    CD-BTF on a mesh without UVs of its own renders its tile mean (said in
    the mesh's notes).
    """
    from ..mesh import detect_up, has_own_uv

    s = spec.surface
    if isinstance(s, SineSheet):
        check_limit("mesh_faces", s.face_count, what=f"a sine sheet of wavelength {s.wavelength_mm:g} mm "
                    f"over {s.width_mm:g} x {s.depth_mm:g} mm")
        return spec, None, btf, (None, None)
    if isinstance(s, Swatch):
        check_limit("mesh_faces", s.face_count, what=f"a swatch of {len(s.radii_mm)} folds over "
                    f"{s.width_mm:.0f} x {s.depth_mm:g} mm")
        return spec, None, btf, (None, None)
    assert isinstance(s, MeshSurface)
    cb = None if progress is None else (lambda done, total: progress("curvature", done, total))
    mesh = s.prepare(table=tbl, maps=spec.maps, progress=cb)
    up, why = (s.up, "given") if s.up != "auto" else detect_up(mesh)
    if btf is not None and not has_own_uv(mesh):  # the per-face UVs prepare_mesh makes follow no fabric
        mesh = mesh.copy()  # the note is this picture's, not the caller's mesh's
        mesh.metadata["notes"] = [*mesh.metadata.get("notes", []),
                                  "no UVs of its own: the CD-BTF's tile mean is rendered on it"]
        btf = None
    return spec.with_mesh(mesh, up), mesh, btf, (up, why)


def _render_mode(tbl: Any, btf: Any, uv_scale: tuple[float, float] | None, spec: RenderSpec, mode: str,
                 progress: Any, *, curvature: bool) -> tuple[NDArray[np.float32], Any]:
    """One mode's RGBA render, and with ``curvature`` the curvature seen at each pixel."""
    from .contrast import curvature_image
    from .scenes import table_scene

    bsdf = None
    if btf is not None and uv_scale is not None:  # with the pixel's angle: the lookup filters its footprint
        bsdf = {**_btf_entry(btf, mode, spec.curvature_mode, uv_scale, spec.texel_filter),
                "pixel_angle": _pixel_angle(spec)}
    scene = table_scene(tbl, spec, mode=mode, bsdf=bsdf)
    cb = None if progress is None else (lambda done, total: progress(f"rendering {mode}", done, total))
    image = render_scene(scene, spp=spec.spp, seed=spec.seed, alpha=True, progress=cb)
    kappa = curvature_image(scene, attribute=spec.curvature.mitsuba_attribute) if curvature else None
    return image, kappa


def _exposure(spec: RenderSpec, images: Mapping[str, NDArray[np.float32]]) -> tuple[float, str]:
    """The exposure of the picture and its rule: given, the grey card, or auto (the CDBRDF image's, else the first)."""
    shown = images["cdbrdf" if "cdbrdf" in images else spec.modes[0]]
    if spec.exposure == "auto":
        return exposure_from_render(shown, irradiance=spec.light.irradiance), "auto"
    if spec.exposure == "card":
        from ..colour import card_exposure_ev
        from .lighting import card_irradiance, environment_map, studio_environment

        envmap = spec.light.envmap
        env = environment_map(envmap) if envmap is not None else studio_environment() if spec.backdrop else None
        return card_exposure_ev(card_irradiance(spec.sun(), env)), "grey card"
    return float(spec.exposure), "given"


def _btf_uv_scale(btf: Any, spec: RenderSpec, mesh: Any) -> tuple[float, float] | None:
    """The UV scale of a CD-BTF: given, a built-in surface's span (:meth:`RenderSpec.uv_span`), or the mesh's
    (its maps', else detected)."""
    from ..mesh import as_uv_scale, detect_uv_scale

    if btf is None:
        return None
    if spec.maps is not None and spec.maps.uv_scale is not None:
        return as_uv_scale(spec.maps.uv_scale)
    span = spec.uv_span()
    if span is not None:
        return span
    if mesh.metadata.get("uv_scale") is not None:
        return as_uv_scale(mesh.metadata["uv_scale"])
    uvs = detect_uv_scale(mesh.vertices, mesh.faces, mesh.uv, units=mesh.metadata.get("units", "mm"))
    mesh.metadata["notes"] = [*mesh.metadata.get("notes", []), f"UV scale: {uvs}"]
    return uvs.pair


def _pixel_angle(spec: RenderSpec) -> float:
    """Radians per pixel of the picture's lens (its smaller side), as :func:`cdbrdf.render.checks.pixel_angle`."""
    lens = spec.resolved_camera().lens_fov_deg
    return 2.0 * math.tan(math.radians(lens) / 2.0) / max(min(spec.size), 1)


def _btf_entry(btf: Any, mode: str, curvature_mode: str, uv_scale: tuple[float, float],
               texel_filter: str | None) -> dict[str, Any]:
    """The plug-in's dict for a CD-BTF at ``uv_scale`` mm per UV unit (two numbers, as they are)."""
    from ..mesh import curvature_mode as mode_of

    entry = {"type": "cdbrdf", "table": btf, "mode": mode, "curvature": mode_of(curvature_mode).mitsuba_attribute,
             "uv_scale": (float(uv_scale[0]), float(uv_scale[1]))}
    if texel_filter is not None:
        entry["texel_filter"] = texel_filter
    return entry
