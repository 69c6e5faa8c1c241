"""File safety: atomic writes, owned folders, sweeping leftovers of killed runs."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from cdbrdf import fsutil, outputs
from cdbrdf.errors import OutputError
from cdbrdf.outputs import output_folder


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


def test_atomic_path_sweeps_unless_told_not_to(tmp_path):
    """sweep=False (many files into a folder just made) leaves the folder unlisted; the default sweeps."""
    dest = tmp_path / "out.png"
    stale = _stale_name(dest, "tmp", ".png")
    stale.write_bytes(b"x")
    with fsutil.atomic_path(dest, suffix=".png", sweep=False) as tmp:
        tmp.write_bytes(b"a")
    assert dest.read_bytes() == b"a" and stale.exists()
    with fsutil.atomic_path(dest, suffix=".png") as tmp:
        tmp.write_bytes(b"b")
    assert dest.read_bytes() == b"b" and not stale.exists()


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
        outputs.remove_owned(d)
    assert (d / "precious.txt").read_text() == "keep"
    outputs.mark_owned(d, "checkpoint")
    assert outputs.is_owned(d, "checkpoint") and not outputs.is_owned(d, "output")
    outputs.remove_owned(d, "checkpoint")
    assert not d.exists()
    assert list(tmp_path.iterdir()) == []


# -- output folders of whole runs (demo, simulate-capture) ------------------------
def test_output_folder_replaces_whole_previous_output(tmp_path):
    dest = tmp_path / "out"
    with output_folder(dest) as d:
        (d / "old.txt").write_text("1")
    assert (dest / "old.txt").exists()
    with output_folder(dest) as d:
        (d / "new.txt").write_text("2")
    assert (dest / "new.txt").exists() and not (dest / "old.txt").exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


def test_output_folder_keeps_old_results_on_failure(tmp_path):
    dest = tmp_path / "out"
    with output_folder(dest) as d:
        (d / "old.txt").write_text("1")
    with pytest.raises(RuntimeError):
        with output_folder(dest) as d:
            (d / "new.txt").write_text("2")
            raise RuntimeError("boom")
    assert (dest / "old.txt").exists() and not (dest / "new.txt").exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


def test_output_folder_refuses_foreign_folder(tmp_path):
    dest = tmp_path / "mine"
    dest.mkdir()
    (dest / "thesis.tex").write_text("precious")
    with pytest.raises(FileExistsError, match="was not written by cdbrdf"):
        with output_folder(dest):
            pass
    assert (dest / "thesis.tex").read_text() == "precious"


def test_output_folder_sweeps_a_killed_runs_partial_folder(tmp_path):
    """A partial folder (with the demo's work folder inside) of a dead process is removed by the next run."""
    import os
    import subprocess
    import sys

    from cdbrdf.fsutil import temp_sibling
    from cdbrdf.outputs import mark_owned

    out = tmp_path / "out"
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                          capture_output=True, text=True, check=True)
    pid = int(dead.stdout)
    stale = temp_sibling(out, "partial")
    stale = stale.with_name(stale.name.replace(f".{os.getpid()}.", f".{pid}.", 1))
    (stale / ".work" / "capture-denim").mkdir(parents=True)
    mark_owned(stale, "output")
    (stale / ".work" / "capture-denim" / "photo.png").write_bytes(b"x")
    mine = temp_sibling(out, "partial")  # a live run's (this process's) partial is left alone
    mine.mkdir()
    mark_owned(mine, "output")
    with output_folder(out) as tmp:
        (tmp / "a.txt").write_text("new\n")
    assert not stale.exists() and mine.exists()
    assert (out / "a.txt").read_text() == "new\n"


def test_output_folder_interrupt_leaves_nothing(tmp_path):
    out = tmp_path / "out"
    with pytest.raises(KeyboardInterrupt):
        with output_folder(out) as tmp:
            (tmp / "a.txt").write_text("half\n")
            raise KeyboardInterrupt
    assert list(tmp_path.iterdir()) == []


def test_check_output_folder_refuses_up_front(tmp_path, monkeypatch):
    from cdbrdf.outputs import check_output_folder

    (tmp_path / "f.txt").write_text("x")
    with pytest.raises(FileExistsError, match="not a folder"):
        check_output_folder(tmp_path / "f.txt")
    with output_folder(tmp_path / "o"):
        pass
    monkeypatch.chdir(tmp_path / "o")
    with pytest.raises(FileExistsError, match="current folder"):
        check_output_folder(".")
    assert check_output_folder(tmp_path / "new") == tmp_path / "new"


