"""A small, seeded mutation fuzzer with crash and hang detection.

Used by the ``test_fuzz_*`` modules: each gives a *target* (a function
``target(data: bytes, workdir: Path) -> object``, importable by name), seed
inputs and a budget. Inputs are generated deterministically from
``(seed, index)`` so any finding is reproduced by its index alone.

The target runs in a child process (``spawn``), which reports each finished
input to the parent. The parent kills the child when one input takes longer
than ``per_input_s`` (a **hang**) or the child dies (a **crash**: segfault,
abort, MemoryError that kills the process), records the input and restarts the
child after it. Every exception the target raises is classified by its class:
only those in ``allowed`` (the project's own error classes) are acceptable.

A target returns ``"ok"`` when the input was accepted and gave the same
result as the unmutated input, ``"changed"`` when it was accepted but gave a
different result (a silently changed value), or raises.

:func:`fuzz_generated` runs targets that build each input themselves from a
random generator seeded by ``(seed, index)`` (``target(rng, workdir)``): a
file with random CF attributes, a special file under a random reader, a
command whose output aliases one of its inputs. Such a target returns
``"ok"`` when the run behaved as the rule says (refused with one line, or
accepted unchanged) and ``"bad"`` (or raises) otherwise.
"""

from __future__ import annotations

import importlib
import multiprocessing as mp
import tempfile
import time
import traceback
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

__all__ = ["mutate", "FuzzReport", "fuzz", "fuzz_generated"]

_INTERESTING = (0, 1, 0x7F, 0x80, 0xFF, 0xFFFF, 0x7FFFFFFF, 0x80000000, 0xFFFFFFFF)


def mutate(data: bytes, rng: np.random.Generator, *, max_ops: int = 4) -> bytes:
    """``data`` with 1 to ``max_ops`` random edits.

    Edits: bit flips, byte overwrites (random or 0x00/0xFF), a 1-, 2- or 4-byte
    big- or little-endian "interesting" integer, truncation, deletion,
    duplication or insertion of a block, and zeroing a block.
    """
    b = bytearray(data)
    for _ in range(int(rng.integers(1, max_ops + 1))):
        n = len(b)
        op = int(rng.integers(0, 9))
        if n == 0:
            b += bytes(rng.integers(0, 256, int(rng.integers(1, 16)), dtype=np.uint8))
            continue
        i = int(rng.integers(0, n))
        if op == 0:
            b[i] ^= 1 << int(rng.integers(0, 8))
        elif op == 1:
            b[i] = int(rng.integers(0, 256))
        elif op == 2:
            b[i] = (0x00, 0xFF)[int(rng.integers(0, 2))]
        elif op == 3:
            width = (1, 2, 4)[int(rng.integers(0, 3))]
            v = _INTERESTING[int(rng.integers(0, len(_INTERESTING)))] & ((1 << (8 * width)) - 1)
            order = ("big", "little")[int(rng.integers(0, 2))]
            b[i : i + width] = v.to_bytes(width, order)
        elif op == 4:
            del b[int(rng.integers(0, n)) :]
        elif op == 5:
            del b[i : i + int(rng.integers(1, 64))]
        elif op == 6:
            j = int(rng.integers(0, n))
            b[j:j] = b[i : i + int(rng.integers(1, 64))]
        elif op == 7:
            b[i:i] = bytes(rng.integers(0, 256, int(rng.integers(1, 32)), dtype=np.uint8))
        else:
            k = int(rng.integers(1, 1024))
            b[i : i + k] = bytes(min(k, n - i))
    return bytes(b)


@dataclass
class FuzzReport:
    """What a fuzz run found.

    Attributes
    ----------
    n
        Inputs tried.
    outcomes
        Count per outcome: ``"ok"``, ``"changed"``, ``"hang"``, ``"crash"`` or
        the name of the exception class raised.
    bad
        ``(index, outcome, detail)`` of every input whose outcome is not
        acceptable (first 20 kept per outcome).
    seconds
        Wall time of the run.
    """

    n: int = 0
    outcomes: Counter = field(default_factory=Counter)
    bad: list = field(default_factory=list)
    seconds: float = 0.0

    def summary(self) -> str:
        parts = ", ".join(f"{k}: {v}" for k, v in self.outcomes.most_common())
        head = f"{self.n} inputs in {self.seconds:.1f} s ({parts})"
        return head + "".join(f"\n  #{i} {o}: {d}" for i, o, d in self.bad[:10])


def _resolve(name: str):
    mod, _, attr = name.partition(":")
    return getattr(importlib.import_module(mod), attr)


