"""File safety: atomic writes, regular files only, leftovers of killed runs.

Rules every reader and writer in cdbrdf follows (what a whole run writes, and
the folders cdbrdf owns, are :mod:`cdbrdf.outputs`'):

1. A file is written to a temporary name beside its destination and renamed
   over it only once complete (:func:`atomic_path`), so an interrupted write
   never leaves a half file under the final name.
2. Temporary names embed the writer's process id
   (``.NAME.<pid>.<random>.<kind>``); :func:`sweep_stale` removes those whose
   process is gone (a run killed with SIGKILL), so nothing piles up.
3. Every path cdbrdf reads is checked to be a regular file before it is
   opened (:func:`check_regular`, :func:`read_regular`): a FIFO would block
   the reader forever and a device such as ``/dev/zero`` never end it.

A replaced file keeps the permission bits of the file it replaces, and a
write that fails because the disk (or the file-size limit) is full is one
line naming the file; the old file is left as it was (:func:`atomic_path`).
"""

from __future__ import annotations

import errno
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
    "umask",
    "atomic_path",
    "check_output_file",
    "check_regular",
    "read_regular",
    "kind_of",
    "temp_sibling",
    "sweep_stale",
]

_LOG = logging.getLogger(__name__)


_TEMP_RE = re.compile(
    r"^\.(?P<name>.+)\.(?P<pid>\d+)\.(?P<host>[0-9a-f]{8})\.[0-9a-f]{8}\.(?P<kind>[a-z]+)(?:\.[A-Za-z0-9]+)?$"
)


def _host_tag() -> str:
    import hashlib

    return hashlib.sha1(socket.gethostname().encode()).hexdigest()[:8]


def umask() -> int:
    """The process's file-creation mask."""
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
    half-deleted folder may already have lost its :data:`cdbrdf.outputs.OWNER_MARK`).
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


def kind_of(mode: int) -> str:
    """What a file that is not a regular file is, for messages (``"a FIFO"``, ``"a folder"``...)."""
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
            f"{dest}: exists and is not a regular file ({kind_of(mode)}); "
            "it is never replaced, choose another output name"
        )
    return dest


def check_regular(path: str | PathLike[str]) -> Path:
    """Refuse, before anything opens it, a path to read that is not a regular file.

    Links are followed. A FIFO would block a reader forever, a device such
    as ``/dev/zero`` never end it and a socket is no file: every reader in
    cdbrdf (tables, imported BRDF files, meshes, photographs, capture files,
    scene files and what they name) checks its path here first, and readers
    of whole files read through :func:`read_regular`.

    Returns
    -------
    pathlib.Path
        ``path``.

    Raises
    ------
    FileNotFoundError
        When ``path`` does not exist (or is a dangling link).
    IsADirectoryError
        When it is a folder.
    OSError
        When it is anything else that is not a regular file (the message says
        what it is), or cannot be examined (a link loop, a folder without
        permission, a name with a NUL character).
    """
    p = Path(path)
    try:
        mode = os.stat(p).st_mode
    except FileNotFoundError:
        raise FileNotFoundError(f"{p}: no such file") from None
    except (OSError, ValueError) as exc:
        why = exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc)
        raise OSError(f"{p}: cannot be examined ({why})") from None
    if stat.S_ISDIR(mode):
        raise IsADirectoryError(f"{p}: not a regular file (a folder)")
    if not stat.S_ISREG(mode):
        raise OSError(f"{p}: not a regular file ({kind_of(mode)}); it is not read: reading it could block or "
                      "never end")
    return p


def read_regular(path: str | PathLike[str], *, max_bytes: int) -> bytes:
    """The bytes of a regular file, reading at most ``max_bytes + 1`` of them.

    A FIFO, a device (``/dev/zero``), a socket or a folder is refused before
    it is opened (:func:`check_regular`, so reading never blocks or runs
    without end), checked again on the open file; a result longer than
    ``max_bytes`` means the file is larger than that (the caller refuses it).

    Raises
    ------
    FileNotFoundError
        When ``path`` does not exist.
    OSError
        When it is not a regular file (the message says what it is) or
        cannot be read.
    """
    p = check_regular(path)
    fd = os.open(p, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_NOCTTY", 0))
    with os.fdopen(fd, "rb") as fh:
        mode = os.fstat(fh.fileno()).st_mode
        if not stat.S_ISREG(mode):  # replaced since the check
            raise OSError(f"{p}: not a regular file ({kind_of(mode)})")
        return fh.read(max(int(max_bytes), 0) + 1)


#: errno values of a full disk, a file-size limit (``ulimit -f``) or a full quota.
_NO_SPACE = frozenset(e for e in (getattr(errno, n, None) for n in ("ENOSPC", "EFBIG", "EDQUOT")) if e is not None)


def _no_space(exc: BaseException, folder: Path, written: int) -> bool:
    """Whether a failed write ran out of space.

    Its errno says so, the folder's file system is full, or the ``written``
    bytes reached the process's file-size limit (``ulimit -f``): libraries
    often report these as other errors.
    """
    if isinstance(exc, OSError) and exc.errno in _NO_SPACE:
        return True
    if isinstance(exc, (KeyboardInterrupt, SystemExit)):
        return False
    try:
        import resource

        soft = resource.getrlimit(resource.RLIMIT_FSIZE)[0]
        if soft != resource.RLIM_INFINITY and written >= soft:
            return True
    except (ImportError, OSError, ValueError):  # pragma: no cover - not POSIX
        pass
    try:
        st = os.statvfs(folder)
    except (OSError, AttributeError):
        return False
    return st.f_bavail == 0 or (st.f_favail == 0 and st.f_files > 0)


def _no_space_error(dest: Path) -> OSError:
    exc = OSError(f"{dest}: cannot be written: no space left on the device (or the file-size limit or the "
                  "quota reached); the old file, if any, is kept")
    exc.errno = errno.ENOSPC
    return exc


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

    The new file gets the permission bits of the file it replaces (a 0600
    table stays 0600), else the usual ``0666 & ~umask``, whatever mode the
    writer created it with. A write that fails because the disk, the quota
    or the file-size limit is full raises one :class:`OSError` naming the
    file (errno ``ENOSPC``), whatever the writing library raised; the old
    file is left as it was.

    Parameters
    ----------
    path
        The destination.
    suffix
        End of the temporary's name.
    sweep
        Remove temporaries of killed runs for ``path`` first.

    Yields
    ------
    pathlib.Path
        The temporary path to write.
    """
    dest = check_output_file(path)
    folder = dest.parent if str(dest.parent) else Path(".")
    if sweep:
        sweep_stale(dest)
    tmp_path = temp_sibling(dest, "tmp")
    if suffix and suffix != ".tmp":
        tmp_path = tmp_path.with_name(tmp_path.name + suffix)
    fd = os.open(tmp_path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666 & ~umask())
    os.close(fd)
    try:
        yield tmp_path
        with open(tmp_path, "rb+") as fh:
            os.fsync(fh.fileno())
        check_output_file(dest)  # not made a device or FIFO meanwhile
        try:
            mode = stat.S_IMODE(os.stat(dest).st_mode)
        except OSError:
            mode = 0o666 & ~umask()
        os.chmod(tmp_path, mode)
        os.replace(tmp_path, dest)
    except BaseException as exc:
        try:
            written = tmp_path.stat().st_size
        except OSError:
            written = 0
        tmp_path.unlink(missing_ok=True)
        if _no_space(exc, folder, written):
            raise _no_space_error(dest) from None
        raise


