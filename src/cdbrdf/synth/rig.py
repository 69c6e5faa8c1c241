"""A simulated capture rig: Mitsuba 3 photographs of a fabric on the paper's stands.

For every row of a capture plan (``docs/capture.md``) the rig renders one
photograph with the row's camera and light:

- the stand's centre is the origin; its face's normal there is +z, the
  bending direction +x, the cylinder axis y (the conventions' local frame);
- the fabric (the ``cdbrdf`` BSDF plug-in of :mod:`cdbrdf.render`, with the
  stand's curvature as a constant) covers the face: the outside of a cylinder
  (``kappa > 0``), a flat face, or the inside of a trough (``kappa < 0``)
  of :class:`~cdbrdf.measure.plan.Stand` geometry, whose edges carry white
  walls; the rest of the stand body is white (diffuse, reflectance 0.8);
- the camera is orthographic, looks at the centre from the row's view
  direction, ``field_mm`` wide, and is shifted so that the centre falls on
  the middle of pixel ``(size // 2, size // 2)``; each pixel integrates its
  footprint with ``spp`` stratified samples and a box filter;
- one directional light of unit irradiance comes from the row's light
  direction; the ``direct`` integrator traces shadow rays, so on a concave
  stand the walls and the trough shadow the centre at grazing light, and at
  grazing views the camera sees the trough or a wall instead of the centre:
  the paper's artefact appears by itself;
- white-reference rows render a flat Lambertian plate of albedo
  ``white_albedo``; dark rows render nothing (noise only);
- the linear pixel value ``x = gain * exposure * L`` is turned into
  electrons ``x * full_well``, gets photon (Poisson) and read (Gaussian)
  noise, is clipped to [0, 1], sRGB-encoded and quantised (16-bit PNG by
  default; 8-bit PNG, 16-bit TIFF, or linear float OpenEXR without clipping).

One scene per stand is loaded once; the camera and light are updated through
:func:`mitsuba.traverse` between renders, so the traced kernels are reused.
"""

from __future__ import annotations

import csv
import logging
import math
import shutil
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from os import PathLike
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..measure.images import FORMATS, linear_to_srgb, write_exr, write_png, write_tiff
from ..measure.capture import CAPTURE_FILE, STAND_FILE, write_plan
from ..measure.stands import Stand, default_stand, read_stands, write_stands
from ..table import CDBRDF, Grid

__all__ = [
    "NoiseModel",
    "SimulationReport",
    "simulate_capture",
    "load_material",
    "stand_meshes",
    "expected_patch_value",
    "IMAGE_KINDS",
    "STAND_REFLECTANCE",
]

_LOG = logging.getLogger(__name__)

#: Image kinds the rig writes: extension -> description.
IMAGE_KINDS: dict[str, str] = {
    "png16": "16-bit sRGB PNG",
    "png8": "8-bit sRGB PNG",
    "tif16": "16-bit sRGB TIFF (uncompressed)",
    "exr": "linear float32 OpenEXR",
}
#: Diffuse reflectance of the white stand body.
STAND_REFLECTANCE = 0.8
_CAMERA_DISTANCE_MM = 60.0


@dataclass(frozen=True)
class NoiseModel:
    """Sensor noise: photon (Poisson) noise of ``full_well`` electrons at full scale, plus read noise.

    Parameters
    ----------
    full_well
        Electrons at the largest code (linear value 1.0); ``0`` disables noise.
    read_e
        Standard deviation of the read noise, electrons.
    """

    full_well: float = 20000.0
    read_e: float = 3.0

    @classmethod
    def parse(cls, text: str) -> "NoiseModel":
        """``"none"`` or ``"FULL_WELL[,READ]"`` (electrons), e.g. ``"20000,3"``."""
        t = text.strip().lower()
        if t in ("none", "off", "0"):
            return cls(0.0, 0.0)
        parts = t.split(",")
        try:
            vals = [float(p) for p in parts]
        except ValueError:
            raise ValueError(f"noise: expected 'none' or 'FULL_WELL[,READ]', got {text!r}") from None
        if len(vals) > 2 or vals[0] <= 0 or (len(vals) == 2 and vals[1] < 0):
            raise ValueError(f"noise: expected 'none' or 'FULL_WELL[,READ]' (positive), got {text!r}")
        return cls(vals[0], vals[1] if len(vals) == 2 else cls.read_e)

    @property
    def enabled(self) -> bool:
        """False when the images are noise-free."""
        return self.full_well > 0

    def apply(self, x: NDArray[np.float64], rng: np.random.Generator) -> NDArray[np.float64]:
        """Noisy linear values (not clipped)."""
        if not self.enabled:
            return x
        e = np.maximum(x, 0.0) * self.full_well
        noisy = rng.poisson(e).astype(np.float64) + rng.normal(0.0, self.read_e, size=x.shape)
        return noisy / self.full_well


