"""Mutated mesh files through ``prepare_mesh``: only cdbrdf errors, no warning, crash or hang.

Seeds are small meshes in every format cdbrdf reads (binary and ASCII PLY
with UVs, normals and a curvature attribute, an OBJ with separate ``vt``
indices and quads, a binary STL, a GLB). A mutated file is read as the
format its first bytes say (so a damaged magic number lands in another
reader), repaired and given its curvature; it must either work or raise a
:class:`cdbrdf.errors.CDBRDFError`, with every warning an error.
"""

from __future__ import annotations

import functools
import tempfile
import warnings
from pathlib import Path

import numpy as np
import pytest

from cdbrdf.errors import CDBRDFError

from .fuzzing import fuzz
from .mesh_helpers import R_CYL, cylinder_patch, write_ascii_ply, write_obj

__all__ = ["seed_files", "target"]

#: Seconds one mutated file may take (a hang otherwise).
PER_INPUT_S = 20.0


@functools.cache
def seed_files() -> tuple[bytes, ...]:
    """The seed files (deterministic)."""
    import trimesh

    from cdbrdf.mesh import Mesh, write_ply

    v, f, uv, _ = cylinder_patch(R_CYL, n=7, seed=3)
    n = v * np.array([1.0, 0.0, 1.0])
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    out = []
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        write_ply(d / "a.ply", Mesh(v, f, n, uv, {"curvature": np.full(len(v), 0.2)}, metadata={"units": "cm"}))
        out.append((d / "a.ply").read_bytes())
        quads = [[0, 1, 8, 7], [1, 2, 9, 8], [2, 3, 10]]
        out.append(write_ascii_ply(d / "b.ply", v[:11], quads, uv=uv[:11]).read_bytes())
        obj = write_obj(d / "c.obj", v, f, uv).read_text()
        obj = obj.replace("f 1/1 2/2", "f 1/2 2/1") + "vn 0 0 1\nf 1/1/1 2/2/1 3/3/1 4/4/1\n"
        out.append(obj.encode())
        t = trimesh.Trimesh(v, f, vertex_normals=n, process=False,
                            visual=trimesh.visual.TextureVisuals(uv=uv, material=trimesh.visual.material.PBRMaterial()))
        t.export(d / "d.stl")
        out.append((d / "d.stl").read_bytes())
        t.export(d / "e.glb")
        out.append((d / "e.glb").read_bytes())
    return tuple(out)


def _suffix(data: bytes) -> str:
    if data.startswith(b"ply"):
        return ".ply"
    if data.startswith(b"glTF"):
        return ".glb"
    if data.startswith(b"solid") or (len(data) >= 84 and b"\nv " not in data[:200]):
        return ".stl"
    return ".obj"


def target(data: bytes, workdir: Path) -> str:
    """Prepare ``data`` as a mesh file for rendering; every warning is an error."""
    from cdbrdf.mesh import prepare_mesh

    p = workdir / f"fuzzed{_suffix(data)}"
    p.write_bytes(data)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        mesh = prepare_mesh(p, units="mm", neighbourhood_mm=1.0)
    k = mesh.attributes["curvature"]
    if not np.isfinite(k).all():
        raise AssertionError("non-finite curvature")
    return "ok"


def _run(n: int, seed: int):
    report = fuzz("tests.test_fuzz_meshes:target", list(seed_files()), n=n, seed=seed,
                  per_input_s=PER_INPUT_S, allowed=(CDBRDFError,))
    print(report.summary())
    return report


def test_seeds_are_read():
    with tempfile.TemporaryDirectory() as tmp:
        for data in seed_files():
            assert target(data, Path(tmp)) == "ok", _suffix(data)


def test_fuzz_mesh_files_small():
    report = _run(300, seed=1)
    assert report.n == 300
    assert not report.bad, report.summary()


@pytest.mark.slow
def test_fuzz_mesh_files_20000():
    report = _run(20_000, seed=2)
    assert report.n == 20_000
    assert not report.bad, report.summary()
