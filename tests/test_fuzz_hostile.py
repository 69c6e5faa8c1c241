"""Hostile input, second round: fuzzed classes of cases that are not file bytes.

Each input is built from ``(seed, index)`` by a target run in a child process
(``tests/fuzzing.py``, :func:`~tests.fuzzing.fuzz_generated`: hangs and crashes
are caught and counted):

- **special files** (:func:`target_files`): a FIFO, a device (``/dev/zero``,
  ``/dev/null``, ``/dev/urandom``), a socket, a folder, a dangling link or a
  link loop given to every reader of a path (tables, imported BRDF files,
  meshes, photographs, capture files, plans, scenes and the files they name,
  environment maps, the command line's file options): each refuses it at
  once with one line, none blocks or reads without end;
- **scene limits** (same target): a Mitsuba scene whose film size and sample
  count come from its text or from ``-D``, with a random
  ``CDBRDF_MAX_RENDER_PIXELS``: loaded exactly when what would be rendered
  is within the limits, refused in one line otherwise;
- **outputs over inputs** (:func:`target_outputs`): every command that reads
  and writes files, its output naming one of its inputs (the same name, a
  relative or ``..`` spelling, a symbolic or hard link, a folder holding it):
  exit status 2, one line, every file unchanged byte for byte;
- **concurrent runs** (same target): a second run on an output whose lock
  another process holds: exit status 2, one line naming that process,
  nothing written;
- **Host and Origin** (:func:`test_fuzz_host_and_origin_small`, in this
  process: requests are cheap): random ``Host``, ``Origin``, ``Referer`` and
  ``Sec-Fetch-*`` headers against the viewer's server: the table is served
  exactly to its own origin.
"""

from __future__ import annotations

import contextlib
import io
import os
import socket
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from cdbrdf.errors import CDBRDFError

from .fuzzing import fuzz_generated

#: Seconds one input may take (a hang otherwise): a refusal is immediate, loading a small scene a second.
PER_INPUT_S = 30.0

_KINDS = ("fifo", "/dev/zero", "/dev/null", "/dev/urandom", "folder", "socket", "dangling", "loop")


def _special(folder: Path, name: str, kind: str) -> Path:
    p = folder / name
    if kind == "fifo":
        os.mkfifo(p)
    elif kind == "folder":
        p.mkdir()
    elif kind == "socket":
        s = socket.socket(socket.AF_UNIX)
        try:
            s.bind(str(p))
        finally:
            s.close()
    elif kind == "dangling":
        p.symlink_to(folder / "nowhere")
    elif kind == "loop":
        p.symlink_to(p)
    else:
        p.symlink_to(kind)
    return p


def _scene(folder: Path, body: str, *, film: str = '<integer name="width" value="8"/>'
           '<integer name="height" value="8"/>', spp: str = "1", defaults: str = "") -> Path:
    """A small scene: a cdbrdf-textured rectangle (a constant curvature) seen from above."""
    import cdbrdf

    g = cdbrdf.Grid(kappa=[0.0], theta_l=[0, 45], phi_l=[0, 180], theta_v=[0, 45], phi_v=[0, 180])
    cdbrdf.CDBRDF(np.full(g.shape + (3,), 0.2), g).save(folder / "t.h5")
    xml = f"""<scene version="3.0.0">{defaults}
  <integrator type="path"><integer name="max_depth" value="2"/></integrator>
  <sensor type="orthographic"><transform name="to_world"><lookat origin="0, 0, 5" target="0, 0, 0" up="0, 1, 0"/>
    </transform><film type="hdrfilm">{film}</film>
    <sampler type="independent"><integer name="sample_count" value="{spp}"/></sampler></sensor>
  <shape type="rectangle"><bsdf type="cdbrdf"><string name="filename" value="t.h5"/>
    <float name="curvature" value="0"/></bsdf></shape>
  <emitter type="directional"><vector name="direction" value="0, 0, -1"/></emitter>
  {body}
</scene>"""
    p = folder / "scene.xml"
    p.write_text(xml)
    return p


