"""What a picture of a table is made of: the surface, camera, light, maps, exposure and film, as one record.

A :class:`RenderSpec` is what :func:`cdbrdf.render.render_table` and the
scene builders (:mod:`cdbrdf.render.scenes`) take; it is checked once, when
it is made (a field of the wrong kind or out of its range, or a combination
the surface cannot have, is one :class:`~cdbrdf.errors.OptionError` line).
It composes the records of each concept:

- the surface: a built-in scene's name (:data:`SCENES`), a
  :class:`~cdbrdf.mesh.SineSheet` or :class:`~cdbrdf.mesh.Swatch`, or a
  user's mesh (a file or a :class:`~cdbrdf.mesh.Mesh`, or a
  :class:`~cdbrdf.mesh.MeshSurface` with its unit, neighbourhood, frame and
  up axis);
- the camera (:class:`~cdbrdf.render.camera.Camera`), the light
  (:class:`~cdbrdf.render.lighting.Light`), the maps laid by the mesh's UVs
  and the UV scale (:class:`~cdbrdf.mesh.SurfaceMaps`);
- the exposure (a number of EV, or a rule of :data:`EXPOSURES`), the film and
  sampling (``size``, ``spp``, ``seed``, ``max_depth``), the render modes,
  the curvature mode, a CD-BTF's texel filter and Mitsuba's variant.

Every range is a :class:`~cdbrdf.ranges.Range` here (:data:`SIZE_RANGE`,
:data:`SPP_RANGE`, ...), which ``cdbrdf render`` reads too. A changed copy
is :func:`dataclasses.replace` (checked again):

.. code-block:: python

    from dataclasses import replace
    from cdbrdf.render import Camera, Light, RenderSpec

    spec = RenderSpec(surface="swatch", camera=Camera(zoom=3, look_at="crest"), spp=32)
    close = replace(spec, light=Light(direction=(30, 0)), size=(320, 240))
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from os import PathLike
from typing import Any

from ..errors import OptionError
from ..limits import MAX_SPP
from ..mesh import CURVATURE_MODES, Mesh, MeshSurface, SineSheet, SurfaceMaps, Swatch, curvature_mode
from ..ranges import Range
from ._btf_jit import TEXEL_FILTERS
from .camera import (
    DEFAULT_MESH_FOV_DEG,
    DEFAULT_MESH_VIEW,
    DEFAULT_SHEET_FOV_DEG,
    DEFAULT_SINE_VIEW,
    DEFAULT_SWATCH_VIEW,
    Camera,
)
from .lighting import Light
from .plugin import VARIANTS

__all__ = [
    "SCENES",
    "EXPOSURES",
    "RENDER_MODES",
    "DEFAULT_SIZE",
    "DEFAULT_SPP",
    "DEFAULT_MAX_DEPTH",
    "SIZE_RANGE",
    "SPP_RANGE",
    "SEED_RANGE",
    "MAX_DEPTH_RANGE",
    "EXPOSURE_RANGE_EV",
    "RenderSpec",
    "check_scene_name",
]

#: The built-in scenes, by name (``cdbrdf render --scene NAME``, ``RenderSpec(surface=NAME)``).
SCENES: Mapping[str, str] = {
    "sine": "the paper's sine sheet (Figs. 9-10) under its one directional light",
    "swatch": "a cloth swatch laid in folds of radius 20, 10, 5 and 3 mm, in the studio: a material at a glance",
}

#: Named exposure rules (:mod:`cdbrdf.render.picture`), beside a number of EV.
EXPOSURES: Mapping[str, str] = {
    "card": "grey card: an 18 % grey card facing the key light shows as mid-grey",
    "auto": "auto: the object's 99th luminance percentile at 0.85 of white",
}

#: Render modes: the CDBRDF (curvature looked up) and the plain BRDF (the kappa = 0 slice).
RENDER_MODES: tuple[str, ...] = ("cdbrdf", "brdf")

#: Default film size, pixels ``(width, height)``.
DEFAULT_SIZE: tuple[int, int] = (512, 384)

#: Default samples per pixel.
DEFAULT_SPP = 64

#: Default Mitsuba path length (3: the direct light and one inter-reflection).
DEFAULT_MAX_DEPTH = 3

#: Accepted film sides, pixels (the film's area is bounded by the ``render_pixels`` limit too).
SIZE_RANGE = Range(1, 65536, integer=True, unit="pixels")

#: Accepted samples per pixel.
SPP_RANGE = Range(1, MAX_SPP, integer=True)

#: Accepted seeds: the passes of a render use ``seed .. seed + spp // 16`` (Mitsuba's seeds are 32-bit).
SEED_RANGE = Range(0, 2**32 - 1 - MAX_SPP, integer=True)

#: Accepted Mitsuba path lengths (2: direct light only).
MAX_DEPTH_RANGE = Range(2, 64, integer=True)

#: Accepted exposures, EV (stops).
EXPOSURE_RANGE_EV = Range(-64.0, 64.0, unit="EV")

#: Per built-in surface: its default camera view and field of view (degrees).
_VIEWS: Mapping[str, tuple[tuple[float, float], float]] = {
    "sine": (DEFAULT_SINE_VIEW, DEFAULT_SHEET_FOV_DEG),
    "swatch": (DEFAULT_SWATCH_VIEW, DEFAULT_SHEET_FOV_DEG),
    "mesh": (DEFAULT_MESH_VIEW, DEFAULT_MESH_FOV_DEG),
}


def check_scene_name(name: object) -> str:
    """Refuse a name that is not one of :data:`SCENES`.

    Parameters
    ----------
    name
        The value given.

    Returns
    -------
    str
        The name.

    Raises
    ------
    OptionError
        For another value (the message lists the valid ones).
    """
    if not isinstance(name, str) or name not in SCENES:
        raise OptionError(f"scene: {name!r:.40} is not one of {', '.join(SCENES)}")
    return name


def _surface(value: Any) -> SineSheet | Swatch | MeshSurface:
    """The surface record of a ``surface`` field: a scene's name as its record, a mesh as a :class:`MeshSurface`."""
    if isinstance(value, (SineSheet, Swatch, MeshSurface)):
        return value
    if isinstance(value, str) and value in SCENES:
        return SineSheet() if value == "sine" else Swatch()
    if isinstance(value, (str, PathLike, Mesh)):
        return MeshSurface(value)
    raise OptionError(f"surface: expected a scene name ({', '.join(SCENES)}), a SineSheet, a Swatch, a mesh file, "
                      f"a Mesh or a MeshSurface, got {type(value).__name__}")