# -- destinations that are not regular files; bounded reads of inputs -----------
def _specials(tmp_path):
    """A FIFO, a link to the character device /dev/null and a socket: none may be replaced."""
    import os
    import socket

    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)
    dev = tmp_path / "devnull"
    dev.symlink_to(os.devnull)
    sock = tmp_path / "sock"
    s = socket.socket(socket.AF_UNIX)
    try:
        s.bind(str(sock))
    except OSError:  # pragma: no cover - a path too long for a socket
        sock = None
    s.close()
    out = {"FIFO": fifo, "character device": dev}
    if sock is not None:
        out["socket"] = sock
    return out


def test_atomic_path_never_replaces_a_device_fifo_or_socket(tmp_path):
    import stat

    for kind, p in _specials(tmp_path).items():
        before = p.lstat()
        with pytest.raises(FileExistsError, match=rf"{p.name}: exists and is not a regular file \(.*{kind}"):
            with fsutil.atomic_path(p) as tmp:
                tmp.write_bytes(b"x")
        after = p.lstat()
        assert stat.S_IFMT(after.st_mode) == stat.S_IFMT(before.st_mode) and after.st_ino == before.st_ino
    assert not [n for n in tmp_path.iterdir() if n.name.startswith(".")]  # no temporary left


def test_atomic_path_refuses_a_device_made_while_writing(tmp_path):
    import os

    dest = tmp_path / "out.bin"
    with pytest.raises(FileExistsError, match="not a regular file"):
        with fsutil.atomic_path(dest) as tmp:
            tmp.write_bytes(b"x")
            os.mkfifo(dest)
    assert [n.name for n in tmp_path.iterdir()] == ["out.bin"]


@pytest.mark.parametrize("name", ["", " ", "sub/", ".", "..", "sub/.."])
def test_check_output_file_refuses_folders_and_empty_names(tmp_path, monkeypatch, name):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "sub").mkdir()
    with pytest.raises(IsADirectoryError):
        fsutil.check_output_file(name)
    with pytest.raises(IsADirectoryError):
        with fsutil.atomic_path(name):
            pass
    assert sorted(n.name for n in tmp_path.iterdir()) == ["sub"]


def test_check_output_file_accepts_new_and_regular_files(tmp_path):
    assert fsutil.check_output_file(tmp_path / "new.h5") == tmp_path / "new.h5"
    (tmp_path / "old.h5").write_bytes(b"x")
    fsutil.check_output_file(tmp_path / "old.h5")
    with pytest.raises(FileNotFoundError, match="does not exist"):
        fsutil.check_output_file(tmp_path / "nope" / "x.h5")


def test_read_regular_refuses_fifos_and_devices_without_blocking(tmp_path):
    specials = _specials(tmp_path)
    zero = tmp_path / "zero"
    zero.symlink_to("/dev/zero")
    for p in [*specials.values(), zero, tmp_path]:
        with pytest.raises(OSError, match="not a regular file"):
            fsutil.read_regular(p, max_bytes=10)  # a FIFO would block, /dev/zero never end
    with pytest.raises(FileNotFoundError):
        fsutil.read_regular(tmp_path / "missing", max_bytes=10)


def test_read_regular_reads_at_most_one_byte_over_the_bound(tmp_path):
    f = tmp_path / "f.json"
    f.write_bytes(b"0123456789" * 100)
    assert fsutil.read_regular(f, max_bytes=5000) == f.read_bytes()
    assert fsutil.read_regular(f, max_bytes=10) == b"01234567890"


# -- the manifest of an output folder: files added since are never deleted -------
def test_output_folder_records_what_the_run_wrote(tmp_path):
    import json

    dest = tmp_path / "out"
    with output_folder(dest) as d:
        (d / "a.txt").write_text("1")
        (d / "sub").mkdir()
        (d / "sub" / "b.png").write_bytes(b"2")
        (d / "link").symlink_to("a.txt")
    info = json.loads((dest / outputs.OWNER_MARK).read_text())
    assert info["kind"] == "output" and info["files"] == ["a.txt", "link", "sub/", "sub/b.png"]
    with output_folder(dest) as d:  # nothing added: replaced whole
        (d / "c.txt").write_text("3")
    assert sorted(p.name for p in dest.iterdir()) == [".cdbrdf-output", ".cdbrdf-owned", "c.txt"]


