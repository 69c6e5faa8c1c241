"""The interactive viewer: assets, export, server, command line, and the page in headless Chromium.

The browser tests share one Chromium per module (software WebGL2: SwiftShader)
and one exported page holding two tables: the bundled denim (anisotropic,
the paper's grid) and a random isotropic table with a first elevation above
0 (a virtual pole node), uneven curvatures and filled samples.
"""

from __future__ import annotations

import errno
import json
import os
import shutil
import signal
import socket
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import cdbrdf
from cdbrdf import materials
from cdbrdf.cli import main
from cdbrdf.errors import LimitError, OptionError
from cdbrdf.view.asset import WEBGL2_MIN_LIMITS, check_texture, parse_grid, resample, table_asset, texture_shape
from cdbrdf.view.export import export_viewer, viewer_files, write_viewer
from cdbrdf.view.server import ViewerServer

from .conftest import make_table

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
needs_chromium = pytest.mark.skipif(
    CHROMIUM is None and not os.environ.get("CI"),
    reason="Debian's chromium is not installed (scripts/setup.sh --test installs it; required in CI)")

#: Software WebGL2 in headless Chromium (no GPU on the test machines).
CHROMIUM_ARGS = ["--no-sandbox", "--use-angle=swiftshader", "--enable-unsafe-swiftshader",
                 "--disable-background-networking", "--disable-component-update", "--disable-sync",
                 "--no-first-run"]


def iso_table() -> cdbrdf.CDBRDF:
    """Isotropic, theta from 10 (virtual pole node), uneven kappa, a few filled samples with sources."""
    g = cdbrdf.Grid(kappa=[-0.2, -0.05, 0.0, 0.25], theta_l=[10.0, 35.0, 60.0, 80.0], phi_l=[0.0],
                    theta_v=[10.0, 30.0, 55.0, 70.0, 85.0], phi_v=np.arange(0.0, 360.0, 45.0),
                    symmetry="isotropic")
    t = make_table(g, seed=3, dtype=np.float32)
    measured = np.ones(g.shape, bool)
    measured[0, 0, 3, :, 4] = False  # a concave stand hides grazing directions
    src = np.full(g.shape, -1, np.int64)
    flat = np.arange(measured.size).reshape(g.shape)
    src[~measured] = flat[2][None][~measured[0:1]]  # from the flat stand, same direction
    return cdbrdf.CDBRDF(t.values, **g.axes(), measured=measured, fill_source=src, symmetry="isotropic",
                         attrs={"material": "random-iso", "quantity": "relative"})


def rel_close(gpu: np.ndarray, ref: np.ndarray, rtol: float) -> np.ndarray:
    return np.abs(gpu - ref) <= rtol * np.abs(ref) + 1e-7