@dataclass
class SimulationReport:
    """What :func:`simulate_capture` wrote."""

    folder: Path
    n_images: int = 0
    n_white: int = 0
    n_dark: int = 0
    n_saturated_pixels: int = 0
    seconds_rendering: float = 0.0
    files: list[str] = field(default_factory=list)

    def summary(self) -> str:
        """One line."""
        return (
            f"{self.folder}: {self.n_images} photographs ({self.n_white} white references, "
            f"{self.n_dark} dark frames), {self.n_saturated_pixels} saturated pixels, "
            f"{self.seconds_rendering:.1f} s rendering"
        )


def load_material(material: CDBRDF | str | PathLike[str]) -> CDBRDF:
    """A table from a :class:`CDBRDF`, a CDBRDF file or a preset name (:mod:`cdbrdf.materials`)."""
    if isinstance(material, CDBRDF):
        return material
    p = Path(material)
    if p.suffix.lower() in (".h5", ".hdf5", ".nc") or p.exists():
        from ..io import load

        return load(p)
    try:
        from .. import materials
    except ImportError as exc:  # pragma: no cover - the presets module is part of the package
        raise ValueError(f"material {material!r}: not a file, and presets are unavailable ({exc})") from None
    return materials.load(str(material))


# --------------------------------------------------------------------------- geometry
def _strip(xz: NDArray, nrm: NDArray, u: NDArray, length_mm: float, *, max_step_mm: float = 0.5
           ) -> dict[str, NDArray]:
    """A ribbon extruded along y from a 2-D profile (points xz, normals, u per point).

    The ribbon is cut every ``max_step_mm`` along y as well, so that no
    triangle is a long sliver (ray-triangle tests on slivers let a few rays
    slip through shared edges).
    """
    n = xz.shape[0]
    ny = max(1, int(math.ceil(length_mm / max_step_mm)))
    ys = np.linspace(-0.5 * length_mm, 0.5 * length_mm, ny + 1)
    pos = np.zeros((ny + 1, n, 3))
    pos[..., 0] = xz[None, :, 0]
    pos[..., 1] = ys[:, None]
    pos[..., 2] = xz[None, :, 1]
    nor = np.zeros((ny + 1, n, 3))
    nor[..., 0] = nrm[None, :, 0]
    nor[..., 2] = nrm[None, :, 1]
    uv = np.zeros((ny + 1, n, 2))
    uv[..., 0] = u[None, :]
    uv[..., 1] = np.linspace(0.0, 1.0, ny + 1)[:, None]
    j, i = np.meshgrid(np.arange(ny), np.arange(n - 1), indexing="ij")
    a = (j * n + i).ravel()
    b, c, d = a + 1, a + n + 1, a + n
    faces = np.concatenate([np.stack([a, b, c], -1), np.stack([a, c, d], -1)]).astype(np.uint32)
    return {"positions": pos.reshape(-1, 3), "normals": nor.reshape(-1, 3), "uv": uv.reshape(-1, 2),
            "faces": faces}


