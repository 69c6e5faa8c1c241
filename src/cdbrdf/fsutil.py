"""File safety: atomic writes, folders cdbrdf owns, leftovers of killed runs.

Three rules every writer in cdbrdf follows:

1. A file is written to a temporary name beside its destination and renamed
   over it only once complete (:func:`atomic_path`), so an interrupted write
   never leaves a half file under the final name.
2. A folder cdbrdf creates carries a marker file (:data:`OWNER_MARK`) naming
   what made it; cdbrdf deletes or replaces only folders that carry the
   marker (:func:`is_owned`, :func:`remove_owned`), never a user's folder.
3. Temporary names embed the writer's process id
   (``.NAME.<pid>.<random>.<kind>``); :func:`sweep_stale` removes those whose
   process is gone (a run killed with SIGKILL), so nothing piles up.

Output folders of whole runs (``cdbrdf demo``, ``cdbrdf simulate-capture``)
are built as a partial folder beside the destination and swapped in whole
(:func:`output_folder`); :func:`check_output_folder` refuses a bad destination
before any work, including an earlier output folder that holds files its run
did not write (the owner mark keeps the run's manifest).
"""

from __future__ import annotations

import json
import logging
import os
import re
import secrets
import shutil
import socket
import stat
from collections.abc import Iterator
from contextlib import contextmanager
from os import PathLike
from pathlib import Path

