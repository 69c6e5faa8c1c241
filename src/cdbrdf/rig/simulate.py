"""Simulated captures: :func:`simulate_capture` renders a capture folder of a known material.

How the rig photographs is one :class:`~cdbrdf.rig.RigOptions` record (:mod:`cdbrdf.rig.options`).

For every row of a capture plan (``docs/capture.md``) the rig renders one
photograph with the row's camera and light (:mod:`cdbrdf.rig.scenes`,
:mod:`cdbrdf.rig.camera`), adds sensor noise and writes it
(:mod:`cdbrdf.rig.sensor`); white-reference rows render a flat Lambertian
plate of albedo ``white_albedo``; dark rows render nothing (noise only).
The capture table and ``stands.json`` are written with
:mod:`cdbrdf.measure.capture` and :mod:`cdbrdf.measure.stands`, so the
folder reads back with :func:`cdbrdf.measure.measure`.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from os import PathLike
from pathlib import Path, PurePosixPath
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..btf import CDBTF
from ..errors import CaptureError, OptionError
from ..frames import direction_from_angles
from ..images import FORMATS
from ..measure.capture import CAPTURE_FILE, STAND_FILE, CaptureRow, Plan, file_key, read_plan
from ..measure.plan import write_plan, write_rows
from ..measure.stands import KAPPA_TOL_PER_MM, Stand, default_stand, stand_for, write_stands
from ..table import CDBRDF, Grid
from .camera import light_to_world
from .options import DEFAULT_FIELD_MM, DEFAULT_SIZE_PX, PX_PER_TEXEL, RigOptions
from .scenes import stand_scene, white_scene
from .sensor import encode, extension, write_photograph

__all__ = ["SimulationReport", "simulate_capture", "load_material", "btf_camera"]


@dataclass
class SimulationReport:
    """What :func:`simulate_capture` wrote.

    Attributes
    ----------
    folder
        The capture folder.
    n_images, n_white, n_dark
        Photographs written: all, white references, dark frames.
    n_saturated_pixels
        Pixels at the sensor's largest code.
    seconds_rendering
        Time spent in Mitsuba, seconds.
    files
        The photographs' paths relative to ``folder``.
    """

    folder: Path
    n_images: int = 0
    n_white: int = 0
    n_dark: int = 0
    n_saturated_pixels: int = 0
    seconds_rendering: float = 0.0
    files: list[str] = field(default_factory=list)

    def summary(self) -> str:
        """The report in one line.

        Returns
        -------
        str
            The counts and the rendering time.
        """
        return (
            f"{self.folder}: {self.n_images} photographs ({self.n_white} white references, "
            f"{self.n_dark} dark frames), {self.n_saturated_pixels} saturated pixels, "
            f"{self.seconds_rendering:.1f} s rendering"
        )


def load_material(material: CDBRDF | CDBTF | str | PathLike[str]) -> CDBRDF | CDBTF:
    """The table of a material.

    Parameters
    ----------
    material
        A :class:`CDBRDF` or :class:`~cdbrdf.CDBTF`, a CDBRDF or CD-BTF file, or
        a bundled material's name (:mod:`cdbrdf.materials`).

    Returns
    -------
    CDBRDF or CDBTF
        The table (a CD-BTF file gives its CD-BTF).
    """
    if isinstance(material, (CDBRDF, CDBTF)):
        return material
    p = Path(material)
    if p.suffix.lower() in (".h5", ".hdf5", ".nc") or p.exists():
        from ..sources import open_source

        return open_source(p, what="material").table
    try:
        from .. import materials
    except ImportError as exc:  # pragma: no cover - the presets module is part of the package
        raise OptionError(f"material {material!r}: not a file, and presets are unavailable ({exc})") from None
    return materials.load(str(material))


def btf_camera(btf: CDBTF, *, px_per_texel: float = PX_PER_TEXEL, size: int | None = None,
               field_mm: float | None = None) -> tuple[int, float]:
    """The image size and field (mm) that photograph a CD-BTF's repeat at ``px_per_texel``.

    The field holds a whole repeat whatever the view's azimuth (1.5 times its
    diagonal), the pixel is the texel's shorter side over ``px_per_texel``;
    a given ``size`` or ``field_mm`` is kept (the other follows from it).

    Returns
    -------
    size, field_mm
        Pixels (even) and mm.
    """
    (nu, nv), (su, sv) = btf.texels, btf.repeat_mm
    pixel = min(su / nu, sv / nv) / float(px_per_texel)
    if field_mm is None:
        field_mm = 1.5 * math.hypot(su, sv) if size is None else size * pixel
    if size is None:
        size = max(8, 2 * math.ceil(0.5 * field_mm / pixel))
    return int(size), float(field_mm)


def _registration(table: CDBRDF | CDBTF, stands: Sequence[Stand], seed: int) -> dict[str, Any] | None:
    """For a CD-BTF: the fabric's (u, v) at each stand's centre, drawn from ``seed`` (in the repeat)."""
    if not isinstance(table, CDBTF):
        return None
    from ..measure.registration import Registration

    rng = np.random.default_rng([int(seed), 27])
    su, sv = table.repeat_mm
    origins = {s.kappa: (round(float(rng.uniform(0, su)), 6), round(float(rng.uniform(0, sv)), 6)) for s in stands}
    return Registration("orthographic", origins, (su, sv)).to_dict()


def simulate_capture(
    material: CDBRDF | CDBTF | str | PathLike[str],
    folder: str | PathLike[str],
    options: RigOptions | None = None,
    *,
    plan: str | PathLike[str] | None = None,
    grid: Grid | None = None,
    stands: Sequence[Stand] | None = None,
    progress: Callable[[int, int], None] | None = None,
    **legacy: Any,
) -> SimulationReport:
    """Render a capture folder of a material with the simulated rig.

    Parameters
    ----------
    material
        A :class:`CDBRDF`, a :class:`~cdbrdf.CDBTF`, a CDBRDF or CD-BTF file,
        or a preset name. A CD-BTF is laid on the stands with its ``(u, v)``
        in mm (arc length along x, length along y) from an origin per stand
        drawn from the seed, recorded as the ``registration`` of
        ``stands.json`` (:mod:`cdbrdf.measure.registration`), so that
        ``measure(..., btf=...)`` can rectify the photographs.
    folder
        Output capture folder. It is built as a partial folder beside it and
        swapped in whole once complete (:func:`cdbrdf.outputs.output_folder`):
        an earlier capture written by cdbrdf is replaced, unless files were
        added to it since (a measured table, notes: refused, naming them); a
        non-empty folder cdbrdf did not make is refused, and an error or
        interrupt leaves no half-written folder.
    options
        How the rig photographs (:class:`~cdbrdf.rig.RigOptions`: image size,
        field, samples, noise, gain, exposures, image kind, white reference,
        seed); default ``RigOptions()``.
    plan
        A ``capture.csv`` to render (its ``stands.json``, if beside it, gives
        the stand geometry). It is checked before anything is rendered with
        the rules :func:`cdbrdf.measure.measure` applies to the capture
        (:func:`cdbrdf.measure.capture.read_plan`: every column's rule, file
        names that are relative paths inside the folder, no photograph named
        by two rows, no stray row). Default: a plan for ``grid`` (default the
        material's own grid) and ``stands`` (default: one per kappa of the
        grid, default geometry), written like ``cdbrdf plan``.
    grid, stands
        Without ``plan``: the samples and the stands of the plan.
    progress
        ``progress(done, total)`` (photographs) after each rendering's photographs are written.
    **legacy
        The former keywords (``size=``, ``spp=``, ``noise=``, ...): the fields
        of :class:`~cdbrdf.rig.RigOptions`, with a :class:`DeprecationWarning`.

    Returns
    -------
    SimulationReport
        What was written.
    """
    opts = _options_of(options, legacy)
    from ..outputs import check_output_folder, output_folder

    final = check_output_folder(folder)  # refuse a foreign folder before any work
    # the plan is checked by the capture format's own parser before anything is rendered
    the_plan = read_plan(plan) if plan is not None else None
    table = load_material(material)
    size, field_mm = opts.size, opts.field_mm
    if isinstance(table, CDBTF):
        size, field_mm = btf_camera(table, px_per_texel=opts.px_per_texel, size=size, field_mm=field_mm)
    opts = replace(opts, size=DEFAULT_SIZE_PX if size is None else int(size),
                   field_mm=DEFAULT_FIELD_MM if field_mm is None else float(field_mm))
    from ..render import variant

    with output_folder(final) as partial, variant():
        rep = _fill_capture(partial, table, opts, plan=the_plan, grid=grid, stands=stands, progress=progress)
    rep.folder = final
    return rep


def _options_of(options: RigOptions | None, legacy: dict[str, Any]) -> RigOptions:
    """The options of :func:`simulate_capture`'s arguments: the record, or the former keywords (deprecated)."""
    if not legacy:
        return RigOptions() if options is None else options
    import warnings

    warnings.warn("simulate_capture(material, folder, size=..., ...) is deprecated: pass a cdbrdf.rig.RigOptions "
                  f"({', '.join(sorted(legacy))})", DeprecationWarning, stacklevel=3)
    if options is not None:
        raise OptionError(f"simulate_capture: give the options in the RigOptions, not beside it ({next(iter(legacy))})")
    unknown = sorted(set(legacy) - set(RigOptions.__dataclass_fields__))
    if unknown:
        raise OptionError(f"simulate_capture: unknown option {unknown[0]!r}")
    return RigOptions(**legacy)


