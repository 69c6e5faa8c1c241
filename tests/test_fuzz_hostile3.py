"""Hostile input, third round: fuzzed classes of the newer surface (``docs/reliability.md``).

Each input is built from ``(seed, index)`` by a target run in a child process
(``tests/fuzzing.py``: hangs and crashes are caught and counted):

- **lock files** (:func:`target_locks`): the ``.NAME.lock`` beside a command's
  output is made beforehand as a symbolic link to a victim file (or to
  nothing), a hard link to the command's own input, a FIFO, a folder, a file
  of other content, an empty file or a killed run's process id: the command
  either runs (an empty or stale lock) or refuses in one line; the victim,
  the input and the lock's target are never written, nothing hangs;
- **what a mesh pulls in** (:func:`target_mesh_refs`): an OBJ whose ``mtllib``
  or MTL map, or a glTF whose buffer or image ``uri``, names a FIFO, a
  device, a folder, a missing file, an absolute path, ``file://`` or a ``..``
  path, read by :func:`cdbrdf.mesh.read_mesh` or rendered with ``-o`` over
  one of the files it names: one line or a mesh, never a hang, never an
  overwritten file;
- **scene includes** (:func:`target_scene_includes`): a scene whose XML
  Python rejects (a duplicate attribute, an undefined entity), an include
  found only in the current folder or beside the top scene, a nested one
  naming a FIFO: refused in one line before Mitsuba opens anything.
"""

from __future__ import annotations

import contextlib
import io
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from .fuzzing import fuzz_generated

#: Seconds one input may take (a hang otherwise).
PER_INPUT_S = 30.0


def _run_cli(argv: list[str]) -> tuple[int, str]:
    from cdbrdf.cli import main

    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        try:
            status = main(["-q", *argv])
        except SystemExit as exc:
            status = exc.code
    return int(status or 0), err.getvalue()


def _snapshot(folder: Path) -> dict[str, bytes]:
    return {str(q.relative_to(folder)): q.read_bytes() for q in sorted(folder.rglob("*"))
            if q.is_file() and not q.is_symlink()}


def _table(path: Path) -> Path:
    import cdbrdf

    g = cdbrdf.Grid(kappa=[0.0], theta_l=[0, 45], phi_l=[0, 180], theta_v=[0, 45], phi_v=[0, 180])
    cdbrdf.CDBRDF(np.full(g.shape + (3,), 0.2), g).save(path)
    return path


def _dead_pid() -> int:
    p = subprocess.Popen([sys.executable, "-c", "pass"])
    p.wait()
    return p.pid


# -- lock files ---------------------------------------------------------------------------------------------
_LOCK_KINDS = ("symlink", "dangling", "hardlink-input", "hardlink-victim", "fifo", "folder", "content", "empty",
               "stale", "none")


def target_locks(rng: np.random.Generator, workdir: Path) -> str:
    """A command whose output's lock file was made beforehand (module docstring)."""
    table = _table(workdir / "t.h5")
    victim = workdir / "victim.txt"
    victim.write_text("precious")
    command = str(rng.choice(["mosaic", "synth", "import"]))
    out = workdir / ("m.png" if command == "mosaic" else "o.h5")
    argv = {"mosaic": ["mosaic", str(table), "-o", str(out)],
            "synth": ["synth", "denim", "--grid", "regular:45,180", "--kappa", "0", "-o", str(out)],
            "import": ["import", str(table), "-o", str(out)]}[command]
    lock = out.with_name(f".{out.name}.lock")
    kind = _LOCK_KINDS[int(rng.integers(0, len(_LOCK_KINDS)))]
    if kind == "symlink":
        lock.symlink_to(victim)
    elif kind == "dangling":
        lock.symlink_to(workdir / "made-by-nobody")
    elif kind == "hardlink-input":
        os.link(table, lock)
    elif kind == "hardlink-victim":
        os.link(victim, lock)
    elif kind == "fifo":
        os.mkfifo(lock)
    elif kind == "folder":
        lock.mkdir()
    elif kind == "content":
        lock.write_bytes(bytes(rng.integers(0, 256, int(rng.integers(1, 200)), dtype=np.uint8)) + b"x")
    elif kind == "empty":
        lock.write_bytes(b"")
    elif kind == "stale":
        lock.write_text(f"{_dead_pid()}\n")
    table_bytes = table.read_bytes()
    status, err = _run_cli(argv)
    if victim.read_text() != "precious" or table.read_bytes() != table_bytes or (workdir / "made-by-nobody").exists():
        return "bad"
    if kind in ("empty", "stale", "none"):
        return "ok" if status == 0 and out.is_file() and not os.path.lexists(lock) else "bad"
    refused = status == 2 and err.count("\n") == 1 and "its lock file" in err and "Traceback" not in err
    return "ok" if refused and not out.exists() and os.path.lexists(lock) else "bad"


