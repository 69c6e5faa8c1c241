"""Checkpoints (cdbrdf.measure.checkpoint): interrupted runs resume bit-identically; damaged or foreign folders."""

from __future__ import annotations

import numpy as np
import pytest

import cdbrdf
from cdbrdf.cli import main
from cdbrdf.measure import MeasurementInterrupted, measure
from cdbrdf.measure.checkpoint import checkpoint_path

from .measure_helpers import (
    GRID,
    SMALL,
    WHITE,
    kill_after_first_batch,
    make_capture,
    pixel,
    same_tables,
    write_image,
)


def test_interrupt_and_resume_is_bit_identical(tmp_path):
    make_capture(tmp_path / "cap", GRID, pixel, kind="png16", white=WHITE)
    ref, _ = measure(tmp_path / "cap", tmp_path / "ref.h5")
    out = tmp_path / "out.h5"
    with pytest.raises(MeasurementInterrupted):
        measure(tmp_path / "cap", out, batch_size=8, _interrupt_after=20)
    assert not out.exists() and checkpoint_path(out).is_dir()
    table, rep = measure(tmp_path / "cap", out, batch_size=8)
    assert rep.n_images_resumed == 24
    assert out.exists() and not checkpoint_path(out).exists()
    same_tables(table, ref)
    same_tables(cdbrdf.load(out), cdbrdf.load(tmp_path / "ref.h5"))


def test_checkpoint_of_other_options_is_discarded(tmp_path):
    make_capture(tmp_path / "cap", GRID, pixel, kind="png16")
    out = tmp_path / "out.h5"
    with pytest.raises(MeasurementInterrupted):
        measure(tmp_path / "cap", out, batch_size=8, _interrupt_after=8)
    table, rep = measure(tmp_path / "cap", out, patch=5)
    assert rep.n_images_resumed == 0


def test_changed_image_is_read_again(tmp_path):
    rows = make_capture(tmp_path / "cap", GRID, pixel, kind="exr")
    out = tmp_path / "out.h5"
    with pytest.raises(MeasurementInterrupted):
        measure(tmp_path / "cap", out, batch_size=8, _interrupt_after=8)
    write_image(tmp_path / "cap" / rows[0]["file"], np.full((15, 15, 3), 0.01), "exr")
    table, rep = measure(tmp_path / "cap", out)
    assert rep.n_images_resumed == 7
    assert table.values[0, 0, 0, 0, 0, 0] == pytest.approx(0.01, rel=1e-6)


def test_killed_process_resumes(tmp_path):
    """SIGKILL a measuring process after its first checkpointed batch; the rerun resumes."""
    make_capture(tmp_path / "cap", GRID, pixel, kind="png16", white=WHITE)
    ref, _ = measure(tmp_path / "cap")
    out = tmp_path / "out.h5"
    assert kill_after_first_batch(tmp_path / "cap", out, batch_size=6, num_workers=1) >= 1
    assert not out.exists()
    table, rep = measure(tmp_path / "cap", out)
    assert rep.n_images_resumed >= 6
    same_tables(table, ref)


# --------------------------------------------------------------------------- checkpoint folders
def _interrupted(tmp_path, after=8):
    make_capture(tmp_path / "cap", GRID, pixel, kind="png16", white=WHITE)
    out = tmp_path / "out.h5"
    with pytest.raises(MeasurementInterrupted):
        measure(tmp_path / "cap", out, batch_size=8, _interrupt_after=after)
    return out, checkpoint_path(out)