def _write_plan(out: Path, table: CDBRDF | CDBTF, opts: RigOptions, *, plan: Plan | None, grid: Grid | None,
                stands: Sequence[Stand] | None) -> tuple[list[CaptureRow], list[Stand], dict[str, Any] | None]:
    """The capture table and ``stands.json`` in ``out``: the rows to photograph, the stands, a CD-BTF's registration."""
    size, field_mm = int(opts.size or DEFAULT_SIZE_PX), float(opts.field_mm or DEFAULT_FIELD_MM)
    ext = extension(opts.image_kind)
    extra: dict[str, Any] = {}
    if plan is not None:
        rows, stand_list = _copy_plan(plan, out, ext)
        if plan.given_grid is not None:
            extra["grid"] = plan.given_grid  # the measurement checks the rows against it, as the plan was
    else:
        g = grid if grid is not None else table.grid
        stand_list = list(stands) if stands is not None else [default_stand(k) for k in g.kappa]
        write_plan(out, g, stand_list, extension=ext, white=opts.white,
                   pixel_mm=field_mm / size, patch_px=opts.patch_px, exposures=opts.exposures)
    reg = _registration(table, stand_list, opts.seed)
    if plan is None:
        if reg is not None and opts.shifts > 1:
            _scan(out / CAPTURE_FILE, reg, opts.shifts)
        rows = read_plan(out / CAPTURE_FILE).rows
    if reg is not None:
        extra["registration"] = reg
    write_stands(out / STAND_FILE, stand_list, white_albedo=float(opts.white_albedo),
                 material=str(table.attrs.get("material", "unknown")), simulated=True,
                 pixel_mm=field_mm / size, **extra)
    return list(rows), stand_list, reg


