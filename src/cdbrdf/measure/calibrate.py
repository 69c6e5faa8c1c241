"""From the patches of the photographs to the table: dark frames, brackets, white reference, fill.

:func:`assemble` is the last stage of :func:`cdbrdf.measure.measure`: for
every sample it merges the brackets of its photographs
(:func:`cdbrdf.measure.patch.merge_exposures`, dark frames of the same or
the nearest exposure subtracted), divides by ``cos(theta_l)``, scales by the
nearest white reference (``quantity = "brdf"``) and fills the invalid
samples by a method of :data:`cdbrdf.measure.fill.FILL_METHODS`
(:func:`cdbrdf.measure.fill.fill`); it also counts what happened in a
:class:`MeasureReport`. ``docs/capture.md`` states the rules.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..errors import CaptureError, TableError
from ..frames import direction_from_angles
from ..table import CDBRDF
from .capture import Capture, CaptureRow
from .fill import DEFAULT_FILL, angle_between_deg, check_fill_method, fill, fill_provenance
from .patch import merge_exposures, patch_statistics
from .stands import KAPPA_TOL_PER_MM

__all__ = ["MeasureReport", "assemble", "merged", "calibration"]

_LOG = logging.getLogger(__name__)


@dataclass
class MeasureReport:
    """What a measurement did (printed by ``cdbrdf measure``).

    Attributes
    ----------
    n_samples, n_measured, n_filled
        Samples of the table: all, measured, filled.
    n_hidden, n_saturated, n_not_photographed, n_skipped_samples
        Samples filled because a stand hides them, every photograph saturated,
        no row photographs them, or their photographs were skipped.
    n_images, n_images_resumed, n_white, n_dark
        Photographs read (of them from a checkpoint), white references, dark frames.
    quantity
        ``"brdf"`` with a white reference, else ``"relative"``.
    fill_method
        The fill method used.
    n_filled_by
        Filled samples per fill method.
    skipped_files
        ``(file, reason)`` of every photograph skipped.
    """

    n_samples: int = 0
    n_measured: int = 0
    n_filled: int = 0
    n_hidden: int = 0
    n_saturated: int = 0
    n_not_photographed: int = 0
    n_skipped_samples: int = 0
    n_images: int = 0
    n_images_resumed: int = 0
    n_white: int = 0
    n_dark: int = 0
    quantity: str = "relative"
    fill_method: str = DEFAULT_FILL
    n_filled_by: dict[str, int] = field(default_factory=dict)
    skipped_files: list[tuple[str, str]] = field(default_factory=list)

    def summary(self) -> str:
        """A few human-readable lines.

        Returns
        -------
        str
            The report as text.
        """
        lines = [
            f"{self.n_images} photographs used ({self.n_images_resumed} from the checkpoint), "
            f"{self.n_white} white reference(s), {self.n_dark} dark frame(s); quantity {self.quantity}",
            f"{self.n_samples} samples: {self.n_measured} measured, {self.n_filled} filled "
            f"({self.n_hidden} hidden by the stand, {self.n_saturated} saturated, "
            f"{self.n_skipped_samples} unreadable, {self.n_not_photographed} not photographed)",
        ]
        if self.n_filled:
            by = self.n_filled_by
            along = by.get("kappa_fit", 0) + by.get("nearest_stand", 0) + by.get("model", 0)
            lines.append(
                f"filled by {self.fill_method}: {along} from the same direction on other stands "
                f"({by.get('model', 0)} by the fitted fabric model's change with curvature, "
                f"{by.get('kappa_fit', 0)} fitted along the curvature, {by.get('nearest_stand', 0)} copied), "
                f"{by.get('nearest', 0)} from the nearest measured direction at the same curvature"
            )
        if self.skipped_files:
            lines.append(f"{len(self.skipped_files)} file(s) skipped:")
            lines += [f"  {f}: {why}" for f, why in self.skipped_files[:20]]
            if len(self.skipped_files) > 20:
                lines.append(f"  ... and {len(self.skipped_files) - 20} more")
        return "\n".join(lines)


def _nearest_white(cap: Capture, samples: list[CaptureRow], whites: list[tuple[CaptureRow, NDArray]]
                   ) -> NDArray[np.intp]:
    """For each sample row, the index into ``whites`` of the white reference that calibrates it.

    The nearest in ``angle(view) + angle(light)`` (degrees; ties within 1e-9
    to the first) among the references without a curvature or of the
    sample's curvature.

    Raises
    ------
    CaptureError
        When no white reference applies to a sample's curvature.
    """
    w_rows = [r for r, _ in whites]
    w_view = direction_from_angles(np.array([r.theta_v for r in w_rows]), np.array([r.phi_v for r in w_rows]))
    w_light = direction_from_angles(np.array([r.theta_l for r in w_rows]), np.array([r.phi_l for r in w_rows]))
    w_any = np.array([math.isnan(r.kappa) for r in w_rows])
    w_kappa = np.array([0.0 if math.isnan(r.kappa) else r.kappa for r in w_rows])
    out = np.empty(len(samples), dtype=np.intp)
    for start in range(0, len(samples), 4096):  # (samples x whites) distances a block at a time
        block = samples[start:start + 4096]
        view = direction_from_angles(np.array([r.theta_v for r in block]), np.array([r.phi_v for r in block]))
        light = direction_from_angles(np.array([r.theta_l for r in block]), np.array([r.phi_l for r in block]))
        d = (angle_between_deg(view[:, None, :], w_view[None, :, :])
             + angle_between_deg(light[:, None, :], w_light[None, :, :]))
        kappa = np.array([r.kappa for r in block])
        applies = w_any[None, :] | (np.abs(w_kappa[None, :] - kappa[:, None]) <= KAPPA_TOL_PER_MM)
        d = np.where(applies, d, np.inf)
        none = ~np.isfinite(d).any(axis=1)
        if none.any():
            raise CaptureError(f"{cap.folder}: no white reference applies to kappa {kappa[np.argmax(none)]:g}")
        out[start:start + len(block)] = np.argmax(d <= d.min(axis=1, keepdims=True) + 1e-9, axis=1)
    return out


def merged(cap: Capture, idx: list[int], results: dict, darks: dict[float, NDArray] | None
           ) -> tuple[NDArray, NDArray, bool, list[int]] | None:
    """Merge the readable rows ``idx`` (the brackets of one condition); None when none is readable.

    Parameters
    ----------
    cap
        The capture (for the rows' exposures).
    idx
        Row indices of one condition (:meth:`~cdbrdf.measure.capture.Capture.brackets`).
    results
        Per row: ``(status, values, saturated, message)``; status 0 = read.
    darks
        Mean dark patch by exposure; each row uses the nearest in log ratio.

    Returns
    -------
    tuple or None
        ``(mean, std, good, rows used)``: the patch mean and standard
        deviation of the merged radiance, whether it is not saturated.
    """
    ok = [i for i in idx if results.get(i, (1,))[0] == 0]
    if not ok:
        return None
    vals = [results[i][1] for i in ok]
    sats = [results[i][2] for i in ok]
    exps = [cap.rows[i].exposure for i in ok]
    dk = None
    if darks:
        keys = np.array(sorted(darks))
        dk = [darks[float(keys[np.argmin(np.abs(np.log(keys / e)))])] for e in exps]
    rad, valid = merge_exposures(vals, sats, exps, dk)
    mean, std, good = patch_statistics(rad, valid)
    return mean, std, good, ok


def calibration(cap: Capture, results: dict, rep: MeasureReport
                ) -> tuple[dict[float, NDArray], list[tuple[CaptureRow, NDArray]]]:
    """The dark frames and the white references of a measurement (counted in ``rep``).

    Parameters
    ----------
    cap
        The parsed capture folder.
    results
        Per row index: ``(status, values, saturated, message)`` (the N x N patches).
    rep
        The report: ``n_dark``, ``n_white`` and ``quantity`` are set.

    Returns
    -------
    darks : dict
        Exposure -> mean dark patch.
    whites : list
        ``(first row, W)`` per white-reference geometry, ``W`` its patch mean
        over ``cos(theta_l)`` per channel.

    Raises
    ------
    CaptureError
        For a black white reference.
    """
    rows = cap.rows
    # dark frames by exposure (mean of the frames of one exposure)
    dark_groups: dict[float, list[int]] = {}
    for i, r in enumerate(rows):
        if r.kind == "dark" and results.get(i, (1,))[0] == 0:
            dark_groups.setdefault(r.exposure, []).append(i)
    darks = {e: np.mean([results[i][1] for i in g], axis=0) for e, g in dark_groups.items()}
    rep.n_dark = sum(len(g) for g in dark_groups.values())

    # white references: W = mean / cos(theta_l) per geometry
    whites: list[tuple[CaptureRow, NDArray]] = []
    for idx in cap.brackets("white").values():
        m = merged(cap, idx, results, darks)
        if m is None:
            continue
        mean, _std, good, ok = m
        r = rows[idx[0]]
        if not good:
            _LOG.warning("white reference %s is saturated; not used", r.file)
            continue
        w = mean / math.cos(math.radians(r.theta_l))
        if np.any(w <= 0):
            raise CaptureError(f"{cap.folder / r.file}: white reference is black (after dark subtraction)")
        whites.append((r, w))
        rep.n_white += len(ok)
    if whites:
        rep.quantity = "brdf"
    return darks, whites


def assemble(cap: Capture, results: dict, *, albedo: float, patch: int, linear: bool,
             material: str | None, fill_method: str = DEFAULT_FILL) -> tuple[CDBRDF, MeasureReport]:
    """The table and the report of a measurement from the patches of its photographs.

    Parameters
    ----------
    cap
        The parsed capture folder.
    results
        Per row index: ``(status, values, saturated, message)`` (status 0 =
        read, 1 = missing, 2 = unusable); rows absent were not read.
    albedo
        Albedo of the white reference (Lambertian).
    patch
        Patch size N (for the provenance).
    linear
        Whether integer images were taken as linear (for the provenance).
    material
        Material name (default: ``stands.json``'s, else the folder's name).
    fill_method
        How invalid samples are filled: a method of
        :data:`cdbrdf.measure.fill.FILL_METHODS` (``"nearest"`` is the
        paper's rule).

    Returns
    -------
    table : CDBRDF
    report : MeasureReport

    Raises
    ------
    CaptureError
        Photographs of different channel counts, a black white reference, no
        white reference for a curvature, or nothing to fill a sample from.
    ValueError
        For an unknown fill method (the message lists them).
    """
    fill_method = check_fill_method(fill_method)
    grid = cap.grid
    rep = MeasureReport()
    rows = cap.rows
    for i, (status, _v, _s, msg) in sorted(results.items()):
        if status != 0:
            rep.skipped_files.append((rows[i].file, msg))
    chans = {results[i][1].shape[-1] for i in results if results[i][0] == 0}
    if len(chans) > 1:
        raise CaptureError(f"{cap.folder}: photographs have different channel counts {sorted(chans)}")
    nc = chans.pop() if chans else 3

    darks, whites = calibration(cap, results, rep)

    values = np.full(grid.shape + (nc,), np.nan)
    std = np.full(grid.shape + (nc,), np.nan)
    valid = np.zeros(grid.shape, dtype=bool)
    photographed = np.zeros(grid.shape, dtype=bool)
    skipped = np.zeros(grid.shape, dtype=bool)
    saturated = np.zeros(grid.shape, dtype=bool)
    n_used = 0
    good_rows: list[tuple[Any, NDArray, NDArray, CaptureRow]] = []  # (sample index, mean, std, first row)
    for idx in cap.brackets("sample").values():
        sidx = cap.sample_index[idx[0]]
        photographed[sidx] = True
        if cap.hidden[sidx]:
            continue
        m = merged(cap, idx, results, darks)
        if m is None:
            skipped[sidx] = True
            continue
        mean, sd, good, ok = m
        n_used += len(ok)
        if not good:
            saturated[sidx] = True
            continue
        good_rows.append((sidx, mean, sd, rows[idx[0]]))
    white_of = _nearest_white(cap, [r for *_, r in good_rows], whites) if whites else None
    for n, (at, mean, sd, r) in enumerate(good_rows):
        scale = np.full(nc, 1.0 / math.cos(math.radians(r.theta_l)))
        if white_of is not None:
            scale = scale / whites[white_of[n]][1] * (albedo / math.pi)
        values[at] = mean * scale
        std[at] = sd * scale
        valid[at] = True

    rep.n_samples = int(np.prod(grid.shape))
    rep.n_measured = int(valid.sum())
    rep.n_filled = rep.n_samples - rep.n_measured
    rep.n_hidden = int(cap.hidden.sum())
    rep.n_saturated = int(saturated.sum())
    rep.n_skipped_samples = int(skipped.sum())
    rep.n_not_photographed = int((~photographed).sum())
    rep.n_images = n_used + rep.n_white + rep.n_dark
    try:
        result = fill(values, valid, grid, method=fill_method, std=std,
                      material=material or cap.settings.get("material"))
    except TableError as exc:
        raise CaptureError(f"{cap.folder}: {exc}") from None
    rep.fill_method = fill_method
    rep.n_filled_by = {k: v for k, v in result.summary["samples"].items() if k != "measured"}

    provenance: dict[str, Any] = {
        "method": "measured",
        "capture": cap.folder.resolve().name,
        "capture_sha256": cap.digest,
        "patch_px": patch,
        # the patch's side at the stand, mm: the default neighbourhood of mesh curvatures
        "patch_mm": patch * float(cap.settings["pixel_mm"]) if cap.settings.get("pixel_mm") else None,
        "encoding": "linear" if linear else "srgb (unless the capture says linear)",
        "white_reference": bool(whites),
        "white_albedo": albedo if whites else None,
        "dark_frames": rep.n_dark,
        "stand_geometry": [s.to_dict() for s in cap.stands.values()] if cap.stands else None,
        "n_hidden": rep.n_hidden,
        "n_saturated": rep.n_saturated,
        "skipped_files": [f for f, _ in rep.skipped_files[:100]],
    }
    if cap.extra_columns:
        prov_cols: dict[str, Any] = {}
        for col in cap.extra_columns:
            uniq = sorted({r.extra.get(col, "") for r in rows})
            prov_cols[col] = uniq if len(uniq) <= 20 else f"{len(uniq)} distinct values"
        provenance["extra_columns"] = prov_cols
    mat = material or cap.settings.get("material") or cap.folder.resolve().name
    attrs = {"quantity": rep.quantity, "material": str(mat), "provenance": provenance,
             "channels": ["R", "G", "B"] if nc == 3 else ["Y"]}
    table = CDBRDF(result.values, grid, std=result.std, attrs=fill_provenance(attrs, result),
                   provenance=result.provenance())
    return table, rep
