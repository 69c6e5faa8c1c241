"""A CD-BTF on a mesh with UVs: the asset carries the UVs, ``--uv-scale``, and the weave in headless Chromium.

The known answer of the browser check: a flat mesh the size of the sine
sheet, with UVs running 0 to 1 across it and ``uv_scale_mm`` its size, is
the flat sine sheet (amplitude 0) to the viewer, weave and all: the sheet's
fabric coordinates are its own (x + width / 2, y + depth / 2) mm.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from cdbrdf.cli import main
from cdbrdf.errors import OptionError
from cdbrdf.mesh import Mesh, SineSheet, prepare_mesh
from cdbrdf.view.asset import mesh_asset
from cdbrdf.view.export import drape_entry, export_viewer, viewer_files

from .test_viewer import CHROMIUM, CHROMIUM_ARGS, needs_chromium, open_page
from .test_viewer_btf import aniso_grid, pixels, random_btf, texel_variance, weave_btf


def flat_grid(width_mm: float, depth_mm: float, *, n: int = 31, uv: bool = True) -> Mesh:
    """A flat n x n grid, z = 0, centred; UVs 0 to 1 across (u along x, v along y) or none."""
    x, y = np.meshgrid(np.linspace(-width_mm / 2, width_mm / 2, n), np.linspace(-depth_mm / 2, depth_mm / 2, n))
    v = np.stack([x.ravel(), y.ravel(), np.zeros(x.size)], axis=1)
    i = np.arange(n * n).reshape(n, n)
    a, b, c, d = i[:-1, :-1].ravel(), i[:-1, 1:].ravel(), i[1:, 1:].ravel(), i[1:, :-1].ravel()
    faces = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])
    uvs = np.stack([(v[:, 0] + width_mm / 2) / width_mm, (v[:, 1] + depth_mm / 2) / depth_mm], axis=1)
    return Mesh(v, faces, None, uvs if uv else None, {}, metadata={"units": "mm", "up": "z"})


def write_obj(path, mesh: Mesh) -> None:
    """A Wavefront OBJ, with ``vt`` lines and ``v/vt`` corners when the mesh has UVs."""
    lines = [f"v {x:.6f} {y:.6f} {z:.6f}" for x, y, z in mesh.vertices]
    if mesh.uv is not None:
        lines += [f"vt {u:.6f} {v:.6f}" for u, v in mesh.uv]
        lines += ["f " + " ".join(f"{i + 1}/{i + 1}" for i in f) for f in mesh.faces]
    else:
        lines += ["f " + " ".join(str(i + 1) for i in f) for f in mesh.faces]
    path.write_text("\n".join(lines) + "\n")


def block(asset, name: str) -> np.ndarray:
    b = asset.header["blocks"][name]
    dt = np.dtype({"float32": "<f4", "uint32": "<u4"}[b["dtype"]])
    return np.frombuffer(asset.blob, dt, b["bytes"] // dt.itemsize, b["offset"]).reshape(b["shape"])


# -- the asset --------------------------------------------------------------------------------
def test_mesh_asset_round_trips_the_uvs_and_the_scale():
    mesh = prepare_mesh(flat_grid(40.0, 30.0, n=9))
    a = mesh_asset(mesh, name="grid", uv_scale_mm=(40.0, 30.0))
    assert a.header["uv"] is True and a.header["uv_scale_mm"] == [40.0, 30.0]
    np.testing.assert_array_equal(block(a, "uv"), mesh.uv.astype(np.float32))
    # the UVs belong to the vertices: u * 40 mm is x + 20 mm of the centred positions
    np.testing.assert_allclose(block(a, "uv")[:, 0] * 40.0, block(a, "position")[:, 0] + 20.0, atol=1e-4)
    assert mesh_asset(mesh, name="grid", uv_scale_mm=2.5).header["uv_scale_mm"] == [2.5, 2.5]
    assert mesh_asset(mesh, name="grid").header["uv_scale_mm"] == [1.0, 1.0]  # the renderer's default: mm
    bare = mesh_asset(prepare_mesh(flat_grid(40.0, 30.0, n=9, uv=False)), name="bare")
    assert bare.header["uv"] is False and "uv" not in bare.header["blocks"]


@pytest.mark.parametrize("bad", [0.0, -1.0, float("nan"), float("inf"), (1.0, 2.0, 3.0), (), "2", (1.0, None)])
def test_bad_uv_scales_are_one_line_errors(bad):
    mesh = prepare_mesh(flat_grid(10.0, 10.0, n=3))
    with pytest.raises(OptionError, match=r"^uv_scale_mm: expected one or two positive numbers \(mm per UV unit\), "):
        mesh_asset(mesh, name="m", uv_scale_mm=bad)


def test_the_draped_cloth_maps_its_uvs_over_its_size():
    label, drape, (su, sv) = drape_entry()
    span = np.ptp(drape.vertices[:, :2], axis=0)
    assert label == "draped cloth" and drape.uv is not None
    np.testing.assert_allclose([su, sv], span / np.ptp(drape.uv, axis=0))
    # u * su runs over the plan in mm: x + size / 2
    x = drape.uv[:, 0] * su
    np.testing.assert_allclose(x - x.min(), drape.vertices[:, 0] - drape.vertices[:, 0].min(), atol=1e-6 * su)


# -- the command line -------------------------------------------------------------------------
@pytest.fixture(scope="module")
def files_on_disk(tmp_path_factory):
    d = tmp_path_factory.mktemp("uvs")
    random_btf(aniso_grid(), rank=3).save(d / "weave.h5")
    from cdbrdf import materials

    materials.load("denim").save(d / "denim.h5")
    write_obj(d / "grid.obj", flat_grid(40.0, 40.0, n=9))
    write_obj(d / "bare.obj", flat_grid(40.0, 40.0, n=9, uv=False))
    return d


def test_cli_uv_scale_reaches_the_mesh_asset(files_on_disk, tmp_path, capsys):
    d = files_on_disk
    assert main(["view", str(d / "weave.h5"), "--mesh", str(d / "grid.obj"), "--uv-scale", "40,20",
                 "--export", str(tmp_path / "a")]) == 0
    h = json.loads((tmp_path / "a" / "assets" / "mesh-user.json").read_text())
    assert h["uv"] is True and h["uv_scale_mm"] == [40.0, 20.0] and h["blocks"]["uv"]["shape"] == [81, 2]
    assert main(["view", str(d / "weave.h5"), "--mesh", str(d / "grid.obj"), "--uv-scale", "4",
                 "--export", str(tmp_path / "b")]) == 0
    assert json.loads((tmp_path / "b" / "assets" / "mesh-user.json").read_text())["uv_scale_mm"] == [4.0, 4.0]
    capsys.readouterr()
    # none given: detected and said, as cdbrdf render detects it (the grid's 40 mm per UV unit)
    assert main(["view", str(d / "weave.h5"), "--mesh", str(d / "grid.obj"), "--export", str(tmp_path / "d")]) == 0
    assert "grid.obj: note: UV scale: 40 mm per UV unit (from the mesh's edges" in capsys.readouterr().err
    assert json.loads((tmp_path / "d" / "assets" / "mesh-user.json").read_text())["uv_scale_mm"] == [40.0, 40.0]
    assert main(["view", str(d / "weave.h5"), "--mesh", str(d / "bare.obj"), "--export", str(tmp_path / "c")]) == 0
    assert "bare.obj: no UVs: the viewer shows the CD-BTF's tile mean on it" in capsys.readouterr().err
    assert json.loads((tmp_path / "c" / "assets" / "mesh-user.json").read_text())["uv"] is False


@pytest.mark.parametrize("value", ["0", "-2", "nan", "inf", "1,2,3", "a", "1,0"])
def test_cli_bad_uv_scales_are_one_line_errors(files_on_disk, tmp_path, capsys, value):
    d = files_on_disk
    with pytest.raises(SystemExit) as exc:
        main(["view", str(d / "weave.h5"), "--mesh", str(d / "grid.obj"), f"--uv-scale={value}",
              "--export", str(tmp_path / "v")])
    assert exc.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert "--uv-scale" in err[-1] and err[-1].startswith("cdbrdf view: error:")
    assert not (tmp_path / "v").exists()


def test_cli_refuses_uv_scale_without_a_mesh_in_one_line(files_on_disk, tmp_path, capsys):
    d = files_on_disk
    # a plain table takes it too: the UV scale of the mesh's maps, as cdbrdf render (recorded and said)
    assert main(["view", str(d / "denim.h5"), "--mesh", str(d / "grid.obj"), "--uv-scale", "10",
                 "--export", str(tmp_path / "v")]) == 0
    assert "grid.obj: note: UV scale: 10 mm per UV unit (given)" in capsys.readouterr().err
    assert main(["view", str(d / "weave.h5"), "--uv-scale", "10", "--export", str(tmp_path / "w")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("cdbrdf view: error: --uv-scale: only for --mesh MESH") and err.count("\n") == 1
    assert not (tmp_path / "w").exists()


# -- the page in headless Chromium ----------------------------------------------------------
@pytest.fixture(scope="module")
def mesh_page(tmp_path_factory):
    from playwright.sync_api import sync_playwright

    sheet = SineSheet()
    w, dp = sheet.width_mm, sheet.depth_mm
    meshes = {"grid": ("uv grid", prepare_mesh(flat_grid(w, dp)), (w, dp)),
              "bare": ("bare grid", prepare_mesh(flat_grid(w, dp, uv=False))), "drape": drape_entry()}
    index = export_viewer(tmp_path_factory.mktemp("vm") / "v", viewer_files([("weave.h5", weave_btf())], meshes=meshes))
    with sync_playwright() as p:
        b = p.chromium.launch(executable_path=CHROMIUM, headless=True, args=CHROMIUM_ARGS)
        try:
            page, messages = open_page(b, index.resolve().as_uri(), width=200, height=140)
            page.messages = messages
            yield page
            page.close()
        finally:
            b.close()


def shot(page, surface: str, *, weave: bool = True, distance_mm: float = 14.0) -> np.ndarray:
    v = "cdbrdfViewer"
    page.evaluate(f"{v}.setSurface('{surface}')")
    page.evaluate(f"{v}.setBend(0)")
    page.evaluate(f"{v}.setLight(40, 20)")
    page.evaluate(f"{v}.setCamera(80, -90, {distance_mm})")  # a close-up (14 mm: about 5 mm across, 3 repeats)
    page.evaluate(f"{v}.setWeave({'true' if weave else 'false'})")
    return pixels(page)


@needs_chromium
@pytest.mark.slow  # a page with a CD-BTF in software WebGL2
def test_weave_shows_on_a_mesh_with_uvs_as_on_the_flat_sheet(mesh_page):
    on_mesh, mean = shot(mesh_page, "grid"), shot(mesh_page, "grid", weave=False)
    bare = shot(mesh_page, "bare")
    bare_text = mesh_page.evaluate("cdbrdfViewer.state()")["btfText"]
    sheet = shot(mesh_page, "sheet")
    assert on_mesh.std() > 5 and mean.std() > 0  # the surface fills the view
    tw, tm = texel_variance(on_mesh), texel_variance(mean)
    assert tw > 20 * max(tm, 0.05), (tw, tm)
    # the known answer: the flat sheet's weave, to a level or two of rounding (interpolated UVs, normals)
    assert np.abs(on_mesh - sheet).mean() < 1.0 and np.percentile(np.abs(on_mesh - sheet), 99) <= 3
    # no UVs: the tile mean, and the read-out says so
    assert np.abs(bare - mean).max() <= 1
    assert bare_text.endswith("this mesh has no UVs: tile mean"), bare_text
    shot(mesh_page, "grid")
    st = mesh_page.evaluate("cdbrdfViewer.setWeaveScale(2)")
    assert st["btfText"].endswith("weave at 2.0x size; UVs x 60.0 x 60.0 mm")
    bigger = pixels(mesh_page)
    mesh_page.evaluate("cdbrdfViewer.setWeaveScale(1)")
    assert np.abs(bigger - on_mesh).mean() > 2  # the slider scales the weave on a mesh too
    assert mesh_page.messages == []


@needs_chromium
@pytest.mark.slow
def test_weave_shows_on_the_draped_cloth(mesh_page):
    """The draped cloth's UVs span its plan (drape_entry): the weave at true size there too."""
    # looking down at the middle of the cloth (about 22 mm above the centre of its box) from 40 mm
    weave, mean = shot(mesh_page, "drape", distance_mm=40), shot(mesh_page, "drape", weave=False, distance_mm=40)
    assert "weave at true size; UVs x 100 x 100 mm" in mesh_page.evaluate("cdbrdfViewer.setWeave(true)")["btfText"]
    tw, tm = texel_variance(weave), texel_variance(mean)
    assert weave.std() > 5 and tw > 20 * max(tm, 0.05), (tw, tm)
    assert mesh_page.messages == []
