"""Pictures of a table: renders in passes, their exposure, the backdrop, and :func:`render_table`.

**Exposure** (:data:`EXPOSURES`): ``"card"`` (the default of
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
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from os import PathLike
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..errors import OptionError, SceneError
from ..limits import MAX_SPP
from .camera import Camera
from .lighting import DEFAULT_IRRADIANCE

__all__ = [
    "BACKDROP",
    "MAX_AUTO_EV",
    "EXPOSURES",
    "DEFAULT_SIZE",
    "DEFAULT_SPP",
    "RENDER_MODES",
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

#: Named exposure rules of :func:`render_table` (see the module's description), beside a number of EV.
EXPOSURES: Mapping[str, str] = {
    "card": "grey card: an 18 % grey card facing the key light shows as mid-grey",
    "auto": "auto: the object's 99th luminance percentile at 0.85 of white",
}


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
    from .plugin import check_scene

    check_scene(scene)
    return render_scene(scene, spp=spp, seed=seed, progress=progress)


# -- one picture of a table ----------------------------------------------------------------------
#: Default film size of :func:`render_table`, pixels.
DEFAULT_SIZE: tuple[int, int] = (512, 384)

#: Default samples per pixel of :func:`render_table`.
DEFAULT_SPP = 64

#: Render modes: the CDBRDF (curvature looked up) and the plain BRDF (the kappa = 0 slice).
RENDER_MODES: tuple[str, ...] = ("cdbrdf", "brdf")


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
        With ``render_table(..., curvature=True)``: the curvature (mm^-1)
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


def _light_of(light: Any, irradiance: float, lighting: str, azimuth_deg: float) -> tuple[float, float, float] | None:
    """The directional light ``(theta, phi, irradiance)`` of :func:`render_table`'s ``light`` argument."""
    from .lighting import STUDIO_KEY

    if light is None:
        return None
    if isinstance(light, str):
        if light != "auto":
            raise OptionError(f"light: expected (theta, phi), 'auto' or None, got {light!r:.40}")
        if lighting == "paper":
            return (45.0, 0.0, float(irradiance))
        return (STUDIO_KEY[0], azimuth_deg + STUDIO_KEY[1], float(irradiance))
    try:
        theta, phi = (float(x) for x in light)
    except (TypeError, ValueError):
        raise OptionError(f"light: expected (theta, phi) in degrees, 'auto' or None, got {light!r:.40}") from None
    return (theta, phi, float(irradiance))