def _one_line_refusal(exc: BaseException, p: Path) -> bool:
    msg = str(exc)
    return "\n" not in msg and bool(msg) and (p.name in msg or "scene" in msg)


def _read_special(rng: np.random.Generator, folder: Path) -> str:
    """A special file under a random reader: refused at once, in one line."""
    import argparse

    import cdbrdf
    from cdbrdf import images
    from cdbrdf.commands._args import existing_file
    from cdbrdf.importers import read_source
    from cdbrdf.measure.capture import read_capture, read_plan
    from cdbrdf.measure.stands import read_stands
    from cdbrdf.mesh import read_mesh

    kind = _KINDS[int(rng.integers(0, len(_KINDS)))]
    reader = str(rng.choice(["load", "source", "mesh", "image", "capture", "plan", "stands", "argument", "scene",
                             "scene-include", "scene-file", "envmap"]))
    suffix = {"mesh": str(rng.choice([".ply", ".obj", ".stl", ".off", ".glb"])), "image": ".png", "plan": ".csv",
              "stands": ".json", "scene-file": ".xml", "envmap": ".exr", "scene": ".ply",
              "scene-include": ".xml"}.get(reader, ".h5")
    if reader == "capture":
        (folder / "cap").mkdir()
        p = _special(folder / "cap", "capture.csv", kind)
        call = lambda: read_capture(folder / "cap")  # noqa: E731
    else:
        p = _special(folder, "special" + suffix, kind)
        if reader in ("scene", "scene-include", "scene-file", "envmap"):
            import cdbrdf.render as cr

            cr.set_variant("llvm_ad_rgb")
        calls = {
            "load": lambda: cdbrdf.load(p),
            "source": lambda: read_source(p, format=str(rng.choice(["auto", "rgl", "merl", "utia", "cdbrdf"]))),
            "mesh": lambda: read_mesh(p),
            "image": lambda: images.read_image(p),
            "plan": lambda: read_plan(p),
            "stands": lambda: read_stands(p),
            "argument": lambda: existing_file()(str(p)),
        }
        if reader == "scene":
            scene = _scene(folder, f'<shape type="ply"><string name="filename" value="{p.name}"/></shape>')
            calls["scene"] = lambda: cr.load_file(scene)
        elif reader == "scene-include":
            scene = _scene(folder, f'<include filename="{p.name}"/>')
            calls["scene-include"] = lambda: cr.load_file(scene)
        elif reader == "scene-file":
            calls["scene-file"] = lambda: cr.load_file(p)
        elif reader == "envmap":
            from cdbrdf.render.lighting import environment_map as _environment_map

            calls["envmap"] = lambda: _environment_map(p)
        call = calls[reader]
    try:
        call()
    except (CDBRDFError, OSError, argparse.ArgumentTypeError) as exc:
        if kind in ("dangling", "loop") or isinstance(exc, FileNotFoundError):
            return "ok"  # nothing to read there; named in one line all the same
        return "ok" if _one_line_refusal(exc, p) else "bad"
    return "bad"  # read something from a special file


_FILM_SIDES = (-1, 0, 1, 8, 31, 64, 9000, 2**31 - 1)
_SPPS = (0, 1, 4, 65536, 65537, 2_000_000_000)


