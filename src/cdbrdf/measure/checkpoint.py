"""The measurement's checkpoint: results of finished photographs, kept between runs.

A measurement with an output file keeps a folder ``<output>.ckpt``
(:func:`checkpoint_path`) of one ``.npz`` file per batch of photographs,
each written atomically, under a key that identifies the capture and the
options. A later run with the same key reuses every photograph whose size
and modification time are unchanged, so an interrupted run resumes and
gives a bit-identical table. The folder carries cdbrdf's owner mark: a
folder of that name that cdbrdf did not make is never touched.
"""

from __future__ import annotations

import json
import logging
import os
import re
import shutil
from os import PathLike
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..fsutil import atomic_path, sweep_stale, temp_sibling
from ..outputs import OWNER_MARK, is_owned, mark_owned, remove_owned
from .preflight import first_line

__all__ = ["Checkpoint", "checkpoint_path", "CHECKPOINT_VERSION"]

_LOG = logging.getLogger(__name__)

#: Version of the checkpoint layout (part of its key). 2: a batch's patches stacked per
#: channel count (``patches_c<C>``, ``saturated_c<C>``, ``patch_rows_c<C>``) instead of
#: one pair of arrays per photograph (a batch of 1,024 photographs saves in a few ms).
CHECKPOINT_VERSION = 2


def checkpoint_path(output: str | PathLike[str]) -> Path:
    """The checkpoint folder used for an output file: ``<output>.ckpt``."""
    return Path(str(output) + ".ckpt")


_CKPT_KIND = "checkpoint"
_KEY_FILE = "key.json"
_BATCH_RE = re.compile(r"^batch-\d{8}\.npz$")
#: temporaries of :func:`cdbrdf.fsutil.atomic_path` inside a checkpoint: ``.<dest>.<pid>.<host>.<rand>.tmp``
_TEMP_DEST_RE = re.compile(r"^\.(key\.json|batch-\d{8}\.npz)\.\d+\.[0-9a-f]{8}\.[0-9a-f]{8}\.tmp$")