def render_table(
    table: Any,
    surface: str | PathLike[str] | Any = "sine",
    *,
    modes: Sequence[str] = ("cdbrdf",),
    size: tuple[int, int] = DEFAULT_SIZE,
    spp: int = DEFAULT_SPP,
    seed: int = 0,
    max_depth: int = 3,
    lighting: str | None = None,
    light: Any = "auto",
    irradiance: float = DEFAULT_IRRADIANCE,
    envmap: str | PathLike[str] | None = None,
    camera: Camera | None = None,
    units: str | float | None = None,
    neighbourhood_mm: float | None = None,
    frame: str | None = None,
    up: str = "auto",
    maps: Any = None,
    curvature_mode: str = "max",
    exposure: float | str = "card",
    variant: str | None = None,
    curvature: bool = False,
    texel_filter: str | None = None,
    progress: Callable[[str, int, int], None] | None = None,
) -> Picture:
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
    surface
        A built-in scene of :data:`cdbrdf.render.scenes.SCENES`: ``"sine"``
        (the paper's sine sheet, :class:`cdbrdf.mesh.SineSheet` defaults) or
        ``"swatch"`` (a swatch laid in folds of known radii,
        :class:`cdbrdf.mesh.Swatch` defaults); a
        :class:`~cdbrdf.mesh.SineSheet` or :class:`~cdbrdf.mesh.Swatch`; a
        :class:`~cdbrdf.mesh.Mesh` or a mesh file.
    modes
        Any of :data:`RENDER_MODES`: ``("brdf", "cdbrdf")`` for the paper's
        comparison (Figs. 9-10).
    size, spp, seed, max_depth
        Film ``(width, height)``, samples per pixel, seed of the first pass,
        Mitsuba path length (2 = direct light only).
    lighting
        ``"paper"`` (one directional light) or ``"studio"`` (a key light and
        a soft sky; the swatch and meshes); default: paper for the sheet,
        studio for the swatch and a mesh (:mod:`cdbrdf.render.lighting`).
    light
        ``(theta_deg, phi_deg)``: direction towards the directional (key)
        light (elevation from the up axis, azimuth from +x); ``"auto"``: the
        lighting's default; None: no directional light (a mesh with an
        environment).
    irradiance
        Of the directional light, W m^-2 (pi: a white Lambertian surface
        facing it is just white at 0 EV).
    envmap
        An environment map file (.exr, .hdr), the swatch and meshes only.
    camera
        A :class:`cdbrdf.render.camera.Camera`: the view ``(elevation_deg,
        azimuth_deg)`` above the ground plane, the zoom, the lens's field of
        view and the point looked at (in the surface's own coordinates and
        unit, or an anchor such as ``"fold"``); None or a field left None:
        the surface's defaults (:data:`~cdbrdf.render.camera.DEFAULT_SINE_VIEW`,
        ``DEFAULT_SWATCH_VIEW``, ``DEFAULT_MESH_VIEW``).
    units, neighbourhood_mm, frame, up
        For a mesh: its length unit, the curvature's neighbourhood (mm), the
        source of the material's x axis, its up axis
        (:func:`cdbrdf.mesh.prepare_mesh`, :func:`cdbrdf.mesh.detect_up`).
    maps
        A :class:`cdbrdf.mesh.SurfaceMaps`: the maps laid on the mesh by its
        UVs (a normal or height map, a high-resolution mesh baked onto it;
        default: the ones the mesh file names), looked up per shading point,
        their curvature added to the mesh's and their normals tilting the
        shading; and the UV scale (mm per UV unit) of the maps and a CD-BTF
        (default: the sheet's size on the sine sheet, the swatch's (its
        profile's length and its depth) on the swatch; detected on a mesh,
        :func:`cdbrdf.mesh.detect_uv_scale`).
    curvature_mode
        ``"max"`` (the paper's) or ``"directional"``.
    exposure
        EV, or a rule of :data:`EXPOSURES`: ``"card"`` (the default: an 18 %
        grey card facing the key light shows as mid-grey) or ``"auto"``
        (:func:`exposure_from_render` of the CDBRDF image, else the first
        mode's). :attr:`Picture.exposure_source` says which, in words.
    variant
        Mitsuba variant (default :data:`cdbrdf.render.DEFAULT_VARIANT`).
    curvature
        Also record the curvature seen at each pixel (:attr:`Picture.curvature`,
        for :func:`cdbrdf.render.contrast.crest_contrast`).
    texel_filter
        For a CD-BTF: the plug-in's ``texel_filter`` (default: the plug-in's default).
    progress
        ``progress(stage, done, total)``: ``"curvature"`` (vertices) while a
        mesh is prepared, ``"rendering MODE"`` (samples per pixel).

    Returns
    -------
    Picture
        The image of every mode, the exposure to show them at and what was rendered.

    Raises
    ------
    OptionError
        For an invalid option or combination (no light at all; the studio
        lighting or an environment map on the sine sheet).
    MeshError, LimitError, SceneError
        For a mesh that cannot be used, a render too large, a damaged
        environment map.
    """
    from ..limits import check as check_limit
    from ..mesh import ATTRIBUTES, Mesh, SineSheet, SurfaceMaps, Swatch, detect_up, has_own_uv, prepare_mesh, read_mesh
    from ..table import CDBRDF
    from ..table import load as load_table
    from .camera import DEFAULT_MESH_VIEW, DEFAULT_SINE_VIEW, DEFAULT_SWATCH_VIEW
    from .contrast import curvature_image
    from .lighting import LIGHTINGS
    from .plugin import DEFAULT_VARIANT
    from .plugin import variant as variant_context
    from .scenes import mesh_scene, sine_scene, swatch_scene

    modes = tuple(modes)
    if not modes or any(m not in RENDER_MODES for m in modes) or len(set(modes)) != len(modes):
        raise OptionError(f"modes: {modes!r:.60} must be distinct values of {', '.join(RENDER_MODES)}")
    if lighting is not None and lighting not in LIGHTINGS:
        raise OptionError(f"lighting: {lighting!r:.40} is not one of {', '.join(LIGHTINGS)}")
    if not (isinstance(exposure, str) and exposure in EXPOSURES):
        if isinstance(exposure, str) or not math.isfinite(float(exposure)):
            raise OptionError(f"exposure: expected a finite number of stops or one of {', '.join(EXPOSURES)}, "
                              f"got {exposure!r:.40}")
    w, h = (int(x) for x in size)
    check_limit("render_pixels", w * h, what=f"a {w} x {h} render")
    if maps is not None and not isinstance(maps, SurfaceMaps):
        raise OptionError(f"maps: expected a cdbrdf.mesh.SurfaceMaps, got {type(maps).__name__}")
    btf = _as_btf(table)
    tbl = btf.mean() if btf is not None else table if isinstance(table, CDBRDF) else load_table(table)
    camera = Camera() if camera is None else camera
    if not isinstance(camera, Camera):
        raise OptionError(f"camera: expected a cdbrdf.render.Camera, got {type(camera).__name__:.40}")
    is_sheet = isinstance(surface, SineSheet) or (isinstance(surface, str) and surface == "sine")
    is_swatch = isinstance(surface, Swatch) or (isinstance(surface, str) and surface == "swatch")
    lighting = lighting or ("paper" if is_sheet else "studio")
    view = DEFAULT_SINE_VIEW if is_sheet else DEFAULT_SWATCH_VIEW if is_swatch else DEFAULT_MESH_VIEW
    sun = _light_of(light, irradiance, lighting, (camera.view or view)[1])
    common: dict[str, Any] = {"size": (w, h), "spp": int(spp), "max_depth": int(max_depth), "camera": camera,
                              "curvature_mode": curvature_mode}
    mesh: Any = None
    up_axis = why = None
    if is_sheet:
        sheet = surface if isinstance(surface, SineSheet) else SineSheet()
        if envmap is not None:
            raise OptionError("envmap: only for meshes (the sine sheet is the paper's set-up)")
        if maps is not None and any(x is not None for x in (maps.normal_map, maps.height_map, maps.hires_mesh)):
            raise OptionError("maps: only for meshes (the sine sheet's folds are its geometry)")
        if lighting == "studio":
            raise OptionError("lighting 'studio': only for meshes (the sine sheet is the paper's set-up)")
        if sun is None:
            raise OptionError("light: the sine sheet needs a light (the paper's directional light)")
        check_limit("mesh_faces", sheet.face_count, what=f"a sine sheet of wavelength {sheet.wavelength_mm:g} mm "
                    f"over {sheet.width_mm:g} x {sheet.depth_mm:g} mm")
        name = "sine sheet"
    elif is_swatch:
        swatch = surface if isinstance(surface, Swatch) else Swatch()
        if maps is not None and any(x is not None for x in (maps.normal_map, maps.height_map, maps.hires_mesh)):
            raise OptionError("maps: only for meshes (the swatch's folds are its geometry)")
        if sun is None and envmap is None and lighting == "paper":
            raise OptionError("light: the scene needs a light; give an environment map or use the studio lighting")
        check_limit("mesh_faces", swatch.face_count, what=f"a swatch of {len(swatch.radii_mm)} folds over "
                    f"{swatch.width_mm:.0f} x {swatch.depth_mm:g} mm")
        name = "swatch"
    else:
        if sun is None and envmap is None and lighting == "paper":
            raise OptionError("light: the scene needs a light; give an environment map or use the studio lighting")
        if isinstance(surface, Mesh):
            source, name = surface, str(surface.metadata.get("source", "mesh"))
        else:
            source, name = read_mesh(surface), str(surface)
        cb = None if progress is None else (lambda done, total: progress("curvature", done, total))
        mesh = prepare_mesh(source, units=units, neighbourhood_mm=neighbourhood_mm, frame=frame, table=tbl,
                            maps=maps, progress=cb)
        up_axis, why = (up, "given") if up != "auto" else detect_up(mesh)
        if btf is not None and not has_own_uv(mesh):  # the per-face UVs prepare_mesh makes follow no fabric
            mesh = mesh.copy()  # the note is this picture's, not the caller's mesh's
            mesh.metadata["notes"] = [*mesh.metadata.get("notes", []),
                                      "no UVs of its own: the CD-BTF's tile mean is rendered on it"]
            btf = None
    images: dict[str, NDArray[np.float32]] = {}
    kappa_image = None
    span = (sheet.width_mm, sheet.depth_mm) if is_sheet else (swatch.length_mm, swatch.depth_mm) if is_swatch \
        else None  # a built-in surface's UVs span it
    uv_scale = _btf_uv_scale(btf, maps, span, mesh)
    with variant_context(variant or DEFAULT_VARIANT):
        for mode in modes:
            bsdf = None
            if btf is not None and uv_scale is not None:  # with the pixel's angle: the lookup filters its footprint
                bsdf = {**_btf_entry(btf, mode, curvature_mode, uv_scale, texel_filter),
                        "pixel_angle": _pixel_angle(camera, is_sheet or is_swatch, (w, h))}
            if is_sheet:
                scene = sine_scene(tbl, mode=mode, sheet=sheet, light=sun, bsdf=bsdf, **common)
            elif is_swatch:
                scene = swatch_scene(tbl, mode=mode, swatch=swatch, lighting=lighting, light=sun, envmap=envmap,
                                     bsdf=bsdf, **common)
            else:
                scene = mesh_scene(tbl, mesh, mode=mode, lighting=lighting, light=sun, envmap=envmap,
                                   up=str(up_axis), bsdf=bsdf, **common)
            cb = None if progress is None else (lambda done, total, m=mode: progress(f"rendering {m}", done, total))
            images[mode] = render_scene(scene, spp=int(spp), seed=seed, alpha=True, progress=cb)
            if curvature and kappa_image is None:
                kappa_image = curvature_image(scene, attribute=ATTRIBUTES[curvature_mode])
            del scene
    shown = images["cdbrdf" if "cdbrdf" in images else modes[0]]
    if exposure == "auto":
        ev, how = exposure_from_render(shown, irradiance=irradiance), "auto"
    elif exposure == "card":
        from ..colour import card_exposure_ev
        from .lighting import card_irradiance, environment_map, studio_environment

        env = environment_map(envmap) if envmap is not None else \
            studio_environment() if (not is_sheet and lighting == "studio") else None
        ev, how = card_exposure_ev(card_irradiance(sun, env)), "grey card"
    else:
        ev, how = float(exposure), "given"
    return Picture(images=images, exposure_ev=ev, exposure_source=how, surface=name, lighting=lighting,
                   light=sun, backdrop=not is_sheet and lighting == "studio" and envmap is None, mesh=mesh,
                   up=up_axis, up_reason=why, curvature=kappa_image)


def _as_btf(table: Any) -> Any:
    """The :class:`~cdbrdf.CDBTF` of ``table`` (an object or a CD-BTF file), or None."""
    from ..btf import CDBTF, is_btf
    from ..btf import load as load_btf

    if isinstance(table, CDBTF):
        return table
    if isinstance(table, (str, PathLike)) and is_btf(table):
        return load_btf(table)
    return None


def _btf_uv_scale(btf: Any, maps: Any, span: tuple[float, float] | None, mesh: Any) -> tuple[float, float] | None:
    """The UV scale of a CD-BTF: given, a built-in surface's ``span``, or the mesh's (its maps', else detected)."""
    from ..mesh import as_uv_scale, detect_uv_scale

    if btf is None:
        return None
    if maps is not None and maps.uv_scale is not None:
        return as_uv_scale(maps.uv_scale)
    if span is not None:
        return float(span[0]), float(span[1])
    if mesh.metadata.get("uv_scale") is not None:
        return as_uv_scale(mesh.metadata["uv_scale"])
    uvs = detect_uv_scale(mesh.vertices, mesh.faces, mesh.uv, units=mesh.metadata.get("units", "mm"))
    mesh.metadata["notes"] = [*mesh.metadata.get("notes", []), f"UV scale: {uvs}"]
    return uvs.pair


def _pixel_angle(camera: Camera, sheet: bool, size: tuple[int, int]) -> float:
    """Radians per pixel of the picture's lens (its smaller side), as :func:`cdbrdf.render.plugin.pixel_angle`."""
    from .camera import DEFAULT_MESH_FOV_DEG, DEFAULT_SHEET_FOV_DEG

    lens = camera.resolved(view=(0.0, 0.0), fov_deg=DEFAULT_SHEET_FOV_DEG if sheet else DEFAULT_MESH_FOV_DEG)
    return 2.0 * math.tan(math.radians(lens.lens_fov_deg) / 2.0) / max(min(size), 1)


def _btf_entry(btf: Any, mode: str, curvature_mode: str, uv_scale: tuple[float, float],
               texel_filter: str | None) -> dict[str, Any]:
    """The plug-in's dict for a CD-BTF at ``uv_scale`` mm per UV unit (two numbers, as they are)."""
    from ..mesh import ATTRIBUTES

    entry = {"type": "cdbrdf", "table": btf, "mode": mode, "curvature": ATTRIBUTES[curvature_mode],
             "uv_scale": (float(uv_scale[0]), float(uv_scale[1]))}
    if texel_filter is not None:
        entry["texel_filter"] = texel_filter
    return entry