def _fill_capture(out: Path, table: CDBRDF | CDBTF, opts: RigOptions, *, plan: Plan | None, grid: Grid | None,
                  stands: Sequence[Stand] | None, progress: Callable[[int, int], None] | None) -> SimulationReport:
    """Write the capture into the (empty, partial) folder ``out``; see :func:`simulate_capture`."""
    rows, stand_list, reg = _write_plan(out, table, opts, plan=plan, grid=grid, stands=stands)
    size, field_mm = int(opts.size or DEFAULT_SIZE_PX), float(opts.field_mm or DEFAULT_FIELD_MM)
    seed, noise, gain, image_kind = opts.seed, opts.noise, opts.gain, opts.image_kind

    import mitsuba as mi

    import cdbrdf.render as cr

    rep = SimulationReport(out)
    t0 = time.perf_counter()
    folders: set[Path] = set()

    def emit(members: list[tuple[int, int]], film: NDArray[np.float64] | None) -> None:
        """Expose, add noise to, encode and write the photographs of ``(row, camera slot)`` pairs.

        ``film``: the rendering, cameras side by side (None: dark frames). The
        noise of a rendering's photographs is drawn from ``(seed, its first row)``.
        """
        idx = [i for i, _ in members]
        if film is None:
            lin = np.zeros((len(members), size, size, 3))
        else:
            lin = film.reshape(size, -1, size, film.shape[-1])[:, [j for _, j in members], :, :3]
            lin = np.moveaxis(lin, 1, 0)
        scale = np.array([gain * rows[i].exposure for i in idx])
        noisy = noise.apply(lin * scale[:, None, None, None], np.random.default_rng([int(seed), idx[0]]))
        codes, n_saturated = encode(noisy, image_kind)
        rep.n_saturated_pixels += n_saturated
        for n, i in enumerate(idx):
            path = out / rows[i].file
            if path.parent not in folders:
                path.parent.mkdir(parents=True, exist_ok=True)
                folders.add(path.parent)
            write_photograph(path, codes[n], image_kind)
            rep.files.append(rows[i].file)
        rep.n_images += len(idx)
        rep.n_white += sum(rows[i].kind == "white" for i in idx)
        if progress is not None:
            progress(rep.n_images, len(rows))

    for batch in _batches(rows):
        if batch.key == "dark":
            rep.n_dark += len(batch.rows)
            for c in range(0, len(batch.rows), MAX_BATCH_VIEWS):
                emit([(i, 0) for i in batch.rows[c:c + MAX_BATCH_VIEWS]], None)
            continue
        kw = {"views": [direction_from_angles(tv, pv) for tv, pv in batch.views], "size": size,
              "field_mm": field_mm, "spp": opts.spp}
        if batch.key == "white":
            scene = white_scene(mi, cr, opts.white_albedo, **kw)
        else:
            if isinstance(batch.key, str):  # pragma: no cover - dark and white are handled above
                continue
            kappa, uv = batch.key
            st = stand_for(stand_list, float(kappa))
            origin = (0.0, 0.0) if uv is None else uv
            if reg is not None and uv is None:
                origin = next((e["u_mm"], e["v_mm"]) for e in reg["stands"] if e["kappa"] == st.kappa)
            scene = stand_scene(mi, cr, table, st, origin_uv_mm=origin, **kw)
        params = mi.traverse(scene)
        for light, members in batch.lights.items():
            params["light.to_world"] = light_to_world(mi, direction_from_angles(*light))
            params.update()
            # one launch photographs every view of the batch under this light
            film = np.asarray(mi.render(scene, seed=(seed * 1000003 + members[0][0]) % 2**32),  # type: ignore[arg-type]
                              dtype=np.float64)
            emit(members, film)
        del scene, params
    rep.seconds_rendering = time.perf_counter() - t0
    return rep


