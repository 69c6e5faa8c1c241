"""Mutated CDBRDF files through ``cdbrdf.load``: only cdbrdf errors, no crash, hang or changed value.

Seeds are small tables saved by the current writer: RGB with std, mask and
fill sources; one channel; a single kappa. Each mutated file must either load
as exactly one of the seed tables (values, axes, mask, fill_source, std,
attrs) or raise a :class:`cdbrdf.errors.CDBRDFError`.
"""

from __future__ import annotations

import functools
import tempfile
import warnings
from pathlib import Path

import numpy as np
import pytest

import cdbrdf
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
    mono = cdbrdf.CDBRDF(0.2 + rng.random(g1.shape + (1,)), g1, attrs={"material": "grey"})
    g0 = cdbrdf.Grid(kappa=[0.0], theta_l=[0, 30], phi_l=[0, 90, 180, 270], theta_v=[0, 30], phi_v=[0, 180])
    plain = cdbrdf.CDBRDF(0.3 + rng.random(g0.shape + (3,)), g0, attrs={"provenance": "model"})
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


# -- CF attributes: packing, missing values, units (hostile input, second round) ----------------------------
#: Attributes a NetCDF tool may put on a variable, with values of every kind.
_CF_VALUES = {
    "scale_factor": [2.0, 0.5, 1.0, -1.0, 0.0, np.nan, 1e300, np.float32(2.0), np.int16(2), np.array([2.0, 3.0])],
    "add_offset": [1.0, 0.0, -1.0, np.nan, np.float32(0.25), np.int8(1)],
    "_FillValue": [np.nan, 0.0, 1.0, -1.0, 0.5, 255, 1e30, np.float32(0.1)],
    "missing_value": [np.nan, 0, 1, -2, -1, 0.2],
    "units": ["1/mm", "mm-1", "degree", "degrees", "deg", "1/sr", "sr-1", "1", "", "1/m", "rad", "radian", "W",
              "1 / sr", " degree ", "Degree", b"\xff\xfe", 5],
    "valid_range": [np.array([0.0, 1.0]), np.array([-1.0, -0.5])],
}
_CF_TARGETS = ("kappa", "theta_l", "phi_l", "theta_v", "phi_v", "reflectance", "measured", "fill_source",
               "reflectance_std")


def target_cf(rng: np.random.Generator, workdir: Path) -> str:
    """A seed file with 1-3 random CF attributes: refused (one line), or read exactly as xarray decodes it."""
    import h5py
    import xarray as xr

    k = int(rng.integers(0, len(seed_files())))
    p = workdir / "cf.h5"
    p.write_bytes(seed_files()[k])
    with h5py.File(p, "r+") as f:
        for _ in range(int(rng.integers(1, 4))):
            name = _CF_TARGETS[int(rng.integers(0, len(_CF_TARGETS)))]
            if name not in f:
                continue
            attr = list(_CF_VALUES)[int(rng.integers(0, len(_CF_VALUES)))]
            choices = _CF_VALUES[attr]
            f[name].attrs[attr] = choices[int(rng.integers(0, len(choices)))]
        del f.attrs["cdbrdf_data_sha256"]  # attributes are metadata: only they changed
    try:
        table = cdbrdf.load(p)
    except CDBRDFError as exc:
        if "\n" in str(exc) or not str(exc).startswith(str(p)):
            return "bad"
        raise
    if table != seed_tables()[k]:
        return "changed"
    try:  # what xarray reads must be what cdbrdf read: no attribute was ignored
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # xarray's notes on odd attributes
            with xr.open_dataset(p, engine="h5netcdf") as ds:
                decoded = ds["reflectance"].transpose(*cdbrdf.schema.AXES).values
                axes = {a: ds[a].values for a in cdbrdf.schema.SAMPLE_AXES}
    except (ValueError, TypeError, KeyError, OSError):
        return "ok"  # xarray cannot decode it: nothing to compare
    same = np.array_equal(decoded, table.values) and all(np.array_equal(axes[a], getattr(table, a)) for a in axes)
    return "ok" if same else "changed"


def _run_cf(n: int, seed: int):
    from .fuzzing import fuzz_generated

    # 30 s: the first input imports xarray, which on a loaded machine can take longer than a mutated file's 10 s
    report = fuzz_generated("tests.test_fuzz_io:target_cf", n=n, seed=seed, per_input_s=30.0,
                            allowed=(CDBRDFError,))
    print(report.summary())
    return report


def test_fuzz_cf_attributes_small():
    report = _run_cf(40, seed=1)
    assert report.n == 40 and not report.bad, report.summary()


@pytest.mark.slow
def test_fuzz_cf_attributes_2000():
    report = _run_cf(2000, seed=2)
    assert report.n == 2000 and not report.bad, report.summary()
