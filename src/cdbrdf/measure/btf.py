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
import dataclasses
import hashlib
import json
import logging
import math
import threading
import time
from collections.abc import Callable, Mapping
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
from ..provenance import Provenance
from .btf_batches import run_conditions
from .btf_geometry import GRAZING_COS, SUBPIXELS, ViewGeometry, btf_hidden, view_geometry
from .calibrate import MeasureReport, _nearest_white, calibration
from .capture import Capture, CaptureRow, read_capture
from .checkpoint import Checkpoint, checkpoint_path
from .fill import BTF_DEFAULT_FILL, BTF_FILLS, check_fill_method, fill
from .options import MeasureOptions
from .patch import decode_codes, merge_exposures
from .preflight import bad_list_path, read_patch_status, remove_bad_list
from .registration import Registration
from .schedulers import check_scheduler, open_client
from .stands import Stand, stand_for

__all__ = ["measure_btf", "BTFReport", "ViewGeometry", "view_geometry", "btf_hidden", "texel_count",
           "SUBPIXELS", "GRAZING_COS", "MIN_PX_PER_TEXEL", "MAX_TEXELS", "DEFAULT_BTF_ERROR"]

_LOG = logging.getLogger(__name__)

#: Fewest pixels per texel (along the texel's shorter side, at the view along the normal) accepted.
MIN_PX_PER_TEXEL = 1.5
#: Most texels along a side of the repeat.
MAX_TEXELS = 256
#: The compression's target relative RMS error of the measured CD-BTF (:meth:`cdbrdf.CDBTF.from_values`).
DEFAULT_BTF_ERROR = 0.01
#: Sample conditions per Dask task (one task computes each view's geometry once: conditions come view by view).
_CONDITIONS_PER_TASK = 8
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


# --------------------------------------------------------------------------- reading
def _origin(reg: Registration, r: CaptureRow) -> tuple[float, float]:
    """The fabric's (u, v) at the stand's centre in the photograph of row ``r`` (its own, else its stand's)."""
    return r.uv_mm if r.uv_mm is not None else (reg.origin(r.kappa) or (0.0, 0.0))


def _condition(rows: Mapping[int, CaptureRow], reg: Registration, idx: list[int], got: dict[int, tuple],
               darks: dict[float, NDArray], texels: tuple[int, int], repeat: tuple[float, float]
               ) -> tuple[str, NDArray | None, int]:
    """The texels ``(n_texels, C)`` of one sample condition from its photographs: ``(status, texels, used)``.

    The rows of one fabric position (``u_mm``, ``v_mm``; else the stand's
    registration) are brackets, merged pixel by pixel; each position gives
    every texel, and each texel is taken at the stand's crest from the
    positions that have it nearest on either side (:func:`_at_the_crest`). Status ``"ok"``,
    ``"saturated"`` (a pixel saturated in every bracket of every position) or
    ``"skipped"`` (no readable photograph). ``rows``: the capture's rows (by index).
    """
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
    """The :class:`ViewGeometry` of each view and image size, made once (thread-safe).

    Pickled (the ``processes`` scheduler, a cluster's workers) without what it made.
    """

    def __init__(self, stands: dict[float, Stand], reg: Registration, **kw: Any) -> None:
        self.stands, self.reg, self.kw = stands, reg, kw
        self.done: dict[tuple, ViewGeometry] = {}
        self.lock = threading.Lock()

    def __getstate__(self) -> dict[str, Any]:
        return {"stands": self.stands, "reg": self.reg, "kw": self.kw}

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__init__(state["stands"], state["reg"], **state["kw"])  # type: ignore[misc]

    def get(self, r: CaptureRow, info: ImageInfo) -> ViewGeometry:
        origin = _origin(self.reg, r)
        key = (r.kappa, r.theta_v, r.phi_v, info.width, info.height, r.cx, r.cy, origin)
        with self.lock:
            got = self.done.get(key)
            if got is None:
                st = stand_for(self.stands, r.kappa)
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


def _condition_tasks(jobs: list[tuple]) -> list[tuple[str, NDArray | None, int, dict[int, tuple[int, str]]]]:
    """One Dask task: per job, a sample condition read (:func:`_read_footprint`) and rectified (:func:`_condition`).

    A job is ``(idx, rows, files, geo, darks, texels, repeat)``, ``files``
    mapping a row to ``(path, linear)`` (its usable photographs). Per job:
    ``(status, texels, used, failed)``, ``failed`` mapping a row whose
    photograph failed to read to ``(status, message)``. Only the texels
    leave the task (the footprints do not).
    """
    out = []
    for idx, rows, files, geo, darks, texels, repeat in jobs:
        got = {i: _read_footprint(path, rows[i], lin, geo) for i, (path, lin) in files.items()}
        status, tex, used = _condition(rows, geo.reg, idx, got, darks, texels, repeat)
        out.append((status, tex, used, {i: (g[0], g[3]) for i, g in got.items() if g[0] != 0}))
    return out


