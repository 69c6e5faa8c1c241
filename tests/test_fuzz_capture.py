"""Fuzzing the capture reader: mutated ``capture.csv`` and ``stands.json``.

Each input replaces one file of a small valid capture folder (the other file
stays valid) and goes through :func:`cdbrdf.measure.read_capture` and, when
that accepts it, :func:`cdbrdf.measure.measure` (pre-flight, decoding,
assembly, filling). Only :mod:`cdbrdf.errors` classes may be raised; no
crash, no hang. A mutated table that is still valid legitimately measures
something else, so acceptance counts as ``ok``.

Byte mutations rarely give a valid file (JSON almost never), so each target
runs an input twice: as bytes (the parsers), then as a value-level edit of
the valid file chosen by the input's hash (NaN, negative, zero, huge, wrong
types, deletions, unknown keys, deep nesting; odd cells, duplicated and
dropped rows: the validation and the measurement behind it).

The default run is short; ``-m slow`` runs a few thousand inputs per file.
"""

from __future__ import annotations

import functools
import json
import os
from pathlib import Path

import numpy as np
import pytest

from cdbrdf.errors import CDBRDFError

from .fuzzing import fuzz

__all__ = ["csv_target", "stands_target", "seeds"]

_STANDS = {"stands": [{"kappa": -0.2, "face_width_mm": 6.0, "wall_height_mm": 1.0},
                      {"kappa": 0.0}, {"kappa": 0.2, "length_mm": 40.0}],
           "pixel_mm": 0.05, "white_albedo": 0.9, "encoding": "srgb", "material": "fuzz"}


def _capture(folder: Path) -> None:
    """A valid capture: 3 curvatures x 2 views x 2 azimuths x 2 lights, whites and a dark frame."""
    from cdbrdf import Grid

    from .measure_helpers import make_capture, write_image

    grid = Grid(kappa=[-0.2, 0.0, 0.2], theta_l=[0.0, 60.0], phi_l=[0.0],
                theta_v=[0.0, 75.0], phi_v=[0.0, 180.0])
    dark = dict(file="dark.png", kappa="", theta_v="", phi_v="", theta_l="", phi_l="", kind="dark",
                exposure=1)
    make_capture(folder, grid, lambda k, tv, pv, tl, pl: np.full(3, 0.2 + 0.1 * k), kind="png16",
                 size=9, white=0.5, stands=_STANDS["stands"],
                 settings={k: v for k, v in _STANDS.items() if k != "stands"}, extra_rows=[dark])
    write_image(folder / "dark.png", np.full((9, 9, 3), 0.01), "png16")


@functools.cache
def seeds(name: str) -> list[bytes]:
    """Seed inputs for ``capture.csv`` or ``stands.json``."""
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        _capture(Path(tmp))
        base = (Path(tmp) / name).read_bytes()
    if name == "capture.csv":
        lines = base.splitlines(keepends=True)
        with_extra = base.replace(b",kind\r\n", b",kind,operator\r\n", 1).replace(b",sample\r\n", b",sample,ak\r\n")
        return [base, b"".join(lines[:9]), with_extra]
    return [base, json.dumps({"stands": _STANDS["stands"]}).encode(), b'{"white_albedo": 1}']


_READY: dict[str, Path] = {}


def _run(data: bytes, workdir: Path, name: str) -> str:
    from cdbrdf.measure import measure, read_capture

    folder = _READY.get(str(workdir))
    if folder is None:
        folder = workdir / "cap"
        _capture(folder)
        _READY[str(workdir)] = folder
        for n in ("capture.csv", "stands.json"):
            (workdir / (n + ".orig")).write_bytes((folder / n).read_bytes())
    for n in ("capture.csv", "stands.json"):
        (folder / n).write_bytes(data if n == name else (workdir / (n + ".orig")).read_bytes())
    read_capture(folder)
    measure(folder, scheduler="synchronous")
    return "ok"


_ODD_CELLS = ["", " ", "nan", "inf", "-1", "0", "1e308", "-1e308", "1e-320", "89.9999999", "90", "360.5",
              "-720", "abc", "1" * 400, "sample", "white", "dark", "linear", "view", "s/missing.png",
              "../cap/dark.png", "s", "s/", "dark.png", "w/0_0.png", "x.jpg", "0x10", "1_000", "٣"]