def _cap(xz: NDArray, y: float, outward: float) -> dict[str, NDArray]:
    """A flat polygon (fan) closing a profile at ``y``, normal ``(0, outward, 0)``."""
    n = xz.shape[0]
    centre = xz.mean(axis=0)
    pos = np.zeros((n + 1, 3))
    pos[:n, 0], pos[:n, 2] = xz[:, 0], xz[:, 1]
    pos[n, 0], pos[n, 2] = centre
    pos[:, 1] = y
    nor = np.tile([0.0, outward, 0.0], (n + 1, 1))
    uv = np.zeros((n + 1, 2))
    i = np.arange(n)
    faces = np.stack([np.full(n, n), i, (i + 1) % n], -1).astype(np.uint32)
    return {"positions": pos, "normals": nor, "uv": uv, "faces": faces}


def _arc(stand: Stand, s0: float, s1: float, n: int) -> tuple[NDArray, NDArray]:
    """Profile points and normals of the stand's face for arc lengths s0..s1 (mm)."""
    s = np.linspace(s0, s1, n)
    if stand.kappa == 0:
        xz = np.stack([s, np.zeros_like(s)], axis=-1)
        nrm = np.tile([0.0, 1.0], (n, 1))
    else:
        r = stand.radius_mm
        a = s / r
        if stand.kappa > 0:
            xz = np.stack([r * np.sin(a), r * np.cos(a) - r], axis=-1)
            nrm = np.stack([np.sin(a), np.cos(a)], axis=-1)
        else:
            xz = np.stack([r * np.sin(a), r - r * np.cos(a)], axis=-1)
            nrm = np.stack([-np.sin(a), np.cos(a)], axis=-1)
    return xz, nrm


def stand_meshes(stand: Stand, *, segments: int = 256) -> dict[str, dict[str, NDArray]]:
    """Triangle meshes of a stand: ``"fabric"`` and the white body parts.

    Each mesh is a dict of ``positions``, ``normals`` (smooth, exact),
    ``uv`` (u along the bending direction x, so dP/du is the material's
    reference tangent) and ``faces``. Lengths in mm.
    """
    w = stand.face_width_mm
    L = stand.length_mm
    xz, nrm = _arc(stand, -0.5 * w, 0.5 * w, segments + 1)
    out = {"fabric": _strip(xz, nrm, np.linspace(0.0, 1.0, segments + 1), L)}
    pad = 12.0
    if stand.kappa > 0:
        r = stand.radius_mm
        a0 = 0.5 * w / r
        ang = np.linspace(a0, 2 * math.pi - a0, segments + 1)
        bxz = np.stack([r * np.sin(ang), r * np.cos(ang) - r], axis=-1)
        bn = np.stack([np.sin(ang), np.cos(ang)], axis=-1)
        out["body"] = _strip(bxz, bn, np.linspace(0, 1, segments + 1), L)
        ring = np.concatenate([xz, bxz[1:-1]])  # the whole circle: close the tube's ends
        ring = ring[np.argsort(np.arctan2(ring[:, 0], ring[:, 1] + r))]
        out["capA"] = _cap(ring, -0.5 * L, -1.0)
        out["capB"] = _cap(ring, 0.5 * L, 1.0)
    elif stand.kappa == 0:
        for side in (-1, 1):
            x = np.array([0.5 * w, 0.5 * w + pad]) * side
            if side < 0:
                x = x[::-1]
            out[f"top{'LR'[side > 0]}"] = _strip(
                np.stack([x, np.zeros(2)], axis=-1), np.tile([0.0, 1.0], (2, 1)), np.array([0.0, 1.0]), L
            )
    else:
        x_e, z_e = stand.edge_mm
        top = z_e + stand.wall_height_mm
        for side in (-1, 1):
            xe = side * x_e
            if stand.wall_height_mm > 0:
                zz = np.array([z_e, top]) if side < 0 else np.array([top, z_e])
                out[f"wall{'LR'[side > 0]}"] = _strip(
                    np.stack([np.full(2, xe), zz], axis=-1), np.tile([-side, 0.0], (2, 1)).astype(float),
                    np.array([0.0, 1.0]), L,
                )
            x = np.array([xe, xe + side * pad])
            if side < 0:
                x = x[::-1]
            out[f"top{'LR'[side > 0]}"] = _strip(
                np.stack([x, np.full(2, top)], axis=-1), np.tile([0.0, 1.0], (2, 1)), np.array([0.0, 1.0]), L
            )
    return out