def test_foreign_checkpoint_folder_is_never_deleted(tmp_path, capsys):
    make_capture(tmp_path / "cap", SMALL, pixel, kind="exr", size=9)
    out = tmp_path / "out.h5"
    ck = checkpoint_path(out)
    ck.mkdir()
    (ck / "thesis.tex").write_text("years of work")
    with pytest.raises(FileExistsError, match=r"out.h5.ckpt: exists and is not a checkpoint made by cdbrdf"):
        measure(tmp_path / "cap", out)
    assert (ck / "thesis.tex").read_text() == "years of work" and not out.exists()
    assert main(["-q", "measure", str(tmp_path / "cap"), "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "out.h5.ckpt" in err
    assert (ck / "thesis.tex").read_text() == "years of work"
    # a file of that name is not touched either
    (ck / "thesis.tex").unlink()
    ck.rmdir()
    ck.write_text("notes")
    with pytest.raises(FileExistsError, match="not a checkpoint"):
        measure(tmp_path / "cap", out)
    assert ck.read_text() == "notes"


def test_checkpoint_is_marked_and_removed(tmp_path):
    from cdbrdf.outputs import is_owned

    out, ck = _interrupted(tmp_path)
    assert is_owned(ck, "checkpoint")
    measure(tmp_path / "cap", out)
    assert not ck.exists() and not [p for p in tmp_path.iterdir() if p.name.startswith(".")]


@pytest.mark.parametrize("content", [{}, {"key.json": b'{"my": "settings"}'}, {"batch-00000000.npz": b"data"},
                                     {"key.json": b"{}", "batch-00000000.npz": b"x", ".batch-abc.npz": b"y"}],
                         ids=["empty", "key.json", "batch", "all"])
def test_folder_without_owner_mark_is_refused_whatever_it_holds(tmp_path, capsys, content):
    """A user's OUT.ckpt folder is never adopted as a checkpoint (nor deleted), even if its names look like one."""
    make_capture(tmp_path / "cap", SMALL, pixel, kind="exr", size=9)
    out = tmp_path / "out.h5"
    ck = checkpoint_path(out)
    ck.mkdir()
    for name, data in content.items():
        (ck / name).write_bytes(data)
    with pytest.raises(FileExistsError, match=r"out.h5.ckpt: exists and is not a checkpoint made by cdbrdf "
                                              r"measure \(it has no \.cdbrdf-owned mark\)"):
        measure(tmp_path / "cap", out)
    assert main(["-q", "measure", str(tmp_path / "cap"), "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "out.h5.ckpt" in err and "move it away" in err
    assert {p.name: p.read_bytes() for p in ck.iterdir()} == content
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cap", "out.h5.ckpt"]


def test_half_removed_checkpoint_of_a_killed_run_is_swept(tmp_path):
    """remove_owned renames before deleting: a dead run's ``.out.h5.ckpt.<pid>...old`` goes, marker or not."""
    import subprocess
    import sys

    from cdbrdf.fsutil import temp_sibling
    from cdbrdf.outputs import OWNER_MARK

    out, ck = _interrupted(tmp_path, after=16)
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                          capture_output=True, text=True, check=True)
    old = temp_sibling(ck, "old")
    old = old.with_name(old.name.replace(f".{__import__('os').getpid()}.", f".{int(dead.stdout)}.", 1))
    ck.rename(old)
    (old / OWNER_MARK).unlink()
    table, rep = measure(tmp_path / "cap", out)
    assert rep.n_images_resumed == 0 and out.exists() and not old.exists() and not ck.exists()


# --------------------------------------------------------------------------- damaged batches
def _truncate(f):
    f.write_bytes(f.read_bytes()[:100])


def _garbage(f):
    f.write_bytes(b"\x00" * 500)


def _empty(f):
    f.write_bytes(b"")


def _missing_key(f):
    with np.load(f) as z:
        d = dict(z)
    d.pop("status")
    np.savez(f, **d)


def _wrong_shape(f):
    with np.load(f) as z:
        d = dict(z)
    k = next(k for k in d if k.startswith("patches_c"))
    d[k] = d[k][:, :2]
    np.savez(f, **d)


def _bad_status(f):
    with np.load(f) as z:
        d = dict(z)
    d["status"] = d["status"][:-1]
    np.savez(f, **d)


def _object_array(f):
    with np.load(f) as z:
        d = dict(z)
    d["rows"] = np.array([object()] * len(d["rows"]), dtype=object)
    np.savez(f, **d)


@pytest.mark.parametrize("damage", [_truncate, _garbage, _empty, _missing_key, _wrong_shape, _bad_status,
                                    _object_array])
def test_damaged_checkpoint_batch_is_read_again(tmp_path, caplog, damage):
    out, ck = _interrupted(tmp_path, after=16)
    ref, _ = measure(tmp_path / "cap")
    batches = sorted(ck.glob("batch-*.npz"))
    assert len(batches) == 2
    damage(batches[1])
    with caplog.at_level("WARNING"):
        table, rep = measure(tmp_path / "cap", out, batch_size=8)
    assert rep.n_images_resumed == 8
    assert any("unreadable checkpoint batch ignored" in r.getMessage() and batches[1].name in r.getMessage()
               for r in caplog.records)
    same_tables(table, ref)


# --------------------------------------------------------------------------- SIGKILL leftovers
def _run_killed(tmp_path, sabotage, out, batch_size=8):
    """Run measure in a child process that SIGKILLs itself where ``sabotage`` says; returns its status."""
    import os
    import subprocess
    import sys

    script = (
        "import os, signal, sys, shutil\n"
        "import numpy as np\n"
        "from cdbrdf.measure import measure\n"
        "def die():\n"
        "    os.kill(os.getpid(), signal.SIGKILL)\n"
        + sabotage +
        f"measure(sys.argv[1], sys.argv[2], batch_size={batch_size}, num_workers=1, scheduler='synchronous')\n"
    )
    env = dict(os.environ)
    src = str(__import__("pathlib").Path(cdbrdf.__file__).parents[1])
    env["PYTHONPATH"] = src + os.pathsep + env.get("PYTHONPATH", "")
    return subprocess.run([sys.executable, "-c", script, str(tmp_path / "cap"), str(out)], env=env,
                          timeout=120).returncode


def _dotfiles(folder):
    return sorted(p.name for p in folder.iterdir() if p.name.startswith("."))


def test_killed_while_saving_a_batch_leaves_nothing_behind(tmp_path):
    import signal

    make_capture(tmp_path / "cap", GRID, pixel, kind="png16", white=WHITE)
    ref, _ = measure(tmp_path / "cap")
    out = tmp_path / "out.h5"
    ck = checkpoint_path(out)
    sabotage = (
        "real = np.savez\n"
        "calls = []\n"
        "def savez(fh, **kw):\n"
        "    calls.append(1)\n"
        "    if len(calls) == 2:\n"
        "        fh.write(b'PK half a batch'); fh.flush(); die()\n"
        "    real(fh, **kw)\n"
        "np.savez = savez\n"
    )
    assert _run_killed(tmp_path, sabotage, out) == -signal.SIGKILL
    temps = [n for n in _dotfiles(ck) if n.endswith(".tmp")]
    assert len(temps) == 1 and temps[0].startswith(".batch-00000008.npz.")
    with pytest.raises(MeasurementInterrupted):
        measure(tmp_path / "cap", out, batch_size=8, _interrupt_after=8)
    assert _dotfiles(ck) == [".cdbrdf-owned"]  # the dead run's temporary is swept
    table, rep = measure(tmp_path / "cap", out, batch_size=8)
    assert rep.n_images_resumed == 16
    same_tables(table, ref)
    assert _dotfiles(tmp_path) == []


def test_killed_while_writing_the_output_leaves_nothing_behind(tmp_path):
    import signal

    make_capture(tmp_path / "cap", GRID, pixel, kind="png16", white=WHITE)
    out = tmp_path / "out.h5"
    sabotage = (
        "real = os.fsync\n"
        "def fsync(fd):\n"
        "    name = os.path.basename(os.readlink(f'/proc/self/fd/{fd}'))\n"
        "    if name.startswith('.out.h5.') and name.endswith('.tmp') and '.ckpt.' not in name:\n"
        "        die()\n"
        "    real(fd)\n"
        "os.fsync = fsync\n"
    )
    if not __import__("os").path.exists("/proc/self/fd"):
        pytest.skip("needs /proc")
    assert _run_killed(tmp_path, sabotage, out) == -signal.SIGKILL
    assert not out.exists() and any(n.startswith(".out.h5.") for n in _dotfiles(tmp_path))
    table, rep = measure(tmp_path / "cap", out)
    assert rep.n_images_resumed == 148 and out.exists()
    assert _dotfiles(tmp_path) == []


def test_killed_while_removing_the_checkpoint(tmp_path):
    """remove_owned renames first: the rerun is not blocked and the half-removed folder is swept."""
    import signal

    from cdbrdf.outputs import OWNER_MARK

    make_capture(tmp_path / "cap", GRID, pixel, kind="png16", white=WHITE)
    out = tmp_path / "out.h5"
    sabotage = (
        "def rmtree(p, *a, **k):\n"
        f"    os.unlink(os.path.join(p, {OWNER_MARK!r}))\n"
        "    os.unlink(os.path.join(p, 'key.json'))\n"
        "    die()\n"
        "shutil.rmtree = rmtree\n"
    )
    assert _run_killed(tmp_path, sabotage, out) == -signal.SIGKILL
    left = [n for n in _dotfiles(tmp_path) if n.endswith(".old")]
    assert out.exists() and len(left) == 1 and not (tmp_path / left[0] / OWNER_MARK).exists()
    out.unlink()
    table, rep = measure(tmp_path / "cap", out)
    assert out.exists() and _dotfiles(tmp_path) == []


def test_killed_while_creating_the_checkpoint_does_not_block_the_rerun(tmp_path):
    """The folder is made under a temporary name and renamed once marked: never an unmarked OUT.ckpt."""
    import signal

    make_capture(tmp_path / "cap", SMALL, pixel, kind="exr", size=9)
    out = tmp_path / "out.h5"
    sabotage = (
        "import cdbrdf.measure.checkpoint as ck\n"
        "ck.mark_owned = lambda *a, **k: die()\n"  # killed between mkdir and the marker
    )
    assert _run_killed(tmp_path, sabotage, out) == -signal.SIGKILL
    assert not checkpoint_path(out).exists() and [n for n in _dotfiles(tmp_path) if n.endswith(".partial")]
    table, rep = measure(tmp_path / "cap", out)
    assert out.exists() and not checkpoint_path(out).exists() and _dotfiles(tmp_path) == []