@pytest.mark.parametrize("added, shown", [
    (["notes.txt"], r"holds 1 file that cdbrdf did not write there \(notes.txt\)"),
    (["sub/result.h5", "mine/"], r"holds 2 files .* \(mine/, sub/result.h5\)"),
    (["a1", "a2", "a3", "a4", "a5"], r"holds 5 files .* \(a1, a2, a3 and 2 more\)"),
])
def test_output_folder_with_added_files_is_refused_up_front(tmp_path, added, shown):
    from cdbrdf.outputs import check_output_folder

    dest = tmp_path / "out"
    with output_folder(dest) as d:
        (d / "sub").mkdir()
        (d / "report.html").write_text("x")
    for name in added:
        if name.endswith("/"):
            (dest / name).mkdir()
        else:
            (dest / name).write_text("user data")
    before = sorted(str(p.relative_to(dest)) for p in dest.rglob("*"))
    with pytest.raises(FileExistsError, match=rf"out: {shown}, which replacing the folder would delete; move"):
        check_output_folder(dest)
    ran = []
    with pytest.raises(FileExistsError, match="did not write there"):
        with output_folder(dest):
            ran.append(1)
    assert ran == [] and sorted(str(p.relative_to(dest)) for p in dest.rglob("*")) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


def test_output_folder_refuses_files_added_while_it_ran(tmp_path):
    dest = tmp_path / "out"
    with output_folder(dest) as d:
        (d / "old.txt").write_text("1")
    with pytest.raises(FileExistsError, match=r"\(result.h5\)"):
        with output_folder(dest) as d:
            (d / "new.txt").write_text("2")
            (dest / "result.h5").write_text("measured meanwhile")
    assert sorted(p.name for p in dest.iterdir() if not p.name.startswith(".")) == ["old.txt", "result.h5"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


def test_output_folder_without_manifest_is_replaced_as_before(tmp_path):
    """Folders written before the manifest (owner mark without 'files', or only the old marker) keep the old rule."""
    for mark in ("owner", "old"):
        dest = tmp_path / mark
        dest.mkdir()
        if mark == "owner":
            outputs.mark_owned(dest, "output")
        else:
            (dest / ".cdbrdf-output").write_text("written by cdbrdf\n")
        (dest / "extra.txt").write_text("x")
        with output_folder(dest) as d:
            (d / "new.txt").write_text("2")
        assert sorted(p.name for p in dest.iterdir() if not p.name.startswith(".")) == ["new.txt"]


# -- hostile input, second round: special files, outputs over inputs, locks, modes, full disks -------------
def test_check_regular_refuses_special_files_before_opening_them(tmp_path):
    zero = tmp_path / "zero"
    zero.symlink_to("/dev/zero")
    for p in [*_specials(tmp_path).values(), zero]:
        with pytest.raises(OSError, match=r"not a regular file \(a (FIFO|character device|socket)\)"):
            fsutil.check_regular(p)  # a FIFO would block, /dev/zero never end
    with pytest.raises(IsADirectoryError, match=r"not a regular file \(a folder\)"):
        fsutil.check_regular(tmp_path)
    with pytest.raises(FileNotFoundError, match="no such file"):
        fsutil.check_regular(tmp_path / "missing")
    (tmp_path / "f").write_bytes(b"x")
    assert fsutil.check_regular(tmp_path / "f") == tmp_path / "f"


def test_find_overlap_sees_links_relative_names_and_folders(tmp_path, monkeypatch):
    import os

    a = tmp_path / "in" / "a.h5"
    a.parent.mkdir()
    a.write_bytes(b"a")
    (tmp_path / "link.h5").symlink_to(a)
    os.link(a, tmp_path / "hard.h5")
    monkeypatch.chdir(tmp_path / "in")
    inputs = [a]
    for out, folder, relation in [("a.h5", False, "is"), ("./a.h5", False, "is"), ("../in/a.h5", False, "is"),
                                  (tmp_path / "link.h5", False, "is"), (tmp_path / "hard.h5", False, "is"),
                                  (tmp_path / "in", True, "holds"), (tmp_path, True, "holds")]:
        hit = outputs.find_overlap([(out, folder)], inputs)
        assert hit is not None and hit[1] == a and hit[2] == relation, (out, hit)
    assert outputs.find_overlap([("b.h5", False), (tmp_path / "other", True)], inputs) is None
    # a folder read whole: nothing may be written inside it
    hit = outputs.find_overlap([(tmp_path / "in" / "new.h5", False)], [tmp_path / "in"])
    assert hit is not None and hit[2] == "is inside"
    with pytest.raises(OutputError, match=r"a\.h5: is the input .*a\.h5; writing it would replace what the run reads"):
        outputs.check_not_input([("a.h5", False)], inputs)
    with pytest.raises(OutputError, match=r"holds the input .*a\.h5"):
        outputs.check_not_input([(tmp_path, True)], inputs)


def _hold_lock(path, seconds=30.0):
    """A separate process holding the output lock of ``path`` (flock is per process here)."""
    code = ("import sys, time\nfrom cdbrdf.outputs import output_lock\n"
            "with output_lock(sys.argv[1]):\n    print('held', flush=True)\n    time.sleep(float(sys.argv[2]))\n")
    p = subprocess.Popen([sys.executable, "-c", code, str(path), str(seconds)], stdout=subprocess.PIPE, text=True)
    assert p.stdout.readline().strip() == "held"
    return p


def test_output_lock_refuses_a_second_run_and_a_killed_holder_releases_it(tmp_path):
    out = tmp_path / "out.h5"
    holder = _hold_lock(out)
    try:
        with pytest.raises(OutputError, match=rf"out\.h5: another cdbrdf run \(process {holder.pid}\) is writing it"):
            with outputs.output_lock(out):
                pass
    finally:
        holder.kill()  # SIGKILL: the system releases the lock
        holder.wait()
        holder.stdout.close()
    with outputs.output_lock(out):
        with outputs.output_lock(out):  # nested in one process (a command and the library it calls)
            pass
    assert list(tmp_path.iterdir()) == []  # the killed holder's lock file is gone with the next run


def test_output_lock_leaves_no_lock_file(tmp_path):
    with outputs.output_lock(tmp_path / "x.png"):
        assert (tmp_path / ".x.png.lock").read_text().strip() == str(__import__("os").getpid())
    assert list(tmp_path.iterdir()) == []


def test_output_lock_reuses_a_killed_runs_lock_file(tmp_path):
    lock = tmp_path / ".x.png.lock"
    lock.write_text(f"{_dead_pid()}\n")
    with outputs.output_lock(tmp_path / "x.png"):
        assert lock.read_text().strip() == str(__import__("os").getpid())
    assert list(tmp_path.iterdir()) == []


def _lock_cases(tmp_path):
    """Lock files that are not cdbrdf's: each must be refused, and nothing they reach changed."""
    import os

    victim = tmp_path / "victim.txt"
    victim.write_text("precious")
    cases = {}
    d = tmp_path / "symlink"
    d.mkdir()
    (d / ".m.png.lock").symlink_to(victim)
    cases["symlink"] = (d / "m.png", "is a symbolic link")
    d = tmp_path / "dangling"
    d.mkdir()
    (d / ".m.png.lock").symlink_to(tmp_path / "created-by-nobody")
    cases["dangling"] = (d / "m.png", "is a symbolic link")
    d = tmp_path / "hardlink"
    d.mkdir()
    os.link(victim, d / ".m.png.lock")
    cases["hardlink"] = (d / "m.png", "other name")
    d = tmp_path / "fifo"
    d.mkdir()
    os.mkfifo(d / ".m.png.lock")
    cases["fifo"] = (d / "m.png", "is a FIFO")
    d = tmp_path / "folder"
    d.mkdir()
    (d / ".m.png.lock").mkdir()
    cases["folder"] = (d / "m.png", "is a folder")
    d = tmp_path / "content"
    d.mkdir()
    (d / ".m.png.lock").write_text("a user's notes, not a process id\n")
    cases["content"] = (d / "m.png", "not a lock file")
    return victim, cases


@pytest.mark.parametrize("case", ["symlink", "dangling", "hardlink", "fifo", "folder", "content"])
def test_output_lock_never_writes_through_a_link_or_over_another_file(tmp_path, case):
    victim, cases = _lock_cases(tmp_path)
    out, words = cases[case]
    lock = out.with_name(f".{out.name}.lock")
    before = lock.read_bytes() if lock.is_file() and not lock.is_symlink() else None
    with pytest.raises(OutputError, match=rf"m\.png: its lock file .*\.m\.png\.lock .*{words}.*remove it"):
        with outputs.output_lock(out):
            pytest.fail("the lock was taken")
    assert victim.read_text() == "precious"
    assert not (tmp_path / "created-by-nobody").exists()
    assert os.path.lexists(lock)  # left as it was, for the user to look at
    if before is not None:
        assert lock.read_bytes() == before


def test_a_lock_linked_to_a_victim_is_refused_by_the_command_line(tmp_path, capsys, small_grid):
    """``.m.png.lock -> victim.txt`` made ``cdbrdf mosaic t.h5 -o m.png`` overwrite the victim (exit 0)."""
    from cdbrdf.cli import main

    from .conftest import make_table

    t = tmp_path / "t.h5"
    make_table(small_grid).save(t)
    victim = tmp_path / "victim.txt"
    victim.write_text("precious")
    (tmp_path / ".m.png.lock").symlink_to(victim)
    assert main(["mosaic", str(t), "-o", str(tmp_path / "m.png")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "is a symbolic link" in err, err
    assert victim.read_text() == "precious" and not (tmp_path / "m.png").exists()
    os.link(t, tmp_path / ".n.png.lock")  # a hard link to the command's own input
    size = t.stat().st_size
    assert main(["mosaic", str(t), "-o", str(tmp_path / "n.png")]) == 2
    assert "other name" in capsys.readouterr().err
    assert t.stat().st_size == size


def test_atomic_path_keeps_the_mode_of_the_file_it_replaces(tmp_path):
    import os
    import stat

    dest = tmp_path / "t.bin"
    dest.write_bytes(b"old")
    os.chmod(dest, 0o600)
    with fsutil.atomic_path(dest) as tmp:
        os.chmod(tmp, 0o644)  # whatever the writer made
        tmp.write_bytes(b"new")
    assert dest.read_bytes() == b"new" and stat.S_IMODE(dest.stat().st_mode) == 0o600
    new = tmp_path / "n.bin"
    with fsutil.atomic_path(new) as tmp:
        os.chmod(tmp, 0o600)  # mkstemp-like: a new file gets the usual 0666 & ~umask instead
        tmp.write_bytes(b"x")
    assert stat.S_IMODE(new.stat().st_mode) == 0o666 & ~fsutil.umask()


def test_atomic_path_turns_a_full_disk_into_one_line_and_keeps_the_old_file(tmp_path):
    import errno

    dest = tmp_path / "t.bin"
    dest.write_bytes(b"old")
    with pytest.raises(OSError, match=r"t\.bin: cannot be written: no space left") as exc:
        with fsutil.atomic_path(dest) as tmp:
            tmp.write_bytes(b"half")
            raise OSError(errno.ENOSPC, "No space left on device")
    assert exc.value.errno == errno.ENOSPC and "\n" not in str(exc.value)
    assert dest.read_bytes() == b"old" and sorted(p.name for p in tmp_path.iterdir()) == ["t.bin"]


def test_output_folders_are_replaced_only_by_the_command_that_made_them(tmp_path):
    with output_folder(tmp_path / "demo", maker="demo") as d:
        (d / "report.html").write_text("r")
    with pytest.raises(OutputError, match=r"an output folder of `cdbrdf demo`, not of `cdbrdf view --export`"):
        outputs.check_output_folder(tmp_path / "demo", maker="view --export", signature=("index.html",))
    with pytest.raises(OutputError):
        with output_folder(tmp_path / "demo", maker="view --export"):
            pass
    assert (tmp_path / "demo" / "report.html").read_text() == "r"
    with output_folder(tmp_path / "demo", maker="demo") as d:  # the same command replaces it
        (d / "report.html").write_text("r2")
    # a folder marked before makers were recorded: replaced only when it looks like the maker's (its signature)
    with output_folder(tmp_path / "old") as d:
        (d / "capture.csv").write_text("c")
    with pytest.raises(OutputError, match=r"not by `cdbrdf view --export` \(it has no index\.html\)"):
        outputs.check_output_folder(tmp_path / "old", maker="view --export", signature=("index.html", "data.js"))
    outputs.check_output_folder(tmp_path / "old")  # the maker that records none (the simulated rig)
