"""Scenes for rendering a CDBRDF: the paper's sine sheet and any user mesh.

World frame: z up, lengths in mm. The light is Mitsuba's ``directional``
emitter given by the direction *towards* the light as elevation ``theta``
from +z and azimuth ``phi`` from +x towards +y (degrees), and its irradiance
(W m^-2 on a surface facing it). The default irradiance is pi, so a white
Lambertian surface (f = 1/pi) facing the light has radiance 1: with the
PNG exposure of 0 EV it is just white.

The sine sheet (the paper's test surface, Figs. 9-10) is
``z = A sin(2 pi x / L)`` swept along y: the bending direction is x, which is
also the direction of the UV coordinate u (so the material frame's x follows
the bending, as on the measurement stands). Its curvature is analytic
(:func:`cdbrdf.curvature.sine_sheet_curvature`) and stored per vertex.
"""

from __future__ import annotations

import logging
import math
import tempfile
from dataclasses import dataclass
from os import PathLike
from pathlib import Path
from typing import Any, Callable

import numpy as np
from numpy.typing import NDArray

from ..curvature import sine_sheet_curvature, sine_sheet_height
from ..errors import OptionError
from ..frames import direction_from_angles
from .meshio import Mesh, read_mesh, write_ply

__all__ = [
    "UNITS_MM",
    "DEFAULT_IRRADIANCE",
    "SineSheet",
    "sine_sheet_mesh",
    "prepare_mesh",
    "directional_light",
    "sine_scene",
    "mesh_scene",
    "render_scene",
]

_LOG = logging.getLogger(__name__)

#: Length units accepted for meshes: millimetres per unit.
UNITS_MM: dict[str, float] = {"mm": 1.0, "cm": 10.0, "m": 1000.0}

#: Default irradiance of the directional light (W m^-2): white Lambertian -> radiance 1.
DEFAULT_IRRADIANCE = math.pi


@dataclass(frozen=True)
class SineSheet:
    """Geometry of the sine sheet (mm).

    Parameters
    ----------
    amplitude_mm, wavelength_mm
        ``z = amplitude sin(2 pi x / wavelength)``; the crest curvature is
        ``amplitude (2 pi / wavelength)^2`` (0.197 mm^-1 by default, inside
        the paper's +-0.22 mm^-1).
    width_mm, depth_mm
        Extent across (x) and along (y) the sweep, centred on the origin.
    vertices_per_wavelength
        Tessellation across; along y the sheet is tessellated to keep
        triangles near-square.
    """

    amplitude_mm: float = 2.0
    wavelength_mm: float = 20.0
    width_mm: float = 60.0
    depth_mm: float = 60.0
    vertices_per_wavelength: int = 64

    def __post_init__(self) -> None:
        for name in ("amplitude_mm", "wavelength_mm", "width_mm", "depth_mm"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise ValueError(f"{name}: must be a positive length in mm, got {v}")
        if self.vertices_per_wavelength < 8:
            raise ValueError("vertices_per_wavelength: at least 8 are needed")

    @property
    def crest_curvature_mm(self) -> float:
        """Curvature at a crest (mm^-1)."""
        return self.amplitude_mm * (2 * math.pi / self.wavelength_mm) ** 2


def sine_sheet_mesh(sheet: SineSheet = SineSheet()) -> Mesh:
    """The sine sheet as a mesh with UVs, analytic normals and curvature.

    The mesh's attribute ``"curvature"`` holds the analytic signed curvature
    (mm^-1) of every vertex; faces wind counter-clockwise seen from +z.
    """
    nx = max(2, int(round(sheet.width_mm / sheet.wavelength_mm * sheet.vertices_per_wavelength)) + 1)
    dx = sheet.width_mm / (nx - 1)
    ny = max(2, int(round(sheet.depth_mm / dx)) + 1)
    ny = min(ny, 4 * nx)
    x = np.linspace(-sheet.width_mm / 2, sheet.width_mm / 2, nx)
    y = np.linspace(-sheet.depth_mm / 2, sheet.depth_mm / 2, ny)
    X, Y = np.meshgrid(x, y, indexing="ij")
    A, L = sheet.amplitude_mm, sheet.wavelength_mm
    Z = sine_sheet_height(X, amplitude_mm=A, wavelength_mm=L)
    V = np.stack([X.ravel(), Y.ravel(), Z.ravel()], axis=1)
    dz = A * 2 * np.pi / L * np.cos(2 * np.pi * X.ravel() / L)
    N = np.stack([-dz, np.zeros_like(dz), np.ones_like(dz)], axis=1)
    N /= np.linalg.norm(N, axis=1, keepdims=True)
    U = np.stack([(X.ravel() + sheet.width_mm / 2) / sheet.width_mm,
                  (Y.ravel() + sheet.depth_mm / 2) / sheet.depth_mm], axis=1)
    i, j = np.meshgrid(np.arange(nx - 1), np.arange(ny - 1), indexing="ij")
    a = (i * ny + j).ravel()
    b = a + ny  # +x
    c = b + 1   # +x +y
    d = a + 1   # +y
    F = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])
    k = sine_sheet_curvature(X.ravel(), amplitude_mm=A, wavelength_mm=L)
    return Mesh(V, F.astype(np.int64), N, U, {"curvature": k})


