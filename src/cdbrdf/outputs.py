"""What a run writes: never one of its inputs, one run at a time, folders cdbrdf owns swapped in whole.

- an output is never one of the run's inputs, never a folder that holds one
  and never inside an input folder (:func:`find_overlap`,
  :func:`check_not_input`), links followed;
- one run at a time writes an output (:func:`output_lock`: an advisory lock
  on ``.NAME.lock`` beside it); a second run is refused at once;
- a folder cdbrdf creates carries a marker file (:data:`OWNER_MARK`) naming
  what made it; cdbrdf deletes or replaces only folders that carry the
  marker (:func:`is_owned`, :func:`remove_owned`), never a user's folder.

Output folders of whole runs (``cdbrdf demo``, ``cdbrdf simulate-capture``,
``cdbrdf view --export``) are built as a partial folder beside the
destination and swapped in whole (:func:`output_folder`);
:func:`check_output_folder` refuses a bad destination before any work,
including an earlier output folder that holds files its run did not write
(the owner mark keeps the run's manifest) or that another command made (the
mark names its maker). Files themselves are written by
:func:`cdbrdf.fsutil.atomic_path`.
"""

from __future__ import annotations

import errno
import json
import logging
import os
import re
import shutil
import stat
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from os import PathLike
from pathlib import Path

from .errors import OutputError
from .fsutil import sweep_stale, temp_sibling, umask

__all__ = [
    "OWNER_MARK",
    "find_overlap",
    "check_not_input",
    "output_lock",
    "mark_owned",
    "is_owned",
    "remove_owned",
    "same_file",
    "check_output_folder",
    "output_folder",
]

_LOG = logging.getLogger(__name__)


#: Name of the marker file in every folder cdbrdf creates.
OWNER_MARK = ".cdbrdf-owned"


#: Kind (and legacy marker file) of the output folders of :func:`output_folder`.
_OUTPUT_KIND = "output"


_OUTPUT_MARKER = ".cdbrdf-output"


def _resolved(p: Path, cache: dict[Path, Path]) -> Path:
    """``p`` with its folder's links resolved (the name itself kept: it may not exist yet)."""
    parent = p.parent
    if parent not in cache:
        try:
            cache[parent] = parent.resolve()
        except (OSError, RuntimeError):
            cache[parent] = parent.absolute()
    return cache[parent] / p.name


def find_overlap(outputs: Iterable[tuple[str | PathLike[str], bool]],
                 inputs: Iterable[str | PathLike[str]]) -> tuple[Path, Path, str] | None:
    """The first output that is an input, holds one or lies inside an input folder.

    The one rule of every command: an output file must not be an input; an
    output folder (replaced whole, or written into) must not be an input
    and must not hold one; no output may lie inside a folder the run reads
    as a whole. The same file is recognised through symbolic and hard links
    (device and inode) and by its resolved path (for names that do not exist
    yet).

    Parameters
    ----------
    outputs
        ``(path, is_folder)`` of everything the run writes or replaces.
    inputs
        Files and folders the run reads.

    Returns
    -------
    tuple or None
        ``(output, input, relation)`` with relation ``"is"``, ``"holds"``
        or ``"is inside"``; None when there is no overlap.
    """
    cache: dict[Path, Path] = {}
    ins = [Path(p) for p in inputs]
    by_path: dict[Path, Path] = {}
    by_inode: dict[tuple[int, int], Path] = {}
    parents: dict[Path, Path] = {}  # resolved folder -> an input inside it
    in_folders: dict[Path, Path] = {}
    for p in ins:
        r = _resolved(p, cache)
        by_path.setdefault(r, p)
        parents.setdefault(r.parent, p)
        try:
            st = os.stat(p)
        except (OSError, ValueError):
            continue
        by_inode.setdefault((st.st_dev, st.st_ino), p)
        if stat.S_ISDIR(st.st_mode):
            try:
                in_folders.setdefault(p.resolve(), p)
            except (OSError, RuntimeError):
                in_folders.setdefault(r, p)
    for out, folder in outputs:
        t = Path(out)
        r = _resolved(t, cache)
        if r in by_path:
            return t, by_path[r], "is"
        ost: os.stat_result | None
        try:
            ost = os.stat(t)
        except (OSError, ValueError):
            ost = None
        if ost is not None and (ost.st_dev, ost.st_ino) in by_inode:
            return t, by_inode[(ost.st_dev, ost.st_ino)], "is"
        if ost is not None and stat.S_ISDIR(ost.st_mode):
            try:
                r = t.resolve()
            except (OSError, RuntimeError):
                pass
        if folder:
            for d, p in parents.items():
                if d == r or r in d.parents:
                    return t, p, "holds"
        for d, p in in_folders.items():
            if r != d and d in r.parents:
                return t, p, "is inside"
    return None


