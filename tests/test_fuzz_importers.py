"""Mutated RGL, MERL, UTIA and Neural-BRDF (Keras weights) files through their readers: only cdbrdf errors, no crash or hang.

Seeds: a small RGB and a small spectral RGL material (the tensor layout of the
database files, a 4 x 4 reflectance grid), a MERL file and a UTIA file written
from analytic BRDFs. None of these formats carries a checksum, so a mutation
inside the data is a valid file with other values: such an input must read,
and its evaluations at a few directions (Mitsuba's ``measured`` plug-in for
RGL files) must be numbers of the right shape. Everything else must raise a
:class:`cdbrdf.errors.CDBRDFError` (one line naming the file). Each input runs
in a child process (``tests/fuzzing.py``), so a crash or a hang of the reader
or of Mitsuba is caught and reported.
"""

from __future__ import annotations

import functools
import tempfile
from pathlib import Path

import numpy as np
import pytest

from cdbrdf.errors import CDBRDFError

from .fuzzing import fuzz

#: Seconds one input may take (a hang otherwise).
PER_INPUT_S = 20.0


@functools.cache
def seeds(kind: str) -> tuple[bytes, ...]:
    """Seed files of one reader."""
    from cdbrdf.importers import rgl

    from .import_helpers import write_merl, write_utia
    from .test_import_rgl import _fields

    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        if kind == "rgl":
            rgl.write_tensor_file(d / "a.bsdf", _fields())
            wl = np.linspace(380, 780, 5).astype(np.float32)
            spec = np.repeat(_fields()["rgb"][:, :, :1], 5, axis=2)
            rgl.write_tensor_file(d / "b.bsdf", _fields(rgb=None, wavelengths=wl, spectra=spec))
            return ((d / "a.bsdf").read_bytes(), (d / "b.bsdf").read_bytes())
        if kind == "merl":
            return (write_merl(d / "a.binary").read_bytes(),)
        if kind == "nbrdf":
            return (_network(d)[1].read_bytes(),)
        return (write_utia(d / "a.bin").read_bytes(),)


def _target(kind: str, suffix: str, data: bytes, workdir: Path) -> str:
    from cdbrdf.importers import read_source

    p = workdir / f"fuzzed{suffix}"
    p.write_bytes(data)
    src = read_source(p, format=kind)
    q = [np.array([0.0, 30.0, 60.0, 85.0]), np.array([0.0, 90.0, -120.0, 10.0]),
         np.array([45.0, 10.0, 70.0, 85.0]), np.array([180.0, 0.0, 33.0, -10.0])]
    f, m = src.evaluate(*q)
    f = np.asarray(f)
    assert f.shape == (4, 3) and not np.isnan(f).any(), f
    assert m is None or (np.shape(m) == (4,) and np.all((np.asarray(m) >= 0) & (np.asarray(m) <= 1)))
    return "ok"


def _network(folder: Path) -> tuple[Path, Path]:
    """A small Neural-BRDF pair (6-4-3) in ``folder``: the weights are fuzzed, the architecture kept."""
    from cdbrdf.importers import nbrdf

    rng = np.random.default_rng(5)
    return nbrdf.write(folder / "fuzzed.h5", [rng.normal(0, 0.3, (6, 4)), rng.normal(0, 0.3, (4, 3))],
                       [np.zeros(4), np.full(3, -1.0)])


def target_nbrdf(data: bytes, workdir: Path) -> str:
    _network(workdir)
    return _target("nbrdf", ".h5", data, workdir)


def target_rgl(data: bytes, workdir: Path) -> str:
    return _target("rgl", ".bsdf", data, workdir)


def target_merl(data: bytes, workdir: Path) -> str:
    return _target("merl", ".binary", data, workdir)


def target_utia(data: bytes, workdir: Path) -> str:
    return _target("utia", ".bin", data, workdir)


def _run(kind: str, n: int, seed: int):
    report = fuzz(f"tests.test_fuzz_importers:target_{kind}", list(seeds(kind)), n=n, seed=seed,
                  per_input_s=PER_INPUT_S, allowed=(CDBRDFError,))
    print(kind, report.summary())
    return report


def test_seeds_read():
    from .import_helpers import need_mitsuba

    need_mitsuba()
    with tempfile.TemporaryDirectory() as tmp:
        for kind, target in (("rgl", target_rgl), ("merl", target_merl), ("utia", target_utia),
                             ("nbrdf", target_nbrdf)):
            for data in seeds(kind):
                assert target(data, Path(tmp)) == "ok"


@pytest.mark.parametrize("kind,n", [("rgl", 120), ("merl", 12), ("utia", 60), ("nbrdf", 24)])
def test_fuzz_readers_small(kind, n):
    if kind == "rgl":
        from .import_helpers import need_mitsuba

        need_mitsuba()
    report = _run(kind, n, seed=1)
    assert report.n == n
    assert not report.bad, report.summary()


@pytest.mark.slow
@pytest.mark.parametrize("kind,n", [("rgl", 3000), ("merl", 400), ("utia", 3000), ("nbrdf", 600)])
def test_fuzz_readers_large(kind, n):
    if kind == "rgl":
        from .import_helpers import need_mitsuba

        need_mitsuba()
    report = _run(kind, n, seed=2)
    assert report.n == n
    assert not report.bad, report.summary()