#: Most cameras (view directions) on one film: one launch renders that many photographs.
MAX_BATCH_VIEWS = 96


@dataclass
class _Batch:
    """Rows photographed with one scene: ``key`` (a stand's kappa, ``"white"`` or ``"dark"``),
    its cameras' ``views`` (``(theta_v, phi_v)``, degrees) and, per light ``(theta_l, phi_l)``,
    the ``(row index, camera slot)`` pairs it photographs."""

    key: tuple[float, tuple[float, float] | None] | str
    rows: list[int] = field(default_factory=list)
    views: list[tuple[float, float]] = field(default_factory=list)
    lights: dict[tuple[float, float], list[tuple[int, int]]] = field(default_factory=dict)


def _batches(rows: Sequence[CaptureRow]) -> list[_Batch]:
    """Group a capture's rows into :class:`_Batch` es: per scene, at most :data:`MAX_BATCH_VIEWS` views each.

    Rows of one scene with the same view and light (exposure brackets) share
    one rendering; each still gets its own exposure and noise.
    """
    by_scene: dict[tuple[float, tuple[float, float] | None] | str, list[int]] = {}
    for i, r in enumerate(rows):  # a stand, and where the fabric lies on it (a scan's rows: u_mm, v_mm)
        by_scene.setdefault(r.kind if r.kind in ("dark", "white") else (float(r.kappa), r.uv_mm), []).append(i)
    out: list[_Batch] = []
    for key, idx in by_scene.items():
        if key == "dark":
            out.append(_Batch(key, rows=idx))
            continue
        views = list(dict.fromkeys((rows[i].theta_v, rows[i].phi_v) for i in idx))
        for c in range(0, len(views), MAX_BATCH_VIEWS):
            chunk = views[c:c + MAX_BATCH_VIEWS]
            slot = {v: j for j, v in enumerate(chunk)}
            b = _Batch(key, views=chunk)
            for i in idx:
                j = slot.get((rows[i].theta_v, rows[i].phi_v))
                if j is not None:
                    b.rows.append(i)
                    b.lights.setdefault((rows[i].theta_l, rows[i].phi_l), []).append((i, j))
            out.append(b)
    return out