def check_not_input(outputs: Iterable[tuple[str | PathLike[str], bool]],
                    inputs: Iterable[str | PathLike[str]]) -> None:
    """Refuse, before any work, an output that is, holds or lies inside an input (:func:`find_overlap`).

    Raises
    ------
    OutputError
        ``"scan.ply: is the input scan.ply; writing it would replace what the
        run reads (choose another output name)"``.
    """
    hit = find_overlap(outputs, inputs)
    if hit is None:
        return
    out, inp, relation = hit
    if relation == "is":
        raise OutputError(f"{out}: is the input {inp}; writing it would replace what the run reads "
                          "(choose another output name)")
    if relation == "holds":
        raise OutputError(f"{out}: holds the input {inp}, which writing this output folder could replace or "
                          "delete; choose another output folder")
    raise OutputError(f"{out}: lies inside the input folder {inp}; choose an output outside it")


#: Largest lock file content accepted (a process id and a newline); anything longer is not a lock.
_LOCK_MAX_BYTES = 32


def _lock_holder(fd: int) -> int | None:
    try:
        text = os.pread(fd, _LOCK_MAX_BYTES, 0).decode("ascii", "replace").strip()
    except OSError:  # pragma: no cover - a vanished descriptor
        return None
    return int(text) if text.isdigit() else None


def _refuse_lock(dest: Path, lock: Path, problem: str) -> OutputError:
    return OutputError(f"{dest}: its lock file {lock} {problem}; remove it (cdbrdf never writes through it) "
                       "or choose another output")


def _open_lock(dest: Path, lock: Path) -> int:
    """A descriptor of the lock file, created or reused; never through a link, never over another file.

    A new lock file is created with ``O_EXCL | O_NOFOLLOW``. An existing one
    (left by a killed run) is reused only when it is a regular file with no
    other name (hard link) holding nothing but a process id: a symbolic link,
    a FIFO, a device, a folder, a file with other names or with other
    content is refused, never opened for writing or truncated.
    """
    flags = os.O_RDWR | getattr(os, "O_CLOEXEC", 0) | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_NONBLOCK", 0) \
        | getattr(os, "O_NOCTTY", 0)
    try:
        return os.open(lock, flags | os.O_CREAT | os.O_EXCL, 0o666 & ~umask())
    except FileExistsError:
        pass
    except OSError as exc:
        raise _refuse_lock(dest, lock, f"cannot be created ({exc.strerror or exc})") from None
    try:
        st = os.lstat(lock)
    except FileNotFoundError:
        return _open_lock(dest, lock)  # removed by its holder in between: create it
    except OSError as exc:
        raise _refuse_lock(dest, lock, f"cannot be examined ({exc.strerror or exc})") from None
    if stat.S_ISLNK(st.st_mode):
        raise _refuse_lock(dest, lock, "is a symbolic link")
    if not stat.S_ISREG(st.st_mode):
        from .fsutil import kind_of

        raise _refuse_lock(dest, lock, f"is {kind_of(st.st_mode)}, not a lock file")
    try:
        fd = os.open(lock, flags)
    except FileNotFoundError:
        return _open_lock(dest, lock)
    except OSError as exc:
        raise _refuse_lock(dest, lock, f"cannot be opened ({exc.strerror or exc})") from None
    try:
        fst = os.fstat(fd)
        if (fst.st_dev, fst.st_ino) != (st.st_dev, st.st_ino) or not stat.S_ISREG(fst.st_mode):
            raise _refuse_lock(dest, lock, "was replaced while it was opened")
        if fst.st_nlink > 1:
            raise _refuse_lock(dest, lock, f"has {fst.st_nlink - 1} other name(s) (hard links), so it is "
                               "another file")
        head = os.pread(fd, _LOCK_MAX_BYTES + 1, 0)
        if fst.st_size > _LOCK_MAX_BYTES or not re.fullmatch(rb"\s*\d*\s*", head):
            raise _refuse_lock(dest, lock, "holds something other than a process id, so it is not a lock file")
    except BaseException:
        os.close(fd)
        raise
    return fd


