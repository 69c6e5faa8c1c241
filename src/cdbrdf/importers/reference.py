"""The imported table against the reference renderer: the same scene with Mitsuba's ``measured`` and the plug-in.

:func:`compare` renders each scene of :data:`SCENES` twice in ``llvm_ad_rgb``:
once with Mitsuba's own ``measured`` BSDF reading the RGL file (the
reference), once with the ``cdbrdf`` plug-in on the imported table (or with
any other BSDF dict as the reference, e.g. Mitsuba's ``roughconductor``, and
the table imported from it). The scenes: a sphere and the paper's sine sheet,
lit by a directional light plus a constant environment, direct lighting by
emitter sampling only (Mitsuba's ``direct`` integrator, ``bsdf_samples=0``):
with the same seed both renderers then trace the same camera rays towards the
same light directions, so their Monte Carlo noise is correlated and cancels
in the difference, whatever each BSDF's own sampling (the plug-in samples
cosine-weighted, ``measured`` its lobe). The figure of merit is the mean
relative difference of luminance over the object's pixels, averaged first in
``block`` x ``block`` pixel blocks (only blocks wholly on the object count).
With ``noise=True`` the pair is rendered again with another seed: the spread
of the figure between the two seeds is its Monte Carlo uncertainty.
"""

from __future__ import annotations

import math
import tempfile
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from os import PathLike
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..colour import luminance

__all__ = ["SCENES", "Comparison", "block_difference", "compare", "scene_dict"]

#: The scenes of the comparison.
SCENES: tuple[str, ...] = ("sphere", "sheet")

#: Directional light: elevation and azimuth (degrees) of the direction towards it, irradiance.
LIGHT = (40.0, 30.0, math.pi)
#: Radiance of the constant environment (a white Lambertian lit by it alone has radiance 0.25).
ENVIRONMENT = 0.25


@dataclass
class Comparison:
    """The result of :func:`compare` for one scene.

    Attributes
    ----------
    scene
        Its name.
    mean_relative
        Mean over the object's blocks of ``|Y_test - Y_ref| / Y_ref``.
    relative_l1
        ``sum |Y_test - Y_ref| / sum Y_ref`` over the blocks.
    brightness_ratio
        ``sum Y_test / sum Y_ref`` over the blocks.
    mean_relative_seed2
        :attr:`mean_relative` of the pair rendered with the second seed
        (with ``noise=True``): the spread of the two is the figure's noise.
    noise_reference, noise_test
        The same mean relative difference between two renders of one
        renderer with different seeds (with ``noise=True``): each render's
        own noise, which the correlated pair largely cancels.
    blocks
        Number of blocks wholly on the object.
    images
        The renders (linear RGB) and the object mask, when asked for.
    """

    scene: str
    mean_relative: float
    relative_l1: float
    brightness_ratio: float
    blocks: int
    mean_relative_seed2: float | None = None
    noise_reference: float | None = None
    noise_test: float | None = None
    images: dict[str, NDArray[np.float32]] = field(default_factory=dict)

    def summary(self) -> dict[str, Any]:
        """The figures as a JSON-ready dict."""
        out = {"scene": self.scene, "mean_relative": round(self.mean_relative, 5),
               "relative_l1": round(self.relative_l1, 5), "brightness_ratio": round(self.brightness_ratio, 5),
               "blocks": self.blocks}
        if self.mean_relative_seed2 is not None:
            out["mean_relative_seed2"] = round(self.mean_relative_seed2, 5)
        if self.noise_reference is not None:
            out["noise_reference"] = round(self.noise_reference, 5)
        if self.noise_test is not None:
            out["noise_test"] = round(self.noise_test, 5)
        return out


def _look_at(mi: Any, origin: NDArray[np.float64], target: NDArray[np.float64], size: int, fov: float,
             spp: int) -> dict[str, Any]:
    return {
        "type": "perspective", "fov": fov, "fov_axis": "smaller",
        "to_world": mi.ScalarTransform4f().look_at(origin=origin.tolist(), target=target.tolist(), up=[0, 0, 1]),
        "film": {"type": "hdrfilm", "width": int(size), "height": int(size), "rfilter": {"type": "box"}},
        "sampler": {"type": "independent", "sample_count": int(spp)},
    }