def prepare_mesh(
    path: str | PathLike[str] | Mesh, *, units: str = "mm", recompute: bool = False
) -> Mesh:
    """Read a user mesh for rendering: check its UVs, compute its curvature if absent.

    ``path`` may also be a :class:`~cdbrdf.render.meshio.Mesh` already in memory
    (it is not modified; a copy with the curvature is returned).

    The curvature (attribute ``"curvature"``, mm^-1) is taken from the file
    when present (written by ``cdbrdf curvature``), otherwise computed with
    :func:`cdbrdf.curvature.max_curvature` and converted from ``units``.

    Raises
    ------
    ValueError
        When the mesh has no UV coordinates (the material frame's x is dP/du)
        or the unit is unknown.
    """
    from ..curvature import max_curvature

    if units not in UNITS_MM:
        raise ValueError(f"units: {units!r} is not one of {', '.join(UNITS_MM)}")
    if isinstance(path, Mesh):
        mesh = Mesh(path.vertices, path.faces, path.normals, path.uv, dict(path.attributes))
        path = "mesh"
    else:
        mesh = read_mesh(path)
    if mesh.uv is None:
        raise ValueError(
            f"{path}: the mesh has no UV coordinates; the CDBRDF's reference direction x is "
            "dP/du of the UV map, so a mesh without UVs has no anisotropy frame (add UVs, "
            "u along the bending direction)"
        )
    if recompute or "curvature" not in mesh.attributes:
        _LOG.info("computing the curvature of %s (%d vertices)", path, mesh.n_vertices)
        k = max_curvature(mesh.vertices, mesh.faces, normals=mesh.normals)
        mesh.attributes["curvature"] = k / UNITS_MM[units]
    return mesh


def directional_light(theta_deg: float = 45.0, phi_deg: float = 0.0, irradiance: float = DEFAULT_IRRADIANCE) -> dict:
    """Mitsuba ``directional`` emitter dict for the direction towards the light.

    Raises
    ------
    OptionError
        When ``theta_deg`` is not in [0, 90) degrees, ``phi_deg`` is not a
        finite number or ``irradiance`` is not a finite positive number.
    """
    def number(name: str, v: Any) -> float:
        if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)) \
                or not math.isfinite(v):
            raise OptionError(f"{name}: expected a finite number, got {v!r:.40}")
        return float(v)

    theta_deg = number("light theta", theta_deg)
    phi_deg = number("light phi", phi_deg)
    irradiance = number("irradiance", irradiance)
    if not (0.0 <= theta_deg < 90.0):
        raise OptionError(f"light theta: elevation must lie in [0, 90) degrees, got {theta_deg:g}")
    if not irradiance > 0:
        raise OptionError(f"irradiance: must be positive, got {irradiance:g}")
    # The world frame (z up) is the local frame of a horizontal surface: theta from +z, phi from +x towards +y.
    to_light = direction_from_angles(theta_deg, phi_deg).tolist()
    return {"type": "directional", "direction": [-c for c in to_light], "irradiance": {"type": "rgb", "value": float(irradiance)}}