# -- what a mesh pulls in --------------------------------------------------------------------------------------
_REF_KINDS = ("fifo", "/dev/zero", "folder", "missing", "absolute", "file-uri", "dotdot", "regular")

_TRI_OBJ = "v 0 0 0\nv 10 0 0\nv 0 10 0\nvt 0 0\nvt 1 0\nvt 0 1\nusemtl cloth\nf 1/1 2/2 3/3\n"


def _gltf_doc(buffer_uri: str, image_uri: str) -> dict:
    import base64

    data = np.array([0, 0, 0, 10, 0, 0, 0, 10, 0], np.float32).tobytes() + np.array([0, 1, 2], np.uint16).tobytes()
    return {"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
            "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1, "material": 0}]}],
            "materials": [{"normalTexture": {"index": 0}}], "textures": [{"source": 0}],
            "images": [{"uri": image_uri}],
            "buffers": [{"uri": buffer_uri or "data:application/octet-stream;base64,"
                         + base64.b64encode(data).decode(), "byteLength": len(data)}],
            "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 36},
                            {"buffer": 0, "byteOffset": 36, "byteLength": 6}],
            "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                           "min": [0, 0, 0], "max": [10, 10, 0]},
                          {"bufferView": 1, "componentType": 5123, "count": 3, "type": "SCALAR"}]}


def _reference(rng: np.random.Generator, folder: Path, name: str, kind: str) -> str:
    """A name to write into the mesh file for a referenced file of ``kind`` (made in ``folder``)."""
    p = folder / name
    if kind == "fifo":
        os.mkfifo(p)
    elif kind == "/dev/zero":
        p.symlink_to("/dev/zero")
    elif kind == "folder":
        p.mkdir()
    elif kind == "regular":
        p.write_bytes(b"not really an image")
    elif kind == "absolute":
        return "/etc/passwd"
    elif kind == "file-uri":
        return "file:///etc/passwd"
    elif kind == "dotdot":
        (folder.parent / name).write_bytes(b"outside")
        return f"../{name}"
    return name


def target_mesh_refs(rng: np.random.Generator, workdir: Path) -> str:
    """A mesh naming a hostile file, read or rendered over what it names (module docstring)."""
    from cdbrdf.errors import CDBRDFError
    from cdbrdf.mesh import read_mesh

    folder = workdir / "mesh"
    folder.mkdir()
    kind = _REF_KINDS[int(rng.integers(0, len(_REF_KINDS)))]
    fmt = str(rng.choice(["obj-mtllib", "obj-map", "gltf-image", "gltf-buffer"]))
    if fmt.startswith("obj"):
        mesh = folder / "a.obj"
        if fmt == "obj-mtllib":
            name = _reference(rng, folder, "a.mtl", kind)
            mesh.write_text(f"mtllib {name}\n" + _TRI_OBJ)
        else:
            name = _reference(rng, folder, "n.png", kind)
            (folder / "a.mtl").write_text(f"newmtl cloth\n{rng.choice(['norm', 'map_Kd', 'bump'])} {name}\n")
            mesh.write_text("mtllib a.mtl\n" + _TRI_OBJ)
    else:
        mesh = folder / "a.gltf"
        if fmt == "gltf-image":
            name = _reference(rng, folder, "n.png", kind)
            mesh.write_text(json.dumps(_gltf_doc("", name)))
        else:
            name = _reference(rng, folder, "b.bin", kind)
            mesh.write_text(json.dumps(_gltf_doc(name, "n.png")))
    if rng.random() < 0.5 or kind in ("fifo", "/dev/zero", "folder", "missing", "absolute", "file-uri"):
        try:
            read_mesh(mesh)
        except CDBRDFError as exc:
            return "ok" if "\n" not in str(exc) and str(exc) else "bad"
        return "ok"
    # -o over the file the mesh names: refused before anything is written
    named = (folder / name).resolve() if kind != "dotdot" else (folder.parent / name.removeprefix("../"))
    table = _table(workdir / "t.h5")
    before = _snapshot(workdir)
    out = named.with_suffix(".png") if named.suffix != ".png" else named
    if out != named:
        return "ok"  # an output of another name: nothing the mesh names is at risk
    status, err = _run_cli(["render", str(table), "--mesh", str(mesh), "--spp", "1", "--size", "8x8", "-o",
                            str(out)])
    return "ok" if status == 2 and err.count("\n") == 1 and _snapshot(workdir) == before else "bad"


