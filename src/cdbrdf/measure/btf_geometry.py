"""measure --btf's geometry: which pixels of a photograph see the footprint, their texel weights, hidden samples.

:func:`view_geometry` maps a view's photograph onto the texels (the
least-squares system of :mod:`cdbrdf.measure.btf`, factored once per view);
:func:`btf_hidden` marks the samples a stand hides from some point of the
footprint or sees at a grazing angle.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..errors import CaptureError
from ..frames import direction_from_angles
from ..images import ImageError
from .capture import Capture
from .registration import face_hits, face_points, image_axes
from .stands import Stand, stand_for

__all__ = ["ViewGeometry", "view_geometry", "btf_hidden", "SUBPIXELS", "GRAZING_COS"]

#: Rays per pixel side traced to the stand to model a pixel (its footprint's average).
SUBPIXELS = 3
#: A sample is hidden when its view or light has a cosine below this at some point of the footprint.
GRAZING_COS = 0.1


@dataclass(frozen=True)
class ViewGeometry:
    """How one view's photographs map to the texels (:func:`view_geometry`).

    Attributes
    ----------
    window
        ``(x0, y0, nx, ny)``: the pixels read.
    pick
        Flat indices, into the window, of the pixels used.
    normals
        ``(n_pixels, 3)``: the face's mean normal over each pixel.
    design
        ``(n_pixels, n_texels)`` sparse: each pixel's texel weights.
    factor
        The Cholesky factor of ``design^T design`` (:func:`scipy.linalg.cho_factor`).
    """

    window: tuple[int, int, int, int]
    pick: NDArray[np.intp]
    normals: NDArray[np.float64]
    design: Any
    factor: Any

    def texels(self, pixels: NDArray[np.float64]) -> NDArray[np.float64]:
        """The texels ``(n_texels, C)`` that best explain ``pixels`` ``(n_pixels, C)`` (least squares)."""
        from scipy.linalg import cho_solve

        return cho_solve(self.factor, self.design.T @ pixels)


def _bilinear(u: NDArray, v: NDArray, texels: tuple[int, int], repeat_mm: tuple[float, float]
              ) -> tuple[NDArray[np.intp], NDArray[np.float64]]:
    """Texel indices ``j * n_u + i`` and weights ``(m, 4)`` of the periodic bilinear rule at ``(u, v)`` mm."""
    (nu, nv), (su, sv) = texels, repeat_mm
    fu = np.mod(u, su) / su * nu - 0.5
    fv = np.mod(v, sv) / sv * nv - 0.5
    iu, iv = np.floor(fu), np.floor(fv)
    tu, tv = fu - iu, fv - iv
    i0, j0 = iu.astype(np.intp) % nu, iv.astype(np.intp) % nv
    i1, j1 = (i0 + 1) % nu, (j0 + 1) % nv
    idx = np.stack([j0 * nu + i0, j0 * nu + i1, j1 * nu + i0, j1 * nu + i1], axis=-1)
    w = np.stack([(1 - tu) * (1 - tv), tu * (1 - tv), (1 - tu) * tv, tu * tv], axis=-1)
    return idx, w


def _half_extent(repeat_mm: tuple[float, float], repeats: int) -> tuple[float, float]:
    return 0.5 * repeats * repeat_mm[0], 0.5 * repeats * repeat_mm[1]


def view_geometry(stand: Stand, origin_uv_mm: tuple[float, float], view: NDArray, *, width: int, height: int,
                  cx: int | None, cy: int | None, pixel_mm: float, texels: tuple[int, int],
                  repeat_mm: tuple[float, float], repeats: int = 1, sub: int = SUBPIXELS) -> ViewGeometry:
    """The pixels of a photograph that see the footprint, and their texel weights.

    The footprint is ``repeats x repeats`` repeats centred on the stand's
    centre (arc length ``|s| <= repeats * size_u / 2``, ``|y| <= repeats *
    size_v / 2``); a pixel is used when all its ``sub x sub`` rays meet the
    face inside it.

    Raises
    ------
    ImageError
        When the footprint does not lie inside the image.
    CaptureError
        When the pixels do not resolve every texel (too coarse a pixel).
    """
    from scipy import sparse
    from scipy.linalg import LinAlgError, cho_factor

    v = np.asarray(view, dtype=np.float64)
    right, down = image_axes(v)
    cx = width // 2 if cx is None else int(cx)
    cy = height // 2 if cy is None else int(cy)
    hu, hv = _half_extent(repeat_mm, repeats)
    s = np.linspace(-hu, hu, 33)
    corners, _n = face_points(stand, np.concatenate([s, s]), np.concatenate([np.full(33, -hv), np.full(33, hv)]))
    col = cx + corners @ right / pixel_mm
    row = cy + corners @ down / pixel_mm
    x0, x1 = int(math.floor(col.min())) - 1, int(math.ceil(col.max())) + 1
    y0, y1 = int(math.floor(row.min())) - 1, int(math.ceil(row.max())) + 1
    if x0 < 0 or y0 < 0 or x1 >= width or y1 >= height:
        raise ImageError(f"the footprint of {repeats} repeat(s) (pixels x {x0}..{x1}, y {y0}..{y1}) does not "
                         f"lie inside the {width} x {height} image: widen the camera's field")
    nx, ny = x1 - x0 + 1, y1 - y0 + 1
    off = (np.arange(sub) + 0.5) / sub - 0.5
    gy, gx, oy, ox = np.meshgrid(np.arange(y0, y1 + 1), np.arange(x0, x1 + 1), off, off, indexing="ij")
    px = ((gx + ox - cx) * pixel_mm)[..., None] * right + ((gy + oy - cy) * pixel_mm)[..., None] * down
    p, n, _t, s_mm = face_hits(stand, px.reshape(-1, 3), v)
    inside = (np.abs(s_mm) <= hu) & (np.abs(p[:, 1]) <= hv) & (n @ v > 0.0)
    inside = inside.reshape(ny * nx, sub * sub).all(axis=1)
    pick = np.flatnonzero(inside)
    m = sub * sub
    u = origin_uv_mm[0] + s_mm.reshape(ny * nx, m)[pick]
    w_ = origin_uv_mm[1] + p[:, 1].reshape(ny * nx, m)[pick]
    idx, w = _bilinear(u.reshape(-1), w_.reshape(-1), texels, repeat_mm)
    nt = texels[0] * texels[1]
    rows = np.repeat(np.arange(pick.size), m * 4)
    design = sparse.csr_matrix((w.reshape(-1) / m, (rows, idx.reshape(-1))), shape=(pick.size, nt))
    gram = (design.T @ design).toarray()
    lam = np.linalg.eigvalsh(gram) if nt <= 2048 else np.array([1.0])
    if pick.size < nt or lam[0] <= 1e-6 * lam[-1]:
        tv = math.degrees(math.acos(min(1.0, abs(float(v[2])))))
        raise CaptureError(f"the photographs at theta_v = {tv:.0f} degrees ({pixel_mm:g} mm per pixel, foreshortened "
                           f"by cos(theta_v)) do not resolve {texels[0]} x {texels[1]} texels of a {repeat_mm[0]:g} x "
                           f"{repeat_mm[1]:g} mm repeat: use fewer texels or a finer camera (pixels per texel x "
                           "cos(theta_v) >= about 1.5)")
    try:
        factor = cho_factor(gram)
    except LinAlgError:
        raise CaptureError(f"the photographs ({pixel_mm:g} mm per pixel) do not resolve the texels") from None
    normals = n.reshape(ny * nx, m, 3)[pick].mean(axis=1)
    return ViewGeometry((x0, y0, nx, ny), pick, normals, design, factor)


def btf_hidden(cap: Capture, repeat_mm: tuple[float, float], *, repeats: int = 1) -> NDArray[np.bool_]:
    """The samples whose footprint a stand hides from the camera or the light, or sees at a grazing angle.

    Returns
    -------
    numpy.ndarray
        ``grid.shape`` booleans (the capture's own hidden marks included).
    """
    g = cap.grid
    hu, _hv = _half_extent(repeat_mm, repeats)
    pixel = float(cap.settings.get("pixel_mm", 0.0))
    out = np.array(cap.hidden, dtype=bool, copy=True)
    for k, kappa in enumerate(g.kappa):
        st = stand_for(cap.stands or {}, float(kappa))
        m = hu + pixel
        view = st.hides(g.theta_v[None, :], g.phi_v[:, None], margin_mm=m)  # (phi_v, theta_v)
        light = st.hides(g.theta_l[None, :], g.phi_l[:, None], margin_mm=m)  # (phi_l, theta_l)
        if st.kappa != 0:  # the normal turns by hu / R at the footprint's edges
            for sign in (-1.0, 1.0):
                _p, nrm = face_points(st, np.array(sign * hu), np.array(0.0))
                view |= direction_from_angles(g.theta_v[None, :], g.phi_v[:, None]) @ nrm < GRAZING_COS
                light |= direction_from_angles(g.theta_l[None, :], g.phi_l[:, None]) @ nrm < GRAZING_COS
        else:
            view |= np.cos(np.radians(g.theta_v))[None, :] < GRAZING_COS
            light |= np.cos(np.radians(g.theta_l))[None, :] < GRAZING_COS
        out[k] |= view[None, None, :, :] | light[:, :, None, None]
    return out