def _scene_limits(rng: np.random.Generator, folder: Path) -> str:
    """A scene's film and sampler, in its text or from -D, under a random pixel limit: refused iff beyond it."""
    import cdbrdf.render as cr
    from cdbrdf.errors import LimitError, SceneError
    from cdbrdf.limits import MAX_SPP

    cr.set_variant("llvm_ad_rgb")
    w, h = (int(rng.choice(_FILM_SIDES)) for _ in range(2))
    spp = int(rng.choice(_SPPS))
    limit = int(rng.choice([64, 4096, 67_108_864]))
    os.environ["CDBRDF_MAX_RENDER_PIXELS"] = str(limit)
    variables: dict[str, str] = {}
    if rng.random() < 0.5:  # through -D, over the scene's defaults
        film = '<integer name="width" value="$w"/><integer name="height" value="$h"/>'
        path = _scene(folder, "", film=film, spp="$spp",
                      defaults='<default name="w" value="8"/><default name="h" value="8"/>'
                               '<default name="spp" value="1"/>')
        variables = {"w": str(w), "h": str(h), "spp": str(spp)}
    else:
        path = _scene(folder, "", film=f'<integer name="width" value="{w}"/><integer name="height" value="{h}"/>',
                      spp=str(spp))
    within = w >= 1 and h >= 1 and w * h <= limit and 1 <= spp <= MAX_SPP
    try:
        scene = cr.load_file(path, variables=variables)
    except (SceneError, LimitError) as exc:
        return "bad" if within or "\n" in str(exc) else "ok"
    if not within:
        return "bad"
    if w * h <= 64 and spp <= 4:  # small enough to render here: what is rendered is what was checked
        from cdbrdf.render.picture import render_scene

        img = render_scene(scene)
        return "ok" if img.shape[:2] == (h, w) and np.all(np.isfinite(img)) else "bad"
    return "ok"


def target_files(rng: np.random.Generator, workdir: Path) -> str:
    """Special files under every reader, or a scene's limits (see the module docstring)."""
    return _scene_limits(rng, workdir) if rng.random() < 0.25 else _read_special(rng, workdir)


# -- outputs over inputs, concurrent runs ----------------------------------------------------------------
def _inputs(folder: Path) -> dict[str, Path]:
    """Small inputs of every kind the commands read."""
    import cdbrdf
    from cdbrdf.outputs import output_folder

    g = cdbrdf.Grid(kappa=[0.0], theta_l=[0, 45], phi_l=[0, 180], theta_v=[0, 45], phi_v=[0, 180])
    t = cdbrdf.CDBRDF(np.full(g.shape + (3,), 0.2), g)
    out = {"table": folder / "t.h5", "table2": folder / "k13.h5", "mesh": folder / "scan.ply",
           "envmap": folder / "env.exr", "pngtable": folder / "t.png"}
    t.save(out["table"])
    out["table2"].write_bytes(out["table"].read_bytes())
    out["pngtable"].write_bytes(out["table"].read_bytes())
    out["mesh"].write_text("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                           "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
                           "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n")
    out["envmap"].write_bytes(b"an environment map")
    with output_folder(folder / "sim") as d:
        (d / "capture.csv").write_text("file,kappa,theta_l,phi_l,theta_v,phi_v,exposure,kind,encoding\n")
    out["plan"] = folder / "sim" / "capture.csv"
    return out


#: Commands that read and write files: (argv with {name} for inputs and {out} for the output, the input the
#: output may alias, whether the output is a folder).
_COMMANDS = [
    (["curvature", "{mesh}", "-o", "{out}"], "mesh", False),
    (["import", "{table}", "-o", "{out}"], "table", False),
    (["stack", "--kappa", "0", "{table}", "--kappa", "0.13", "{table2}", "-o", "{out}"], "table2", False),
    (["render", "{table}", "--mesh", "{mesh}", "--envmap", "{envmap}", "-o", "{out}"], "envmap", False),
    (["render", "{table}", "--scene", "sine", "-o", "{out}"], "table", False),
    (["mosaic", "{pngtable}", "-o", "{out}"], "pngtable", False),
    (["view", "{table}", "--export", "{out}"], "table", True),
    (["simulate-capture", "{table}", "--plan", "{plan}", "-o", "{out}"], "plan", True),
    (["synth", "denim", "-o", "{out}"], None, False),
    (["plan", "-o", "{out}"], None, True),
    (["demo", "-o", "{out}"], None, True),
]


def _alias(rng: np.random.Generator, folder: Path, target: Path, is_folder: bool) -> str:
    """A name for ``target`` (or, for a folder output, a folder holding it) spelled in a random way."""
    if is_folder:
        return str(rng.choice([str(target.parent), str(target.parent) + "/", f"{target.parent}/."]))
    style = str(rng.choice(["same", "relative", "dot", "dotdot", "symlink", "hardlink", "absolute"]))
    if style == "symlink":
        link = folder / "alias-link"
        link.symlink_to(target)
        return str(link)
    if style == "hardlink":
        link = folder / "alias-hard"
        os.link(target, link)
        return str(link)
    if style == "relative":
        return os.path.relpath(target)
    if style == "dot":
        return f"./{os.path.relpath(target)}"
    if style == "dotdot":
        return str(target.parent / ".." / target.parent.name / target.name)
    if style == "absolute":
        return str(target.resolve())
    return str(target)


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


