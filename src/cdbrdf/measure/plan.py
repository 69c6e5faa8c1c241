"""Writing capture plans: the rows of ``capture.csv`` for a grid and its stands, exposure brackets, the file.

The format is :mod:`cdbrdf.measure.capture`'s (its columns, row rules and
file names); this module writes it: :func:`plan_rows` (one row per sample,
named ``k<i>/l<theta_l>_<phi_l>_v<theta_v>_<phi_v>.<ext>``, its ``hidden``
mark from the stand geometry, white-reference rows), :func:`bracket_rows`
(exposure brackets), :func:`write_rows` and :func:`write_plan`
(``capture.csv`` and ``stands.json`` of a new capture folder), as
``cdbrdf plan`` and the simulated rig use them.
"""

from __future__ import annotations

import csv
from collections.abc import Mapping, Sequence
from os import PathLike
from pathlib import Path
from typing import Any

from ..errors import CaptureError, OptionError
from ..fsutil import atomic_path, check_output_file
from ..table import Grid
from .capture import CAPTURE_FILE, HIDDEN_NAMES, PLAN_COLUMNS, STAND_FILE, check_duplicates, check_file_name
from .stands import Stand, hidden_mask, write_stands

__all__ = ["plan_rows", "bracket_rows", "write_rows", "write_plan"]


# --------------------------------------------------------------------------- writing
def _fmt(x: float) -> str:
    return f"{x:g}"


def plan_rows(
    grid: Grid,
    stands: Sequence[Stand],
    *,
    extension: str = "png",
    white: bool = True,
    pixel_mm: float = 0.0,
    patch_px: int = 7,
) -> list[dict[str, Any]]:
    """The rows of a capture plan, in table order (kappa, phi_l, theta_l, phi_v, theta_v).

    Each sample row names its photograph ``k<i>/l<theta_l>_<phi_l>_v<theta_v>_<phi_v>.<ext>``
    and says in ``hidden`` whether (and how) its stand hides it. With
    ``white`` one white-reference row per light direction follows, with the
    camera along the normal (``white/l<theta_l>_<phi_l>.<ext>``, blank kappa).
    """
    ext = extension.lstrip(".").lower() if isinstance(extension, str) else ""
    if f".{ext}" not in (".png", ".tif", ".tiff", ".exr"):
        raise OptionError(f"extension: {extension!r:.40} is not one of png, tif, tiff, exr")
    hid = hidden_mask(grid, stands, pixel_mm=pixel_mm, patch_px=patch_px)
    rows: list[dict[str, Any]] = []
    for k, kappa in enumerate(grid.kappa):
        for a, pl in enumerate(grid.phi_l):
            for b, tl in enumerate(grid.theta_l):
                for c, pv in enumerate(grid.phi_v):
                    for d, tv in enumerate(grid.theta_v):
                        rows.append({
                            "file": f"k{k}/l{_fmt(tl)}_{_fmt(pl)}_v{_fmt(tv)}_{_fmt(pv)}.{ext}",
                            "kappa": _fmt(kappa),
                            "theta_v": _fmt(tv), "phi_v": _fmt(pv),
                            "theta_l": _fmt(tl), "phi_l": _fmt(pl),
                            "exposure": "1", "kind": "sample",
                            "hidden": HIDDEN_NAMES[int(hid[k, a, b, c, d])],
                        })
    if white:
        for pl in grid.phi_l:
            for tl in grid.theta_l:
                rows.append({
                    "file": f"white/l{_fmt(tl)}_{_fmt(pl)}.{ext}", "kappa": "",
                    "theta_v": _fmt(grid.theta_v[0]), "phi_v": _fmt(grid.phi_v[0]),
                    "theta_l": _fmt(tl), "phi_l": _fmt(pl),
                    "exposure": "1", "kind": "white", "hidden": "",
                })
    return rows


def bracket_rows(rows: Sequence[Mapping[str, Any]], exposures: Sequence[float]) -> list[dict[str, Any]]:
    """Repeat every sample and white row once per exposure (``..._e<i>`` file names).

    Row ``j`` of a bracket gets the file name ``<stem>_e<j>.<ext>`` and the
    exposure ``exposures[j]``; other rows (dark frames) are kept as they are.
    """
    out = []
    for r in rows:
        if r["kind"] not in ("sample", "white"):
            out.append(dict(r))
            continue
        stem, dot, ext = r["file"].rpartition(".")
        for j, e in enumerate(exposures):
            rr = dict(r)
            rr["file"] = f"{stem}_e{j}.{ext}"
            rr["exposure"] = f"{float(e):g}"
            out.append(rr)
    return out


def write_rows(path: str | PathLike[str], rows: Sequence[Mapping[str, Any]],
               columns: Sequence[str] = PLAN_COLUMNS) -> None:
    """Write ``rows`` (dicts keyed by column) as a ``capture.csv`` with the header ``columns``.

    Each row's ``file`` must be a relative path inside the capture folder,
    and no two rows may name the same photograph (the rules of
    :func:`read_capture`): :class:`CaptureError` naming the line otherwise,
    before anything is written. The file is written atomically
    (:func:`cdbrdf.fsutil.atomic_path`: never over a device or a FIFO).
    """
    names = []
    for line, r in enumerate(rows, start=2):
        fname = str(r.get("file") or "").strip()
        where = f"{path}: line {line}"
        if not fname:
            raise CaptureError(f"{where}: column 'file' is empty")
        check_file_name(where, fname)
        names.append((line, fname))
    check_duplicates(Path(path), names)
    with atomic_path(path) as tmp, open(tmp, "w", newline="", encoding="utf-8") as fh:
        w = csv.DictWriter(fh, fieldnames=list(columns))
        w.writeheader()
        w.writerows(rows)


def write_plan(
    folder: str | PathLike[str],
    grid: Grid,
    stands: Sequence[Stand],
    *,
    extension: str = "png",
    white: bool = True,
    pixel_mm: float = 0.0,
    patch_px: int = 7,
    exposures: Sequence[float] = (1.0,),
) -> list[dict[str, Any]]:
    """Write ``capture.csv`` and ``stands.json`` into ``folder`` (created if needed).

    Parameters
    ----------
    folder
        The capture folder.
    grid
        The samples to photograph.
    stands
        One stand per curvature of ``grid``.
    extension
        The photographs' file type.
    white
        Also plan a white frame per light direction.
    pixel_mm
        Written to ``stands.json`` when > 0; the hidden marks then cover the
        whole ``patch_px`` patch (:func:`hidden_mask`).
    patch_px
        The patch's side, pixels.
    exposures
        Relative exposure times; more than the single exposure 1 make each
        sample and white photograph a bracket (:func:`bracket_rows`).

    Returns
    -------
    list of dict
        The rows written to ``capture.csv``.
    """
    out = Path(folder)
    out.mkdir(parents=True, exist_ok=True)
    for name in (CAPTURE_FILE, STAND_FILE):
        check_output_file(out / name)  # before either is written
    rows = plan_rows(grid, stands, extension=extension, white=white, pixel_mm=pixel_mm,
                     patch_px=patch_px)
    if len(exposures) != 1 or float(exposures[0]) != 1.0:
        rows = bracket_rows(rows, exposures)
    write_rows(out / CAPTURE_FILE, rows)
    extra = {"pixel_mm": float(pixel_mm)} if pixel_mm else {}
    write_stands(out / STAND_FILE, stands, **extra)
    return rows
