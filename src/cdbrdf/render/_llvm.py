"""Find the libLLVM that Dr.Jit will load, and check its version, without loading it.

Mitsuba's ``llvm_*`` variants JIT-compile through a shared libLLVM that Dr.Jit
opens at run time. Dr.Jit 1.x looks for it in this order (``jitc_find_library``
in drjit-core):

1. the path in the environment variable ``DRJIT_LIBLLVM_PATH`` (if set and
   non-empty; when it cannot be opened, the LLVM backend is off);
2. ``libLLVM.so`` through the dynamic loader's search (``LD_LIBRARY_PATH``,
   the ``ld.so`` cache, the default folders);
3. the files matching ``/usr/lib/{x86_64-linux-gnu,aarch64-linux-gnu,wsl/lib}/
   libLLVM*.so.*``, sorted with numbers compared as numbers, the last regular
   file (not a symbolic link) being chosen.

Dr.Jit 1.5 with Mitsuba 3.9 needs LLVM 19: with libLLVM 15 or 16 (the default
on many Debian machines) the process *aborts* at the first render, so the check
must happen before a variant is set. The check runs the same search in a short
child process, which opens the library and calls ``LLVMGetVersion`` (present
from LLVM 16; an older library lacks it), so a broken or wrong library can
never take the caller's process down.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from dataclasses import dataclass

from ..errors import CDBRDFError

__all__ = ["LLVMInfo", "LLVMError", "find_llvm", "check_llvm", "REQUIRED_LLVM_MAJOR", "INSTALL_HINT"]

#: The libLLVM major version Dr.Jit 1.5 (Mitsuba 3.9) works with.
REQUIRED_LLVM_MAJOR = 19

#: What to tell the user.
INSTALL_HINT = "install Debian's libllvm19 (apt-get install libllvm19)"

# The child process: replicate Dr.Jit's search, report path and version as JSON.
_PROBE = r"""
import ctypes, glob, json, os, re, sys
env = os.environ.get("DRJIT_LIBLLVM_PATH") or None
out = {"env": env, "path": None, "version": None, "error": None}
handle = None
def opened_path(name):
    try:
        with open("/proc/self/maps") as f:
            for line in f:
                p = line.split()[-1]
                if "libLLVM" in os.path.basename(p) and os.path.exists(p):
                    return os.path.realpath(p)
    except OSError:
        pass
    return name
try:
    if env:
        handle = ctypes.CDLL(env)
        out["path"] = opened_path(env)
    else:
        try:
            handle = ctypes.CDLL("libLLVM.so")
            out["path"] = opened_path("libLLVM.so")
        except OSError:
            files = []
            for d in ("x86_64-linux-gnu", "aarch64-linux-gnu", "wsl/lib"):
                files += glob.glob("/usr/lib/%s/libLLVM*.so.*" % d)
            def key(s):
                return [(0, int(t), "") if t.isdigit() else (1, 0, t) for t in re.split(r"(\d+)", s)]
            files.sort(key=key)
            regular = [f for f in files if not os.path.islink(f)]
            chosen = (regular or files or [None])[-1]
            if chosen is None:
                out["error"] = (
                    "no libLLVM found (libLLVM.so is not on the library search path and "
                    "/usr/lib/<arch>/libLLVM*.so.* matches nothing)"
                )
            else:
                handle = ctypes.CDLL(chosen)
                out["path"] = chosen
except OSError as exc:
    out["error"] = "cannot open: %s" % exc
if handle is not None:
    try:
        fn = handle.LLVMGetVersion
    except AttributeError:
        out["version"] = [0, 0, 0]
        out["error"] = "the library has no LLVMGetVersion (LLVM older than 16)"
        try:
            g = getattr(handle, "_ZN4llvm16LTOCodeGenerator16getVersionStringEv")
            g.restype = ctypes.c_char_p
            m = re.search(r"(\d+)\.(\d+)\.(\d+)", (g() or b"").decode("ascii", "replace"))
            if m:
                out["version"] = [int(x) for x in m.groups()]
        except (AttributeError, OSError):
            pass
    else:
        a, b, c = ctypes.c_uint(), ctypes.c_uint(), ctypes.c_uint()
        fn(ctypes.byref(a), ctypes.byref(b), ctypes.byref(c))
        out["version"] = [a.value, b.value, c.value]