def scene_dict(name: str, bsdf: Any, *, size: int, spp: int, folder: Path, light: tuple[float, float, float] = LIGHT,
               environment: float = ENVIRONMENT) -> dict[str, Any]:
    """The Mitsuba scene dict of one comparison scene with ``bsdf`` on the object.

    Parameters
    ----------
    name
        ``"sphere"`` (radius 1, seen from 25 degrees above the horizon) or
        ``"sheet"`` (the paper's sine sheet in mm, seen as by
        :func:`cdbrdf.render.scenes.sine_scene`).
    bsdf
        A BSDF dict or instance.
    size, spp
        Film size (square) and samples per pixel.
    folder
        Where the sheet's PLY file is written.
    light, environment
        The directional light ``(theta, phi, irradiance)`` and the environment's radiance.
    """
    import mitsuba as mi

    from ..frames import direction_from_angles
    from ..mesh import sine_sheet_mesh, write_ply
    from ..render.lighting import directional_light

    if name == "sphere":
        obj: dict[str, Any] = {"type": "sphere", "radius": 1.0, "bsdf": bsdf}
        d = direction_from_angles(65.0, -90.0)
        sensor = _look_at(mi, 4.2 * d, np.zeros(3), size, 32.0, spp)
    elif name == "sheet":
        mesh = sine_sheet_mesh()
        ply = folder / "sheet.ply"
        write_ply(ply, mesh)
        obj = {"type": "ply", "filename": str(ply), "bsdf": bsdf}
        d = direction_from_angles(50.0, -90.0)
        sensor = _look_at(mi, 120.0 * d, np.zeros(3), size, 30.0, spp)
    else:
        raise ValueError(f"scene: {name!r} is not one of {', '.join(SCENES)}")
    return {
        "type": "scene",
        # direct lighting, emitter sampling only: both renderers then draw the same camera rays and
        # light directions (same seed), so their noise is correlated and the difference is the BRDF's
        "integrator": {"type": "direct", "emitter_samples": 1, "bsdf_samples": 0},
        "sensor": sensor,
        "object": obj,
        "light": directional_light(*light),
        "environment": {"type": "constant", "radiance": {"type": "rgb", "value": float(environment)}},
    }


def block_difference(test: NDArray[np.floating], ref: NDArray[np.floating], mask: NDArray[np.bool_],
                     block: int = 4) -> tuple[float, float, float, int]:
    """``(mean relative, relative L1, brightness ratio, blocks)`` of luminance over blocks wholly in ``mask``."""
    h, w = mask.shape
    hb, wb = h // block, w // block

    def blocks(a: NDArray[np.floating]) -> NDArray[np.float64]:
        a = np.asarray(a, dtype=np.float64)[: hb * block, : wb * block]
        return a.reshape(hb, block, wb, block, *a.shape[2:]).mean(axis=(1, 3))

    inside = blocks(mask.astype(np.float64)) == 1.0
    yt = blocks(luminance(np.asarray(test)[..., :3]))[inside]
    yr = blocks(luminance(np.asarray(ref)[..., :3]))[inside]
    if yr.size == 0:
        return math.nan, math.nan, math.nan, 0
    ok = yr > 0
    mean_rel = float(np.mean(np.abs(yt[ok] - yr[ok]) / yr[ok]))
    return mean_rel, float(np.sum(np.abs(yt - yr)) / np.sum(yr)), float(np.sum(yt) / np.sum(yr)), int(yr.size)