def _mi_mesh(mi, name: str, m: dict[str, NDArray], bsdf: Any):  # noqa: ANN001, ANN202
    mesh = mi.Mesh(name, vertex_count=m["positions"].shape[0], face_count=m["faces"].shape[0],
                   has_vertex_normals=True, has_vertex_texcoords=True)
    params = mi.traverse(mesh)
    params["vertex_positions"] = m["positions"].astype(np.float32).ravel()
    params["vertex_normals"] = m["normals"].astype(np.float32).ravel()
    params["vertex_texcoords"] = m["uv"].astype(np.float32).ravel()
    params["faces"] = m["faces"].ravel()
    params.update()
    mesh.set_bsdf(bsdf)
    return mesh


# --------------------------------------------------------------------------- camera/light
def _up_for(d: NDArray) -> list[float]:
    return [0.0, 1.0, 0.0] if abs(d[1]) < 0.9 else [1.0, 0.0, 0.0]


def _direction(theta_deg: float, phi_deg: float) -> NDArray[np.float64]:
    t, p = math.radians(theta_deg), math.radians(phi_deg)
    return np.array([math.sin(t) * math.cos(p), math.sin(t) * math.sin(p), math.cos(t)])


def _sensor_to_world(mi, v: NDArray, size: int, field_mm: float):  # noqa: ANN001, ANN202
    T = mi.ScalarTransform4f
    px = field_mm / size
    shift = (size // 2 + 0.5 - 0.5 * size) * px  # centre of pixel size//2 on the optical axis
    up = [0.0, 0.0, 1.0] if math.hypot(v[0], v[1]) > 1e-6 else [0.0, 1.0, 0.0]
    return (
        T().look_at(origin=list(v * _CAMERA_DISTANCE_MM), target=[0.0, 0.0, 0.0], up=up)
        @ T().translate([shift, shift, 0.0])
        @ T().scale([0.5 * field_mm, 0.5 * field_mm, 1.0])
    )


def _light_to_world(mi, l: NDArray):  # noqa: ANN001, ANN202, E741
    T = mi.ScalarTransform4f
    return T().look_at(origin=[0.0, 0.0, 0.0], target=list(-l), up=_up_for(l))


def _surface_hits(stand: Stand, origins: NDArray, v: NDArray
                  ) -> tuple[NDArray, NDArray, NDArray]:
    """Where rays ``origins - s v`` (from the camera at s = -inf) meet the stand's face.

    Returns the points, the face normals and the tangents x (dP/du).
    """
    ox, oz = origins[:, 0], origins[:, 2]
    vx, vz = v[0], v[2]
    if stand.kappa == 0:
        s = oz / vz
        p = origins - s[:, None] * v
        n = np.tile([0.0, 0.0, 1.0], (len(p), 1))
        t = np.tile([1.0, 0.0, 0.0], (len(p), 1))
        return p, n, t
    r = stand.radius_mm
    cz = -r if stand.kappa > 0 else r  # the cylinder's axis (x = 0, z = cz)
    # |(ox - s vx, oz - s vz - cz)|^2 = r^2  (a quadratic in s)
    a = vx * vx + vz * vz
    b = -2.0 * (ox * vx + (oz - cz) * vz)
    c = ox * ox + (oz - cz) ** 2 - r * r
    disc = np.sqrt(np.maximum(b * b - 4 * a * c, 0.0))
    # the camera sits at s -> -inf: convex, the first hit (smaller root); concave, the
    # ray enters the circle above the trough and meets the face on the way out (larger root)
    s = (-b - disc) / (2 * a) if stand.kappa > 0 else (-b + disc) / (2 * a)
    p = origins - s[:, None] * v
    if stand.kappa > 0:
        n = np.stack([p[:, 0], np.zeros(len(p)), p[:, 2] + r], axis=-1) / r
        t = np.stack([n[:, 2], np.zeros(len(p)), -n[:, 0]], axis=-1)
    else:
        n = np.stack([-p[:, 0], np.zeros(len(p)), r - p[:, 2]], axis=-1) / r
        t = np.stack([n[:, 2], np.zeros(len(p)), -n[:, 0]], axis=-1)
    return p, n, t


def expected_patch_value(
    table: CDBRDF,
    stand: Stand,
    theta_v: float,
    phi_v: float,
    theta_l: float,
    phi_l: float,
    *,
    size: int = 64,
    field_mm: float = 2.0,
    n: int = 7,
    sub: int = 4,
) -> NDArray[np.float64]:
    """What an ideal (noise-free) measurement of one rig photograph gives.

    The N x N patch of the rig's camera covers a small area of the stand's
    face, over which the normal turns on a curved stand; the measurement
    therefore averages the table over nearby local directions. This
    integrates ``f(v_local, l_local, kappa) * cos(theta_l_local)`` over the
    patch (``sub x sub`` points per pixel, shadows ignored) and divides by
    ``cos(theta_l)`` at the centre, as :func:`cdbrdf.measure.measure` does.
    With a tiny field it tends to the table's own value at the grid node.

    Returns
    -------
    numpy.ndarray
        ``(channels,)``.
    """
    from ..frames import angles_from_direction

    v = _direction(theta_v, phi_v)
    light = _direction(theta_l, phi_l)
    up = np.array([0.0, 0.0, 1.0]) if math.hypot(v[0], v[1]) > 1e-6 else np.array([0.0, 1.0, 0.0])
    fwd = -v
    left = np.cross(up, fwd)
    left /= np.linalg.norm(left)
    cam_up = np.cross(fwd, left)
    px = field_mm / size
    k = n * sub
    off = (np.arange(k) + 0.5) / sub - 0.5 * n  # pixel units, centred on the patch
    a, b = np.meshgrid(off * px, off * px, indexing="ij")
    origins = a.reshape(-1, 1) * left + b.reshape(-1, 1) * cam_up
    _p, nrm, tx = _surface_hits(stand, origins, v)
    ty = np.cross(nrm, tx)
    loc_v = np.stack([tx @ v, ty @ v, nrm @ v], axis=-1)
    loc_l = np.stack([tx @ light, ty @ light, nrm @ light], axis=-1)
    tv, pv = angles_from_direction(loc_v)
    tl, pl = angles_from_direction(loc_l)
    ok = (tv < 90.0) & (tl < 90.0)
    f = table.evaluate(np.minimum(tv, 90.0), pv, np.minimum(tl, 90.0), pl, stand.kappa)
    rad = np.where(ok[:, None], f * np.maximum(loc_l[:, 2], 0.0)[:, None], 0.0)
    return rad.mean(axis=0) / math.cos(math.radians(theta_l))


# --------------------------------------------------------------------------- scenes
def _scene(mi, cr, parts: dict[str, Any], *, size: int, field_mm: float, spp: int):  # noqa: ANN001, ANN202
    d = {
        "type": "scene",
        "integrator": {"type": "direct", "emitter_samples": 1, "bsdf_samples": 0},
        "sensor": {
            "type": "orthographic",
            "to_world": _sensor_to_world(mi, np.array([0.0, 0.0, 1.0]), size, field_mm),
            "near_clip": 1.0,
            "far_clip": 1000.0,
            "film": {"type": "hdrfilm", "width": size, "height": size, "rfilter": {"type": "box"},
                     "pixel_format": "rgb"},
            "sampler": {"type": "stratified", "sample_count": spp},
        },
        "light": {"type": "directional", "direction": [0.0, 0.0, -1.0],
                  "irradiance": {"type": "rgb", "value": 1.0}},
    }
    d.update(parts)
    return cr.load_dict(d)


def _stand_scene(mi, cr, table: CDBRDF, stand: Stand, **kw: Any):  # noqa: ANN001, ANN202
    fabric = cr.make_bsdf(table, mode="cdbrdf", curvature=float(stand.kappa))
    white = mi.load_dict({"type": "twosided", "bsdf": {"type": "diffuse", "reflectance": {
        "type": "rgb", "value": STAND_REFLECTANCE}}})
    parts = {}
    for name, m in stand_meshes(stand).items():
        parts[name] = _mi_mesh(mi, name, m, fabric if name == "fabric" else white)
    return _scene(mi, cr, parts, **kw)


def _white_scene(mi, cr, albedo: float, **kw: Any):  # noqa: ANN001, ANN202
    plate = {"type": "rectangle", "to_world": mi.ScalarTransform4f().scale([30.0, 30.0, 1.0]),
             "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": float(albedo)}}}
    return _scene(mi, cr, {"plate": plate}, **kw)