print(json.dumps(out))
"""


class LLVMError(CDBRDFError, OSError):
    """No usable libLLVM for Mitsuba's ``llvm_*`` variants (the message says what to install).

    An :class:`OSError` (a missing or wrong system library), so the command
    line reports it in one line.
    """


@dataclass(frozen=True)
class LLVMInfo:
    """The libLLVM Dr.Jit would load.

    Attributes
    ----------
    path
        File that would be opened, or None when none is found.
    version
        ``(major, minor, patch)``; ``(0, 0, 0)`` for a library older than LLVM 16
        (no version query), None when nothing could be opened.
    source
        ``"DRJIT_LIBLLVM_PATH"`` or ``"search"``.
    error
        Why nothing usable was found, or None.
    """

    path: str | None
    version: tuple[int, int, int] | None
    source: str
    error: str | None = None

    @property
    def ok(self) -> bool:
        """True when the library is LLVM 19."""
        return self.version is not None and self.version[0] == REQUIRED_LLVM_MAJOR


def find_llvm(*, timeout_s: float = 60.0) -> LLVMInfo:
    """Locate the libLLVM that Dr.Jit would load and read its version.

    Runs Dr.Jit's search (see the module docstring) in a child process, so
    nothing is loaded into this one.

    Parameters
    ----------
    timeout_s
        How long the child may take, seconds.

    Returns
    -------
    LLVMInfo
        The library's path and version, or why none was found.
    """
    env = dict(os.environ)
    try:
        proc = subprocess.run(
            [sys.executable, "-I", "-c", _PROBE],
            capture_output=True, text=True, timeout=timeout_s, env=env, check=False,
        )
        data = json.loads(proc.stdout.strip().splitlines()[-1])
    except (OSError, subprocess.SubprocessError, ValueError, IndexError) as exc:
        return LLVMInfo(None, None, "search", f"the libLLVM probe failed ({exc})")
    source = "DRJIT_LIBLLVM_PATH" if data.get("env") else "search"
    version = tuple(data["version"]) if data.get("version") is not None else None
    return LLVMInfo(data.get("path"), version, source, data.get("error"))


def llvm_message(info: LLVMInfo) -> str:
    """A one-paragraph explanation of ``info`` when it is not usable."""
    where = (
        f"DRJIT_LIBLLVM_PATH={os.environ.get('DRJIT_LIBLLVM_PATH')!r}"
        if info.source == "DRJIT_LIBLLVM_PATH" else "the shared-library search"
    )
    if info.path is None or info.version is None:
        found = f"no usable libLLVM via {where}: {info.error or 'not found'}"
    elif info.version[0] == 0:
        found = f"{info.path} (via {where}) is older than LLVM 16"
    else:
        v = ".".join(map(str, info.version))
        found = f"{info.path} (via {where}) is LLVM {v}"
    return (
        f"Mitsuba's llvm variants need libLLVM {REQUIRED_LLVM_MAJOR}, but {found}: "
        f"{INSTALL_HINT}, or point DRJIT_LIBLLVM_PATH at a libLLVM {REQUIRED_LLVM_MAJOR} "
        "(other versions abort the process at the first render)."
    )


def check_llvm(*, info: LLVMInfo | None = None) -> LLVMInfo:
    """Raise :class:`LLVMError` unless Dr.Jit would load libLLVM 19.

    Call before setting an ``llvm_*`` Mitsuba variant. When such a variant is
    already active the version Dr.Jit loaded is checked instead.

    Parameters
    ----------
    info
        A result of :func:`find_llvm` to judge (default: search now).

    Returns
    -------
    LLVMInfo
        The library found, when usable.

    Raises
    ------
    LLVMError
        When it is missing or not LLVM 19; the message says
        "install Debian's libllvm19 (apt-get install libllvm19)".
    """
    if info is None:
        loaded = _loaded_llvm_version()
        if loaded is not None:
            env = os.environ.get("DRJIT_LIBLLVM_PATH") or None
            info = LLVMInfo(env or "the libLLVM Dr.Jit loaded", loaded,
                            "DRJIT_LIBLLVM_PATH" if env else "search")
        else:
            info = find_llvm()
    if not info.ok:
        raise LLVMError(llvm_message(info))
    return info


def _loaded_llvm_version() -> tuple[int, int, int] | None:
    """The version Dr.Jit already loaded, if an llvm variant is active."""
    mi = sys.modules.get("mitsuba")
    if mi is None:
        return None
    variant = mi.variant()
    if not variant or not str(variant).startswith("llvm"):
        return None
    import drjit as dr

    v = dr.detail.llvm_version()
    return tuple(int(x) for x in v)  # type: ignore[return-value]
