"""Benchmark: reading PLY, ASCII with its line checks and binary, against trimesh's PLY loader.

Run: ``.venv/bin/python benchmarks/bench_meshio.py [--vertices 1000000] [--repeat 3]``

The mesh: a jittered grid of about ``--vertices`` vertices (about twice as
many triangles) with what ``cdbrdf curvature`` writes: ``x y z nx ny nz u v
curvature_x curvature_dir_x``; written once as binary PLY (cdbrdf's writer)
and once as ASCII PLY (the same float32 values, ``%.9g``, one record a
line), in a temporary folder. Timed in the same run, best of ``--repeat``
after one untimed run (numba compilation, the file cache):

1. **Line checks, before/after**: parsing the ASCII file's bytes with
   cdbrdf's reader (:func:`cdbrdf.mesh._ply.parse_ply`: every record one
   line with exactly its values) against the token-based reading it
   replaced (a copy below, ``token_based_parse``: the whole body as one
   stream of numbers, records taken from it in order), on the same bytes;
   the two results are checked to be equal.
2. **Against trimesh**: :func:`cdbrdf.mesh.read_ply` against
   ``trimesh.load(path, process=False)`` on the same files, binary and
   ASCII.

Target: the line-checked ASCII parse at most ``TARGET_RATIO`` times the
token-based one. Exits 1 when it is missed.
"""

from __future__ import annotations

import argparse
import math
import os
import re
import sys
import tempfile
import warnings
from pathlib import Path

import numpy as np

from _common import best_seconds, jittered_triangulation

TARGET_RATIO = 1.25


def _mesh(n_vertices: int):
    from cdbrdf.mesh import Mesh

    rng = np.random.default_rng(0)
    uv, f = jittered_triangulation(n_vertices, rng)
    p = np.c_[200 * uv, 5 * np.sin(20 * uv[:, 0])]
    nn = rng.normal(size=p.shape)
    nn /= np.linalg.norm(nn, axis=1, keepdims=True)
    k = rng.normal(scale=0.1, size=(2, p.shape[0]))
    return Mesh(p, f, nn, uv, {"curvature": k[0], "curvature_dir": k[1]}, metadata={"units": "mm"})


def _write_ascii(path: Path, binary: Path) -> None:
    """The binary file's header and float32 values as ASCII PLY, one record a line."""
    data = binary.read_bytes()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    head = data[:end].decode("ascii").replace("binary_little_endian", "ascii")
    names = re.findall(r"property float (\w+)", head)
    nv = int(re.search(r"element vertex (\d+)", head).group(1))
    nf = int(re.search(r"element face (\d+)", head).group(1))
    vert = np.frombuffer(data, dtype="<f4", count=nv * len(names), offset=end).reshape(nv, len(names))
    faces = np.frombuffer(data, dtype=np.dtype([("n", "u1"), ("i", "<i4", (3,))]), count=nf,
                          offset=end + vert.nbytes)["i"]
    with path.open("w", encoding="ascii", newline="\n") as fh:
        fh.write(head)
        np.savetxt(fh, vert.astype(np.float64), fmt="%.9g")
        np.savetxt(fh, np.c_[np.full(nf, 3), faces], fmt="%d")


# -- the token-based ASCII reading the line checks replaced (reference) ------------------------------
def _scan_tokens():
    from cdbrdf._jit import njit

    @njit(cache=False)
    def scan(tok, start, count, is_list):
        npr = is_list.shape[0]
        offs = np.empty((count, npr), np.int64)
        lens = np.zeros((count, npr), np.int64)
        pos = start
        n = tok.shape[0]
        for r in range(count):
            for p in range(npr):
                if pos >= n:
                    return offs, lens, -1
                offs[r, p] = pos
                if is_list[p]:
                    c = tok[pos]
                    if not (c >= 0 and c <= n and c == math.floor(c)):
                        return offs, lens, -1
                    lens[r, p] = int(c)
                    pos += 1 + int(c)
                else:
                    pos += 1
        if pos > n:
            return offs, lens, -1
        return offs, lens, pos

    return scan