_HOLDER = ("import fcntl, os, sys, time\n"
           "fd = os.open(sys.argv[1], os.O_RDWR | os.O_CREAT)\n"
           "fcntl.flock(fd, fcntl.LOCK_EX)\n"
           "os.write(fd, str(os.getpid()).encode())\n"
           "print('held', flush=True)\n"
           "time.sleep(120)\n")


def target_outputs(rng: np.random.Generator, workdir: Path) -> str:
    """A command whose output aliases an input, or whose output another run holds (module docstring)."""
    os.chdir(workdir)  # relative spellings are relative to here
    names = _inputs(workdir)
    concurrent = rng.random() < 0.35
    choices = [c for c in _COMMANDS if concurrent or c[1] is not None]
    argv_t, aliased, is_folder = choices[int(rng.integers(0, len(choices)))]
    if concurrent:
        out = workdir / str(rng.choice(["out.h5", "out.png", "out.ply", "outdir"]))
        if is_folder:
            out = workdir / "outdir"
        elif argv_t[0] in ("mosaic", "render"):
            out = out.with_suffix(".png")
        elif argv_t[0] == "curvature":
            out = out.with_suffix(".ply")
        else:
            out = out.with_suffix(".h5")
        if not is_folder and rng.random() < 0.5:
            out.write_bytes(b"the other run's result")
        lock = out.with_name(f".{out.name}.lock")
        holder = subprocess.Popen([sys.executable, "-I", "-S", "-c", _HOLDER, str(lock)], stdout=subprocess.PIPE,
                                  text=True)
        try:
            if holder.stdout.readline().strip() != "held":
                return "bad"
            before = _snapshot(workdir)
            argv = [a.format(out=str(out), **{k: str(v) for k, v in names.items()}) for a in argv_t]
            status, err = _run_cli(argv)
            ok = (status == 2 and err.count("\n") == 1 and f"another cdbrdf run (process {holder.pid})" in err
                  and _snapshot(workdir) == before)
            return "ok" if ok else "bad"
        finally:
            holder.kill()
            holder.wait()
            holder.stdout.close()
    target = names[aliased]
    out_text = _alias(rng, workdir, target, is_folder)
    before = _snapshot(workdir)
    argv = [a.format(out=out_text, **{k: str(v) for k, v in names.items()}) for a in argv_t]
    status, err = _run_cli(argv)
    ok = status == 2 and err.count("\n") == 1 and "Traceback" not in err and _snapshot(workdir) == before
    return "ok" if ok else "bad"


def _run(target: str, n: int, seed: int):
    report = fuzz_generated(f"tests.test_fuzz_hostile:{target}", n=n, seed=seed, per_input_s=PER_INPUT_S,
                            allowed=())
    print(report.summary())
    return report


def test_fuzz_special_files_and_scene_limits_small():
    from .render_helpers import needs_llvm_marker

    if needs_llvm_marker().args[0]:
        pytest.skip("needs libLLVM for Mitsuba's llvm variant")
    report = _run("target_files", 40, seed=1)
    assert report.n == 40 and not report.bad, report.summary()


def test_fuzz_outputs_over_inputs_and_concurrent_runs_small():
    report = _run("target_outputs", 30, seed=1)
    assert report.n == 30 and not report.bad, report.summary()


@pytest.mark.slow
def test_fuzz_special_files_and_scene_limits_1000():
    report = _run("target_files", 1000, seed=2)
    assert report.n == 1000 and not report.bad, report.summary()


@pytest.mark.slow
def test_fuzz_outputs_over_inputs_and_concurrent_runs_600():
    report = _run("target_outputs", 600, seed=2)
    assert report.n == 600 and not report.bad, report.summary()


