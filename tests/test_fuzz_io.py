"""Mutated CDBRDF files through ``cdbrdf.load``: only cdbrdf errors, no crash, hang or changed value.

Seeds are small tables saved by the current writer: RGB with std, mask and
fill sources; one channel; a single kappa. Each mutated file must either load
as exactly one of the seed tables (values, axes, mask, fill_source, std,
attrs) or raise a :class:`cdbrdf.errors.CDBRDFError`.
"""

from __future__ import annotations

import functools
import tempfile
from pathlib import Path

import numpy as np
import pytest

import cdbrdf
from cdbrdf import io
from cdbrdf.errors import CDBRDFError

from .fuzzing import fuzz

__all__ = ["seed_tables", "seed_files", "target"]

#: Seconds one mutated file may take (a hang otherwise).
PER_INPUT_S = 10.0


@functools.cache
def seed_tables() -> tuple[cdbrdf.CDBRDF, ...]:
    """The tables whose files are mutated (deterministic)."""
    rng = np.random.default_rng(7)
    g = cdbrdf.Grid(kappa=[-0.2, 0.0, 0.3], theta_l=[0, 30, 60], phi_l=[0, 120, 240],
                    theta_v=[0, 45], phi_v=[0, 90, 180, 270])
    measured = np.ones(g.shape, bool)
    measured[1, 2, 1, 3, 1] = False
    src = np.full(g.shape, -1)
    src[1, 2, 1, 3, 1] = np.ravel_multi_index((1, 2, 1, 2, 1), g.shape)
    rgb = cdbrdf.CDBRDF(
        (0.1 + rng.random(g.shape + (3,))).astype(np.float32), **g.axes(),
        measured=measured, fill_source=src, std=np.full(g.shape + (3,), 0.01, np.float32),
        attrs={"quantity": "brdf", "material": "fuzz cloth", "provenance": {"seed": 7, "p": [1, 2.5]}},
    )
    g1 = cdbrdf.Grid(kappa=[-0.1, 0.1], theta_l=[0, 40], phi_l=[0, 180], theta_v=[0, 40], phi_v=[0, 180])
    mono = cdbrdf.CDBRDF(0.2 + rng.random(g1.shape + (1,)), **g1.axes(), attrs={"material": "grey"})
    g0 = cdbrdf.Grid(kappa=[0.0], theta_l=[0, 30], phi_l=[0, 90, 180, 270], theta_v=[0, 30], phi_v=[0, 180])
    plain = cdbrdf.CDBRDF(0.3 + rng.random(g0.shape + (3,)), **g0.axes(), attrs={"provenance": "model"})
    return rgb, mono, plain


@functools.cache
def seed_files() -> tuple[bytes, ...]:
    """The seed tables as files written by :func:`cdbrdf.io.save`."""
    out = []
    with tempfile.TemporaryDirectory() as tmp:
        for i, t in enumerate(seed_tables()):
            p = Path(tmp) / f"seed{i}.h5"
            t.save(p)
            out.append(p.read_bytes())
    return tuple(out)


def target(data: bytes, workdir: Path) -> str:
    """Load ``data`` as a file: ``"ok"`` if it equals a seed table, ``"changed"`` otherwise."""
    io.LEGACY_READ_TIMEOUT_S = 4.0  # files without metadata checksums: child process, stopped in time
    p = workdir / "fuzzed.h5"
    p.write_bytes(data)
    table = cdbrdf.load(p)
    return "ok" if any(table == t for t in seed_tables()) else "changed"


def _run(n: int, seed: int):
    report = fuzz(
        "tests.test_fuzz_io:target", list(seed_files()), n=n, seed=seed,
        per_input_s=PER_INPUT_S, allowed=(CDBRDFError,),
    )
    print(report.summary())
    return report


def test_seeds_load_unchanged():
    with tempfile.TemporaryDirectory() as tmp:
        for data in seed_files():
            assert target(data, Path(tmp)) == "ok"


def test_fuzz_load_small():
    report = _run(600, seed=1)
    assert report.n == 600
    assert not report.bad, report.summary()


@pytest.mark.slow
def test_fuzz_load_10000():
    report = _run(10_000, seed=2)
    assert report.n == 10_000
    assert not report.bad, report.summary()
