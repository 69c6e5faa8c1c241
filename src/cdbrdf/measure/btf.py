"""Measuring a CD-BTF: every photograph rectified onto the fabric's texels instead of averaged.

:func:`measure_btf` (``cdbrdf measure FOLDER --btf N``, ``measure(..., btf=N)``)
reads a capture folder whose ``stands.json`` has a ``registration``
(:mod:`cdbrdf.measure.registration`: the camera model and the fabric's
``(u, v)`` at each stand's centre) and gives a :class:`~cdbrdf.CDBTF` of
``n_u x n_v`` texels per repeat. Per view (stand, view direction) it maps the
photograph's pixels back to the fabric (:func:`view_geometry`): each pixel of
the camera's footprint of ``repeats x repeats`` weave repeats around the
stand's centre is traced (``SUBPIXELS x SUBPIXELS`` rays) to the stand's
cylinder, and its value is modelled as the texels' periodic bilinear
interpolation (the CD-BTF's own rule, :meth:`cdbrdf.CDBTF.evaluate`) averaged
over the pixel. The texels are the least-squares solution over every pixel
of the footprint (every repeat it holds counts); the cosine of the light is
taken at each pixel's own normal. Then, per texel, exactly what the CDBRDF
path does per patch (:mod:`cdbrdf.measure.calibrate`): brackets merged
pixel by pixel (saturated pixels excluded; a pixel saturated in every
exposure invalidates the sample), the dark frame subtracted, the white
reference's scale, and the invalid samples filled by the same
:func:`cdbrdf.measure.fill.fill` with texels x channels as its channels.

Hidden samples are those the stands hide from any point of the footprint
(:meth:`~cdbrdf.measure.stands.Stand.hides` at a margin of the footprint's
half width), plus those whose view or light is within
:data:`GRAZING_COS` of the face's horizon somewhere on the footprint (a
convex stand turns the normal by ``repeat / 2R`` at its edge).
"""

from __future__ import annotations

import contextlib
import logging
import math
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from os import PathLike
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..btf import CDBTF
from ..errors import CaptureError, OptionError, TableError
from ..frames import direction_from_angles
from ..fsutil import check_output_file
from ..images import ImageError, ImageInfo, read_window
from ..outputs import output_lock
from .calibrate import MeasureReport, _nearest_white, calibration
from .capture import Capture, CaptureRow, read_capture
from .fill import DEFAULT_FILL, check_fill_method, fill
from .patch import decode_codes, merge_exposures
from .preflight import read_patch_status
from .registration import Registration, face_hits, face_points, image_axes
from .stands import Stand, stand_for

__all__ = ["measure_btf", "BTFReport", "ViewGeometry", "view_geometry", "btf_hidden", "texel_count",
           "SUBPIXELS", "GRAZING_COS", "MIN_PX_PER_TEXEL", "MAX_TEXELS", "DEFAULT_BTF_ERROR"]

_LOG = logging.getLogger(__name__)

#: Rays per pixel side traced to the stand to model a pixel (its footprint's average).
SUBPIXELS = 3
#: A sample is hidden when its view or light has a cosine below this at some point of the footprint.
GRAZING_COS = 0.1
#: Fewest pixels per texel (along the texel's shorter side, at the view along the normal) accepted.
MIN_PX_PER_TEXEL = 1.5
#: Most texels along a side of the repeat.
MAX_TEXELS = 256
#: The compression's target relative RMS error of the measured CD-BTF (:meth:`cdbrdf.CDBTF.from_values`).
DEFAULT_BTF_ERROR = 0.01
#: Sample conditions read per batch (bounds the memory of the photographs' footprints).
_CONDITIONS_PER_BATCH = 256
#: Texel-channels filled at once (bounds the float64 copies of :func:`~cdbrdf.measure.fill.fill`).
_FILL_CHANNELS = 192


def texel_count(texels: object) -> tuple[int, int]:
    """``(n_u, n_v)`` of a ``texels`` option: an integer or two, each in [1, :data:`MAX_TEXELS`].

    Raises
    ------
    OptionError
        Otherwise (one line).
    """
    t = (texels, texels) if isinstance(texels, (int, np.integer)) and not isinstance(texels, bool) else texels
    try:
        vals: tuple[Any, ...] = tuple(t)  # type: ignore[arg-type]
    except TypeError:
        vals = ()
    ok = len(vals) == 2 and all(isinstance(x, (int, np.integer)) and not isinstance(x, bool)
                                and 1 <= x <= MAX_TEXELS for x in vals)
    if not ok:
        raise OptionError(f"btf: expected a number of texels per repeat side (or two), 1 to {MAX_TEXELS}, "
                          f"got {texels!r:.40}")
    return int(vals[0]), int(vals[1])