# -- Host and Origin ----------------------------------------------------------------------------------------
def _request(port: int, path: str, headers: list[tuple[str, str]]) -> int:
    head = "".join(f"{k}: {v}\r\n" for k, v in headers)
    with socket.create_connection(("127.0.0.1", port), timeout=10) as s:
        s.sendall(f"GET {path} HTTP/1.1\r\n{head}Connection: close\r\n\r\n".encode("utf-8", "surrogateescape"))
        data = b""
        while b"\r\n" not in data:
            chunk = s.recv(4096)
            if not chunk:
                break
            data += chunk
    parts = data.split(b" ", 2)
    return int(parts[1]) if len(parts) > 1 and parts[1].isdigit() else -1


def _pick(rng: np.random.Generator, items: list[str]) -> str:
    """One of ``items`` as it is (numpy's choice would drop a trailing NUL)."""
    return items[int(rng.integers(0, len(items)))]


def _fuzz_host_origin(n: int, seed: int) -> tuple[int, list]:
    from cdbrdf.view.server import ViewerServer

    files = {"index.html": b"<html></html>", "data.js": b"window.CDBRDF_VIEWER_DATA = {};", "assets/t.bin": b"x"}
    rng = np.random.default_rng(seed)
    bad = []
    with ViewerServer(files).start() as srv:
        port = srv.port
        ours = [f"127.0.0.1:{port}", f"localhost:{port}", f"LOCALHOST:{port}"]
        foreign = [f"evil.example:{port}", "127.0.0.1", f"127.0.0.1:{port + 1}", f"127.0.0.2:{port}",
                   f"[::1]:{port}", f"127.0.0.1.:{port}", f"127.0.0.1:{port} evil", f"user@127.0.0.1:{port}",
                   "", f"127.0.0.1:{port}\x00", f"xn--e1a.example:{port}", f"127.1:{port}", f"0x7f000001:{port}"]
        origins = [f"http://127.0.0.1:{port}", f"http://localhost:{port}", "http://evil.example", "null",
                   f"https://127.0.0.1:{port}", f"http://127.0.0.1:{port + 1}", f"http://127.0.0.1:{port}.evil.example"]
        for _ in range(n):
            path = str(rng.choice(["/", "/index.html", "/data.js", "/assets/t.bin"]))
            host_ok = rng.random() < 0.6
            headers: list[tuple[str, str]] = []
            if host_ok:
                headers.append(("Host", _pick(rng, ours)))
            elif rng.random() < 0.9:
                headers.append(("Host", _pick(rng, foreign)))
            ok_origin = True
            for name in ("Origin", "Referer"):
                if rng.random() < 0.4:
                    o = _pick(rng, origins)
                    o = o + "/page.html" if name == "Referer" else o
                    headers.append((name, o))
                    ok_origin &= o.startswith((f"http://127.0.0.1:{port}/", f"http://localhost:{port}/")) or o in (
                        f"http://127.0.0.1:{port}", f"http://localhost:{port}")
            site = None
            if rng.random() < 0.5:
                site = str(rng.choice(["same-origin", "none", "same-site", "cross-site"]))
                headers.append(("Sec-Fetch-Site", site))
            mode = None
            if rng.random() < 0.5:
                mode = str(rng.choice(["navigate", "no-cors", "cors"]))
                headers.append(("Sec-Fetch-Mode", mode))
            rng.shuffle(headers)
            page = path in ("/", "/index.html") and (mode is None or mode == "navigate")
            want = 200 if host_ok and (page or (ok_origin and site in (None, "same-origin", "none"))) else 403
            got = _request(port, path, headers)
            if (got == 200) != (want == 200):  # a refusal is 403 (or 400 for a header HTTP itself refuses)
                bad.append((path, headers, want, got))
    return n, bad


def test_fuzz_host_and_origin_small():
    n, bad = _fuzz_host_origin(150, seed=1)
    assert not bad, bad[:5]


@pytest.mark.slow
def test_fuzz_host_and_origin_5000():
    n, bad = _fuzz_host_origin(5000, seed=2)
    assert not bad, bad[:5]
