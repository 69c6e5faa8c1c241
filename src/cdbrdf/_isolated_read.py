"""Reading a CDBRDF file in an isolated child process that dies with its parent and answers in seconds.

:func:`cdbrdf.io.read` reads files without HDF5 metadata checksums here: a
damaged structure in such a file can make the HDF5 library loop forever
with the interpreter lock held, which only a separate process can stop. The
child cannot import anything from the current folder, sees a clean
environment and answers with an ``.npz`` (no pickle); see :data:`_CHILD`.
"""

from __future__ import annotations

import io as _bytes_io
import json
import subprocess
import sys
from pathlib import Path

import numpy as np

from ._hdf5 import fail, one_line
from .errors import FormatError, LimitError
from .schema import SAMPLE_AXES, TableParts

__all__ = ["read_in_child", "arrays_in_child"]


#: The child's program. It runs as ``python -I -S -c`` (no environment variables of Python, no user or
#: site folder, no script folder or current folder on ``sys.path``), in a fresh private folder as its
#: current folder, with a clean environment: only the standard library is importable until it puts
#: the parent's own package folders on ``sys.path`` (argv[2]), so no file beside the table (a
#: ``pickle.py`` in a downloaded dataset) can ever be imported. It dies with the parent: the kernel
#: kills it when the parent dies (Linux, PR_SET_PDEATHSIG), a thread ends it when its stdin pipe closes
#: (the parent gone, elsewhere) and a CPU-time limit ends it in any case. It answers on stdout:
#: ``ready``, then ``ok`` and the parts as an .npz (no pickle), or ``error`` and one JSON line.
_CHILD = r"""
import sys


def _die_with_parent(parent, cpu_s):
    import os, resource, signal, threading
    try:
        import ctypes
        ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
    except (OSError, AttributeError, ImportError):
        pass
    if os.getppid() != parent:  # the parent died before that
        os._exit(3)
    try:
        resource.setrlimit(resource.RLIMIT_CPU, (cpu_s, cpu_s + 1))
    except (ValueError, OSError):
        pass

    def watch():
        try:
            while os.read(0, 4096):
                pass
        finally:
            os._exit(4)

    threading.Thread(target=watch, daemon=True).start()


def _table_arrays(file):
    import json
    from pathlib import Path

    import numpy as np
    from cdbrdf import io as cio

    parts = cio.read_guarded(Path(file))
    arrays = {"values": parts.values, "attrs": np.array(json.dumps(parts.attrs))}
    for name, a in parts.axes.items():
        arrays["axis_" + name] = a
    for name in ("measured", "fill_source", "std", "fill_method", "fill_sources", "fill_weights", "fill_std"):
        a = getattr(parts, name)
        if a is not None:
            arrays[name] = a
    return arrays


def main():
    import json
    parent, cpu_s, path_json, file = int(sys.argv[1]), int(sys.argv[2]), sys.argv[3], sys.argv[4]
    reader = sys.argv[5] if len(sys.argv) > 5 else "table"
    _die_with_parent(parent, cpu_s)
    sys.path[:0] = json.loads(path_json)
    import importlib
    import io

    import h5py
    import numpy as np
    try:
        h5py.h5pl.set_loading_state(0)  # no filter plug-in is loaded from anywhere
    except (AttributeError, RuntimeError):
        pass
    from cdbrdf.errors import FormatError, LimitError

    if reader == "table":
        read = _table_arrays
    else:  # "cdbrdf.package.module:function", a function of the file's path answering a dict of arrays
        module, _, name = reader.partition(":")
        if not module.startswith("cdbrdf."):
            raise SystemExit("the reader must be a function of cdbrdf")
        read = getattr(importlib.import_module(module), name)
    out = sys.stdout.buffer
    out.write(b"ready\n")
    out.flush()
    try:
        arrays = read(file)
    except (FormatError, LimitError) as exc:
        out.write(b"error\n" + json.dumps([type(exc).__name__, str(exc)]).encode() + b"\n")
        out.flush()
        return
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    out.write(b"ok\n" + buf.getvalue())
    out.flush()


main()
sys.stdout.flush()
import os
os._exit(0)  # not a normal shutdown: the watching thread may be in a read
"""


def _child_path() -> list[str]:
    """The folders the child imports from: this package's, then the parent's absolute ``sys.path``.

    The parent's current folder (and relative entries, which name it) are
    left out: only installed code is imported.
    """
    import os

    cwd = os.path.realpath(os.getcwd())
    out = [str(Path(__file__).resolve().parent.parent)]
    for entry in sys.path:
        if entry and os.path.isabs(entry) and os.path.realpath(entry) != cwd and entry not in out:
            out.append(entry)
    return out


def _child_env() -> dict[str, str]:
    """A clean environment for the child: the limits, HDF5's file locking and what starts Python, nothing else."""
    import os

    keep = {"PATH", "LD_LIBRARY_PATH", "DYLD_LIBRARY_PATH", "SYSTEMROOT", "HDF5_USE_FILE_LOCKING"}
    return {k: v for k, v in os.environ.items() if k in keep or k.startswith("CDBRDF_MAX_")}


