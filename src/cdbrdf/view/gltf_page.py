"""The browser renderer of a glTF export (``cdbrdf view x.glb``): the page's files, the asset and its view.

:func:`gltf_viewer_files` builds, in memory, the files the local server
(:class:`cdbrdf.view.server.ViewerServer`) serves or ``--export`` writes:

- ``index.html`` and ``renderer.js``: the renderer, a three.js page with the
  ``CDBRDF_materials_curvature_brdf`` plugin for three's ``GLTFLoader``
  (``js/src/`` in the repository, bundled with three.js by ``js/build.mjs``
  into ``view/assets/gltf/``: no network at run time);
- ``lookup.js``: the GLSL lookup, shared with the viewer;
- ``plain.html`` and ``three-plain.js``: the same asset in a plain three.js
  page (GLTFLoader without the plugin): the fallback material every viewer shows;
- ``data.js``: ``window.CDBRDF_GLTF_DATA``, the asset in base64 and the
  view's options (:func:`view_options`), so that the pages open from ``file://``.
"""

from __future__ import annotations

import base64
import json
import math
from collections.abc import Mapping
from importlib import resources
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..errors import OptionError

__all__ = ["GLTF_PAGE_FILES", "BUNDLE_FILES", "bundle_missing", "view_options", "gltf_viewer_files", "glb_positions"]

#: Files of the pages: package data (``view/assets``) -> name served.
GLTF_PAGE_FILES: Mapping[str, str] = {"gltf.html": "index.html", "plain.html": "plain.html", "lookup.js": "lookup.js"}

#: The built bundles (``view/assets/gltf``, made by ``js/build.mjs``) -> name served.
BUNDLE_FILES: Mapping[str, str] = {"renderer.js": "renderer.js", "three-plain.js": "three-plain.js"}


def bundle_missing() -> list[str]:
    """The built bundles that are missing (none once ``scripts/setup.sh`` has built them).

    Returns
    -------
    list of str
        Their names.
    """
    pkg = resources.files("cdbrdf.view") / "assets" / "gltf"
    return [name for name in BUNDLE_FILES if not (pkg / name).is_file()]


def glb_positions(glb: bytes) -> NDArray[np.float64]:
    """The positions of every mesh primitive of a GLB written by ``cdbrdf export`` (glTF frame, metres).

    Parameters
    ----------
    glb
        The file's bytes.

    Returns
    -------
    numpy.ndarray
        ``(n, 3)`` positions.
    """
    import warnings

    from pygltflib import GLTF2

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        doc = GLTF2.load_from_bytes(glb)
    blob = doc.binary_blob()
    out = []
    for m in doc.meshes or []:
        for p in m.primitives:
            acc = doc.accessors[p.attributes.POSITION]
            bv = doc.bufferViews[acc.bufferView]
            start = int(bv.byteOffset or 0) + int(acc.byteOffset or 0)
            out.append(np.frombuffer(blob, "<f4", acc.count * 3, start).reshape(-1, 3).astype(np.float64))
    return np.concatenate(out) if out else np.zeros((0, 3))


def view_options(glb: bytes, *, size: tuple[int, int] = (960, 600), view: tuple[float, float] | None = None,
                 fov_deg: float | None = None) -> dict[str, Any]:
    """The renderer's first view of an asset, as ``cdbrdf render`` frames and lights a mesh.

    The camera frames the mesh as :func:`cdbrdf.render.camera.frame_camera`
    does (view elevation and azimuth of :data:`~cdbrdf.render.camera.DEFAULT_MESH_VIEW`,
    a 30-degree lens along the picture's smaller side); the key light and the
    sky are the studio's (:mod:`cdbrdf.render.lighting`), the exposure the grey card's.

    Parameters
    ----------
    glb
        The asset.
    size
        The canvas, pixels.
    view
        ``(elevation_deg, azimuth_deg)`` of the camera (default: the mesh default).
    fov_deg
        The lens's field of view (default 30 degrees).

    Returns
    -------
    dict
        ``camera`` (``position``, ``target``, ``up`` in glTF's frame, metres;
        ``fov_deg``), ``light`` (theta, phi in the z-up world, irradiance),
        ``sky``, ``exposure_ev``, ``width``, ``height``.
    """
    from ..colour import card_exposure_ev
    from ..render.camera import DEFAULT_MESH_FOV_DEG, DEFAULT_MESH_VIEW, FRAME_FILL, frame_camera
    from ..render.lighting import DEFAULT_IRRADIANCE, STUDIO_KEY, STUDIO_SKY, card_irradiance, studio_environment

    elev, azim = view if view is not None else DEFAULT_MESH_VIEW
    fov = float(fov_deg if fov_deg is not None else DEFAULT_MESH_FOV_DEG)
    p = glb_positions(glb)
    if p.shape[0] == 0:
        raise OptionError("the asset has no mesh to show")
    world = np.stack([p[:, 0], -p[:, 2], p[:, 1]], axis=1)  # glTF (x, y, z) -> z-up (x, -z, y)
    origin, target, _ = frame_camera(world, width=size[0], height=size[1], elevation_deg=elev, azimuth_deg=azim,
                                     fov_deg=fov, fill=FRAME_FILL)

    def gl(v: NDArray[np.float64]) -> list[float]:
        return [float(v[0]), float(v[2]), float(-v[1])]

    light = (STUDIO_KEY[0], azim + STUDIO_KEY[1], DEFAULT_IRRADIANCE)
    ev = card_exposure_ev(card_irradiance(light, studio_environment()))
    return {"camera": {"position": gl(origin), "target": gl(target), "up": [0.0, 1.0, 0.0], "fov_deg": fov},
            "light": [float(x) for x in light], "sky": [float(x) for x in STUDIO_SKY],
            "exposure_ev": float(ev) if math.isfinite(ev) else 0.0, "width": int(size[0]), "height": int(size[1])}


def gltf_viewer_files(glb: bytes, *, name: str, options: Mapping[str, Any] | None = None) -> dict[str, bytes]:
    """Every file of the glTF renderer's pages, by relative path (see the module's description).

    Parameters
    ----------
    glb
        The asset (binary glTF).
    name
        Its name, shown by the page.
    options
        The view (:func:`view_options`; default: computed).

    Returns
    -------
    dict
        The files' bytes.

    Raises
    ------
    OptionError
        When the renderer's bundle is not built (``scripts/setup.sh`` builds it with npm).
    """
    missing = bundle_missing()
    if missing:
        raise OptionError(f"the glTF renderer is not built ({', '.join(missing)} missing): run scripts/setup.sh, "
                          "which builds it with node and npm (js/, npm ci && npm run build)")
    pkg = resources.files("cdbrdf.view") / "assets"
    files = {dst: (pkg / src).read_bytes() for src, dst in GLTF_PAGE_FILES.items()}
    files.update({dst: (pkg / "gltf" / src).read_bytes() for src, dst in BUNDLE_FILES.items()})
    data = {"name": str(name), "glb": base64.b64encode(glb).decode("ascii"),
            "options": dict(options) if options is not None else view_options(glb)}
    files["data.js"] = ("window.CDBRDF_GLTF_DATA = " + json.dumps(data, separators=(",", ":"), allow_nan=False)
                        + ";\n").encode("ascii")
    return files