@dataclass
class BTFReport(MeasureReport):
    """What :func:`measure_btf` did: :class:`~cdbrdf.measure.calibrate.MeasureReport` plus the texels.

    Attributes
    ----------
    texels
        ``(n_u, n_v)``.
    repeat_mm
        The repeat, mm.
    px_per_texel
        Pixels per texel (shorter side) of the photographs, at the view along the normal.
    measured
        ``grid.shape`` booleans: the samples measured (not filled).
    compression
        The CD-BTF's :attr:`~cdbrdf.CDBTF.compression`.
    seconds
        Wall time of the measurement, s.
    """

    texels: tuple[int, int] = (0, 0)
    repeat_mm: tuple[float, float] = (0.0, 0.0)
    px_per_texel: float = 0.0
    measured: NDArray[np.bool_] | None = None
    compression: dict[str, Any] = field(default_factory=dict)
    seconds: float = 0.0

    def summary(self) -> str:
        """The report as text (the CDBRDF report plus a line on the texels)."""
        err = self.compression.get("relative_rms_error")
        return super().summary() + (
            f"\nCD-BTF: {self.texels[0]} x {self.texels[1]} texels per repeat of {self.repeat_mm[0]:g} x "
            f"{self.repeat_mm[1]:g} mm, {self.px_per_texel:.2f} px per texel, rank "
            f"{self.compression.get('rank', '?')}, compression error "
            f"{'?' if err is None else f'{100 * err:.2f} %'}; {self.seconds:.1f} s")


# --------------------------------------------------------------------------- geometry
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


# --------------------------------------------------------------------------- reading
def _origin(reg: Registration, r: CaptureRow) -> tuple[float, float]:
    """The fabric's (u, v) at the stand's centre in the photograph of row ``r`` (its own, else its stand's)."""
    return r.uv_mm if r.uv_mm is not None else (reg.origin(r.kappa) or (0.0, 0.0))


def _condition(cap: Capture, reg: Registration, idx: list[int], got: dict[int, tuple], darks: dict[float, NDArray],
               texels: tuple[int, int], repeat: tuple[float, float]) -> tuple[str, NDArray | None, int]:
    """The texels ``(n_texels, C)`` of one sample condition from its photographs: ``(status, texels, used)``.

    The rows of one fabric position (``u_mm``, ``v_mm``; else the stand's
    registration) are brackets, merged pixel by pixel; each position gives
    every texel, and each texel is taken at the stand's crest from the
    positions that have it nearest on either side (:func:`_at_the_crest`). Status ``"ok"``,
    ``"saturated"`` (a pixel saturated in every bracket of every position) or
    ``"skipped"`` (no readable photograph).
    """
    rows = cap.rows
    groups: dict[tuple[float, float], list[int]] = {}
    for i in idx:
        if i in got and got[i][0] == 0:
            groups.setdefault(_origin(reg, rows[i]), []).append(i)
    keys = np.array(sorted(darks)) if darks else None
    found: list[tuple[NDArray, NDArray]] = []  # per position: the texels and their signed offsets from the crest
    used = 0
    any_saturated = False
    (nu, nv), su = texels, repeat[0]
    u_t = np.tile((np.arange(nu) + 0.5) * su / nu, nv)
    for (u0, _v0), ok in groups.items():
        if len({got[i][4].window for i in ok}) > 1:  # brackets framed differently: not one position
            continue
        g = got[ok[0]][4]
        exps = [rows[i].exposure for i in ok]
        dk = None if keys is None else [darks[float(keys[np.argmin(np.abs(np.log(keys / e)))])] for e in exps]
        rad, ok_px = merge_exposures([got[i][1][:, None, :] for i in ok], [got[i][2][:, None] for i in ok], exps, dk)
        used += len(ok)
        if not ok_px.all():
            any_saturated = True
            continue
        r = rows[ok[0]]
        cos_l = g.normals @ direction_from_angles(r.theta_l, r.phi_l)
        if cos_l.min() < 0.5 * GRAZING_COS:  # pragma: no cover - btf_hidden marks these first
            continue
        tex = g.texels(rad[:, 0, :] / cos_l[:, None])  # (nt, C)
        found.append((tex, (u_t - u0 + 0.5 * su) % su - 0.5 * su))
    if not found:
        return ("saturated" if any_saturated else "skipped"), None, used
    return "ok", _at_the_crest(found), used