# --------------------------------------------------------------------------- main
def _encode(x: NDArray[np.float64], kind: str) -> tuple[NDArray, int]:
    """Codes of linear values and the number of saturated pixels."""
    if kind == "exr":
        return x.astype(np.float32), 0
    top = 65535 if kind in ("png16", "tif16") else 255
    c = np.clip(x, 0.0, 1.0)
    codes = np.round(linear_to_srgb(c) * top)
    sat = int(np.count_nonzero(np.any(codes >= top, axis=-1)))
    return codes.astype(np.uint16 if top == 65535 else np.uint8), sat


def _write(path: Path, codes: NDArray, kind: str) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    if kind in ("png16", "png8"):
        write_png(path, codes, level=1)
    elif kind == "tif16":
        write_tiff(path, codes)
    else:
        write_exr(path, codes)


def _ext(kind: str) -> str:
    return {"png16": "png", "png8": "png", "tif16": "tif", "exr": "exr"}[kind]


def simulate_capture(
    material: CDBRDF | str | PathLike[str],
    folder: str | PathLike[str],
    *,
    plan: str | PathLike[str] | None = None,
    grid: Grid | None = None,
    stands: Sequence[Stand] | None = None,
    size: int = 64,
    field_mm: float = 2.0,
    spp: int = 4,
    noise: NoiseModel = NoiseModel(),
    gain: float = 2.0,
    exposures: Sequence[float] = (1.0,),
    image_kind: str = "png16",
    white_albedo: float = 0.99,
    white: bool = True,
    patch_px: int = 7,
    seed: int = 0,
    progress: Callable[[int, int], None] | None = None,
) -> SimulationReport:
    """Render a capture folder of a material with the simulated rig.

    Parameters
    ----------
    material
        A :class:`CDBRDF`, a CDBRDF file, or a preset name.
    folder
        Output capture folder. It is built as a partial folder beside it and
        swapped in whole once complete (:func:`cdbrdf.report.output_folder`):
        an earlier capture written by cdbrdf is replaced, a non-empty folder
        cdbrdf did not make is refused, and an error or interrupt leaves no
        half-written folder.
    plan
        A ``capture.csv`` to render (its ``stands.json``, if beside it, gives
        the stand geometry). Default: a plan for ``grid`` (default the
        material's own grid) and ``stands`` (default: one per kappa of the
        grid, default geometry), written like ``cdbrdf plan``.
    size
        Image width and height in pixels.
    field_mm
        Width of the camera's field at the stand, mm; ``field_mm / size``
        (the pixel size) is written to ``stands.json`` as ``pixel_mm``, so
        that the measurement discards photographs in which any pixel of the
        patch sees a wall or lies in its shadow.
    spp
        Stratified samples per pixel (integrate each pixel's footprint; box filter).
    noise
        Sensor noise; ``NoiseModel(0, 0)`` for none.
    gain
        Linear pixel value per unit radiance at exposure 1.
    exposures
        Without ``plan``: the exposures of each sample and white photograph
        (several make brackets, each rendered once and given its own noise).
    image_kind
        One of :data:`IMAGE_KINDS`.
    white_albedo
        Albedo of the white reference plate (written to ``stands.json``).
    white
        Without ``plan``: add white-reference rows.
    patch_px
        Without ``plan``: the patch size the plan's ``hidden`` marks assume.
    seed
        Noise seed (each photograph draws from ``(seed, row)``).
    progress
        ``progress(done, total)`` after each photograph.
    """
    if image_kind not in IMAGE_KINDS:
        raise ValueError(f"image_kind: {image_kind!r} is not one of {', '.join(IMAGE_KINDS)}")
    if size < 8:
        raise ValueError(f"size: must be at least 8 pixels, got {size}")
    if not (field_mm > 0 and gain > 0 and spp >= 1):
        raise ValueError("field_mm, gain and spp must be positive")
    from ..report import check_output_folder, output_folder

    final = check_output_folder(folder)  # refuse a foreign folder before any work
    table = load_material(material)
    with output_folder(final) as partial:
        rep = _fill_capture(
            partial, table, plan=plan, grid=grid, stands=stands, size=size, field_mm=field_mm,
            spp=spp, noise=noise, gain=gain, exposures=exposures, image_kind=image_kind,
            white_albedo=white_albedo, white=white, patch_px=patch_px, seed=seed,
            progress=progress,
        )
    rep.folder = final
    return rep