def _size(value: Any) -> tuple[int, int]:
    try:
        w, h = value
    except (TypeError, ValueError):
        w = h = None
    if w not in SIZE_RANGE or h not in SIZE_RANGE:
        raise OptionError(f"size: expected (width, height), each {SIZE_RANGE.expect()} pixels, got {value!r:.40}")
    return int(w), int(h)


@dataclass(frozen=True)
class RenderSpec:
    """A picture of a table: surface, camera, light, maps, exposure, film (see the module's description).

    Parameters
    ----------
    surface
        ``"sine"`` (the paper's sine sheet) or ``"swatch"`` (:data:`SCENES`),
        a :class:`~cdbrdf.mesh.SineSheet` or :class:`~cdbrdf.mesh.Swatch`, a
        mesh file or :class:`~cdbrdf.mesh.Mesh`, or a
        :class:`~cdbrdf.mesh.MeshSurface` (a mesh with its unit,
        neighbourhood, frame and up axis). Kept as its record (a name becomes
        the default sheet or swatch, a mesh a :class:`~cdbrdf.mesh.MeshSurface`).
    modes
        Distinct values of :data:`RENDER_MODES`: ``("brdf", "cdbrdf")`` for
        the paper's comparison (Figs. 9-10).
    camera
        The :class:`~cdbrdf.render.camera.Camera`; a field left None takes
        the surface's default (:meth:`resolved_camera`).
    light
        The :class:`~cdbrdf.render.lighting.Light` (set-up, direction,
        irradiance, environment map).
    maps
        A :class:`~cdbrdf.mesh.SurfaceMaps`: the maps laid on a mesh by its
        UVs (meshes only), and the UV scale of the maps and a CD-BTF (any
        surface; default: the sheet's size on the sine sheet, the swatch's
        profile length and depth on the swatch, detected on a mesh).
    exposure
        EV in :data:`EXPOSURE_RANGE_EV`, or a rule of :data:`EXPOSURES`:
        ``"card"`` (an 18 % grey card facing the key light shows as
        mid-grey) or ``"auto"`` (from the CDBRDF image).
    size
        Film ``(width, height)``, pixels, each in :data:`SIZE_RANGE`.
    spp
        Samples per pixel, in :data:`SPP_RANGE`.
    seed
        Seed of the first pass, in :data:`SEED_RANGE`.
    max_depth
        Mitsuba path length, in :data:`MAX_DEPTH_RANGE` (2: direct light only).
    curvature_mode
        The curvature looked up (:data:`cdbrdf.mesh.CURVATURE_MODES`):
        ``"max"`` (the paper's) or ``"directional"``.
    texel_filter
        A CD-BTF's texel filter (:data:`cdbrdf.render.TEXEL_FILTERS`); None: the plug-in's default.
    variant
        Mitsuba variant (:data:`cdbrdf.render.VARIANTS`); None: :data:`cdbrdf.render.DEFAULT_VARIANT`.
    curvature_image
        Also record the curvature seen at each pixel
        (:attr:`cdbrdf.render.Picture.curvature`).

    Raises
    ------
    OptionError
        For a field of the wrong kind or out of its range, or a combination
        the surface cannot have (the sine sheet is the paper's set-up: one
        directional light, no studio, no environment map, no maps; the
        swatch's folds are its geometry: no maps; some light is needed).
    """

    surface: str | PathLike[str] | SineSheet | Swatch | Mesh | MeshSurface = "sine"
    modes: Sequence[str] = ("cdbrdf",)
    camera: Camera = Camera()
    light: Light = Light()
    maps: SurfaceMaps | None = None
    exposure: float | str = "card"
    size: tuple[int, int] = DEFAULT_SIZE
    spp: int = DEFAULT_SPP
    seed: int = 0
    max_depth: int = DEFAULT_MAX_DEPTH
    curvature_mode: str = "max"
    texel_filter: str | None = None
    variant: str | None = None
    curvature_image: bool = False

    def __post_init__(self) -> None:
        put = object.__setattr__
        put(self, "surface", _surface(self.surface))
        modes = tuple(self.modes) if not isinstance(self.modes, str) else (self.modes,)
        if not modes or any(m not in RENDER_MODES for m in modes) or len(set(modes)) != len(modes):
            raise OptionError(f"modes: {modes!r:.60} must be distinct values of {', '.join(RENDER_MODES)}")
        put(self, "modes", modes)
        if not isinstance(self.camera, Camera):
            raise OptionError(f"camera: expected a cdbrdf.render.Camera, got {type(self.camera).__name__:.40}")
        if not isinstance(self.light, Light):
            raise OptionError(f"light: expected a cdbrdf.render.Light, got {type(self.light).__name__:.40}")
        if self.maps is not None and not isinstance(self.maps, SurfaceMaps):
            raise OptionError(f"maps: expected a cdbrdf.mesh.SurfaceMaps, got {type(self.maps).__name__}")
        if isinstance(self.exposure, str) and self.exposure not in EXPOSURES or \
                not isinstance(self.exposure, str) and self.exposure not in EXPOSURE_RANGE_EV:
            raise OptionError(f"exposure: expected a finite number of stops ({EXPOSURE_RANGE_EV.text()}) or one of "
                              f"{', '.join(EXPOSURES)}, got {self.exposure!r:.40}")
        if not isinstance(self.exposure, str):
            put(self, "exposure", float(self.exposure))
        put(self, "size", _size(self.size))
        put(self, "spp", SPP_RANGE.check("spp", self.spp))
        put(self, "seed", SEED_RANGE.check("seed", self.seed))
        put(self, "max_depth", MAX_DEPTH_RANGE.check("max_depth", self.max_depth))
        put(self, "curvature_mode", curvature_mode(self.curvature_mode).name)
        if self.texel_filter is not None and self.texel_filter not in TEXEL_FILTERS:
            raise OptionError(f"texel_filter: {self.texel_filter!r:.40} is not one of {', '.join(TEXEL_FILTERS)}")
        if self.variant is not None and self.variant not in VARIANTS:
            raise OptionError(f"variant: {self.variant!r:.40} is not one of {', '.join(VARIANTS)}")
        put(self, "curvature_image", bool(self.curvature_image))
        self._check_surface()

    def _check_surface(self) -> None:
        """The combinations a built-in surface cannot have, and a scene without any light."""
        lit = self.light.direction is not None or self.light.envmap is not None or self.lighting == "studio"
        laid = self.maps is not None and any(x is not None for x in (self.maps.normal_map, self.maps.height_map,
                                                                      self.maps.hires_mesh))
        if self.kind == "sine":
            if self.light.envmap is not None:
                raise OptionError("envmap: only for meshes (the sine sheet is the paper's set-up)")
            if laid:
                raise OptionError("maps: only for meshes (the sine sheet's folds are its geometry)")
            if self.lighting == "studio":
                raise OptionError("lighting 'studio': only for meshes (the sine sheet is the paper's set-up)")
            if self.light.direction is None:
                raise OptionError("light: the sine sheet needs a light (the paper's directional light)")
        elif self.kind == "swatch" and laid:
            raise OptionError("maps: only for meshes (the swatch's folds are its geometry)")
        if not lit:
            raise OptionError("light: the scene needs a light; give an environment map or use the studio lighting")

    # -- what follows from the fields ----------------------------------------------------------
    @property
    def kind(self) -> str:
        """``"sine"``, ``"swatch"`` or ``"mesh"``."""
        s = self.surface
        return "sine" if isinstance(s, SineSheet) else "swatch" if isinstance(s, Swatch) else "mesh"

    @property
    def name(self) -> str:
        """What is rendered, in words: ``"sine sheet"``, ``"swatch"`` or the mesh's name."""
        s = self.surface
        return "sine sheet" if self.kind == "sine" else "swatch" if self.kind == "swatch" else s.name  # type: ignore[union-attr]

    @property
    def lighting(self) -> str:
        """The lighting set-up: the light's, else paper for the sine sheet and studio for the swatch and a mesh."""
        return self.light.lighting or ("paper" if self.kind == "sine" else "studio")

    @property
    def backdrop(self) -> bool:
        """Whether the background is the studio's hidden sky, shown as a uniform backdrop."""
        return self.kind != "sine" and self.lighting == "studio" and self.light.envmap is None

    @property
    def curvature(self) -> Any:
        """The :class:`~cdbrdf.mesh.CurvatureMode` looked up."""
        return CURVATURE_MODES[self.curvature_mode]

    def resolved_camera(self) -> Camera:
        """The camera with the surface's defaults (its view and field of view) where a field is None.

        Returns
        -------
        Camera
            The camera, its ``view`` and ``fov_deg`` set.
        """
        view, fov = _VIEWS[self.kind]
        return self.camera.resolved(view=view, fov_deg=fov)

    def sun(self) -> tuple[float, float, float] | None:
        """The directional light the scene places (:meth:`cdbrdf.render.Light.resolve`).

        Returns
        -------
        tuple or None
            ``(theta_deg, phi_deg, irradiance)``, or None without a directional light.
        """
        return self.light.resolve(self.lighting, self.resolved_camera().azimuth_deg)

    def uv_span(self) -> tuple[float, float] | None:
        """The mm a built-in surface's UVs (0 to 1) span.

        Returns
        -------
        tuple or None
            The sheet's width and depth, the swatch's profile length and depth; None for a mesh.
        """
        s = self.surface
        if isinstance(s, SineSheet):
            return float(s.width_mm), float(s.depth_mm)
        if isinstance(s, Swatch):
            return float(s.length_mm), float(s.depth_mm)
        return None

    def with_mesh(self, mesh: Mesh, up: str) -> RenderSpec:
        """This spec on a prepared mesh (its curvature computed) turned upright by ``up``.

        Parameters
        ----------
        mesh
            The prepared mesh (:meth:`cdbrdf.mesh.MeshSurface.prepare`).
        up
            Its up axis, ``"y"`` or ``"z"``.

        Returns
        -------
        RenderSpec
            The spec, its surface that mesh.
        """
        surface = self.surface if isinstance(self.surface, MeshSurface) else MeshSurface(mesh)
        return replace(self, surface=replace(surface, mesh=mesh, up=up))

    @classmethod
    def from_options(cls, surface: Any = "sine", **options: Any) -> RenderSpec:
        """The record of ``render_table(table, surface, **options)``'s former keywords (the migration path).

        ``lighting``, ``light``, ``irradiance`` and ``envmap`` make the
        :class:`~cdbrdf.render.lighting.Light`; ``units``,
        ``neighbourhood_mm``, ``frame`` and ``up`` the
        :class:`~cdbrdf.mesh.MeshSurface`; ``curvature`` is
        ``curvature_image``; the others are fields of the same name.

        Parameters
        ----------
        surface
            The former second argument.
        **options
            The former keywords.

        Returns
        -------
        RenderSpec
            The record.

        Raises
        ------
        OptionError
            For a keyword that is none of these.
        """
        light = {new: options.pop(old) for old, new in (("lighting", "lighting"), ("light", "direction"),
                                                          ("irradiance", "irradiance"), ("envmap", "envmap"))
                 if old in options}
        prep = {k: options.pop(k) for k in ("units", "neighbourhood_mm", "frame", "up") if k in options}
        if "curvature" in options:
            options["curvature_image"] = options.pop("curvature")
        fields = set(cls.__dataclass_fields__)
        unknown = sorted(set(options) - fields)
        if unknown:
            raise OptionError(f"render_table: unknown option {unknown[0]!r}")
        if prep:
            s = _surface(surface)
            if not isinstance(s, MeshSurface):
                return cls(surface=s, light=Light(**light), **options)  # a built-in surface ignored them
            surface = replace(s, **prep)
        return cls(surface=surface, light=Light(**light), **options)