def _at_the_crest(found: list[tuple[NDArray, NDArray]]) -> NDArray:
    """Each texel at the stand's crest from the fabric positions that measured it.

    ``found``: per position, the texels ``(n_texels, C)`` and each texel's
    signed arc length from the crest ``s`` (mm). Where positions lie on both
    sides of a texel (a scan), the two nearest are interpolated linearly in
    ``s`` to ``s = 0`` (the turn of the normal is linear in ``s``: its first
    order cancels); elsewhere the nearest position's value is taken.
    """
    tex = np.stack([t for t, _ in found])  # (positions, nt, C)
    s = np.stack([o for _, o in found])  # (positions, nt)
    cols = np.arange(s.shape[1])
    big = np.inf
    plus = np.where(s >= 0, s, big)
    minus = np.where(s < 0, -s, big)
    ip, im = np.argmin(plus, axis=0), np.argmin(minus, axis=0)
    sp, sm = plus[ip, cols], minus[im, cols]  # distances >= 0
    near = np.where(sp <= sm, ip, im)
    out = tex[near, cols]
    both = np.isfinite(sp) & np.isfinite(sm) & (sp + sm > 0)
    if both.any():
        wp = np.where(both, sm / np.where(both, sp + sm, 1.0), 0.0)[:, None]
        out = np.where(both[:, None], wp * tex[ip, cols] + (1 - wp) * tex[im, cols], out)
    return out


class _Geometries:
    """The :class:`ViewGeometry` of each view and image size, made once (thread-safe)."""

    def __init__(self, cap: Capture, reg: Registration, **kw: Any) -> None:
        self.cap, self.reg, self.kw = cap, reg, kw
        self.done: dict[tuple, ViewGeometry] = {}
        self.lock = threading.Lock()

    def get(self, r: CaptureRow, info: ImageInfo) -> ViewGeometry:
        origin = _origin(self.reg, r)
        key = (r.kappa, r.theta_v, r.phi_v, info.width, info.height, r.cx, r.cy, origin)
        with self.lock:
            got = self.done.get(key)
            if got is None:
                st = stand_for(self.cap.stands or {}, r.kappa)
                got = view_geometry(st, origin,
                                    direction_from_angles(r.theta_v, r.phi_v), width=info.width,
                                    height=info.height, cx=r.cx, cy=r.cy, **self.kw)
                if len(self.done) >= 16:  # the rows come view by view: keep the memory bounded
                    self.done.clear()
                self.done[key] = got
            return got


def _read_footprint(path: Path, r: CaptureRow, linear: bool, geo: _Geometries
                    ) -> tuple[int, NDArray | None, NDArray | None, str, ViewGeometry | None]:
    """One photograph's footprint pixels: ``(status, values (n_px, C), saturated (n_px,), message, geometry)``."""
    from .preflight import describe, problem

    box: list[ViewGeometry] = []

    def window(info: ImageInfo) -> tuple[int, int, int, int]:
        box.append(geo.get(r, info))
        return box[0].window

    try:
        raw, info = read_window(path, window)
    except FileNotFoundError:
        return 1, None, None, "missing", None
    except ImageError as exc:
        return 2, None, None, problem(path, exc), None
    except OSError as exc:
        return 2, None, None, f"cannot be read ({exc.strerror or exc})", None
    except CaptureError:
        raise
    except Exception as exc:  # noqa: BLE001 - a decoder failing on this file
        return 2, None, None, f"cannot be decoded ({describe(exc)})", None
    vals, sat = decode_codes(raw, info, linear=linear)
    g = box[0]
    return 0, vals.reshape(-1, vals.shape[-1])[g.pick], sat.reshape(-1)[g.pick], "", g


def _read_all(jobs: list[tuple], scheduler: str, num_workers: int | None) -> list[tuple]:
    """:func:`_read_footprint` of every job, in Dask tasks on a local scheduler."""
    import dask
    from dask import delayed

    def some(part: list[tuple]) -> list[tuple]:
        return [_read_footprint(*j) for j in part]

    chunks = [jobs[c:c + 16] for c in range(0, len(jobs), 16)]
    kw: dict[str, Any] = {"scheduler": scheduler}
    if num_workers and scheduler != "synchronous":
        kw["num_workers"] = num_workers
    return [x for part in dask.compute(*[delayed(some, pure=False)(c) for c in chunks], **kw) for x in part]