def _fill_capture(
    out: Path,
    table: CDBRDF,
    *,
    plan: str | PathLike[str] | None,
    grid: Grid | None,
    stands: Sequence[Stand] | None,
    size: int,
    field_mm: float,
    spp: int,
    noise: NoiseModel,
    gain: float,
    exposures: Sequence[float],
    image_kind: str,
    white_albedo: float,
    white: bool,
    patch_px: int,
    seed: int,
    progress: Callable[[int, int], None] | None,
) -> SimulationReport:
    """Write the capture into the (empty, partial) folder ``out``; see :func:`simulate_capture`."""
    import time

    ext = _ext(image_kind)
    if plan is not None:
        plan_path = Path(plan)
        if not plan_path.is_file():
            raise FileNotFoundError(f"{plan_path}: no such capture plan")
        rows = _read_plan_rows(plan_path)
        src_stands = plan_path.parent / STAND_FILE
        stand_map = read_stands(src_stands) if src_stands.is_file() else {}
        if _match_extension(plan_path, rows, ext):
            # file names renamed to the image kind's extension: write the plan as rendered
            with open(out / CAPTURE_FILE, "w", newline="", encoding="utf-8") as fh:
                wr = csv.DictWriter(fh, fieldnames=list(rows[0].keys()))
                wr.writeheader()
                wr.writerows(rows)
        elif plan_path.resolve() != (out / CAPTURE_FILE).resolve():
            shutil.copyfile(plan_path, out / CAPTURE_FILE)
        kappas = sorted({float(r["kappa"]) for r in rows if (r.get("kind") or "sample") == "sample"})
        for k in kappas:
            if not any(abs(k - s) <= 1e-9 for s in stand_map):
                stand_map[k] = default_stand(k)
        stand_list = [stand_map[s] for s in sorted(stand_map)]
    else:
        g = grid if grid is not None else table.grid
        stand_list = list(stands) if stands is not None else [default_stand(k) for k in g.kappa]
        rows = write_plan(out, g, stand_list, extension=ext, white=white,
                          pixel_mm=field_mm / size, patch_px=patch_px)
        if len(exposures) != 1 or float(exposures[0]) != 1.0:
            rows = _bracket(rows, [float(e) for e in exposures])
            with open(out / CAPTURE_FILE, "w", newline="", encoding="utf-8") as fh:
                wr = csv.DictWriter(fh, fieldnames=list(rows[0].keys()))
                wr.writeheader()
                wr.writerows(rows)
    write_stands(out / STAND_FILE, stand_list, white_albedo=float(white_albedo),
                 material=str(table.attrs.get("material", "unknown")), simulated=True,
                 pixel_mm=field_mm / size)

    import cdbrdf.render as cr

    cr.set_variant()
    import mitsuba as mi

    kw = {"size": size, "field_mm": field_mm, "spp": spp}
    rep = SimulationReport(out)
    by_scene: dict[Any, list[int]] = {}
    for i, r in enumerate(rows):
        kind = (r.get("kind") or "sample").strip().lower()
        key = "dark" if kind == "dark" else ("white" if kind == "white" else float(r["kappa"]))
        by_scene.setdefault(key, []).append(i)
    total = len(rows)
    done = 0
    t0 = time.perf_counter()
    for key, idx in by_scene.items():
        if key == "dark":
            scene = None
        elif key == "white":
            scene = _white_scene(mi, cr, white_albedo, **kw)
        else:
            st = next(s for s in stand_list if abs(s.kappa - key) <= 1e-9)
            scene = _stand_scene(mi, cr, table, st, **kw)
        params = mi.traverse(scene) if scene is not None else None
        for i in idx:
            r = rows[i]
            exposure = float(r.get("exposure") or 1.0)
            if scene is None:
                lin = np.zeros((size, size, 3))
                rep.n_dark += 1
            else:
                v = _direction(float(r["theta_v"]), float(r["phi_v"]))
                light = _direction(float(r["theta_l"]), float(r["phi_l"]))
                params["sensor.to_world"] = _sensor_to_world(mi, v, size, field_mm)
                params["light.to_world"] = _light_to_world(mi, light)
                params.update()
                img = np.asarray(mi.render(scene, seed=(seed * 1000003 + i) % 2**32), dtype=np.float64)
                lin = img[..., :3] * gain * exposure
                if key == "white":
                    rep.n_white += 1
            rng = np.random.default_rng([int(seed), i])
            lin = noise.apply(lin, rng)
            codes, nsat = _encode(lin, image_kind)
            rep.n_saturated_pixels += nsat
            _write(out / r["file"], codes, image_kind)
            rep.files.append(r["file"])
            rep.n_images += 1
            done += 1
            if progress is not None:
                progress(done, total)
    rep.seconds_rendering = time.perf_counter() - t0
    return rep