@contextmanager
def output_lock(path: str | PathLike[str]) -> Iterator[Path]:
    """Hold the lock of an output for a whole run: one run at a time writes it.

    The lock is an advisory ``flock`` on ``.NAME.lock`` beside the output
    (file or folder), holding the process id of its holder; it is removed
    when the run ends and released by the system when the process dies
    (SIGKILL included), so a killed run never blocks the next. Nested use in
    one process (a command and the library function it calls) is allowed.
    The lock file is never reached through a link and never replaces or
    truncates another file (:func:`_open_lock`). On systems without
    ``fcntl`` nothing is locked.

    Raises
    ------
    OutputError
        When another process holds the lock: ``"out.h5: another cdbrdf run
        (process 1234) is writing it; wait for it to end or choose another
        output"``; when ``.NAME.lock`` is a link, a special file, a file
        with other names or another file's content.
    """
    dest = Path(path)
    try:
        import fcntl
    except ImportError:  # pragma: no cover - not POSIX
        yield dest
        return
    lock = dest.with_name(f".{dest.name}.lock")
    while True:
        fd = _open_lock(dest, lock)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError as exc:
            holder = _lock_holder(fd)
            os.close(fd)
            if exc.errno not in (errno.EAGAIN, errno.EACCES, errno.EWOULDBLOCK):
                raise _refuse_lock(dest, lock, f"cannot be locked ({exc.strerror or exc})") from None
            if holder == os.getpid():  # this process holds it (nested): the outer use releases it
                yield dest
                return
            who = f" (process {holder})" if holder else ""
            raise OutputError(f"{dest}: another cdbrdf run{who} is writing it; wait for it to end or choose "
                              "another output") from None
        try:  # the holder before us may have removed the file after we opened it: lock the one that is there
            same = os.fstat(fd).st_ino == os.lstat(lock).st_ino
        except OSError:
            same = False
        if same:
            break
        os.close(fd)
    try:
        os.ftruncate(fd, 0)  # a lock file: empty or a dead holder's process id (checked by _open_lock)
        os.pwrite(fd, f"{os.getpid()}\n".encode("ascii"), 0)
        yield dest
    finally:
        try:
            os.unlink(lock)
        except OSError:  # pragma: no cover - removed by hand
            pass
        os.close(fd)


def mark_owned(folder: str | PathLike[str], kind: str, *, files: list[str] | None = None,
               maker: str | None = None) -> None:
    """Write the owner marker into ``folder`` (which cdbrdf has just created).

    ``files``: the manifest of what cdbrdf wrote there (:func:`output_folder`),
    relative POSIX paths, folders ending in ``/``. ``maker``: the command
    that made it (``"demo"``, ``"view --export"``), when it says.
    """
    info: dict[str, object] = {"written_by": "cdbrdf", "kind": kind}
    if maker is not None:
        info["maker"] = maker
    if files is not None:
        info["files"] = files
    Path(folder, OWNER_MARK).write_text(json.dumps(info) + "\n", encoding="utf-8")