# --------------------------------------------------------------------------- the measurement
def measure_btf(
    folder: str | PathLike[str],
    output: str | PathLike[str] | None = None,
    *,
    texels: int | tuple[int, int],
    repeat_mm: tuple[float, float] | None = None,
    repeats: int = 1,
    patch: int = 7,
    linear: bool = False,
    skip_bad: bool = False,
    scheduler: str | None = None,
    white_albedo: float | None = None,
    material: str | None = None,
    num_workers: int | None = None,
    progress: Callable[[int, int], None] | None = None,
    overwrite: bool = True,
    fill: str = DEFAULT_FILL,
    max_error: float = DEFAULT_BTF_ERROR,
) -> tuple[CDBTF, BTFReport]:
    """Measure a registered capture folder into a CD-BTF (see the module's description).

    Parameters
    ----------
    folder, output
        The capture folder and the CD-BTF file to write (atomically), if any.
    texels
        Texels per repeat side: ``n`` or ``(n_u, n_v)``.
    repeat_mm
        The repeat ``(size_u, size_v)``, mm (default: the registration's).
    repeats
        Repeats per side of the footprint solved for the texels.
    patch
        The N x N patch (pixels) of the white references and dark frames.
    linear, skip_bad, white_albedo, material, num_workers, progress, overwrite, fill
        As :func:`cdbrdf.measure.measure`.
    scheduler
        ``None``/``"threads"`` or ``"synchronous"`` (local only: no checkpoint, no cluster).
    max_error
        The compression's target relative RMS error.

    Returns
    -------
    btf : CDBTF
        ``quantity = "brdf"`` with a white reference, else ``"relative"``.
    report : BTFReport

    Raises
    ------
    CaptureError
        No ``registration`` in ``stands.json``, no stands, no ``pixel_mm``,
        no repeat, a stand without its origin, photographs too coarse for the
        texels, or any error of the CDBRDF path.
    OptionError
        For a bad option (one line, before anything is read).
    """
    t0 = time.perf_counter()
    nu, nv = texel_count(texels)
    if isinstance(repeats, bool) or not isinstance(repeats, (int, np.integer)) or not 1 <= repeats <= 16:
        raise OptionError(f"repeats: expected a whole number in [1, 16], got {repeats!r:.40}")
    if scheduler not in (None, "threads", "synchronous"):
        raise OptionError(f"scheduler: a CD-BTF is measured on local threads only (threads or synchronous), "
                          f"got {scheduler!r:.40}")
    if isinstance(max_error, bool) or not isinstance(max_error, (int, float)) or not 0 <= max_error < 1:
        raise OptionError(f"max_error: expected a fraction in [0, 1), got {max_error!r:.40}")
    fill = check_fill_method(fill)
    out_path = None if output is None else check_output_file(output)
    if out_path is not None and not overwrite and (out_path.exists() or out_path.is_symlink()):
        raise FileExistsError(f"{out_path}: already exists (use --force to overwrite)")
    with output_lock(out_path) if out_path is not None else contextlib.nullcontext():
        cap = read_capture(folder, patch=patch)
        where = cap.folder / "stands.json"
        reg = cap.settings.get("registration")
        if not isinstance(reg, Registration):
            raise CaptureError(f"{where}: no registration (the fabric's (u, v) on the stands): a CD-BTF cannot "
                               "be measured from this capture (docs/capture.md, 'Measuring a CD-BTF')")
        pixel_mm = float(cap.settings.get("pixel_mm", 0.0))
        if cap.stands is None or pixel_mm <= 0:
            raise CaptureError(f"{where}: a CD-BTF needs the stands' geometry and pixel_mm")
        rep_mm = repeat_mm if repeat_mm is not None else reg.repeat_mm
        if rep_mm is None:
            raise CaptureError(f"{where}: registration: no repeat_mm, and none given")
        su, sv = (float(x) for x in rep_mm)
        if not (math.isfinite(su) and math.isfinite(sv) and su > 0 and sv > 0):
            raise OptionError(f"repeat_mm: expected two positive sizes in mm, got {rep_mm!r:.40}")
        missing = [k for k in cap.grid.kappa if reg.origin(float(k)) is None]
        if missing:
            raise CaptureError(f"{where}: registration: no origin for the stand of kappa {missing[0]:g}")
        for st in cap.stands.values():
            if repeats * su > st.face_width_mm:
                raise CaptureError(f"{where}: the stand of kappa {st.kappa:g} ({st.face_width_mm:g} mm wide) "
                                   f"is narrower than {repeats} repeat(s) of {su:g} mm")
        if out_path is not None:
            from .preflight import refuse_overlap

            refuse_overlap(cap, [], [out_path])
        table, report = _measure(cap, reg, texels=(nu, nv), repeat=(su, sv), repeats=int(repeats), patch=patch,
                                 linear=linear, skip_bad=skip_bad, scheduler=scheduler or "threads",
                                 white_albedo=white_albedo, material=material, num_workers=num_workers,
                                 progress=progress, fill_method=fill, max_error=float(max_error),
                                 out_path=out_path)
        if out_path is not None:
            table.save(out_path)
        report.seconds = time.perf_counter() - t0
        return table, report