# -- scene includes -----------------------------------------------------------------------------------------
_SCENE = ('<scene version="3.0.0">{body}<integrator type="path"/><sensor type="perspective">'
          '<film type="hdrfilm"><integer name="width" value="4"/><integer name="height" value="4"/></film>'
          '<sampler type="independent"><integer name="sample_count" value="1"/></sampler></sensor></scene>')


def target_scene_includes(rng: np.random.Generator, workdir: Path) -> str:
    """A scene with hostile includes or XML that only Mitsuba accepts (module docstring)."""
    import cdbrdf.render as cr
    from cdbrdf.errors import SceneError

    cr.set_variant("llvm_ad_rgb")
    top = workdir / "scene"
    (top / "sub").mkdir(parents=True)
    cwd = workdir / "cwd"
    cwd.mkdir()
    os.chdir(cwd)
    os.mkfifo(workdir / "pipe.xml")
    shape = '<scene version="3.0.0"><shape type="sphere"/></scene>'
    case = str(rng.choice(["duplicate-attribute", "undefined-entity", "only-in-cwd", "beside-top", "fifo-nested",
                           "fine", "fine-nested"]))
    body = ""
    if case == "duplicate-attribute":
        body = '<include filename="../pipe.xml"/><shape type="sphere" type="sphere"/>'
    elif case == "undefined-entity":
        body = '<include filename="../pipe.xml"/>&bogus;'
    elif case == "only-in-cwd":
        (cwd / "inc.xml").write_text(shape)
        body = '<include filename="inc.xml"/>'
    elif case == "beside-top":
        (top / "inc.xml").write_text(shape)
        (top / "sub" / "a.xml").write_text('<scene version="3.0.0"><include filename="inc.xml"/></scene>')
        body = '<include filename="sub/a.xml"/>'
    elif case == "fifo-nested":
        (top / "sub" / "a.xml").write_text('<scene version="3.0.0"><include filename="../../pipe.xml"/></scene>')
        body = '<include filename="sub/a.xml"/>'
    elif case == "fine":
        (top / "inc.xml").write_text(shape)
        body = '<include filename="inc.xml"/>'
    else:
        (top / "sub" / "inc.xml").write_text(shape)
        (top / "sub" / "a.xml").write_text('<scene version="3.0.0"><include filename="inc.xml"/></scene>')
        body = '<include filename="sub/a.xml"/>'
    scene = top / "s.xml"
    scene.write_text(_SCENE.format(body=body))
    try:
        loaded = cr.load_file(scene, check=False)
    except SceneError as exc:
        return "ok" if not case.startswith("fine") and "\n" not in str(exc) else "bad"
    return "ok" if case.startswith("fine") and len(loaded.shapes()) == 1 else "bad"


def _run(target: str, n: int, seed: int):
    report = fuzz_generated(f"tests.test_fuzz_hostile3:{target}", n=n, seed=seed, per_input_s=PER_INPUT_S,
                            allowed=())
    print(report.summary())
    return report


def _needs_llvm() -> None:
    from .render_helpers import needs_llvm_marker

    if needs_llvm_marker().args[0]:
        pytest.skip("needs libLLVM for Mitsuba's llvm variant")


def test_fuzz_lock_files_small():
    report = _run("target_locks", 30, seed=1)
    assert report.n == 30 and not report.bad, report.summary()


def test_fuzz_what_a_mesh_pulls_in_small():
    _needs_llvm()
    report = _run("target_mesh_refs", 40, seed=1)
    assert report.n == 40 and not report.bad, report.summary()


def test_fuzz_scene_includes_small():
    _needs_llvm()
    report = _run("target_scene_includes", 20, seed=1)
    assert report.n == 20 and not report.bad, report.summary()


@pytest.mark.slow
def test_fuzz_lock_files_400():
    report = _run("target_locks", 400, seed=2)
    assert report.n == 400 and not report.bad, report.summary()


@pytest.mark.slow
def test_fuzz_what_a_mesh_pulls_in_600():
    _needs_llvm()
    report = _run("target_mesh_refs", 600, seed=2)
    assert report.n == 600 and not report.bad, report.summary()


@pytest.mark.slow
def test_fuzz_scene_includes_300():
    _needs_llvm()
    report = _run("target_scene_includes", 300, seed=2)
    assert report.n == 300 and not report.bad, report.summary()