# -- assets and resampling (no browser) -----------------------------------------------
def test_table_asset_holds_the_lookup_grid():
    t = materials.load("denim")
    a = table_asset(t, name="denim.h5")
    h = a.header
    lg = t.lookup_grid()
    b = h["blocks"]["lookup"]
    tex = np.frombuffer(a.blob, "<f4", b["bytes"] // 4, b["offset"]).reshape(b["shape"])
    # each layer: the Fig. 7 image (72 x 72) row-major, folded into rows of 2048 texels, the last padded
    assert h["lookup"]["texture"] == {"width": 2048, "height": 3, "layers": 5, "columns": 72, "rows": 72,
                                      "format": "RGBA", "type": "float32"}
    np.testing.assert_array_equal(unfold(tex, lg.values.shape)[..., :3], lg.values)  # the pole rule of interp, not a new one
    assert np.all(tex.reshape(5, -1, 4)[:, 72 * 72:] == 0)
    assert h["axes"]["kappa"] == t.kappa.tolist() and h["units"]["kappa"] == "1/mm"
    assert h["symmetry"] == "anisotropic" and h["material"] == "denim" and h["quantity"] == "brdf"
    s = h["blocks"]["samples"]
    np.testing.assert_array_equal(np.frombuffer(a.blob, "<f4", s["bytes"] // 4, s["offset"]).reshape(t.shape), t.values)
    json.loads(a.header_json())


def test_isotropic_asset_keeps_its_layout_and_pole_node():
    t = iso_table()
    h = table_asset(t, name="iso").header
    assert h["symmetry"] == "isotropic" and h["lookup"]["isotropic"]
    assert h["lookup"]["theta_l"][0] == 0.0 and h["lookup"]["shape"] == [4, 1, 5, 8, 6]  # virtual pole nodes
    f = h["blocks"]["fill_source"]
    assert f["dtype"] == "int32" and f["shape"] == list(t.grid.shape)


def unfold(tex: np.ndarray, shape: tuple[int, ...]) -> np.ndarray:
    """The lookup texture (layers, height, width, 4) back to (kappa, phi_l, theta_l, phi_v, theta_v, 4)."""
    n = int(np.prod(shape[1:5]))
    return tex.reshape(shape[0], -1, 4)[:, :n].reshape(*shape[:5], 4)


def test_float16_asset():
    t = materials.load("denim")
    a = table_asset(t, precision="float16")
    b = a.header["blocks"]["lookup"]
    tex = np.frombuffer(a.blob, "<f2", b["bytes"] // 2, b["offset"]).reshape(b["shape"])
    lg = t.lookup_grid()
    np.testing.assert_allclose(unfold(tex, lg.values.shape)[..., :3], lg.values, rtol=1e-3)
    with pytest.raises(OptionError, match="precision: 'half' is not one of auto, float32, float16"):
        table_asset(t, precision="half")


def test_grey_tables_and_other_channel_counts():
    g = cdbrdf.Grid(kappa=[0.0], theta_l=[0.0, 45.0], phi_l=[0.0, 180.0], theta_v=[0.0, 45.0], phi_v=[0.0, 180.0])
    a = table_asset(make_table(g, channels=1, dtype=np.float32))
    b = a.header["blocks"]["lookup"]
    tex = np.frombuffer(a.blob, "<f4", b["bytes"] // 4, b["offset"]).reshape(b["shape"])
    assert (tex[..., 0] == tex[..., 1]).all() and (tex[..., 0] == tex[..., 2]).all() and a.header["n_channels"] == 1
    with pytest.raises(OptionError, match="the viewer shows RGB or grey tables; this one has 2 channels"):
        table_asset(make_table(g, channels=2))


def wide_table() -> cdbrdf.CDBRDF:
    g = cdbrdf.Grid(kappa=[0.0], theta_l=[0.0, 45.0], phi_l=[0.0], theta_v=np.arange(0.0, 76.0, 15.0),
                    phi_v=np.arange(360) * 1.0)
    return make_table(g, dtype=np.float32)


def many_kappa_table() -> cdbrdf.CDBRDF:
    """More curvatures than WebGL2 guarantees texture layers (256)."""
    g = cdbrdf.Grid(kappa=np.linspace(-0.3, 0.3, 257), theta_l=[0.0, 45.0], phi_l=[0.0], theta_v=[0.0, 45.0],
                    phi_v=[0.0, 180.0])
    return make_table(g, dtype=np.float32)


def test_texture_limit_names_the_limit_and_grid():
    t = wide_table()
    check_texture(t)  # 2,160 view directions: folded into rows of 2048, within the guaranteed size
    assert texture_shape(t) == (2048, 3, 1)
    with pytest.raises(LimitError, match=r"wide: too large .*4,320 light x view directions per curvature > "
                       r"MAX_TEXTURE_SIZE\^2 = 4,096 texels.*--grid THETA_STEP,PHI_STEP"):
        check_texture(t, name="wide", limits={**WEBGL2_MIN_LIMITS, "MAX_TEXTURE_SIZE": 64})
    with pytest.raises(LimitError, match=r"257 curvatures \(texture layers\) > MAX_ARRAY_TEXTURE_LAYERS 256"):
        check_texture(many_kappa_table())
    small = resample(t, **dict(zip(("theta_step_deg", "phi_step_deg", "n_kappa"), parse_grid("15,30"))))
    assert small.shape == (1, 1, 6, 12, 6, 3) or small.grid.phi_v.size == 12
    check_texture(small)
    m = small.grid.mesh()
    np.testing.assert_allclose(small.values, t.evaluate(m["theta_v"], m["phi_v"], m["theta_l"], m["phi_l"], m["kappa"]),
                               rtol=1e-6)
    assert small.attrs["resampled_from"] == "1x1x2x360x6"


def test_resample_keeps_isotropy_and_evaluates():
    t = iso_table()
    r = resample(t, theta_step_deg=20, phi_step_deg=90, n_kappa=3)
    assert r.isotropic and r.kappa.tolist() == pytest.approx([-0.2, 0.025, 0.25])
    m = r.grid.mesh()
    np.testing.assert_allclose(r.values, t.evaluate(m["theta_v"], m["phi_v"], m["theta_l"], m["phi_l"], m["kappa"]),
                               rtol=1e-6)


@pytest.mark.parametrize("text, msg", [("15", "THETA_STEP,PHI_STEP"), ("a,30", "THETA_STEP"),
                                       ("0,30", "must lie in"), ("15,25", "does not divide 360"),
                                       ("15,30,0", "N_KAPPA")])
def test_parse_grid_refusals(text, msg):
    with pytest.raises(OptionError, match=msg):
        parse_grid(text)


# -- export and server ------------------------------------------------------------------
@pytest.fixture(scope="module")
def user_ply(tmp_path_factory):
    """A user's mesh with per-vertex curvature, written by ``cdbrdf curvature``: a bump, convex on top."""
    from cdbrdf.mesh import Mesh, write_ply

    d = tmp_path_factory.mktemp("mesh")
    n = 33
    x = np.linspace(-20.0, 20.0, n)
    X, Y = np.meshgrid(x, x, indexing="ij")
    Z = 8.0 * np.exp(-(X**2 + Y**2) / 120.0)
    i, j = np.meshgrid(np.arange(n - 1), np.arange(n - 1), indexing="ij")
    a = (i * n + j).ravel()
    faces = np.concatenate([np.stack([a, a + n, a + n + 1], 1), np.stack([a, a + n + 1, a + 1], 1)])
    uv = np.stack([(X.ravel() + 20) / 40, (Y.ravel() + 20) / 40], 1)
    write_ply(d / "bump.ply", Mesh(np.stack([X.ravel(), Y.ravel(), Z.ravel()], 1), faces, uv=uv))
    assert main(["-q", "curvature", str(d / "bump.ply"), "-o", str(d / "bump-curvature.ply")]) == 0
    return d / "bump-curvature.ply"


@pytest.fixture(scope="module")
def files(user_ply):
    from cdbrdf.mesh import prepare_mesh
    from cdbrdf.view.export import default_meshes

    meshes = {"drape": ("draped cloth", default_meshes()["drape"]), "user": ("bump", prepare_mesh(user_ply))}
    return viewer_files([("denim.h5", materials.load("denim")), ("iso.h5", iso_table())], meshes=meshes)


def test_user_mesh_asset(files, user_ply):
    from cdbrdf.mesh import read_mesh

    h = json.loads(files["assets/mesh-user.json"])
    m = read_mesh(user_ply)
    k = m.attributes["curvature"]
    assert h["n_vertices"] == m.n_vertices and h["curvature_range"] == pytest.approx([k.min(), k.max()], rel=1e-6)
    assert h["curvature_range"][1] > 0.05  # the top of the bump is convex
    blob = files["assets/mesh-user.bin"]
    t = h["blocks"]["tangent"]
    tan = np.frombuffer(blob, "<f4", t["bytes"] // 4, t["offset"]).reshape(-1, 3)
    nb = h["blocks"]["normal"]
    nrm = np.frombuffer(blob, "<f4", nb["bytes"] // 4, nb["offset"]).reshape(-1, 3)
    np.testing.assert_allclose(np.linalg.norm(tan, axis=1), 1, atol=1e-5)
    np.testing.assert_allclose(np.einsum("ij,ij->i", tan, nrm), 0, atol=1e-5)  # in the tangent plane
    assert np.mean(tan[:, 0]) > 0.9  # dP/du: u runs along x


def test_export_is_self_contained(files, tmp_path):
    index = export_viewer(tmp_path / "v", files)
    page = index.read_text()
    assert '<script src="data.js">' in page and '<script src="viewer.js">' in page
    for f in ("index.html", "viewer.js", "data.js", "assets/table-0.bin", "assets/table-0.json",
              "assets/mesh-drape.bin"):
        assert (tmp_path / "v" / f).is_file(), f
    text = page + (tmp_path / "v" / "viewer.js").read_text()
    assert "http://" not in text and "https://" not in text and "fetch(" not in text  # works offline, from file://
    header = json.loads((tmp_path / "v" / "assets" / "table-1.json").read_text())
    assert header["symmetry"] == "isotropic" and header["name"] == "iso.h5"
    assert (tmp_path / "v" / "assets" / "table-1.bin").stat().st_size == sum(
        (b["bytes"] + 3) // 4 * 4 for b in header["blocks"].values())


def test_export_is_atomic_and_refuses_a_users_folder(files, tmp_path, monkeypatch):
    dest = tmp_path / "v"
    export_viewer(dest, files)
    export_viewer(dest, files)  # an earlier export is replaced whole
    (dest / "notes.txt").write_text("mine")
    with pytest.raises(FileExistsError, match="cdbrdf did not write"):
        export_viewer(dest, files)
    assert (dest / "notes.txt").read_text() == "mine"
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "a.txt").write_text("keep")
    with pytest.raises(FileExistsError, match="not written by cdbrdf"):
        export_viewer(mine, files)
    assert sorted(p.name for p in mine.iterdir()) == ["a.txt"]

    def broken(folder, fs):
        write_viewer(folder, {"index.html": b"half"})
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr("cdbrdf.view.export.write_viewer", broken)
    with pytest.raises(OSError, match="No space"):
        export_viewer(tmp_path / "new", files)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["mine", "v"]  # no half-written folder


def test_server_serves_the_files_and_refuses_a_busy_port(files):
    import urllib.error
    import urllib.request

    with ViewerServer(files).start() as srv:
        assert srv.url.startswith("http://127.0.0.1:")
        with urllib.request.urlopen(srv.url) as r:
            assert r.headers["Content-Type"].startswith("text/html") and r.read() == files["index.html"]
        with urllib.request.urlopen(srv.url + "assets/table-0.bin") as r:
            assert r.read() == files["assets/table-0.bin"]
        with pytest.raises(urllib.error.HTTPError, match="404"):
            urllib.request.urlopen(srv.url + "../../etc/passwd")
        with pytest.raises(OptionError, match=f"port {srv.port}: already in use on 127.0.0.1"):
            ViewerServer(files, port=srv.port)


def _request(port, path="/data.js", headers=None):
    """The status of a raw GET with exactly ``headers`` (Host included: no client adds its own)."""
    head = "".join(f"{k}: {v}\r\n" for k, v in (headers or {}).items())
    with socket.create_connection(("127.0.0.1", port), timeout=10) as s:
        s.sendall(f"GET {path} HTTP/1.1\r\n{head}Connection: close\r\n\r\n".encode("latin-1"))
        data = b""
        while b"\r\n\r\n" not in data:
            chunk = s.recv(65536)
            if not chunk:
                break
            data += chunk
    status_line, _, rest = data.partition(b"\r\n")
    return int(status_line.split()[1]), rest.decode("latin-1").lower()


def test_server_answers_only_its_own_host_and_origin(files):
    """It answered any Host (DNS rebinding) and served data.js to any Origin (a <script src> on another site)."""
    with ViewerServer(files).start() as srv:
        host = f"127.0.0.1:{srv.port}"
        own = f"http://{host}"
        status, head = _request(srv.port, headers={"Host": host})
        assert status == 200 and "cross-origin-resource-policy: same-origin" in head
        assert _request(srv.port, headers={"Host": f"localhost:{srv.port}"})[0] == 200
        assert _request(srv.port, headers={"Host": host, "Origin": own, "Referer": own + "/",
                                           "Sec-Fetch-Site": "same-origin"})[0] == 200
        refused = [{"Host": f"evil.example:{srv.port}"}, {"Host": "127.0.0.1"}, {"Host": f"127.0.0.1:{srv.port + 1}"},
                   {}, {"Host": host, "Origin": "http://evil.example"}, {"Host": host, "Origin": "null"},
                   {"Host": host, "Referer": "http://evil.example/page.html"},
                   {"Host": host, "Sec-Fetch-Site": "cross-site"}, {"Host": host, "Sec-Fetch-Site": "same-site"}]
        for headers in refused:
            assert _request(srv.port, headers=headers)[0] == 403, headers
            assert _request(srv.port, "/assets/table-0.bin", headers=headers)[0] == 403, headers
        # the page itself may be opened from a link on another site (it holds no data), never for another Host
        assert _request(srv.port, "/", {"Host": host, "Sec-Fetch-Site": "cross-site", "Sec-Fetch-Mode": "navigate"})[0] == 200
        assert _request(srv.port, "/", {"Host": f"evil.example:{srv.port}"})[0] == 403


def test_two_host_headers_are_a_400_and_a_malformed_origin_a_403(files):
    """The first of two Hosts won (HTTP requires 400); an Origin of ``http://[::1`` raised in the handler."""
    with ViewerServer(files).start() as srv:
        host = f"127.0.0.1:{srv.port}"
        head = f"GET /data.js HTTP/1.1\r\nHost: {host}\r\nHost: evil.example\r\nConnection: close\r\n\r\n"
        with socket.create_connection(("127.0.0.1", srv.port), timeout=10) as s:
            s.sendall(head.encode())
            assert s.recv(100).split()[1] == b"400"
        assert _request(srv.port, headers={"Host": host, "Origin": "http://[::1"})[0] == 403
        assert _request(srv.port, headers={"Host": host, "Referer": "http://[::1/x"})[0] == 403
        assert _request(srv.port, headers={"Host": host})[0] == 200


def test_silent_connections_are_closed_and_cannot_hold_every_thread(files, monkeypatch):
    """300 half-open connections held 300 threads for ever."""
    import time

    from cdbrdf.view import server

    monkeypatch.setattr(server, "IDLE_TIMEOUT_S", 0.5)
    with ViewerServer(files).start() as srv:
        idle = [socket.create_connection(("127.0.0.1", srv.port), timeout=10) for _ in range(server.MAX_CONNECTIONS + 8)]
        try:
            time.sleep(0.3)
            t0 = time.monotonic()
            for s in idle[:4]:  # the server closes them: recv returns b"" (or an error page) without hanging
                s.recv(100)
            assert time.monotonic() - t0 < 5
            time.sleep(0.8)
            assert _request(srv.port, headers={"Host": f"127.0.0.1:{srv.port}"})[0] == 200  # still serving
        finally:
            for s in idle:
                s.close()


def test_a_client_that_resets_mid_download_is_logged_without_a_traceback(files, capfd, caplog):
    import logging
    import struct
    import time

    caplog.set_level(logging.DEBUG, logger="cdbrdf.view.server")
    with ViewerServer(files).start() as srv:
        for _ in range(3):
            s = socket.create_connection(("127.0.0.1", srv.port))
            s.sendall(f"GET /data.js HTTP/1.1\r\nHost: 127.0.0.1:{srv.port}\r\n\r\n".encode())
            s.recv(100)
            s.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack("ii", 1, 0))
            s.close()  # a reset while the server still writes data.js
        time.sleep(0.5)
        assert _request(srv.port, headers={"Host": f"127.0.0.1:{srv.port}"})[0] == 200  # still serving
    err = capfd.readouterr().err
    assert "Traceback" not in err and err == "", err
    assert all("\n" not in r.getMessage() for r in caplog.records)


def test_export_never_replaces_a_folder_another_command_made(tmp_path, files):
    """--export onto a capture folder wiped 735 photographs; onto the demo's folder, its input tables."""
    from cdbrdf.errors import OutputError
    from cdbrdf.outputs import output_folder

    with output_folder(tmp_path / "capture") as d:  # a simulated capture: no maker recorded
        (d / "capture.csv").write_text("file\n")
        (d / "k0").mkdir()
        (d / "k0" / "a.png").write_bytes(b"photo")
    with pytest.raises(OutputError, match=r"capture: an output folder cdbrdf made, but not by `cdbrdf view --export`"):
        export_viewer(tmp_path / "capture", files)
    assert (tmp_path / "capture" / "k0" / "a.png").read_bytes() == b"photo"
    export_viewer(tmp_path / "v", files)
    export_viewer(tmp_path / "v", files)  # an earlier export is replaced


# -- command line ------------------------------------------------------------------------
def test_cli_errors_are_one_line(tmp_path, capsys):
    bad = tmp_path / "bad.h5"
    bad.write_bytes(b"not a table at all")
    assert main(["view", str(bad), "--export", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("cdbrdf view: error: ") and str(bad) in err and err.count("\n") == 1
    assert not (tmp_path / "o").exists()
    deep = tmp_path / "deep.h5"
    many_kappa_table().save(deep)
    assert main(["view", str(deep), "--export", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "MAX_ARRAY_TEXTURE_LAYERS 256" in err and "--grid" in err and err.count("\n") == 1
    assert not (tmp_path / "o").exists()
    d = materials.path("denim")
    assert main(["view", str(d), str(d), str(d), "--export", str(tmp_path / "o")]) == 2
    assert "at most 2 tables" in capsys.readouterr().err
    with pytest.raises(SystemExit) as e:
        main(["view", str(d), "--grid", "15,25"])
    assert e.value.code == 2 and "does not divide 360" in capsys.readouterr().err


def test_cli_export_with_grid(tmp_path, capsys):
    wide = tmp_path / "wide.h5"
    wide_table().save(wide)
    assert main(["view", str(wide), "--grid", "15,30", "--export", str(tmp_path / "o")]) == 0
    assert "wrote" in capsys.readouterr().out
    h = json.loads((tmp_path / "o" / "assets" / "table-0.json").read_text())
    assert h["lookup"]["texture"]["columns"] == 72 and h["resampled_from"] == "1x1x2x360x6"


def test_cli_export_with_a_users_mesh(tmp_path, user_ply, capsys):
    assert main(["-q", "view", str(materials.path("denim")), "--mesh", str(user_ply), "--export",
                 str(tmp_path / "o")]) == 0
    h = json.loads((tmp_path / "o" / "assets" / "mesh-user.json").read_text())
    assert h["name"] == "bump-curvature.ply" and h["n_faces"] == 2 * 32 * 32
    assert '"user":' in (tmp_path / "o" / "data.js").read_text()


def _bump_obj(path, *, units_per_mm: float = 1.0) -> None:
    """The bump of ``user_ply`` as a Y-up OBJ (height along +y, the bump's y along -z), no curvature."""
    n = 17
    x = np.linspace(-20.0, 20.0, n)
    X, Y = np.meshgrid(x, x, indexing="ij")
    H = 8.0 * np.exp(-(X**2 + Y**2) / 120.0)
    lines = [f"v {a:.6f} {h:.6f} {-b:.6f}" for a, b, h in
             zip(X.ravel() * units_per_mm, Y.ravel() * units_per_mm, H.ravel() * units_per_mm, strict=True)]
    for i in range(n - 1):
        for j in range(n - 1):
            a = i * n + j + 1
            lines += [f"f {a} {a + n} {a + n + 1}", f"f {a} {a + n + 1} {a + 1}"]
    path.write_text("\n".join(lines) + "\n")


def _mesh_positions(folder):
    h = json.loads((folder / "assets" / "mesh-user.json").read_text())
    b = h["blocks"]["position"]
    blob = (folder / "assets" / "mesh-user.bin").read_bytes()
    return h, np.frombuffer(blob, "<f4", b["bytes"] // 4, b["offset"]).reshape(-1, 3)


def test_cli_export_turns_a_y_up_obj_upright(tmp_path, capsys):
    obj = tmp_path / "bump.obj"
    _bump_obj(obj, units_per_mm=0.1)  # in cm
    assert main(["view", str(materials.path("denim")), "--mesh", str(obj), "--units", "cm", "--export",
                 str(tmp_path / "o")]) == 0
    err = capsys.readouterr().err
    assert "up axis: y (the object is flat along y)" in err
    h, pos = _mesh_positions(tmp_path / "o")
    # z-up and in mm: 40 x 40 mm wide, 8 mm high; the top of the bump is convex (curvature in 1/mm)
    np.testing.assert_allclose(h["size_mm"], [40.0, 40.0, 8.0 - 8.0 * np.exp(-800 / 120)], rtol=1e-4)
    top = np.argmax(pos[:, 2])
    assert abs(pos[top, 0]) < 1e-4 and abs(pos[top, 1]) < 1e-4
    assert h["curvature_range"][1] > 0.05
    # --up z keeps the file's axes: the bump then stands along y
    assert main(["-q", "view", str(materials.path("denim")), "--mesh", str(obj), "--units", "cm", "--up", "z",
                 "--export", str(tmp_path / "o")]) == 0
    h, _ = _mesh_positions(tmp_path / "o")
    np.testing.assert_allclose(h["size_mm"], [40.0, 8.0 - 8.0 * np.exp(-800 / 120), 40.0], rtol=1e-4)


def _default_sigint() -> None:
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_cli_serves_until_interrupted_and_refuses_a_busy_port(tmp_path):
    env = {**os.environ, "PYTHONPATH": str(Path(cdbrdf.__file__).parents[1])}
    env.pop("DISPLAY", None)
    env.pop("WAYLAND_DISPLAY", None)
    cmd = [sys.executable, "-m", "cdbrdf.cli", "view", str(materials.path("denim"))]
    # Ctrl-C as in a terminal: a suite run as a background job has SIGINT ignored, which the child
    # would inherit (and Python then installs no KeyboardInterrupt handler)
    p = subprocess.Popen(cmd + ["--port", str(_free_port())], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                         text=True, env=env, preexec_fn=_default_sigint)
    try:
        line = p.stdout.readline()
        assert "serving denim.h5 at http://127.0.0.1:" in line, line + p.stderr.read()
        port = int(line.split("127.0.0.1:")[1].split("/")[0])
        busy = subprocess.run(cmd + ["--port", str(port), "--no-browser"], capture_output=True, text=True, env=env,
                              timeout=60)
        assert busy.returncode == 2
        assert busy.stderr == (f"cdbrdf view: error: port {port}: already in use on 127.0.0.1; choose another "
                               "--port or leave it out for a free one\n")
        p.send_signal(signal.SIGINT)
        out, err = p.communicate(timeout=30)
    finally:
        if p.poll() is None:
            p.kill()
    assert p.returncode == 0 and "Traceback" not in err and "stopped" in err


# -- the page in headless Chromium (the browser fixture: conftest.py) --------------------


def open_page(browser, url, *, width=320, height=200):
    page = browser.new_page(viewport={"width": 1200, "height": 900})
    page.set_default_timeout(60_000)
    messages = []
    page.on("console", lambda m: messages.append(f"{m.type}: {m.text}"))
    page.on("pageerror", lambda e: messages.append(f"pageerror: {e}"))
    page.on("requestfailed", lambda r: messages.append(f"requestfailed: {r.url}"))
    page.goto(url, wait_until="load")
    page.evaluate("window.cdbrdfViewer.ready")
    page.evaluate(f"cdbrdfViewer.setSize({width}, {height})")
    return page, messages


@pytest.fixture(scope="module")
def exported(files, tmp_path_factory):
    return export_viewer(tmp_path_factory.mktemp("viewer") / "v", files)


@pytest.fixture(scope="module")
def page(browser, exported):
    page, messages = open_page(browser, exported.resolve().as_uri())
    page.messages = messages
    yield page
    page.close()


@needs_chromium
def test_page_opens_from_disk_without_console_messages(page):
    assert page.messages == []
    st = page.evaluate("cdbrdfViewer.state()")
    assert st["tables"] == ["denim.h5", "iso.h5"] and st["surfaces"] == ["sheet", "stand", "drape", "user"]


@needs_chromium
def test_page_served_without_console_messages(browser, files):
    with ViewerServer(files).start() as srv:
        page, messages = open_page(browser, srv.url)
        page.close()
    assert messages == []


def random_queries(rng, n):
    tv, tl = rng.uniform(0, 90, n), rng.uniform(0, 90, n)
    pv, pl = rng.uniform(-720, 1080, n), rng.uniform(-360, 720, n)
    k = rng.uniform(-0.4, 0.4, n)  # beyond the axis ends: clamped
    m = n // 10
    tv[:m] = 0.0  # the view pole
    tl[m:2 * m] = 0.0  # the light pole
    pv[2 * m:3 * m] = rng.choice([0.0, 360.0, -360.0, 359.9999, 1e-4, 720.0, 1e30, -7.2e12 + 15.5], m)  # wrap
    pl[3 * m:4 * m] = rng.choice([0.0, 330.0, 345.0, -15.0, 360.0], m)
    tv[4 * m:5 * m] = rng.choice([0.0, 15.0, 45.0, 75.0, 90.0], m)  # samples and beyond the last
    k[5 * m:6 * m] = rng.choice([-0.22, 0.0, 0.13, 0.5, -1.0], m)
    return np.stack([tv, pv, tl, pl, k], axis=1)


@needs_chromium
@pytest.mark.parametrize("index, name", [(0, "denim"), (1, "iso")])
def test_gpu_lookup_matches_evaluate(page, index, name):
    table = materials.load("denim") if name == "denim" else iso_table()
    q = random_queries(np.random.default_rng(index), 1000)
    gpu = np.array(page.evaluate("([q, t]) => cdbrdfViewer.evaluateMany(q, {table: t})", [q.tolist(), index]))
    ref = table.evaluate(*q.T)
    ok = rel_close(gpu, ref, 1e-3)
    assert ok.all(), (q[~ok.all(1)][:5], gpu[~ok.all(1)][:5], ref[~ok.all(1)][:5])
    one = page.evaluate(f"cdbrdfViewer.evaluate(30, 45, 10, 200, 0.05, {{table: {index}}})")
    assert rel_close(np.array(one), table.evaluate(30, 45, 10, 200, 0.05), 1e-3).all()


@pytest.mark.slow  # a page of its own and an import
@needs_chromium
def test_gpu_lookup_on_an_imported_rgl_table(browser, tmp_path):
    """A real measured material (RGL satin) imported at the default grid (isotropic, 8,100 view
    directions at 2 degrees, folded into the texture): the GPU lookup matches evaluate."""
    from cdbrdf.importers import import_brdf

    from .import_helpers import need_mitsuba, rgl_path

    need_mitsuba()
    t = import_brdf(rgl_path("satin"))
    assert t.isotropic and texture_shape(t)[0] == 2048
    index = export_viewer(tmp_path / "v", viewer_files([("satin.h5", t)], meshes={}))
    page, messages = open_page(browser, index.resolve().as_uri())
    q = random_queries(np.random.default_rng(11), 1000)
    gpu = np.array(page.evaluate("(q) => cdbrdfViewer.evaluateMany(q)", q.tolist()))
    page.close()
    assert messages == []
    assert rel_close(gpu, t.evaluate(*q.T), 1e-3).all()


@pytest.mark.slow  # a page of its own
@needs_chromium
def test_gpu_lookup_float16(browser, tmp_path):
    t = materials.load("denim")
    index = export_viewer(tmp_path / "v", viewer_files([("denim.h5", t)], meshes={}, precision="float16"))
    page, messages = open_page(browser, index.resolve().as_uri())
    q = random_queries(np.random.default_rng(7), 1000)
    gpu = np.array(page.evaluate("(q) => cdbrdfViewer.evaluateMany(q)", q.tolist()))
    page.close()
    assert messages == []
    assert rel_close(gpu, t.evaluate(*q.T), 5e-3).all()


def pixels(page):
    import base64

    p = page.evaluate("cdbrdfViewer.pixels()")
    a = np.frombuffer(base64.b64decode(p["data"]), np.uint8).reshape(p["height"], p["width"], 4)
    return a[::-1, :, :3].astype(np.int16)


def curvature(page):
    """Per pixel: the kappa looked up, the surface's kappa, front-facing, n.l."""
    import base64

    p = page.evaluate("cdbrdfViewer.curvatureImage()")
    return np.frombuffer(base64.b64decode(p["data"]), "<f4").reshape(p["height"], p["width"], 4)[::-1]


@needs_chromium
def test_brdf_toggle_changes_the_crests_not_the_flat_parts(page):
    page.evaluate("cdbrdfViewer.setSideBySide(false)")
    page.evaluate("cdbrdfViewer.setSurface('sheet')")
    page.evaluate("cdbrdfViewer.setCamera(90, -90, 110)")
    page.evaluate("cdbrdfViewer.setLight(40, 20)")
    page.evaluate("cdbrdfViewer.setBend(3)")
    cd = pixels(page)
    k = curvature(page)
    page.evaluate("cdbrdfViewer.setMode('brdf')")
    br = pixels(page)
    kb = curvature(page)
    page.evaluate("cdbrdfViewer.setMode('split')")  # BRDF left of the line, CDBRDF right of it
    sp = pixels(page)
    page.evaluate("cdbrdfViewer.setMode('cdbrdf')")
    w = sp.shape[1]
    np.testing.assert_array_equal(sp[:, : w // 2 - 2], br[:, : w // 2 - 2])
    np.testing.assert_array_equal(sp[:, w // 2 + 2 :], cd[:, w // 2 + 2 :])
    assert (kb[..., 0][kb[..., 2] > 0.5] == 0).all()  # the plain BRDF looks up kappa = 0
    front = k[..., 2] > 0.5
    crest = front & (k[..., 1] > 0.2)
    flat = front & (np.abs(k[..., 1]) < 0.004)
    assert crest.sum() > 200 and flat.sum() > 50
    diff = np.abs(cd - br).max(axis=-1)
    assert diff[flat].max() <= 1  # rounding of one 8-bit level at most
    assert np.mean(diff[crest] >= 3) > 0.5, np.percentile(diff[crest], [10, 50, 90])
    # a crest pixel's colour is the table's value at the query the click reads: f cos(theta_l) pi 2^EV, sRGB
    from cdbrdf.colour import srgb_encode

    ys, xs = np.nonzero(crest & (k[..., 3] > 0.3))
    y, x = int(ys[len(ys) // 2]), int(xs[len(xs) // 2])
    q = page.evaluate(f"cdbrdfViewer.pick({x}, {y})")
    assert q["kappa"] == pytest.approx(k[y, x, 0], abs=1e-6) and q["kappa"] > 0.2  # crests are convex
    ev = page.evaluate("cdbrdfViewer.state()")["exposure"]
    f = materials.load("denim").evaluate(q["theta_v"], q["phi_v"], q["theta_l"], q["phi_l"], q["kappa"])
    expect = 255 * srgb_encode(np.clip(f * k[y, x, 3] * np.pi * 2**ev, 0, 1))
    assert 20 < expect.min() and expect.max() < 235  # not clipped: the colour tells the value
    np.testing.assert_allclose(cd[y, x], expect, atol=1.5)


@needs_chromium
def test_bend_slider_changes_the_crest_curvature_shown(page):
    page.evaluate("cdbrdfViewer.setSurface('sheet')")
    page.locator("#wave").fill("20")
    page.locator("#bend").fill("4")
    assert page.locator("#crest").text_content() == "0.395 mm^-1 (radius 2.53 mm)"
    page.locator("#bend").fill("1")
    assert page.locator("#crest").text_content() == "0.099 mm^-1 (radius 10.13 mm)"
    assert page.evaluate("cdbrdfViewer.state()")["amplitude"] == 1


def not_blank(png: bytes, colours: int = 10) -> None:
    import io

    from PIL import Image

    a = np.asarray(Image.open(io.BytesIO(png)).convert("RGB"), dtype=np.float64)
    assert a.std() > 8 and len(np.unique(a.reshape(-1, 3) // 16, axis=0)) > colours


@needs_chromium
def test_views_are_not_blank_and_linked(page):
    page.evaluate("cdbrdfViewer.setCamera(50, -90, 150)")
    for surface in ("sheet", "stand", "drape", "user"):
        page.evaluate(f"cdbrdfViewer.setSurface('{surface}')")
        not_blank(page.locator("#view").screenshot())
    page.evaluate("cdbrdfViewer.setSurface('sheet')")
    one = page.locator("#view").screenshot()
    page.evaluate("cdbrdfViewer.setEnvironment(true)")
    env = page.locator("#view").screenshot()
    page.evaluate("cdbrdfViewer.setEnvironment(false)")
    not_blank(env, colours=3)  # a sky lights the sheet evenly (the recalibrated denim: a few shades)
    assert env != one
    page.evaluate("cdbrdfViewer.setOverlay(true)")
    not_blank(page.locator("#view").screenshot())
    page.evaluate("cdbrdfViewer.setOverlay(false)")
    not_blank(page.locator("#mosaic").screenshot())
    not_blank(page.locator("#polar").screenshot())
    # a click on the surface reads its query and highlights the mosaic cell it reads
    page.evaluate("cdbrdfViewer.setSideBySide(true)")
    page.locator("#view").click(position={"x": 80, "y": 100})  # the middle of the left table's view
    text = page.locator("#pickout").text_content()
    assert "theta_v" in text and "kappa" in text and "mm^-1" in text, text
    st = page.evaluate("cdbrdfViewer.state()")
    q, cell = st["pick"], st["pickCell"]
    assert q["table"] == 0 and 0 <= q["theta_v"] <= 90 and -0.3 < q["kappa"] < 0.3
    g = materials.load("denim").grid  # the highlighted cell: the sample nearest to the query, kappa nearest too

    def near(axis, x, periodic=False):
        d = np.abs(axis - x)
        return int(np.argmin(np.minimum(d, 360 - d) if periodic else d))

    assert cell["kappa_index"] == near(g.kappa, q["kappa"])
    assert cell["col"] == near(g.phi_v, q["phi_v"], True) * g.theta_v.size + near(g.theta_v, q["theta_v"])
    assert cell["row"] == near(g.phi_l, q["phi_l"], True) * g.theta_l.size + near(g.theta_l, q["theta_l"])
    # hover read-out of the mosaic: a filled sample of the isotropic table names its source
    page.select_option("#mosaicTable", "1")
    page.select_option("#mosaicK", "0")
    readout = page.evaluate("cdbrdfViewer.mosaicReadout(1, 0, 3, 4)")  # theta_l 80, dphi 0, theta_v 85
    assert "filled (unknown)" in readout or "filled (nearest)" in readout, readout
    assert "fill source: theta_v 85, dphi 0, theta_l 80, phi_l 0, kappa 0" in readout
    # the polar slice: each pixel is the table at (theta_v = 90 r, phi_v = its angle), the current light
    from cdbrdf.colour import srgb_encode

    page.evaluate("cdbrdfViewer.setExposure(-3)")  # the random table's values within the display's range
    st = page.evaluate("cdbrdfViewer.state()")
    W = H = 200
    for x, y in ((150, 60), (40, 120), (100, 100)):
        px = page.evaluate(f"Array.from(document.getElementById('polar').getContext('2d').getImageData({x}, {y}, 1, 1).data)")
        qx, qy = (x + 0.5) / W * 2 - 1, (H - 1 - y + 0.5) / H * 2 - 1
        tv, pv = min(np.hypot(qx, qy) * 90, 90), np.degrees(np.arctan2(qy, qx)) % 360
        f = iso_table().evaluate(tv, pv, st["lightTheta"], st["lightPhi"], -0.2)
        expect = 255 * srgb_encode(np.clip(f * np.pi * 2 ** st["exposure"], 0, 1))
        assert 20 < expect.min() and expect.max() < 235
        np.testing.assert_allclose(px[:3], expect, atol=1.5)
    mbox = page.locator("#mosaic").bounding_box()
    page.mouse.move(mbox["x"] + 2, mbox["y"] + 2)
    assert "measured" in page.locator("#readout").text_content()
    # shift-drag moves the light (and its sliders), a plain drag the camera
    page.evaluate("cdbrdfViewer.setLight(45, 0)")
    page.locator("#view").scroll_into_view_if_needed()
    box = page.locator("#view").bounding_box()
    page.keyboard.down("Shift")
    page.mouse.move(box["x"] + 100, box["y"] + 100)
    page.mouse.down()
    page.mouse.move(box["x"] + 60, box["y"] + 120, steps=2)
    page.mouse.up()
    page.keyboard.up("Shift")
    st = page.evaluate("cdbrdfViewer.state()")
    assert st["lightPhi"] == pytest.approx(20.0) and st["lightTheta"] == pytest.approx(51.0)
    assert page.locator("#lightPOut").text_content() == "20.0 deg"


def test_cli_export_refuses_a_users_folder(tmp_path, capsys):
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "notes.txt").write_text("keep")
    with pytest.raises(SystemExit) as e:
        main(["view", str(materials.path("denim")), "--export", str(mine)])
    err = capsys.readouterr().err
    assert e.value.code == 2 and err.count("\n") == 1 and "not written by cdbrdf" in err
    assert [p.name for p in mine.iterdir()] == ["notes.txt"]


@pytest.mark.slow  # a page of its own
@needs_chromium
def test_page_checks_the_gpus_texture_limits(browser, tmp_path):
    """A texture beyond this GPU's MAX_TEXTURE_SIZE: the page says which limit and offers --grid."""
    files = viewer_files([("denim.h5", materials.load("denim"))], meshes={})
    text = files["data.js"].decode()
    assert '"texture":{"width":2048' in text
    files["data.js"] = text.replace('"texture":{"width":2048', '"texture":{"width":1000000', 1).encode()
    index = write_viewer(tmp_path / "v", files)
    page = browser.new_page()
    page.goto(index.resolve().as_uri(), wait_until="load")
    err = page.evaluate("cdbrdfViewer.ready.then(() => 'ok', e => e.message)")
    shown = page.locator("#message").text_content()
    page.close()
    assert "texture width 1000000 > MAX_TEXTURE_SIZE" in err and "--grid" in err and shown == err


def test_a_wide_isotropic_mosaic_is_wrapped_and_read_back(browser, tmp_path):
    """An isotropic table's Fig. 7 image is one light azimuth tall: shown wrapped, each cell once."""
    g = cdbrdf.Grid(kappa=[0.0], theta_l=np.arange(0.0, 76.0, 15.0), phi_l=[0.0],
                    theta_v=np.arange(0.0, 76.0, 15.0), phi_v=np.arange(0.0, 360.0, 10.0), symmetry="isotropic")
    t = make_table(g, seed=5, dtype=np.float32)
    index = export_viewer(tmp_path / "v", viewer_files([("iso.h5", t)], meshes={}))
    page, messages = open_page(browser, index.resolve().as_uri())
    try:
        lay = page.evaluate("cdbrdfViewer.mosaicLayout()")
        assert (lay["rows"], lay["cols"]) == (6, 36 * 6) and lay["bands"] > 1
        assert 0.5 <= lay["width"] / lay["height"] <= 2.0  # not a 216 x 6 strip
        seen = page.evaluate("""(() => { const L = cdbrdfViewer.mosaicLayout(), out = [];
            for (let y = 0; y < L.H; y++) for (let x = 0; x < L.W; x++) out.push(cdbrdfViewer.mosaicAt(x, y));
            return out; })()""")
        cells = [(s["row"], s["col"]) for s in seen if s is not None]
        assert sorted(cells) == [(r, c) for r in range(6) for c in range(216)]  # every sample exactly once
        # hovering a display cell reads the sample it shows
        x, y = 2 * 6 + 3, lay["H"] - 2  # a cell of the last band
        want = page.evaluate(f"cdbrdfViewer.mosaicAt({x}, {y})")
        box = page.locator("#mosaic").bounding_box()
        page.locator("#mosaic").hover(position={"x": (x + 0.5) * box["width"] / lay["W"],
                                                "y": (y + 0.5) * box["height"] / lay["H"]})
        text = page.locator("#readout").text_content()
        assert text == page.evaluate(f"cdbrdfViewer.mosaicReadout(0, 0, {want['row']}, {want['col']})")
        itv, ipv = want["col"] % 6, want["col"] // 6
        assert text.startswith(f"theta_v {g.theta_v[itv]:g}, dphi {g.phi_v[ipv]:g}, theta_l {g.theta_l[want['row']]:g}")
        assert messages == []
    finally:
        page.close()