def token_based_parse(data: bytes, name: str, scan):
    """cdbrdf's ASCII PLY reading before the line checks: the body as one stream of numbers."""
    from cdbrdf.mesh._ply import PlyData, _as_index, _fan
    from cdbrdf.mesh._ply_format import _list_items, ply_header

    fmt, elements, comments, start = ply_header(data, name)
    text = data[start:].decode("ascii")
    if re.search(r"[^0-9eE+\-.nNaAiIfFtTyY \t\r\n]", text):
        raise ValueError("not numbers")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        tok = np.fromstring(text, dtype=np.float64, sep=" ")
    pos = 0
    vertex, faces = {}, []
    for el in elements:
        out = {}
        if not el.has_lists:
            need = len(el.props) * el.count
            a = tok[pos:pos + need].reshape(el.count, len(el.props))
            out = {p.name: a[:, i] for i, p in enumerate(el.props)}
            pos += need
        else:
            is_list = np.array([p.count_dtype is not None for p in el.props])
            offs, lens, pos = scan(tok, pos, el.count, is_list)
            for i, p in enumerate(el.props):
                if p.count_dtype is None:
                    out[p.name] = tok[offs[:, i]]
                else:
                    out[p.name] = (tok[_list_items(offs[:, i] + 1, lens[:, i], 1)], lens[:, i])
        if el.name == "vertex":
            vertex = {k: np.asarray(a, dtype=np.float64) for k, a in out.items()}
        elif el.name == "face":
            vals, lens = out["vertex_indices"]
            faces.append(_fan(_as_index(vals, name), lens)[0])
    return PlyData(vertex, np.concatenate(faces), None, comments)



def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--vertices", type=int, default=1_000_000, help="vertices of the mesh (default 1000000)")
    ap.add_argument("--repeat", type=int, default=3, help="timed runs per case (default 3)")
    args = ap.parse_args(argv)

    import trimesh

    from cdbrdf.mesh import read_ply, write_ply
    from cdbrdf.mesh._ply import parse_ply

    print(f"cores: {os.cpu_count()}, load average: {os.getloadavg()[0]:.1f}")
    mesh = _mesh(args.vertices)
    print(f"mesh: {mesh.n_vertices:,} vertices, {mesh.faces.shape[0]:,} triangles, 10 vertex properties")
    with tempfile.TemporaryDirectory() as tmp:
        b_path, a_path = Path(tmp) / "b.ply", Path(tmp) / "a.ply"
        write_ply(b_path, mesh)
        _write_ascii(a_path, b_path)
        print(f"files: binary {b_path.stat().st_size / 1e6:.0f} MB, ASCII {a_path.stat().st_size / 1e6:.0f} MB")
        data = a_path.read_bytes()

        scan = _scan_tokens()
        new, old = parse_ply(data, "a.ply"), token_based_parse(data, "a.ply", scan)
        assert np.array_equal(new.faces, old.faces)
        assert all(np.array_equal(new.vertex[k], old.vertex[k]) for k in old.vertex)
        t_new = best_seconds(lambda: parse_ply(data, "a.ply"), args.repeat)
        t_old = best_seconds(lambda: token_based_parse(data, "a.ply", scan), args.repeat)
        ratio = t_new / t_old
        flag = "" if ratio <= TARGET_RATIO else f"  MISSED (target {TARGET_RATIO:g})"
        print("ASCII parse (bytes in memory):")
        print(f"  token-based (before):  {t_old:6.2f} s")
        print(f"  line-checked (after):  {t_new:6.2f} s  ({ratio:.2f} x before){flag}")

        def load(p):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                return trimesh.load(p, process=False)

        print("read from the file, cdbrdf's read_ply against trimesh.load(process=False):")
        for label, p in (("binary", b_path), ("ASCII", a_path)):
            ours = read_ply(p)
            theirs = load(p)
            assert np.allclose(theirs.vertices, ours.vertices) and np.array_equal(theirs.faces, ours.faces)
            t_ours = best_seconds(lambda p=p: read_ply(p), args.repeat)
            t_tri = best_seconds(lambda p=p: load(p), args.repeat)
            print(f"  {label:6s}: cdbrdf {t_ours:6.2f} s, trimesh {t_tri:6.2f} s  (trimesh / cdbrdf: "
                  f"{t_tri / t_ours:.2f})")
    print(f"load average at the end: {os.getloadavg()[0]:.1f}")
    return 0 if ratio <= TARGET_RATIO else 1


if __name__ == "__main__":
    sys.exit(main())
