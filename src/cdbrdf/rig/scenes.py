"""The rig's Mitsuba 3 scenes: a stand with the fabric on it, or the white reference plate.

A scene holds one stand (or the white plate) and a row of orthographic
cameras (:func:`~cdbrdf.rig.camera.camera_row`), one per view direction of
the photographs it makes, side by side on one film: one ``mi.render``
photographs the stand from every view under one light. The light is then moved through
:func:`mitsuba.traverse` (``light.to_world``; :mod:`cdbrdf.rig.camera`)
between renders, so the traced kernels are reused. The ``direct`` integrator traces shadow rays, so on a concave stand
the walls and the trough shadow the centre at grazing light, and at grazing
views the camera sees the trough or a wall instead of the centre: the
paper's artefact appears by itself. The functions take the :mod:`mitsuba`
and :mod:`cdbrdf.render` modules as arguments (imported, with the variant
set, by the caller), so importing this module loads neither.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..btf import CDBTF
from ..measure.stands import Stand
from ..table import CDBRDF
from .camera import camera_row
from .stands import stand_meshes

__all__ = ["STAND_REFLECTANCE", "stand_scene", "white_scene"]

#: Diffuse reflectance of the white stand body.
STAND_REFLECTANCE = 0.8


def _mi_mesh(mi, name: str, m: dict[str, NDArray], bsdf: Any):  # noqa: ANN001, ANN202
    """A Mitsuba mesh of a part of :func:`~cdbrdf.rig.stands.stand_meshes`, with ``bsdf``."""
    from ..mesh import Mesh
    from ..render.scenes import mitsuba_mesh

    part = Mesh(np.asarray(m["positions"], dtype=np.float64), np.asarray(m["faces"], dtype=np.int64),
                normals=np.asarray(m["normals"], dtype=np.float64), uv=np.asarray(m["uv"], dtype=np.float64))
    return mitsuba_mesh(part, bsdf=bsdf, name=name)


def _scene(mi, cr, parts: dict[str, Any], *, views: Sequence[NDArray], size: int, field_mm: float,  # noqa: ANN001, ANN202
           spp: int):
    """The rig's scene with ``parts`` (shapes by name): the ``direct`` integrator, the cameras, the light.

    ``views``: unit view directions; camera ``i`` fills columns
    ``i * size .. (i + 1) * size`` of the film.
    """
    d = {
        "type": "scene",
        "integrator": {"type": "direct", "emitter_samples": 1, "bsdf_samples": 0},
        "sensor": camera_row(mi, views, size=size, field_mm=field_mm, spp=spp),
        "light": {"type": "directional", "direction": [0.0, 0.0, -1.0],
                  "irradiance": {"type": "rgb", "value": 1.0}},
    }
    d.update(parts)
    return cr.load_dict(d)


def stand_scene(mi, cr, table: CDBRDF | CDBTF, stand: Stand, *,  # noqa: ANN001, ANN201
                origin_uv_mm: tuple[float, float] = (0.0, 0.0), **kw: Any):
    """The scene of a stand: the fabric (the ``cdbrdf`` BSDF at its curvature), the white body.

    ``mi`` is :mod:`mitsuba`, ``cr`` :mod:`cdbrdf.render` (variant set);
    ``kw``: ``views`` (unit view directions, one camera each), ``size``,
    ``field_mm``, ``spp``. The fabric's UVs are its ``(u, v)`` in mm: arc
    length along x and length along y from the stand's centre, plus
    ``origin_uv_mm`` (the registration, :mod:`cdbrdf.measure.registration`),
    which a CD-BTF reads (periodic over its repeat).
    """
    # a CD-BTF: the exact bilinear texel filter (the stochastic default adds a texel-choice noise per sample)
    extra = {"texel_filter": "bilinear"} if isinstance(table, CDBTF) else {}
    fabric = cr.make_bsdf(table, mode="cdbrdf", curvature=float(stand.kappa), **extra)
    white = mi.load_dict({"type": "twosided", "bsdf": {"type": "diffuse", "reflectance": {
        "type": "rgb", "value": STAND_REFLECTANCE}}})
    parts = {}
    for name, m in stand_meshes(stand).items():
        if name == "fabric":  # u, v in [0, 1] across the face's arc and along the axis, linear in length
            uv = np.asarray(m["uv"], dtype=np.float64)
            m = {**m, "uv": np.stack([origin_uv_mm[0] + (uv[:, 0] - 0.5) * stand.face_width_mm,
                                      origin_uv_mm[1] + (uv[:, 1] - 0.5) * stand.length_mm], axis=-1)}
        parts[name] = _mi_mesh(mi, name, m, fabric if name == "fabric" else white)
    return _scene(mi, cr, parts, **kw)


def white_scene(mi, cr, albedo: float, **kw: Any):  # noqa: ANN001, ANN201
    """The scene of the white reference: a Lambertian plate of ``albedo`` (arguments as :func:`stand_scene`)."""
    plate = {"type": "rectangle", "to_world": mi.ScalarTransform4f().scale([30.0, 30.0, 1.0]),
             "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": float(albedo)}}}
    return _scene(mi, cr, {"plate": plate}, **kw)