def _parts_from_npz(path: Path, data: bytes) -> TableParts:
    """The child's answer (an .npz, loaded without pickle) as parts."""
    try:
        with np.load(_bytes_io.BytesIO(data), allow_pickle=False) as z:
            arrays = {k: z[k] for k in z.files}
        attrs = json.loads(str(arrays.pop("attrs")))
        axes = {name: arrays.pop("axis_" + name) for name in SAMPLE_AXES}
    except (ValueError, KeyError, OSError, EOFError) as exc:  # pragma: no cover - the child writes it
        raise fail(path, f"the reader's answer cannot be read ({one_line(exc)})") from None
    return TableParts(values=arrays.pop("values"), axes=axes, attrs=attrs,
                      **{k: arrays.get(k) for k in ("measured", "fill_source", "std", "fill_method",
                                                    "fill_sources", "fill_weights", "fill_std")})


def read_in_child(path: Path, *, timeout_s: float, start_timeout_s: float) -> TableParts:
    """The parts of a CDBRDF file read by :mod:`cdbrdf.io` in an isolated child process, stopped after a time limit.

    For files without metadata checksums, where a damaged structure can make
    the HDF5 library loop forever with the interpreter lock held. See
    :data:`_CHILD` for the isolation; the limit (``timeout_s`` plus one second
    per 10 MB) counts from the moment the child has imported its libraries
    (at most ``start_timeout_s``). Ctrl-C in the parent stops the child too.
    """
    return _parts_from_npz(path, _run_child(path, "table", timeout_s=timeout_s, start_timeout_s=start_timeout_s))


def arrays_in_child(path: Path, reader: str, *, timeout_s: float, start_timeout_s: float) -> dict[str, np.ndarray]:
    """The arrays ``reader`` reads from an HDF5 file of another format, run in the isolated child process.

    As :func:`read_in_child` (the same isolation and time limits), for the
    HDF5 files of other programs that cdbrdf imports (a Keras network's
    weights): ``reader`` names a function of cdbrdf, ``"cdbrdf.module:function"``,
    that takes the file's path and returns a dict of NumPy arrays (no object
    arrays), or raises :class:`~cdbrdf.errors.FormatError` /
    :class:`~cdbrdf.errors.LimitError`, which is raised here with its message.
    """
    data = _run_child(path, reader, timeout_s=timeout_s, start_timeout_s=start_timeout_s)
    try:
        with np.load(_bytes_io.BytesIO(data), allow_pickle=False) as z:
            return {k: z[k] for k in z.files}
    except (ValueError, KeyError, OSError, EOFError) as exc:  # pragma: no cover - the child writes it
        raise fail(path, f"the reader's answer cannot be read ({one_line(exc)})") from None


def _run_child(path: Path, reader: str, *, timeout_s: float, start_timeout_s: float) -> bytes:
    """Run :data:`_CHILD` with ``reader`` on ``path``; its .npz answer (bytes), or its error raised."""
    import os
    import selectors
    import shutil
    import signal
    import tempfile
    import time

    timeout = timeout_s + path.stat().st_size / 10e6
    start_s = start_timeout_s
    folder = tempfile.mkdtemp(prefix="cdbrdf-read-")
    cpu_s = int(start_s + timeout) + 5
    cmd = [sys.executable, "-I", "-S", "-c", _CHILD, str(os.getpid()), str(cpu_s), json.dumps(_child_path()),
           str(path.absolute()), reader]
    chunks: dict[str, list[bytes]] = {"out": [], "err": []}
    proc = None
    try:
        proc = subprocess.Popen(cmd, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                cwd=folder, env=_child_env(), start_new_session=False)
        assert proc.stdout is not None and proc.stderr is not None
        sel = selectors.DefaultSelector()
        sel.register(proc.stdout, selectors.EVENT_READ, "out")
        sel.register(proc.stderr, selectors.EVENT_READ, "err")
        deadline = time.monotonic() + start_s
        ready = False
        open_streams = 2
        while open_streams:
            left = deadline - time.monotonic()
            if left <= 0:
                if not ready:
                    raise fail(path, f"the reader did not start within {start_s:.0f} s")
                raise fail(path, f"reading it took longer than {timeout:.0f} s and was stopped: its HDF5 "
                                 "structure is damaged")
            for key, _ in sel.select(min(left, 0.5)):
                data = os.read(key.fd, 1 << 20)
                if not data:
                    sel.unregister(key.fileobj)
                    open_streams -= 1
                    continue
                chunks[key.data].append(data)
                if not ready and b"\n" in b"".join(chunks["out"]):
                    ready = True
                    deadline = time.monotonic() + timeout
        sel.close()
        proc.wait(timeout=5)
    finally:
        if proc is not None:
            if proc.poll() is None:
                proc.kill()
                proc.wait()
            for stream in (proc.stdin, proc.stdout, proc.stderr):
                if stream is not None:
                    stream.close()
        shutil.rmtree(folder, ignore_errors=True)
    out = b"".join(chunks["out"])
    head, _, rest = out.partition(b"\n")
    kind, _, payload = rest.partition(b"\n")
    if head != b"ready" or kind not in (b"ok", b"error") or proc.returncode != 0:
        err = b"".join(chunks["err"]).decode("utf-8", "replace").strip().splitlines()[-1:]
        code = proc.returncode
        why = err[0][:200] if err else (f"killed by signal {-code}" if code < 0 and -code in signal.valid_signals()
                                         else f"exit status {code}")
        raise fail(path, f"the reader stopped on it ({why}): the file is damaged")
    if kind == b"error":
        name, message = json.loads(payload.decode("utf-8"))
        raise (LimitError if name == "LimitError" else FormatError)(message)
    return payload