def _scan(path: Path, reg: dict[str, Any], shifts: int) -> None:
    """Photograph every sample row of the plan at ``path`` with the fabric at ``shifts`` positions along u.

    Each sample row becomes ``shifts`` rows (files ``NAME_u0.png`` ...) with
    ``u_mm = u0 + j size_u / shifts`` and ``v_mm = v0`` (``u0, v0``: the
    registration's origin of the row's stand).
    """
    from ..measure.capture import read_rows

    columns, records = read_rows(path)
    su = float(reg["repeat_mm"][0])
    origin = {float(e["kappa"]): (float(e["u_mm"]), float(e["v_mm"])) for e in reg["stands"]}
    out: list[dict[str, str]] = []
    for rec in records:
        if rec.get("kind", "sample") not in ("", "sample"):
            out.append({**rec, "u_mm": "", "v_mm": ""})
            continue
        k = float(rec["kappa"])
        u0, v0 = next(uv for kk, uv in origin.items() if abs(kk - k) <= KAPPA_TOL_PER_MM)
        name = PurePosixPath(rec["file"])
        for j in range(shifts):
            out.append({**rec, "file": str(name.with_name(f"{name.stem}_u{j}{name.suffix}")),
                        "u_mm": repr(round((u0 + j * su / shifts) % su, 6)), "v_mm": repr(v0)})
    write_rows(path, out, [*columns, "u_mm", "v_mm"])


def _copy_plan(plan: Plan, out: Path, ext: str) -> tuple[list[CaptureRow], list[Stand]]:
    """Put a checked plan into ``out`` as the capture table; its rows (as rendered) and the stands.

    The stands come from the plan's ``stands.json`` (when beside it); a
    sample curvature it does not describe gets the default stand.
    """
    rows = _match_extension(plan, ext)
    # the rows as read (never the file read again), with the names as rendered
    write_rows(out / CAPTURE_FILE, plan.records, plan.columns)
    stand_map = dict(plan.stands)
    for k in sorted({r.kappa for r in rows if r.kind == "sample"}):
        if not any(abs(k - s) <= KAPPA_TOL_PER_MM for s in stand_map):
            stand_map[k] = default_stand(k)
    return rows, [stand_map[s] for s in sorted(stand_map)]


def _match_extension(plan: Plan, ext: str) -> list[CaptureRow]:
    """The plan's rows with every file given the extension of the image kind (``a.png`` -> ``a.tif``).

    A plan names its photographs ``.png`` (``cdbrdf plan``'s default): rendered
    as TIFF or EXR they must not be written under a name whose extension
    selects another format. ``plan.records`` get the new names too. Refuses
    renames that would make two rows share a file.
    """
    want = FORMATS["." + ext]
    rows = list(plan.rows)
    changed = False
    for i, r in enumerate(rows):
        if FORMATS.get(Path(r.file).suffix.lower()) != want:
            name = str(PurePosixPath(r.file).with_suffix("." + ext))
            rows[i] = replace(r, file=name)
            plan.records[i]["file"] = name
            changed = True
    if not changed:
        return plan.rows
    seen: dict[str, int] = {}
    for r in rows:
        first = seen.setdefault(file_key(r.file), r.line)
        if first != r.line:
            raise CaptureError(f"{plan.path}: line {r.line}: giving the files the .{ext} extension makes "
                               f"it share {r.file} with line {first}")
    return rows
