"""Damage a CDBRDF file without metadata checksums many times and count what loading gives.

Run: ``.venv/bin/python scripts/legacy_damage.py [N] [SEED]`` (default 600 and 7; about 6 minutes on
2 cores: every such file is read in a child process).

A small table is written the way format 1.0 and other HDF5 writers lay files out (superblock 0,
B-tree v1 chunk index, no metadata checksums), then mutated ``N`` times, in turn: a zeroed run of 1
to 1024 bytes, 1 to 16 random bytes, one flipped bit, at a random offset. Each mutated file is loaded
with :func:`cdbrdf.load` and counted as a ``FormatError``, another cdbrdf error, equal to the
original, CHANGED (loaded without an error, other values), or a foreign exception. The numbers are
quoted in ``docs/reliability.md`` (known limits: files without checksums).
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import numpy as np

import cdbrdf
from cdbrdf import io


def legacy_file(folder: Path) -> tuple[cdbrdf.CDBRDF, Path]:
    """A small table with a mask, fill sources and std, saved with superblock 0."""
    rng = np.random.default_rng(1)
    th, ph = [0, 30, 60], [0, 120, 240]
    v = rng.uniform(0.1, 0.9, (2, 3, 3, 3, 3, 3))
    m = np.ones(v.shape[:-1], bool)
    m[0, 0, 0, 0, 0] = False
    t = cdbrdf.CDBRDF(v, kappa=[0, 0.1], theta_l=th, phi_l=ph, theta_v=th, phi_v=ph, measured=m,
                      fill_source=np.where(m, -1, -2), std=v * 0.01,
                      attrs={"material": "x", "quantity": "brdf"})
    saved = io._LIBVER
    io._LIBVER = ("earliest", "v110")  # what format 1.0 and older writers produced
    try:
        p = folder / "legacy.h5"
        t.save(p)
    finally:
        io._LIBVER = saved
    assert io.superblock_version(p) == 0
    return t, p


def main(n: int = 600, seed: int = 7) -> dict[str, int]:
    with tempfile.TemporaryDirectory() as d:
        table, src = legacy_file(Path(d))
        data = src.read_bytes()
        r = np.random.default_rng(seed)
        out = {"FormatError": 0, "other cdbrdf error": 0, "equal": 0, "CHANGED": 0, "foreign": 0}
        p = Path(d) / "mutated.h5"
        for i in range(n):
            b = bytearray(data)
            off = int(r.integers(0, len(b)))
            if i % 3 == 0:
                k = int(r.integers(1, 1025))
                b[off : off + k] = bytes(len(b[off : off + k]))
            elif i % 3 == 1:
                k = int(r.integers(1, 17))
                b[off : off + k] = r.integers(0, 256, len(b[off : off + k]), dtype=np.uint8).tobytes()
            else:
                b[off] ^= 1 << int(r.integers(0, 8))
            p.write_bytes(bytes(b))
            try:
                t = cdbrdf.load(p)
            except cdbrdf.FormatError:
                out["FormatError"] += 1
                continue
            except cdbrdf.CDBRDFError:
                out["other cdbrdf error"] += 1
                continue
            except Exception as exc:  # noqa: BLE001 - counted: must stay 0
                out["foreign"] += 1
                print(f"mutation {i}: {type(exc).__name__}: {exc}"[:200])
                continue
            if t == table:
                out["equal"] += 1
            else:
                out["CHANGED"] += 1
                print(f"mutation {i} (kind {i % 3}, offset {off}): loaded with other values")
    print(out)
    return out


if __name__ == "__main__":
    args = [int(a) for a in sys.argv[1:3]]
    main(*args)