def _read_mark(folder: Path) -> dict | None:
    try:
        info = json.loads((folder / OWNER_MARK).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return info if isinstance(info, dict) else None


def _entries(folder: Path) -> list[str]:
    """Every entry under ``folder`` but the markers: relative POSIX paths, real folders ending in ``/``."""
    out: list[str] = []
    for root, dirs, files in os.walk(folder):  # links are not followed
        rel = Path(root).relative_to(folder)
        for d in dirs:
            p = (rel / d).as_posix()
            out.append(p if os.path.islink(os.path.join(root, d)) else p + "/")
        for f in files:
            p = (rel / f).as_posix()
            if p not in (OWNER_MARK, _OUTPUT_MARKER):
                out.append(p)
    return sorted(out)


def _unlisted(folder: Path) -> list[str]:
    """Entries of an owned output folder that its manifest does not list ([] for folders without one)."""
    info = _read_mark(folder)
    listed = info.get("files") if info else None
    if not isinstance(listed, list):
        return []  # made before the manifest: replaced as it always was
    known = set(listed)
    return [e for e in _entries(folder) if e not in known]


def is_owned(folder: str | PathLike[str], kind: str | None = None) -> bool:
    """True when ``folder`` is a folder that cdbrdf made (of ``kind``, when given)."""
    p = Path(folder)
    mark = p / OWNER_MARK
    if p.is_symlink() or not p.is_dir() or not mark.is_file() or mark.is_symlink():
        return False
    if kind is None:
        return True
    info = _read_mark(p)
    return info is not None and info.get("kind") == kind


def remove_owned(folder: str | PathLike[str], kind: str | None = None) -> None:
    """Delete ``folder`` if cdbrdf made it; :class:`FileExistsError` otherwise.

    A missing folder is fine. Nothing of a folder without the marker is touched.
    """
    p = Path(folder)
    if not p.exists() and not p.is_symlink():
        return
    if not is_owned(p, kind):
        raise FileExistsError(
            f"{p}: exists and was not made by cdbrdf; move it away or choose another name"
        )
    # rename first so that a run killed half-way leaves a stale temporary, not a damaged folder
    doomed = temp_sibling(p, "old")
    p.rename(doomed)
    shutil.rmtree(doomed, ignore_errors=True)


def same_file(a: str | PathLike[str], b: str | PathLike[str]) -> bool:
    """True when ``a`` and ``b`` name the same existing file (links resolved)."""
    try:
        return os.path.samefile(a, b)
    except OSError:
        return Path(a).resolve() == Path(b).resolve()


def check_output_folder(path: str | PathLike[str], *, maker: str | None = None,
                        signature: tuple[str, ...] = ()) -> Path:
    """Refuse, before any work, an output folder that :func:`output_folder` would refuse.

    Cheap (no file is written), so that a command fails at once instead of
    after its computation. Returns the folder as a :class:`~pathlib.Path`.

    Parameters
    ----------
    path
        The output folder.
    maker, signature
        The command that writes it and files every folder it writes holds
        (see :func:`output_folder`).

    Raises
    ------
    FileExistsError
        When ``path`` is a file or a link, a non-empty folder cdbrdf did not
        make, an output folder of cdbrdf that holds files its run did not
        write (added since: a measured table, notes; listed in the message),
        or the current folder (or one that holds it).
    OutputError
        When it is an output folder that another command made (the demo's,
        a simulated capture, the viewer's export): only the command that
        made a folder replaces it.
    """
    dest = Path(path)
    if dest.exists() or dest.is_symlink():
        if dest.is_symlink() or not dest.is_dir():
            raise FileExistsError(f"{dest}: exists and is not a folder")
        if any(dest.iterdir()) and not _owned(dest):
            raise FileExistsError(
                f"{dest}: folder exists, is not empty and was not written by cdbrdf; "
                "choose another output folder"
            )
        _refuse_other_maker(dest, maker, signature)
        _refuse_added_files(dest)
        cwd = Path.cwd().resolve()
        if cwd == dest.resolve() or dest.resolve() in cwd.parents:
            raise FileExistsError(
                f"{dest}: is the current folder (or holds it) and would be replaced whole; "
                "run from another folder or choose another output folder"
            )
    return dest


@contextmanager
def output_folder(path: str | PathLike[str], *, maker: str | None = None,
                  signature: tuple[str, ...] = ()) -> Iterator[Path]:
    """Build an output folder beside ``path`` and swap it in only on success.

    Old results are never mixed with new ones: the new folder replaces a
    previous output folder of the same command whole. A folder that exists,
    is not empty and was not made by cdbrdf is refused (nothing of the
    user's is deleted), as is the current folder (:func:`check_output_folder`).
    The owner mark names ``maker``, the command that made the folder; a
    folder another command made (a demo's output under ``view --export``) is
    refused. A folder marked before the maker was recorded is replaced only
    when it holds every file of ``signature`` (the files every folder of
    that command holds: ``report.html`` for the demo). The run holds the
    folder's lock (:func:`output_lock`) while it works.
    On failure (or interrupt) the partial folder is removed and the old one
    left as it was; partial folders of killed runs (``.NAME.<pid>...partial``,
    with everything inside them) are removed by the next run.

    Yields
    ------
    pathlib.Path
        The partial folder to fill (marked as cdbrdf's own).
    """
    dest = check_output_folder(path, maker=maker, signature=signature)
    parent = dest.parent if str(dest.parent) else Path(".")
    parent.mkdir(parents=True, exist_ok=True)
    with output_lock(dest):
        sweep_stale(dest)
        tmp = temp_sibling(dest, "partial")
        tmp.mkdir(mode=0o777)
        try:
            mark_owned(tmp, _OUTPUT_KIND, maker=maker)
            (tmp / _OUTPUT_MARKER).write_text("written by cdbrdf; the whole folder is replaced on the next run\n")
            yield tmp
            # the manifest: what this run wrote; anything added later stops the next run from replacing it
            mark_owned(tmp, _OUTPUT_KIND, files=_entries(tmp), maker=maker)
            if dest.exists() or dest.is_symlink():
                check_output_folder(dest, maker=maker, signature=signature)  # changed while this run worked
        except BaseException:
            shutil.rmtree(tmp, ignore_errors=True)
            raise
        if dest.exists():
            old = temp_sibling(dest, "old")
            dest.rename(old)
            tmp.rename(dest)
            shutil.rmtree(old, ignore_errors=True)
        else:
            tmp.rename(dest)


def _refuse_other_maker(dest: Path, maker: str | None, signature: tuple[str, ...]) -> None:
    """Refuse to replace an output folder that another command made (an empty folder is anyone's)."""
    if not any(dest.iterdir()):
        return
    info = _read_mark(dest) if is_owned(dest) else None
    made_by = info.get("maker") if info else None
    if isinstance(made_by, str):
        if made_by != maker:
            raise OutputError(
                f"{dest}: an output folder of `cdbrdf {made_by}`"
                + (f", not of `cdbrdf {maker}`" if maker else "")
                + "; only the command that made a folder replaces it: choose another output folder"
            )
        return
    missing = [f for f in signature if not (dest / f).is_file()]
    if missing and maker is not None:
        raise OutputError(
            f"{dest}: an output folder cdbrdf made, but not by `cdbrdf {maker}` (it has no {missing[0]}); only "
            "the command that made a folder replaces it: choose another output folder"
        )


def _refuse_added_files(dest: Path) -> None:
    """Refuse to replace an output folder that holds entries its manifest does not list."""
    extra = _unlisted(dest) if is_owned(dest, _OUTPUT_KIND) else []
    if extra:
        shown = ", ".join(extra[:3]) + (f" and {len(extra) - 3} more" if len(extra) > 3 else "")
        raise FileExistsError(
            f"{dest}: holds {len(extra)} file{'s' * (len(extra) > 1)} that cdbrdf did not write there "
            f"({shown}), which replacing the folder would delete; move them away or choose another "
            "output folder"
        )


def _owned(folder: Path) -> bool:
    # folders of cdbrdf <= 0.1 carry only the old marker
    return is_owned(folder, _OUTPUT_KIND) or (folder / _OUTPUT_MARKER).is_file()