def _worker(target_name, seeds, start, stop, seed, max_ops, progress, results, generated=False):
    target = _resolve(target_name)
    with tempfile.TemporaryDirectory(prefix="cdbrdf-fuzz-") as tmp:
        for i in range(start, stop):
            progress.value = i
            rng = np.random.default_rng([seed, i])
            work = Path(tmp) / str(i)
            work.mkdir()
            try:
                if generated:
                    out = target(rng, work)
                else:
                    base = seeds[int(rng.integers(0, len(seeds)))]
                    out = target(mutate(base, rng, max_ops=max_ops), work)
                outcome, detail = (str(out), "") if out in ("ok", "changed", "bad") else ("ok", "")
            except BaseException as exc:  # noqa: BLE001 - classified by the parent
                outcome = type(exc).__module__ + "." + type(exc).__qualname__
                detail = f"{exc}"[:300] + " | " + traceback.format_exc(limit=-2)[-600:].replace("\n", " / ")
            results.send((i, outcome, detail))
            _rmtree(work)
        progress.value = stop


def _rmtree(p: Path) -> None:
    import shutil

    shutil.rmtree(p, ignore_errors=True)


def fuzz_generated(target: str, *, n: int, seed: int = 0, per_input_s: float = 10.0,
                   allowed: tuple[type[BaseException], ...] = (), startup_s: float = 60.0) -> FuzzReport:
    """Run ``n`` inputs that ``target(rng, workdir)`` builds itself (see the module docstring).

    ``"bad"``, hangs, crashes and exceptions not in ``allowed`` are listed in
    :attr:`FuzzReport.bad`.
    """
    return fuzz(target, [], n=n, seed=seed, per_input_s=per_input_s, allowed=allowed, startup_s=startup_s,
                _generated=True)


def fuzz(
    target: str,
    seeds: list[bytes],
    *,
    n: int,
    seed: int = 0,
    per_input_s: float = 10.0,
    allowed: tuple[type[BaseException], ...] = (),
    max_ops: int = 4,
    startup_s: float = 60.0,
    _generated: bool = False,
) -> FuzzReport:
    """Run ``n`` mutated inputs through ``target`` (``"module:function"``).

    Exceptions that are instances of a class in ``allowed`` count as handled;
    ``"changed"``, hangs, crashes and any other exception are listed in
    :attr:`FuzzReport.bad`.
    """
    allowed_names = set()
    for cls in allowed:
        for sub in _all_subclasses(cls) | {cls}:
            allowed_names.add(sub.__module__ + "." + sub.__qualname__)
    ctx = mp.get_context("spawn")
    report = FuzzReport()
    t0 = time.perf_counter()
    start = 0
    per_outcome: Counter = Counter()

    def record(i, outcome, detail):
        report.n += 1
        report.outcomes[outcome] += 1
        if outcome != "ok" and outcome not in allowed_names:
            per_outcome[outcome] += 1
            if per_outcome[outcome] <= 20:
                report.bad.append((i, outcome, detail))

    while start < n:
        progress = ctx.Value("q", -1)
        results, child_end = ctx.Pipe(duplex=False)
        proc = ctx.Process(
            target=_worker, args=(target, seeds, start, n, seed, max_ops, progress, child_end, _generated),
            daemon=True,
        )
        proc.start()
        child_end.close()
        last, last_t, done = -1, time.perf_counter(), start

        def drain(timeout, results=results):
            nonlocal done
            try:
                while results.poll(timeout):
                    i, outcome, detail = results.recv()
                    record(i, outcome, detail)
                    done = i + 1
            except (EOFError, OSError):
                pass

        while True:
            drain(0.05)
            cur = progress.value
            if cur != last:
                last, last_t = cur, time.perf_counter()
            limit = startup_s if cur < 0 else per_input_s
            if done >= n or not proc.is_alive():
                break
            if time.perf_counter() - last_t > limit and cur >= 0:
                proc.kill()
                proc.join()
                break
        proc.join(timeout=5)
        drain(0.2)
        results.close()
        if done >= n:
            break
        # the input at `done` neither finished nor raised: a hang or a crash
        cur = done
        kind = "hang" if proc.exitcode in (-9,) or proc.exitcode is None else "crash"
        record(cur, kind, f"exit code {proc.exitcode}")
        start = cur + 1
    report.seconds = time.perf_counter() - t0
    return report


def _all_subclasses(cls):
    out = set()
    for s in cls.__subclasses__():
        out.add(s)
        out |= _all_subclasses(s)
    return out