def _render(scene: Any, spp: int, seed: int) -> NDArray[np.float32]:
    from ..render.picture import render_scene

    return render_scene(scene, spp=spp, seed=seed, passes=max(1, spp // 256))


def _mask(name: str, size: int, folder: Path) -> NDArray[np.bool_]:
    import mitsuba as mi

    d = scene_dict(name, {"type": "diffuse"}, size=size, spp=1, folder=folder)
    d["integrator"] = {"type": "aov", "aovs": "dd.y:depth"}
    img = np.asarray(mi.render(mi.load_dict(d), spp=1))
    return img[..., 0] > 0.0


def compare(
    table: Any,
    reference: str | PathLike[str] | Mapping[str, Any],
    *,
    scenes: tuple[str, ...] = SCENES,
    size: int = 256,
    spp: int = 1024,
    block: int = 4,
    seed: int = 0,
    noise: bool = False,
    keep_images: bool = False,
    progress: Callable[[int, int], None] | None = None,
) -> list[Comparison]:
    """Render ``scenes`` with the reference BSDF and with the plug-in on ``table``; compare (module docstring).

    Parameters
    ----------
    table
        The imported table (a CDBRDF; its first curvature is used everywhere).
    reference
        An RGL ``.bsdf`` file (rendered with Mitsuba's ``measured``) or a BSDF dict.
    scenes
        Names from :data:`SCENES`.
    size, spp, block
        Film size, samples per pixel, block size in pixels.
    seed
        Seed of the first renders (the noise renders use ``seed + 1``).
    noise
        Also render each scene again with another seed and report the noise floors.
    keep_images
        Keep the renders and masks in :attr:`Comparison.images`.
    progress
        ``progress(done, total)`` over the renders.

    Returns
    -------
    list of Comparison
    """
    from ..render import variant

    with variant("llvm_ad_rgb"):
        return _compare(table, reference, scenes=scenes, size=size, spp=spp, seed=seed, block=block, noise=noise,
                        keep_images=keep_images, progress=progress)


def _compare(table: Any, reference: Any, *, scenes: tuple[str, ...], size: int, spp: int, seed: int, block: int,
             noise: bool, keep_images: bool, progress: Callable[[int, int], None] | None) -> list[Comparison]:
    """:func:`compare` in the variant it set."""
    import mitsuba as mi

    from ..render import load_dict

    if isinstance(reference, Mapping):
        ref_bsdf: Any = dict(reference)
    else:
        ref_bsdf = {"type": "measured", "filename": str(Path(reference))}
    test_bsdf = {"type": "cdbrdf", "table": table, "mode": "cdbrdf", "curvature": float(table.kappa[0])}
    out = []
    total = len(scenes) * (4 if noise else 2)
    done = 0
    with tempfile.TemporaryDirectory(prefix="cdbrdf-compare-") as tmp:
        folder = Path(tmp)
        for name in scenes:
            mask = _mask(name, size, folder)
            ref_scene = mi.load_dict(scene_dict(name, ref_bsdf, size=size, spp=spp, folder=folder))
            test_scene = load_dict(scene_dict(name, test_bsdf, size=size, spp=spp, folder=folder))
            imgs = {}
            for key, sc, sd in (("reference", ref_scene, seed), ("test", test_scene, seed)) + (
                    (("reference_2", ref_scene, seed + 1), ("test_2", test_scene, seed + 1)) if noise else ()):
                imgs[key] = _render(sc, spp, sd)
                done += 1
                if progress is not None:
                    progress(done, total)
            m, l1, ratio, nb = block_difference(imgs["test"], imgs["reference"], mask, block)
            c = Comparison(scene=name, mean_relative=m, relative_l1=l1, brightness_ratio=ratio, blocks=nb)
            if noise:
                c.mean_relative_seed2 = block_difference(imgs["test_2"], imgs["reference_2"], mask, block)[0]
                c.noise_reference = block_difference(imgs["reference_2"], imgs["reference"], mask, block)[0]
                c.noise_test = block_difference(imgs["test_2"], imgs["test"], mask, block)[0]
            if keep_images:
                c.images = {**imgs, "mask": mask.astype(np.float32)}
            out.append(c)
    return out