def _measure(cap: Capture, reg: Registration, *, texels: tuple[int, int], repeat: tuple[float, float],
             repeats: int, patch: int, linear: bool, skip_bad: bool, scheduler: str, white_albedo: float | None,
             material: str | None, num_workers: int | None, progress: Callable[[int, int], None] | None,
             fill_method: str, max_error: float, out_path: Path | None) -> tuple[CDBTF, BTFReport]:
    from .preflight import preflight, refuse_bad

    grid, rows = cap.grid, cap.rows
    enc = cap.settings.get("encoding")
    albedo = float(white_albedo if white_albedo is not None else cap.settings.get("white_albedo", 1.0))
    pixel_mm = float(cap.settings["pixel_mm"])
    hidden = btf_hidden(cap, repeat, repeats=repeats)

    def lin(r: CaptureRow) -> bool:
        return r.linear if r.linear is not None else (enc == "linear") if enc is not None else bool(linear)

    conds = [idx for idx in cap.brackets("sample").values() if not hidden[cap.sample_index[idx[0]]]]
    conds.sort(key=lambda idx: (rows[idx[0]].kappa, rows[idx[0]].theta_v, rows[idx[0]].phi_v))  # view by view
    calib = [i for i, r in enumerate(rows) if r.kind in ("white", "dark")]
    needed = calib + [i for idx in conds for i in idx]
    root = cap.folder.resolve()
    paths = {i: root / rows[i].file for i in needed}
    _stats, bad = preflight(cap, needed, paths, patch)
    if bad and not skip_bad:
        refuse_bad(cap, bad, paths, out_path, during=False)
    total = len(needed)
    done = 0
    results: dict[int, tuple] = {i: (st, None, None, why) for i, (st, why) in bad.items()}
    for i in calib:
        if i not in bad:
            results[i] = read_patch_status(paths[i], patch, rows[i].cx, rows[i].cy, lin(rows[i]))
    done += len(calib)
    if progress is not None:
        progress(done, total)
    rep = BTFReport(texels=texels, repeat_mm=repeat, px_per_texel=min(repeat[0] / texels[0],
                                                                      repeat[1] / texels[1]) / pixel_mm)
    darks, whites = calibration(cap, results, rep)
    darks = {e: d.reshape(-1, d.shape[-1]).mean(axis=0) for e, d in darks.items()}
    nt = texels[0] * texels[1]
    nc: int | None = None
    values: NDArray[np.float32] | None = None
    valid = np.zeros(grid.shape, dtype=bool)
    saturated = np.zeros(grid.shape, dtype=bool)
    skipped = np.zeros(grid.shape, dtype=bool)
    geo = _Geometries(cap, reg, pixel_mm=pixel_mm, texels=texels, repeat_mm=repeat, repeats=repeats)
    failed: dict[int, tuple[int, str]] = {}
    n_used = 0
    for b in range(0, len(conds), _CONDITIONS_PER_BATCH):
        batch = conds[b:b + _CONDITIONS_PER_BATCH]
        todo = [i for idx in batch for i in idx if i not in bad]
        got = dict(zip(todo, _read_all([(paths[i], rows[i], lin(rows[i]), geo) for i in todo],
                                       scheduler, num_workers)))
        good: list[tuple[Any, NDArray, CaptureRow]] = []
        for idx in batch:
            sidx = cap.sample_index[idx[0]]
            for i in idx:
                if i in got and got[i][0] != 0:
                    failed[i] = (got[i][0], got[i][3])
            status, tex, used = _condition(cap, reg, idx, got, darks, texels, repeat)
            n_used += used
            if status == "saturated":
                saturated[sidx] = True
            elif tex is None:
                skipped[sidx] = True
            else:
                good.append((sidx, tex, rows[idx[0]]))
        if failed and not skip_bad:
            refuse_bad(cap, failed, paths, out_path, during=True)
        white_of = _nearest_white(cap, [r for *_, r in good], whites) if (whites and good) else None
        for n, (sidx, tex, _r) in enumerate(good):
            if values is None:
                nc = tex.shape[-1]
                values = np.full(grid.shape + (nt * nc,), np.nan, dtype=np.float32)
            scale = np.ones(tex.shape[-1]) if white_of is None else albedo / math.pi / whites[white_of[n]][1]
            values[sidx] = (tex * scale).reshape(-1)
            valid[sidx] = True
        done += len(todo) + sum(1 for idx in batch for i in idx if i in bad)
        if progress is not None:
            progress(done, total)
    for i, (_st, why) in sorted({**bad, **failed}.items()):
        rep.skipped_files.append((rows[i].file, why))
    if values is None or nc is None:
        raise CaptureError(f"{cap.folder}: no sample could be measured")
    rep.n_samples = int(np.prod(grid.shape))
    rep.n_measured = int(valid.sum())
    rep.n_filled = rep.n_samples - rep.n_measured
    rep.n_hidden = int(hidden.sum())
    rep.n_saturated = int(saturated.sum())
    rep.n_skipped_samples = int(skipped.sum())
    photographed = np.zeros(grid.shape, dtype=bool)
    for idx in cap.brackets("sample").values():
        photographed[cap.sample_index[idx[0]]] = True
    rep.n_not_photographed = int((~photographed).sum())
    rep.n_images = n_used + rep.n_white + rep.n_dark
    rep.measured = valid.copy()
    summary: dict[str, Any] = {}
    provenance_kwargs: dict[str, Any] = {}
    for c in range(0, values.shape[-1], _FILL_CHANNELS):  # fill is per channel: texels x channels in slices
        try:
            res = fill(values[..., c:c + _FILL_CHANNELS].astype(np.float64), valid, grid, method=fill_method)
        except TableError as exc:
            raise CaptureError(f"{cap.folder}: {exc}") from None
        values[..., c:c + _FILL_CHANNELS] = res.values
        summary = summary or res.summary
        if not provenance_kwargs:  # the same for every texel and channel (it depends on the mask and the grid)
            provenance_kwargs = {k: v for k, v in res.table_kwargs().items() if k not in ("std", "fill_std")}
    rep.fill_method = fill_method
    rep.n_filled_by = {k: v for k, v in summary.get("samples", {}).items() if k != "measured"}
    dense = np.moveaxis(values.reshape(grid.shape + (texels[1], texels[0], nc)), (5, 6), (0, 1))
    del values
    mat = material or cap.settings.get("material") or cap.folder.resolve().name
    provenance = {
        "method": "measured_btf", "capture": cap.folder.resolve().name, "capture_sha256": cap.digest,
        "texels": list(texels), "repeat_mm": list(repeat), "footprint_repeats": repeats,
        "pixel_mm": pixel_mm, "px_per_texel": rep.px_per_texel, "white_reference": bool(whites),
        "white_albedo": albedo if whites else None, "dark_frames": rep.n_dark,
        "stand_geometry": [s.to_dict() for s in cap.stands.values()] if cap.stands else None,
        "registration": reg.to_dict(), "n_measured": rep.n_measured, "n_hidden": rep.n_hidden,
        "n_saturated": rep.n_saturated, "fill": fill_method, "n_filled_by": rep.n_filled_by,
        "skipped_files": [f for f, _ in rep.skipped_files[:100]],
    }
    attrs = {"quantity": rep.quantity, "material": str(mat), "provenance": provenance,
             "channels": ["R", "G", "B"] if nc == 3 else ["Y"]}
    btf = CDBTF.from_values(dense, grid, repeat_mm=repeat, max_error=max_error, attrs=attrs,
                            mean_kwargs=provenance_kwargs)
    rep.compression = btf.compression
    return btf, rep