def _camera(mi, lo, hi, width: int, height: int, *, elevation_deg: float, azimuth_deg: float, fov_deg: float, spp: int) -> dict:
    """Perspective camera looking at the box ``[lo, hi]`` from the given direction, framing it."""
    # Towards the camera in the world frame (z up); its elevation is above the horizontal plane,
    # i.e. 90 degrees minus the elevation from +z that frames uses.
    d = direction_from_angles(90.0 - elevation_deg, azimuth_deg)
    center = (np.asarray(lo) + np.asarray(hi)) / 2
    up0 = np.array([0.0, 0.0, 1.0]) if abs(d[2]) < 0.999 else np.array([0.0, 1.0, 0.0])
    right = np.cross(up0, d)
    right /= np.linalg.norm(right)
    up = np.cross(d, right)
    t_small = math.tan(math.radians(fov_deg) / 2)
    t_x = t_small * max(1.0, width / height)
    t_y = t_small * max(1.0, height / width)
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])]) - center
    need = corners @ d + np.maximum(np.abs(corners @ right) / t_x, np.abs(corners @ up) / t_y)
    dist = max(float(need.max()) * 1.08, 1e-3)
    origin = center + dist * d
    extent = float(np.linalg.norm(np.asarray(hi) - np.asarray(lo)))
    return {
        "type": "perspective",
        "fov": fov_deg,
        "fov_axis": "smaller",
        "near_clip": max(dist * 1e-3, 1e-4),
        "far_clip": dist + 2 * extent,
        "to_world": mi.ScalarTransform4f().look_at(origin=origin.tolist(), target=center.tolist(), up=up0.tolist()),
        "film": {"type": "hdrfilm", "width": int(width), "height": int(height), "rfilter": {"type": "gaussian"}},
        "sampler": {"type": "independent", "sample_count": int(spp)},
    }


def _bsdf_entry(table: Any, mode: str, scale: float) -> dict:
    return {"type": "cdbrdf", "table": table, "mode": mode, "curvature": "vertex_curvature", "scale": scale}


def _scene_dict(mi, mesh: Mesh, ply_path: Path, bsdf: Any, *, size, spp, light, envmap, max_depth, elevation_deg, azimuth_deg, fov_deg) -> dict:
    write_ply(ply_path, mesh)
    lo, hi = mesh.vertices.min(0), mesh.vertices.max(0)
    d: dict[str, Any] = {
        "type": "scene",
        "integrator": {"type": "path", "max_depth": int(max_depth)},
        "sensor": _camera(mi, lo, hi, size[0], size[1], elevation_deg=elevation_deg,
                          azimuth_deg=azimuth_deg, fov_deg=fov_deg, spp=spp),
        "object": {"type": "ply", "filename": str(ply_path), "bsdf": bsdf},
    }
    if envmap is not None:
        d["envmap"] = {"type": "envmap", "filename": str(envmap)}
    if light is not None:
        d["light"] = directional_light(*light)
    if envmap is None and light is None:
        raise ValueError("the scene needs a light: give a directional light or an environment map")
    return d


def _build(mesh: Mesh, table: Any, *, mode, scale, size, spp, light, envmap, max_depth, elevation_deg, azimuth_deg, fov_deg, bsdf=None):
    import mitsuba as mi

    from . import load_dict

    if bsdf is None:
        bsdf = _bsdf_entry(table, mode, scale)
    with tempfile.TemporaryDirectory(prefix="cdbrdf-") as tmp:
        d = _scene_dict(mi, mesh, Path(tmp) / "object.ply", bsdf, size=size, spp=spp, light=light,
                        envmap=envmap, max_depth=max_depth, elevation_deg=elevation_deg,
                        azimuth_deg=azimuth_deg, fov_deg=fov_deg)
        return load_dict(d)


