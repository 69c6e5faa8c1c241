"""Tangent-space normal maps read as data: the normals of a surface's fine detail.

Garments from fashion CAD tools and scanned fabrics carry their fine folds
in a normal map, not in the mesh. A tangent-space normal ``(a, b, c)`` (in
the frame of dP/du, dP/dv and the normal; ``c > 0``) is the normal of a
height field ``h`` over the surface with slopes ``dh/dx = -a / c`` and
``dh/dy = -b / c`` (``x``, ``y``: arc length along dP/du and dP/dv, mm); its
curvature, the derivative of the normal along the surface, is baked per
texel by :func:`cdbrdf.mesh.bake.bake_normal_map` and looked up per shading
point by the renderer (:mod:`cdbrdf.mesh.curvature_map`, :mod:`cdbrdf.mesh.maps`).

The texel values are decoded as data (``2 code / max - 1``), never as sRGB;
``convention`` ``"opengl"`` (+v up, green up: Blender, glTF) or
``"directx"`` (green down). Texels steeper than ``c = 0.1`` (84 degrees) are
clipped there.
"""

from __future__ import annotations

from dataclasses import dataclass
from os import PathLike
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import MeshError

if TYPE_CHECKING:
    from ..images import ImageInfo

__all__ = ["NORMAL_MAP_CONVENTIONS", "NormalMap", "read_normal_map", "normal_map_from_image",
           "normal_map_from_normals", "unusable_map"]

#: Green-channel conventions of tangent-space normal maps: +v up (OpenGL, Blender, glTF) or down (DirectX).
NORMAL_MAP_CONVENTIONS: tuple[str, ...] = ("opengl", "directx")

#: Smallest ``c`` (the normal's component along the surface normal) accepted: steeper texels are clipped.
_MIN_NZ = 0.1


@dataclass(frozen=True)
class NormalMap:
    """A tangent-space normal map.

    Parameters
    ----------
    normals
        ``(H, W, 3)`` unit normals, row 0 at the top (v = 1).
    name
        What to call it in messages (its file).
    """

    normals: NDArray[np.float64]
    name: str = "normal map"


def normal_map_from_normals(normals: ArrayLike, *, convention: str = "opengl", name: str = "normal map") -> NormalMap:
    """A :class:`NormalMap` from ``(H, W, 3)`` tangent-space normals (any length; normalised).

    Parameters
    ----------
    normals
        ``(H, W, 3)`` (or more channels: the first three) normals, row 0 at v = 1.
    convention
        ``"opengl"`` (green up) or ``"directx"`` (green down: turned to up).
    name
        What to call it in messages.

    Returns
    -------
    NormalMap
        Unit normals, OpenGL convention, ``c`` clipped at 0.1.
    """
    if convention not in NORMAL_MAP_CONVENTIONS:
        raise MeshError(f"normal map convention: {convention!r} is not one of {', '.join(NORMAL_MAP_CONVENTIONS)}")
    n = np.array(normals, dtype=np.float64)
    if n.ndim != 3 or n.shape[2] < 3 or n.shape[0] < 2 or n.shape[1] < 2:
        raise MeshError(f"{name}: expected an RGB image of at least 2 x 2 texels, got shape {n.shape}")
    n = n[..., :3]
    if not np.isfinite(n).all():
        raise MeshError(f"{name}: has NaN or infinite texels")
    if convention == "directx":
        n[..., 1] = -n[..., 1]
    n[..., 2] = np.maximum(n[..., 2], _MIN_NZ)
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    return NormalMap(n, name)


def read_normal_map(path: str | PathLike[str], *, convention: str = "opengl") -> NormalMap:
    """Read a tangent-space normal map (PNG or TIFF 8/16 bit, float TIFF or OpenEXR) as data.

    Integer codes are decoded as ``2 code / max - 1`` (not as sRGB); float
    images hold the components directly.

    Parameters
    ----------
    path
        The image file.
    convention
        ``"opengl"`` (+y up, Blender, glTF) or ``"directx"`` (+y down), one
        of :data:`NORMAL_MAP_CONVENTIONS`.

    Returns
    -------
    NormalMap
        The unit normals.

    Raises
    ------
    MeshError
        For an image that is not RGB or a convention not in
        :data:`NORMAL_MAP_CONVENTIONS`; :class:`~cdbrdf.errors.ImageError`
        for a damaged file.
    """
    from ..images import read_image

    px, info = read_image(path)
    return normal_map_from_image(px, info, convention=convention, name=str(path))


def normal_map_from_image(px: NDArray[Any], info: ImageInfo, *, convention: str = "opengl",
                          name: str = "normal map") -> NormalMap:
    """A normal map from decoded image codes (:func:`cdbrdf.images.read_image`, :func:`~cdbrdf.images.decode_image`):
    integer codes as ``2 code / max - 1``, floats as they are (:func:`read_normal_map`'s rule)."""
    if px.ndim != 3 or px.shape[2] < 3:
        got = px.shape[2] if px.ndim == 3 else 1
        raise MeshError(f"{name}: a normal map must be an RGB image, got {got} channel(s)")
    v = px[..., :3].astype(np.float64)
    if info.max_code is not None:
        v = 2.0 * v / float(info.max_code) - 1.0
    return normal_map_from_normals(v, convention=convention, name=name)


def unusable_map(notes: list[str], msg: str) -> None:
    """A map that a mesh file names but that cannot be used: one warning (logged) and one note of the mesh.

    ``msg`` names the mesh (or its material library), the map and why; what is done instead is added.
    A map the user names (``--normal-map``) is an error instead, raised by its reader.
    """
    import logging

    msg = " ".join(msg.split()) + ": not used, the mesh is shaded without it"
    logging.getLogger("cdbrdf.mesh.maps").warning("%s", msg)
    notes.append(msg)