def _match_extension(plan: Path, rows: list[dict[str, str]], ext: str) -> bool:
    """Give every row's file the extension of the image kind (``a.png`` -> ``a.tif``); True if any changed.

    A plan names its photographs ``.png`` (``cdbrdf plan``'s default): rendered
    as TIFF or EXR they must not be written under a name whose extension
    selects another format. Refuses renames that would make two rows share a file.
    """
    want = FORMATS["." + ext]
    changed = False
    for r in rows:
        name = r["file"]
        if FORMATS.get(Path(name).suffix.lower()) != want:
            r["file"] = str(Path(name).with_suffix("." + ext).as_posix())
            changed = True
    if changed:
        names = [r["file"] for r in rows]
        if len(set(names)) != len(names):
            dup = next(n for n in names if names.count(n) > 1)
            raise ValueError(f"{plan}: giving the files the .{ext} extension makes two rows share {dup}")
    return changed


def _read_plan_rows(path: Path) -> list[dict[str, str]]:
    with open(path, newline="", encoding="utf-8-sig") as fh:
        rows = list(csv.DictReader(fh))
    for c in ("file", "kappa", "theta_v", "phi_v", "theta_l", "phi_l"):
        if rows and c not in rows[0]:
            raise ValueError(f"{path}: missing column {c!r}")
    return rows


def _bracket(rows: list[dict[str, Any]], exposures: list[float]) -> list[dict[str, Any]]:
    """Repeat every sample and white row once per exposure (``..._e<i>`` file names)."""
    out = []
    for r in rows:
        if r["kind"] not in ("sample", "white"):
            out.append(r)
            continue
        stem, dot, ext = r["file"].rpartition(".")
        for j, e in enumerate(exposures):
            rr = dict(r)
            rr["file"] = f"{stem}_e{j}.{ext}"
            rr["exposure"] = f"{e:g}"
            out.append(rr)
    return out
