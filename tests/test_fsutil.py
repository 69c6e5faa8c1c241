"""File safety: atomic writes, owned folders, sweeping leftovers of killed runs."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from cdbrdf import fsutil


def _dead_pid() -> int:
    p = subprocess.Popen([sys.executable, "-c", "pass"])
    p.wait()
    return p.pid


def _stale_name(dest: Path, kind: str, suffix: str = "") -> Path:
    name = fsutil.temp_sibling(dest, kind).name
    parts = name.split(".")
    # .NAME.<pid>.<host>.<rand>.<kind>: put a dead pid in place of ours
    parts[-4] = str(_dead_pid())
    return dest.with_name(".".join(parts) + suffix)


def test_atomic_path_replaces_only_on_success(tmp_path):
    dest = tmp_path / "out.bin"
    dest.write_bytes(b"old")
    with pytest.raises(RuntimeError):
        with fsutil.atomic_path(dest) as tmp:
            tmp.write_bytes(b"half")
            raise RuntimeError("killed")
    assert dest.read_bytes() == b"old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.bin"]
    with fsutil.atomic_path(dest, suffix=".npz") as tmp:
        assert tmp.name.endswith(".npz")
        tmp.write_bytes(b"new")
    assert dest.read_bytes() == b"new"


@pytest.mark.parametrize("suffix", ["", ".npz", ".png"])
def test_sweep_removes_temporaries_of_dead_runs_only(tmp_path, suffix):
    dest = tmp_path / "out.h5"
    stale = _stale_name(dest, "tmp", suffix)
    stale.write_bytes(b"x")
    live = fsutil.temp_sibling(dest, "tmp")  # this process: alive
    live.write_bytes(b"y")
    other = tmp_path / ".out.h5.not-ours.tmp"
    other.write_bytes(b"z")
    removed = fsutil.sweep_stale(dest)
    assert removed == [stale]
    assert live.exists() and other.exists()


def test_sweep_removes_half_deleted_folders_without_marker(tmp_path):
    dest = tmp_path / "out"
    old = _stale_name(dest, "old")
    (old / "sub").mkdir(parents=True)
    (old / "sub" / "f").write_text("x")  # the marker is already gone
    assert fsutil.sweep_stale(dest) == [old]
    assert not old.exists()


def test_remove_owned_refuses_foreign_folders(tmp_path):
    d = tmp_path / "user"
    d.mkdir()
    (d / "precious.txt").write_text("keep")
    with pytest.raises(FileExistsError, match="not made by cdbrdf"):
        fsutil.remove_owned(d)
    assert (d / "precious.txt").read_text() == "keep"
    fsutil.mark_owned(d, "checkpoint")
    assert fsutil.is_owned(d, "checkpoint") and not fsutil.is_owned(d, "output")
    fsutil.remove_owned(d, "checkpoint")
    assert not d.exists()
    assert list(tmp_path.iterdir()) == []