def _table_mutation(data: bytes) -> bytes:
    """A cell-level edit of the valid capture table (cells, duplicated or dropped rows), chosen by ``data``'s hash."""
    import csv
    import hashlib
    import io

    rng = np.random.default_rng(int.from_bytes(hashlib.sha256(data).digest()[:8], "little"))
    pick = lambda seq: seq[int(rng.integers(0, len(seq)))]  # noqa: E731
    rows = list(csv.reader(io.StringIO(seeds("capture.csv")[0].decode())))
    for _ in range(int(rng.integers(1, 4))):
        op = int(rng.integers(0, 6))
        r = int(rng.integers(1, len(rows)))
        if op <= 3:
            rows[r][int(rng.integers(0, len(rows[r])))] = pick(_ODD_CELLS)
        elif op == 4:
            rows.insert(r, list(rows[int(rng.integers(1, len(rows)))]))
        elif len(rows) > 2:
            del rows[r]
    buf = io.StringIO()
    csv.writer(buf).writerows(rows)
    return buf.getvalue().encode()


def csv_target(data: bytes, workdir: Path) -> str:
    """Fuzz target: ``data`` is the capture table (as bytes, then as a cell-level edit)."""
    try:
        _run(data, workdir, "capture.csv")
    except CDBRDFError:
        pass
    return _run(_table_mutation(data), workdir, "capture.csv")


_ODD_VALUES: list[object] = [float("nan"), float("inf"), -1, 0, 1e308, -1e308, 1e-320, True, None, "0.1",
                              [], {}, 10**400, [[[[0.1]]]], -0.2, 0.2, 90, 1.5, 2]


def _tree_mutation(data: bytes) -> bytes:
    """A value-level edit of the valid stand document, chosen by ``data``'s hash."""
    import copy
    import hashlib

    rng = np.random.default_rng(int.from_bytes(hashlib.sha256(data).digest()[:8], "little"))
    doc: dict = copy.deepcopy(_STANDS)
    pick = lambda seq: seq[int(rng.integers(0, len(seq)))]  # noqa: E731
    for _ in range(int(rng.integers(1, 4))):
        op = int(rng.integers(0, 5))
        stands = doc.get("stands")
        if op <= 2 and isinstance(stands, list) and stands and isinstance(stands[0], dict):
            pick(stands)[pick(["kappa", "face_width_mm", "wall_height_mm", "length_mm", "radius"])] = \
                pick(_ODD_VALUES)
        elif op <= 3:  # a setting
            doc[pick(["pixel_mm", "white_albedo", "encoding", "material", "grid", "stands"])] = pick(_ODD_VALUES)
        elif doc:  # a deletion
            doc.pop(pick(sorted(doc)))
    out: object = doc
    if rng.integers(0, 6) == 0:  # nesting
        out = {"stands": doc} if rng.integers(0, 2) else [doc]
    text = json.dumps(out)
    if rng.integers(0, 8) == 0:
        text = text.replace("[", "[" * 50_000, 1).replace("]", "]" * 50_000, 1)
    return text.encode()


def stands_target(data: bytes, workdir: Path) -> str:
    """Fuzz target: ``data`` is the stand file (as bytes, then as a value-level edit)."""
    try:
        _run(data, workdir, "stands.json")
    except CDBRDFError:
        pass
    return _run(_tree_mutation(data), workdir, "stands.json")


def _check(target: str, name: str, n: int, seed: int) -> None:
    rep = fuzz(f"tests.test_fuzz_capture:{target}", seeds(name), n=n, seed=seed, per_input_s=20,
               allowed=(CDBRDFError,))
    print(f"\n{name}: {rep.summary()}")
    assert not rep.bad, rep.summary()
    assert rep.outcomes["ok"] > 0  # some mutations are still valid captures


N_QUICK = int(os.environ.get("CDBRDF_FUZZ_QUICK", "40"))


@pytest.mark.parametrize("target,name", [("csv_target", "capture.csv"), ("stands_target", "stands.json")])
def test_fuzz_capture_quick(target, name):
    _check(target, name, N_QUICK, seed=1)


@pytest.mark.slow
@pytest.mark.parametrize("target,name", [("csv_target", "capture.csv"), ("stands_target", "stands.json")])
def test_fuzz_capture_long(target, name):
    _check(target, name, 3000, seed=2)