# --------------------------------------------------------------------------- the measurement
def measure_btf(
    folder: str | PathLike[str],
    output: str | PathLike[str] | None = None,
    *,
    texels: int | tuple[int, int],
    options: MeasureOptions | None = None,
    repeat_mm: tuple[float, float] | None = None,
    repeats: int = 1,
    max_error: float = DEFAULT_BTF_ERROR,
    scheduler: Any = None,
    progress: Callable[[int, int], None] | None = None,
    _interrupt_after: int | None = None,
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
    options
        The options shared with :func:`cdbrdf.measure.measure`
        (:class:`~cdbrdf.measure.MeasureOptions`: patch, linear, skip_bad,
        white_albedo, material, fill (default :data:`~cdbrdf.measure.fill.BTF_DEFAULT_FILL`),
        checkpoint, batch_size, num_workers, overwrite). With ``output`` and
        ``checkpoint``, each batch of sample conditions (about ``batch_size``
        photographs) keeps its texels in ``<output>.ckpt``
        (:mod:`cdbrdf.measure.btf_batches`); a later run with the same capture
        and options (texels, repeat, footprint, patch, linear, dark frames)
        reuses them: the same CD-BTF, bit for bit.
    scheduler, progress
        As :func:`cdbrdf.measure.measure`: a Dask task reads and rectifies
        :data:`_CONDITIONS_PER_TASK` sample conditions, on any of its schedulers.
    max_error
        The compression's target relative RMS error.
    _interrupt_after
        For the tests: stop as a killed run would once this many photographs are read.

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
    o = MeasureOptions() if options is None else options
    if not isinstance(o, MeasureOptions):
        raise OptionError(f"options: expected a cdbrdf.measure.MeasureOptions, got {type(o).__name__:.40}")
    nu, nv = texel_count(texels)
    if isinstance(repeats, bool) or not isinstance(repeats, (int, np.integer)) or not 1 <= repeats <= 16:
        raise OptionError(f"repeats: expected a whole number in [1, 16], got {repeats!r:.40}")
    check_scheduler(scheduler)
    if isinstance(max_error, bool) or not isinstance(max_error, (int, float)) or not 0 <= max_error < 1:
        raise OptionError(f"max_error: expected a fraction in [0, 1), got {max_error!r:.40}")
    fill = check_fill_method(BTF_DEFAULT_FILL if o.fill is None else o.fill)
    if fill not in BTF_FILLS:
        raise OptionError(f"fill: {fill!r} fills a CDBRDF, not a CD-BTF's texels; for --btf use one of "
                          f"{', '.join(BTF_FILLS)}")
    out_path = None if output is None else check_output_file(output)
    if out_path is not None:
        check_output_file(bad_list_path(out_path))  # what refuse_bad writes beside it
        if not o.overwrite and (out_path.exists() or out_path.is_symlink()):
            raise FileExistsError(f"{out_path}: already exists (use --force to overwrite)")
    with output_lock(out_path) if out_path is not None else contextlib.nullcontext():
        cap = read_capture(folder, patch=o.patch)
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
        ck_path = checkpoint_path(out_path) if (out_path is not None and o.checkpoint) else None
        if out_path is not None:
            from .preflight import refuse_overlap

            refuse_overlap(cap, [ck_path] if ck_path is not None else [], [out_path, bad_list_path(out_path)])
        table, report, ck = _measure(cap, reg, texels=(nu, nv), repeat=(su, sv), repeats=int(repeats), patch=o.patch,
                                     linear=o.linear, skip_bad=o.skip_bad, scheduler=scheduler,
                                     white_albedo=o.white_albedo, material=o.material, num_workers=o.num_workers,
                                     progress=progress, fill_method=fill, max_error=float(max_error),
                                     out_path=out_path, ck_path=ck_path, batch_size=int(o.batch_size),
                                     interrupt_after=_interrupt_after)
        if out_path is not None:
            table.save(out_path)
            ck.remove()
            remove_bad_list(out_path)  # an earlier run's list of unusable photographs is stale now
        report.seconds = time.perf_counter() - t0
        return table, report


def _checkpoint_key(cap: Capture, *, texels: tuple[int, int], repeat: tuple[float, float], repeats: int,
                    patch: int, linear: bool, darks: dict[float, NDArray], n_conditions: int) -> str:
    """The checkpoint's key: the capture and every option that changes a condition's texels.

    The dark frames' means (read again by every run) stand for the patch's
    reading; the white references, the fill and the compression act after
    the checkpoint and are not in it.
    """
    dark = hashlib.sha256(b"".join(np.float64(e).tobytes() + np.asarray(darks[e], dtype=np.float64).tobytes()
                                   for e in sorted(darks))).hexdigest()
    doc = {"kind": "btf", "capture": cap.digest, "texels": list(texels), "repeat_mm": list(repeat),
           "repeats": repeats, "patch": patch, "linear": bool(linear), "subpixels": SUBPIXELS,
           "darks": dark, "conditions": n_conditions}
    return hashlib.sha256(json.dumps(doc, sort_keys=True).encode()).hexdigest()


def _measure(cap: Capture, reg: Registration, *, texels: tuple[int, int], repeat: tuple[float, float],
             repeats: int, patch: int, linear: bool, skip_bad: bool, scheduler: Any, white_albedo: float | None,
             material: str | None, num_workers: int | None, progress: Callable[[int, int], None] | None,
             fill_method: str, max_error: float, out_path: Path | None, ck_path: Path | None, batch_size: int,
             interrupt_after: int | None) -> tuple[CDBTF, BTFReport, Checkpoint]:
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
    stats, bad = preflight(cap, needed, paths, patch)
    if bad and not skip_bad:
        refuse_bad(cap, bad, paths, out_path, during=False)
    total = len(needed)
    results: dict[int, tuple] = {i: (st, None, None, why) for i, (st, why) in bad.items()}
    for i in calib:
        if i not in bad:
            results[i] = read_patch_status(paths[i], patch, rows[i].cx, rows[i].cy, lin(rows[i]))
    if progress is not None:
        progress(len(calib), total)
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
    geo = _Geometries(cap.stands or {}, reg, pixel_mm=pixel_mm, texels=texels, repeat_mm=repeat, repeats=repeats)
    failed: dict[int, tuple[int, str]] = {}
    n_used = 0
    key = _checkpoint_key(cap, texels=texels, repeat=repeat, repeats=repeats, patch=patch, linear=linear,
                          darks=darks, n_conditions=len(conds))
    client, own_client = open_client(scheduler)  # an unreachable scheduler: before the checkpoint exists
    try:
        ck = Checkpoint(ck_path, key, shape=(texels[1], texels[0]))
    except BaseException:
        if own_client:
            client.close()
        raise

    def job(idx: list[int]) -> tuple:
        return (idx, {i: rows[i] for i in idx}, {i: (paths[i], lin(rows[i])) for i in idx if i not in bad},
                geo, darks, texels, repeat)

    def tick(n: int) -> None:
        if progress is not None:
            progress(len(calib) + n, total)

    size = {idx[0]: len(idx) for idx in conds}
    first = True
    try:
        for part in run_conditions(conds, job, stats, ck, task=_condition_tasks, per_task=_CONDITIONS_PER_TASK,
                                   batch_size=batch_size, scheduler=scheduler, client=client,
                                   num_workers=num_workers, failed=failed, progress=tick,
                                   interrupt_after=interrupt_after):
            if first:  # the conditions resumed from the checkpoint
                rep.n_images_resumed = sum(size[r[0]] for r in part)
                first = False
            if failed and not skip_bad:
                refuse_bad(cap, failed, paths, out_path, during=True)
            good: list[tuple[Any, NDArray, CaptureRow]] = []
            for i0, status, tex, used in part:
                sidx = cap.sample_index[i0]
                n_used += used
                if status == "saturated":
                    saturated[sidx] = True
                elif tex is None:
                    skipped[sidx] = True
                else:
                    good.append((sidx, tex, rows[i0]))
            white_of = _nearest_white(cap, [r for *_, r in good], whites) if (whites and good) else None
            for n, (sidx, tex, _r) in enumerate(good):
                if values is None:
                    nc = tex.shape[-1]
                    values = np.full(grid.shape + (nt * nc,), np.nan, dtype=np.float32)
                scale = np.ones(tex.shape[-1]) if white_of is None else albedo / math.pi / whites[white_of[n]][1]
                values[sidx] = (tex * scale).reshape(-1)
                valid[sidx] = True
    except BaseException:
        ck.discard_if_empty()  # made by this run and nothing saved: leave nothing behind
        raise
    finally:
        if own_client:
            client.close()
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
    btf = _fill_and_compress(cap, reg, rep, values, valid, nc=nc, texels=texels, repeat=repeat, repeats=repeats,
                             pixel_mm=pixel_mm, whites=bool(whites), albedo=albedo, material=material,
                             fill_method=fill_method, max_error=max_error)
    return btf, rep, ck


def _fill_and_compress(cap: Capture, reg: Registration, rep: BTFReport, values: NDArray[np.float32],
                       valid: NDArray[np.bool_], *, nc: int, texels: tuple[int, int], repeat: tuple[float, float],
                       repeats: int, pixel_mm: float, whites: bool, albedo: float, material: str | None,
                       fill_method: str, max_error: float) -> CDBTF:
    """The invalid samples of ``values`` (``grid.shape + (n_texels * C,)``) filled, the CD-BTF compressed."""
    grid = cap.grid
    summary: dict[str, Any] = {}
    sample_provenance: Provenance | None = None
    for c in range(0, values.shape[-1], _FILL_CHANNELS):  # fill is per channel: texels x channels in slices
        try:
            res = fill(values[..., c:c + _FILL_CHANNELS].astype(np.float64), valid, grid, method=fill_method)
        except TableError as exc:
            raise CaptureError(f"{cap.folder}: {exc}") from None
        values[..., c:c + _FILL_CHANNELS] = res.values
        summary = summary or res.summary
        if sample_provenance is None:  # the same for every texel and channel (it depends on the mask and the grid)
            sample_provenance = dataclasses.replace(res.provenance(), fill_std=None)
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
                            provenance=sample_provenance)
    rep.compression = btf.compression
    return btf