__all__ = [
    "OWNER_MARK",
    "atomic_path",
    "check_output_file",
    "read_regular",
    "temp_sibling",
    "mark_owned",
    "is_owned",
    "remove_owned",
    "sweep_stale",
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

_TEMP_RE = re.compile(
    r"^\.(?P<name>.+)\.(?P<pid>\d+)\.(?P<host>[0-9a-f]{8})\.[0-9a-f]{8}\.(?P<kind>[a-z]+)(?:\.[A-Za-z0-9]+)?$"
)


def _host_tag() -> str:
    import hashlib

    return hashlib.sha1(socket.gethostname().encode()).hexdigest()[:8]


def _umask() -> int:
    m = os.umask(0)
    os.umask(m)
    return m


def temp_sibling(dest: str | PathLike[str], kind: str) -> Path:
    """A fresh temporary name beside ``dest``: ``.NAME.<pid>.<host>.<random>.<kind>``.

    ``kind`` is a lower-case word (``tmp``, ``partial``, ``old``...). Nothing is
    created; :func:`sweep_stale` recognises the name once its process is gone.
    """
    if not kind.isalpha() or not kind.islower():
        raise ValueError(f"kind: {kind!r} must be a lower-case word")
    d = Path(dest)
    return d.with_name(f".{d.name}.{os.getpid()}.{_host_tag()}.{secrets.token_hex(4)}.{kind}")


def _pid_alive(pid: int) -> bool:
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    except OverflowError:
        return False
    return True


def sweep_stale(dest: str | PathLike[str]) -> list[Path]:
    """Remove temporaries beside ``dest`` left by runs that no longer exist.

    Only names made by :func:`temp_sibling` for ``dest`` on this host whose
    process id is not running are removed, files and folders alike (a
    half-deleted folder may already have lost its :data:`OWNER_MARK`).
    Returns what was removed.
    """
    d = Path(dest)
    folder = d.parent if str(d.parent) else Path(".")
    removed: list[Path] = []
    try:
        entries = list(folder.iterdir())
    except OSError:
        return removed
    host = _host_tag()
    for p in entries:
        m = _TEMP_RE.match(p.name)
        if not m or m["name"] != d.name or m["host"] != host or _pid_alive(int(m["pid"])):
            continue
        try:
            if p.is_symlink() or p.is_file():
                p.unlink()
            elif p.is_dir():
                # only cdbrdf makes folders with these names (mkdir of a partial
                # folder, or the rename of an owned one before it is deleted), so
                # the marker may already be gone from a half-deleted one
                shutil.rmtree(p)
            removed.append(p)
            _LOG.info("removed %s, left by an interrupted run", p)
        except OSError as exc:  # pragma: no cover - races with another cleaner
            _LOG.debug("could not remove %s: %s", p, exc)
    return removed


def _kind_of(mode: int) -> str:
    """What a file that is not a regular file is, for messages."""
    for test, name in ((stat.S_ISDIR, "a folder"), (stat.S_ISFIFO, "a FIFO"),
                       (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"),
                       (stat.S_ISSOCK, "a socket")):
        if test(mode):
            return name
    return "not a plain file"  # pragma: no cover - no other kinds on POSIX


def check_output_file(path: str | PathLike[str]) -> Path:
    """Refuse, before any work, a file destination that :func:`atomic_path` must not replace.

    Cheap (nothing is written), so that a command fails at once instead of
    after its computation. Returns the destination as a :class:`~pathlib.Path`.

    Raises
    ------
    IsADirectoryError
        When ``path`` is empty or names a folder (links followed).
    FileNotFoundError
        When the folder that would hold it does not exist.
    FileExistsError
        When it exists and is not a regular file (a character device such as
        ``/dev/null``, a FIFO, a socket): replacing it by a regular file
        would destroy it.
    """
    if not str(path).strip():
        raise IsADirectoryError(f"{str(path)!r}: an empty output name; give a file name")
    dest = Path(path)
    if str(path).endswith(("/", os.sep)) or dest.name in ("", ".", ".."):
        raise IsADirectoryError(f"{path}: names a folder; give a file name")
    folder = dest.parent if str(dest.parent) else Path(".")
    if not folder.is_dir():
        raise FileNotFoundError(f"{dest}: the folder {folder} does not exist")
    try:
        mode = dest.stat().st_mode  # links followed: what would be written through
    except OSError:
        return dest  # missing (or a dangling link): created
    if stat.S_ISDIR(mode):
        raise IsADirectoryError(f"{dest}: is a folder; give a file name")
    if not stat.S_ISREG(mode):
        raise FileExistsError(
            f"{dest}: exists and is not a regular file ({_kind_of(mode)}); "
            "it is never replaced, choose another output name"
        )
    return dest


def read_regular(path: str | PathLike[str], *, max_bytes: int) -> bytes:
    """The bytes of a regular file, reading at most ``max_bytes + 1`` of them.

    A FIFO, a device (``/dev/zero``), a socket or a folder is refused before
    it is opened (so reading never blocks or runs without end), checked again
    on the open file; a result longer than ``max_bytes`` means the file is
    larger than that (the caller refuses it).

    Raises
    ------
    FileNotFoundError
        When ``path`` does not exist.
    OSError
        When it is not a regular file (the message says what it is) or
        cannot be read.
    """
    p = Path(path)
    mode = p.stat().st_mode
    if not stat.S_ISREG(mode):
        raise OSError(f"{p}: not a regular file ({_kind_of(mode)})")
    fd = os.open(p, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_NOCTTY", 0))
    with os.fdopen(fd, "rb") as fh:
        mode = os.fstat(fh.fileno()).st_mode
        if not stat.S_ISREG(mode):  # replaced since the check
            raise OSError(f"{p}: not a regular file ({_kind_of(mode)})")
        return fh.read(max(int(max_bytes), 0) + 1)


@contextmanager
def atomic_path(path: str | PathLike[str], *, suffix: str = ".tmp", sweep: bool = True) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; rename it onto ``path`` on success.

    On any exception the temporary file is removed and ``path`` is untouched.
    Temporaries of killed runs for the same destination are swept first
    (:func:`sweep_stale`, which lists the folder) unless ``sweep`` is False: a
    writer of many files into a folder that it has just made with
    :func:`output_folder` (which sweeps when it makes it) passes False, or
    writing n files would list the folder n times.
    ``suffix`` is kept for writers that pick the format from the name
    (``.png``, ``.exr``): the temporary is ``.NAME.<pid>...tmp<suffix>``.
    A destination that is a folder or exists and is not a regular file (a
    device, a FIFO, a socket) is refused (:func:`check_output_file`).
    """
    dest = check_output_file(path)
    if sweep:
        sweep_stale(dest)
    tmp_path = temp_sibling(dest, "tmp")
    if suffix and suffix != ".tmp":
        tmp_path = tmp_path.with_name(tmp_path.name + suffix)
    fd = os.open(tmp_path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666 & ~_umask())
    os.close(fd)
    try:
        yield tmp_path
        with open(tmp_path, "rb+") as fh:
            os.fsync(fh.fileno())
        check_output_file(dest)  # not made a device or FIFO meanwhile
        os.replace(tmp_path, dest)
    except BaseException:
        tmp_path.unlink(missing_ok=True)
        raise


def mark_owned(folder: str | PathLike[str], kind: str, *, files: list[str] | None = None) -> None:
    """Write the owner marker into ``folder`` (which cdbrdf has just created).

    ``files``: the manifest of what cdbrdf wrote there (:func:`output_folder`),
    relative POSIX paths, folders ending in ``/``.
    """
    info: dict[str, object] = {"written_by": "cdbrdf", "kind": kind}
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


def check_output_folder(path: str | PathLike[str]) -> Path:
    """Refuse, before any work, an output folder that :func:`output_folder` would refuse.

    Cheap (no file is written), so that a command fails at once instead of
    after its computation. Returns the folder as a :class:`~pathlib.Path`.

    Raises
    ------
    FileExistsError
        When ``path`` is a file or a link, a non-empty folder cdbrdf did not
        make, an output folder of cdbrdf that holds files its run did not
        write (added since: a measured table, notes; listed in the message),
        or the current folder (or one that holds it).
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
        _refuse_added_files(dest)
        cwd = Path.cwd().resolve()
        if cwd == dest.resolve() or dest.resolve() in cwd.parents:
            raise FileExistsError(
                f"{dest}: is the current folder (or holds it) and would be replaced whole; "
                "run from another folder or choose another output folder"
            )
    return dest


@contextmanager
def output_folder(path: str | PathLike[str]) -> Iterator[Path]:
    """Build an output folder beside ``path`` and swap it in only on success.

    Old results are never mixed with new ones: the new folder replaces a
    previous cdbrdf output folder whole. A folder that exists, is not empty
    and was not made by cdbrdf is refused (nothing of the user's is deleted),
    as is the current folder (:func:`check_output_folder`).
    On failure (or interrupt) the partial folder is removed and the old one
    left as it was; partial folders of killed runs (``.NAME.<pid>...partial``,
    with everything inside them) are removed by the next run.

    Yields
    ------
    pathlib.Path
        The partial folder to fill (marked as cdbrdf's own).
    """
    dest = check_output_folder(path)
    parent = dest.parent if str(dest.parent) else Path(".")
    parent.mkdir(parents=True, exist_ok=True)
    sweep_stale(dest)
    tmp = temp_sibling(dest, "partial")
    tmp.mkdir(mode=0o777)
    try:
        mark_owned(tmp, _OUTPUT_KIND)
        (tmp / _OUTPUT_MARKER).write_text("written by cdbrdf; the whole folder is replaced on the next run\n")
        yield tmp
        # the manifest: what this run wrote; anything added later stops the next run from replacing it
        mark_owned(tmp, _OUTPUT_KIND, files=_entries(tmp))
        if dest.exists() or dest.is_symlink():
            check_output_folder(dest)  # files added to the old folder while this run worked
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