def sine_scene(
    table: Any,
    *,
    mode: str = "cdbrdf",
    sheet: SineSheet = SineSheet(),
    light: tuple[float, float, float] | None = (45.0, 0.0, DEFAULT_IRRADIANCE),
    size: tuple[int, int] = (512, 384),
    spp: int = 64,
    max_depth: int = 3,
    scale: float = 1.0,
    elevation_deg: float = 40.0,
    azimuth_deg: float = -90.0,
    fov_deg: float = 40.0,
    bsdf: Any = None,
):
    """The paper's sine sheet under a directional light, seen by a perspective camera.

    Parameters
    ----------
    table
        A :class:`~cdbrdf.table.CDBRDF` or a file name.
    mode
        ``"cdbrdf"`` or ``"brdf"`` (the plug-in's mode).
    sheet
        The sheet's geometry.
    light
        ``(theta_deg, phi_deg, irradiance)`` of the directional light
        (direction towards the light, world frame; x = bending direction).
    size
        Film ``(width, height)`` in pixels.
    spp, max_depth
        Samples per pixel and Mitsuba path length (2 = direct light only; the
        default 3 adds one inter-reflection between the corrugations).
    elevation_deg, azimuth_deg, fov_deg
        Camera elevation above the sheet, azimuth (from +x; -90 looks along
        +y, across the corrugations) and field of view (smaller axis).
    bsdf
        A BSDF dict or instance used instead of the plug-in (e.g. Mitsuba's
        ``diffuse`` for comparisons).

    Returns
    -------
    mitsuba.Scene
    """
    return _build(sine_sheet_mesh(sheet), table, mode=mode, scale=scale, size=size, spp=spp,
                  light=light, envmap=None, max_depth=max_depth, elevation_deg=elevation_deg,
                  azimuth_deg=azimuth_deg, fov_deg=fov_deg, bsdf=bsdf)


def mesh_scene(
    table: Any,
    mesh: Mesh | str | PathLike[str],
    *,
    units: str = "mm",
    mode: str = "cdbrdf",
    light: tuple[float, float, float] | None = (45.0, 0.0, DEFAULT_IRRADIANCE),
    envmap: str | PathLike[str] | None = None,
    size: tuple[int, int] = (512, 384),
    spp: int = 64,
    max_depth: int = 3,
    scale: float = 1.0,
    elevation_deg: float = 35.0,
    azimuth_deg: float = -90.0,
    fov_deg: float = 40.0,
):
    """A user mesh (PLY/OBJ with UVs) with the CDBRDF, lit by a directional light and/or an envmap.

    The curvature comes from the file (``curvature_x`` vertex property) or is
    computed (see :func:`prepare_mesh`). Set ``light=None`` to light with the
    environment map alone. Other parameters as in :func:`sine_scene`.
    """
    if not isinstance(mesh, Mesh):
        mesh = prepare_mesh(mesh, units=units)
    elif mesh.uv is None:
        raise ValueError("mesh: no UV coordinates, so no anisotropy frame (dP/du) for the CDBRDF")
    elif "curvature" not in mesh.attributes:
        raise ValueError("mesh: no 'curvature' attribute (use prepare_mesh)")
    return _build(mesh, table, mode=mode, scale=scale, size=size, spp=spp, light=light,
                  envmap=envmap, max_depth=max_depth, elevation_deg=elevation_deg,
                  azimuth_deg=azimuth_deg, fov_deg=fov_deg)


def render_scene(
    scene,
    *,
    spp: int | None = None,
    seed: int = 0,
    passes: int | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> NDArray[np.float32]:
    """Render ``scene`` in passes; returns linear RGB ``(H, W, 3)`` float32.

    Parameters
    ----------
    spp
        Samples per pixel (default: the sensor's).
    seed
        Seed of the first pass (pass ``i`` uses ``seed + i``).
    passes
        Number of passes (default: about 16 spp each); the image is their mean.
    progress
        Called as ``progress(samples_done, samples_total)`` after each pass.
    """
    import mitsuba as mi

    sensor = scene.sensors()[0]
    total = int(spp if spp is not None else sensor.sampler().sample_count())
    if total < 1:
        raise ValueError(f"spp: must be >= 1, got {total}")
    n = passes if passes is not None else max(1, math.ceil(total / 16))
    n = min(n, total)
    chunks = [total // n + (1 if i < total % n else 0) for i in range(n)]
    acc = None
    done = 0
    for i, c in enumerate(chunks):
        img = np.asarray(mi.render(scene, spp=c, seed=seed + i), dtype=np.float64)
        acc = img * c if acc is None else acc + img * c
        done += c
        if progress is not None:
            progress(done, total)
    out = (acc / total).astype(np.float32)
    return out[..., :3]