def _read_key(folder: Path) -> object:
    try:
        return json.loads((folder / _KEY_FILE).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None


class Checkpoint:
    """Results of finished images, one ``.npz`` file per batch (each written atomically).

    A result is ``((size, mtime_ns), status, values, saturated, message)``
    under a row index: ``values`` of shape ``shape + (C,)`` (float64) and
    ``saturated`` of ``shape`` (bool) when ``status`` is 0, else None.
    (:mod:`cdbrdf.measure.btf_batches` keeps a sample condition's texels the
    same way, with its own meaning of the pair and of the status.)

    The folder carries cdbrdf's owner mark (:func:`cdbrdf.outputs.mark_owned`);
    a folder of that name without the mark is refused and never touched,
    whatever it holds (names like ``key.json`` or ``batch-*.npz`` prove
    nothing). An unreadable batch is ignored (its photographs are read
    again) with a warning.
    """

    def __init__(self, folder: Path | None, key: str, *, legacy_keys: tuple[str, ...] = (),
                 patch: int = 7, shape: tuple[int, ...] | None = None) -> None:
        self.folder = folder
        self.key = key
        #: the shape of each result's values without their channels: ``(patch, patch)`` unless given
        #: (measure --btf: the texels ``(n_v, n_u)``)
        self.shape = (patch, patch) if shape is None else tuple(int(x) for x in shape)
        self.done: dict[int, tuple[tuple[int, int], int, NDArray | None, NDArray | None, str]] = {}
        #: the folder was created by this object (not resumed), and batches it saved since
        self.created = False
        self.saved = 0
        if folder is None:
            return
        self._sweep_leftovers()
        accepted = [{"key": k, "version": CHECKPOINT_VERSION} for k in (key, *legacy_keys)]
        if folder.exists() or folder.is_symlink():
            if not is_owned(folder, _CKPT_KIND):
                # whatever it holds (even only a key.json or batch files, or nothing): not ours to delete
                raise FileExistsError(
                    f"{folder}: exists and is not a checkpoint made by cdbrdf measure (it has no "
                    f"{OWNER_MARK} mark) and is left untouched; move it away (or delete it if it is a "
                    "checkpoint of an older cdbrdf), or choose another output name"
                )
            if _read_key(folder) not in accepted:
                _LOG.warning("%s: checkpoint of a different run; starting afresh", folder)
                remove_owned(folder, _CKPT_KIND)
        if folder.is_dir():
            for f in sorted(folder.iterdir()):
                if _BATCH_RE.match(f.name):
                    self._load(f)
            if _read_key(folder) != accepted[0]:
                self._write_key()
        else:
            # made complete (marked, keyed) under a pid-tagged name, then renamed: a run killed
            # half-way leaves a temporary that the next run sweeps, never an unmarked OUT.ckpt
            tmp = temp_sibling(folder, "partial")
            tmp.mkdir()
            try:
                mark_owned(tmp, _CKPT_KIND)
                with atomic_path(tmp / _KEY_FILE) as key_tmp:
                    key_tmp.write_text(json.dumps({"key": self.key, "version": CHECKPOINT_VERSION}),
                                       encoding="utf-8")
                os.rename(tmp, folder)
            except BaseException:
                shutil.rmtree(tmp, ignore_errors=True)
                raise
            self.created = True

    def _sweep_leftovers(self) -> None:
        """Remove what killed runs left: temporaries inside, half-removed checkpoints beside.

        :func:`cdbrdf.outputs.remove_owned` renames the folder to a temporary
        name (``.NAME.<pid>...old``) before deleting it; a run killed then
        leaves that folder, maybe without its marker, which
        :func:`cdbrdf.fsutil.sweep_stale` removes once its process is gone.
        """
        assert self.folder is not None
        folder = self.folder
        sweep_stale(folder)
        if is_owned(folder, _CKPT_KIND):
            dests = set()
            for p in folder.iterdir():
                m = _TEMP_DEST_RE.match(p.name)
                if m:
                    dests.add(m[1])
            for d in sorted(dests):
                sweep_stale(folder / d)

    def _write_key(self) -> None:
        assert self.folder is not None
        with atomic_path(self.folder / _KEY_FILE) as tmp:
            tmp.write_text(json.dumps({"key": self.key, "version": CHECKPOINT_VERSION}), encoding="utf-8")

    def _load(self, f: Path) -> None:
        """Add one batch; an unreadable or inconsistent batch is ignored (and deleted)."""
        shape = self.shape
        got = {}
        try:
            with open(f, "rb") as fh, np.load(fh, allow_pickle=False) as z:
                rows, stats, status, msgs = z["rows"], z["stats"], z["status"], z["messages"]
                k = rows.shape[0] if rows.ndim == 1 else -1
                if k < 1 or stats.shape != (k, 2) or status.shape != (k,) or msgs.shape != (k,) \
                        or rows.dtype.kind != "i" or stats.dtype.kind != "i" or status.dtype.kind != "i":
                    raise ValueError("arrays of inconsistent shapes or types")
                patches: dict[int, tuple[NDArray, NDArray]] = {}
                for name in z.files:
                    m = re.fullmatch(r"patch_rows_c(\d+)", name)
                    if m is None:
                        continue
                    c = int(m[1])
                    prow, v, sat = z[name], z[f"patches_c{c}"], z[f"saturated_c{c}"]
                    if prow.ndim != 1 or prow.dtype.kind != "i" or v.shape != (prow.size, *shape, c) \
                            or v.dtype != np.float64 or c < 1 or sat.shape != (prow.size, *shape) \
                            or sat.dtype != np.bool_:
                        raise ValueError(f"patches {name} of shape {v.shape} {v.dtype}")
                    for q, r in enumerate(prow.tolist()):
                        patches[r] = (v[q], sat[q])
                for j, r in enumerate(rows.tolist()):
                    st = int(status[j])
                    if st not in (0, 1, 2):
                        raise ValueError(f"status {st} of row {r}")
                    v = s = None
                    if st == 0:
                        if r not in patches:
                            raise ValueError(f"no patch for row {r}")
                        v, s = patches[r]
                    got[r] = ((int(stats[j, 0]), int(stats[j, 1])), st, v, s, str(msgs[j]))
        except Exception as exc:  # noqa: BLE001 - any damage: read the photographs again
            _LOG.warning("%s: unreadable checkpoint batch ignored, its photographs are read again (%s: %s)",
                         f, type(exc).__name__, first_line(exc))
            f.unlink(missing_ok=True)
            return
        self.done.update(got)

    def add(self, results: dict[int, tuple[tuple[int, int], int, NDArray | None, NDArray | None, str]]) -> None:
        """Record results and, with a folder, save them as one batch.

        ``results``: per row index, ``((size, mtime_ns), status, values,
        saturated, message)``.
        """
        self.done.update(results)
        if self.folder is None or not results:
            return
        rows = sorted(results)
        arrays: dict[str, Any] = {
            "rows": np.array(rows, dtype=np.int64),
            "stats": np.array([results[r][0] for r in rows], dtype=np.int64).reshape(-1, 2),
            "status": np.array([results[r][1] for r in rows], dtype=np.int8),
            "messages": np.array([results[r][4] for r in rows], dtype=str),
        }
        by_channels: dict[int, list[int]] = {}
        for r in rows:
            if results[r][1] == 0:
                by_channels.setdefault(int(results[r][2].shape[-1]), []).append(r)  # type: ignore[union-attr]
        for c, rs in by_channels.items():
            arrays[f"patch_rows_c{c}"] = np.array(rs, dtype=np.int64)
            arrays[f"patches_c{c}"] = np.stack([results[r][2] for r in rs])  # type: ignore[misc]
            arrays[f"saturated_c{c}"] = np.stack([results[r][3] for r in rs])  # type: ignore[misc]
        with atomic_path(self.folder / f"batch-{rows[0]:08d}.npz") as tmp:
            with open(tmp, "wb") as fh:
                np.savez(fh, **arrays)
        self.saved += 1

    def discard_if_empty(self) -> None:
        """Delete the folder if this run created it and saved nothing in it (a run that failed at once)."""
        if self.folder is not None and self.created and not self.saved:
            remove_owned(self.folder, _CKPT_KIND)

    def remove(self) -> None:
        """Delete the checkpoint folder (once the output is written)."""
        if self.folder is not None:
            remove_owned(self.folder, _CKPT_KIND)
