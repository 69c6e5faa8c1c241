"""A normal map that a mesh names but that cannot be used (issue 38, items 3 and 6): one warning naming the mesh,
the map and why, never silently dropped; an error for the map the user names; glTF textures read by the
project's image reader under its limits; a map on UVs spanning 1e8 takes the map's mean, fast."""

from __future__ import annotations

import base64
import json
import logging
import os
import struct
import zlib

import numpy as np
import pytest

from cdbrdf.errors import CDBRDFError
from cdbrdf.images import write_png
from cdbrdf.mesh import Mesh, SurfaceMaps, prepare_mesh, read_mesh

from .mesh_helpers import write_obj
from .test_normalmap import sheet, sine_normals


def _png_bytes(rgb: np.ndarray, tmp_path) -> bytes:
    write_png(tmp_path / "_tmp.png", rgb)
    data = (tmp_path / "_tmp.png").read_bytes()
    (tmp_path / "_tmp.png").unlink()
    return data


def _huge_png_header() -> bytes:
    ihdr = struct.pack(">IIBBBBB", 100000, 100000, 8, 2, 0, 0, 0)
    chunk = struct.pack(">I", 13) + b"IHDR" + ihdr + struct.pack(">I", zlib.crc32(b"IHDR" + ihdr))
    return b"\x89PNG\r\n\x1a\n" + chunk + b"\0" * 64


def _obj(tmp_path, map_name):
    v0, f0, uv0 = sheet(n=21)
    obj = write_obj(tmp_path / "cloth.obj", v0, f0, uv0)
    obj.write_text("mtllib cloth.mtl\nusemtl cloth\n" + obj.read_text())
    (tmp_path / "cloth.mtl").write_text(f"newmtl cloth\nnorm {map_name}\n")
    return obj


def _bad_map(tmp_path, kind):
    """A name for the MTL and what the warning must say."""
    p = tmp_path / "n.png"
    if kind == "missing":
        return "n.png", "does not exist"
    if kind == "garbage":
        p.write_bytes(b"garbage" * 20)
        return "n.png", "not a PNG"
    if kind == "passwd":
        return "/etc/passwd", "/etc/passwd"
    if kind == "file-uri":
        return "file:///etc/passwd", "does not exist"
    if kind == "huge-header":
        p.write_bytes(_huge_png_header())
        return "n.png", "10,000,000,000 pixels"
    if kind == "truncated":
        p.write_bytes(_png_bytes(np.full((8, 8, 3), 128, np.uint8), tmp_path)[:60])
        return "n.png", "truncated"
    if kind == "grey":
        write_png(p, np.zeros((4, 4), np.uint8))
        return "n.png", "RGB image"
    raise AssertionError(kind)


@pytest.mark.parametrize("kind", ["missing", "garbage", "passwd", "file-uri", "huge-header", "truncated", "grey"])
def test_an_mtl_normal_map_that_cannot_be_used_is_a_warning(tmp_path, caplog, kind):
    name, why = _bad_map(tmp_path, kind)
    obj = _obj(tmp_path, name)
    with caplog.at_level(logging.WARNING):
        mesh = prepare_mesh(obj, neighbourhood_mm=5.0)
    said = [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING and "not used" in r.getMessage()]
    assert len(said) == 1, said
    assert "\n" not in said[0] and why in said[0] and ("n.png" in said[0] or "passwd" in said[0]), said
    assert "cloth" in said[0]  # the mesh or its material library
    assert said[0] in mesh.metadata["notes"]
    assert "curvature_map" not in mesh.metadata


@pytest.mark.parametrize("kind", ["garbage", "huge-header", "truncated"])
def test_the_map_the_user_names_is_an_error(tmp_path, kind):
    from .test_fuzz_hostile3 import _run_cli, _table

    _bad_map(tmp_path, kind)
    v0, f0, uv0 = sheet(n=11)
    obj = write_obj(tmp_path / "plain.obj", v0, f0, uv0)
    status, err = _run_cli(["render", str(_table(tmp_path / "t.h5")), "--mesh", str(obj), "--normal-map",
                            str(tmp_path / "n.png"), "--spp", "1", "--size", "8x8", "-o", str(tmp_path / "o.png")])
    assert status == 2 and err.count("\n") == 1 and "n.png" in err, err
    assert not (tmp_path / "o.png").exists()


# -- glTF: the normal texture through the project's reader -----------------------------------------------
def _gltf(tmp_path, image: dict, *, glb_image: bytes | None = None, name="cloth"):
    """A 2-triangle sheet (60 mm, UVs) whose material's normalTexture is ``image``; a GLB holding
    ``glb_image`` in its binary chunk (``image`` then names bufferView 3)."""
    v = np.array([[0, 0, 0], [0.06, 0, 0], [0.06, 0.06, 0], [0, 0.06, 0]], np.float32)
    uv = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], np.float32)
    f = np.array([0, 1, 2, 0, 2, 3], np.uint16)
    blob = v.tobytes() + uv.tobytes() + f.tobytes()
    views = [{"buffer": 0, "byteOffset": 0, "byteLength": 48}, {"buffer": 0, "byteOffset": 48, "byteLength": 32},
             {"buffer": 0, "byteOffset": 80, "byteLength": 12}]
    if glb_image is not None:
        blob += b"\0" * 4 + glb_image
        views.append({"buffer": 0, "byteOffset": 96, "byteLength": len(glb_image)})
    blob += b"\0" * (-len(blob) % 4)
    doc = {"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
           "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "TEXCOORD_0": 1}, "indices": 2,
                                       "material": 0}]}],
           "materials": [{"normalTexture": {"index": 0}}], "textures": [{"source": 0}], "images": [image],
           "bufferViews": views,
           "accessors": [{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
                          "min": [0, 0, 0], "max": [0.06, 0.06, 0]},
                         {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC2"},
                         {"bufferView": 2, "componentType": 5123, "count": 6, "type": "SCALAR"}]}
    if glb_image is None:
        doc["buffers"] = [{"uri": "data:application/octet-stream;base64," + base64.b64encode(blob).decode(),
                           "byteLength": len(blob)}]
        path = tmp_path / f"{name}.gltf"
        path.write_text(json.dumps(doc))
        return path
    doc["buffers"] = [{"byteLength": len(blob)}]
    js = json.dumps(doc).encode()
    js += b" " * (-len(js) % 4)
    body = struct.pack("<I4s", len(js), b"JSON") + js + struct.pack("<I4s", len(blob), b"BIN\x00") + blob
    path = tmp_path / f"{name}.glb"
    path.write_bytes(b"glTF" + struct.pack("<II", 2, 12 + len(body)) + body)
    return path


def _map_png(tmp_path) -> bytes:
    return _png_bytes(np.round((sine_normals(32) + 1) / 2 * 255).astype(np.uint8), tmp_path)


def test_an_embedded_png_is_read_as_data(tmp_path):
    png = _map_png(tmp_path)
    for path in (_gltf(tmp_path, {"bufferView": 3, "mimeType": "image/png"}, glb_image=png),
                 _gltf(tmp_path, {"uri": "data:image/png;base64," + base64.b64encode(png).decode()}, name="b")):
        mesh = read_mesh(path)
        nm = mesh.metadata["normal_map"]
        want = 2.0 * np.round((sine_normals(32) + 1) / 2 * 255) / 255 - 1.0
        want /= np.linalg.norm(want, axis=-1, keepdims=True)
        np.testing.assert_allclose(nm.normals, want, atol=1e-9)


@pytest.mark.parametrize("kind", ["bad-base64", "truncated-view", "truncated-png", "over-the-limit", "garbage",
                                  "missing-file", "no-image"])
def test_a_gltf_normal_texture_that_cannot_be_used_is_a_warning(tmp_path, caplog, monkeypatch, kind):
    png = _map_png(tmp_path)
    glb = None
    image: dict = {"bufferView": 3}
    if kind == "bad-base64":
        image = {"uri": "data:image/png;base64,@@@not base64@@@"}
    elif kind == "truncated-view":
        glb = png
        path = _gltf(tmp_path, image, glb_image=glb)
        data = path.read_bytes()
        path.write_bytes(data[: len(data) - 40])  # the binary chunk cut short
    elif kind == "truncated-png":
        image = {"uri": "data:image/png;base64," + base64.b64encode(png[: len(png) // 2]).decode()}
    elif kind == "over-the-limit":
        glb = png
        monkeypatch.setenv("CDBRDF_MAX_IMAGE_PIXELS", "100")  # 32 x 32 = 1024 pixels
    elif kind == "garbage":
        glb = b"garbage!" * 16
    elif kind == "missing-file":
        image = {"uri": "n.png"}
    elif kind == "no-image":
        image = {"bufferView": 99}
    path = tmp_path / "cloth.glb" if kind == "truncated-view" else _gltf(tmp_path, image, glb_image=glb)
    with caplog.at_level(logging.WARNING):
        try:
            mesh = read_mesh(path)
        except CDBRDFError as exc:  # a file trimesh cannot read either is refused whole: one line naming it
            assert kind in ("truncated-view", "no-image") and "\n" not in str(exc) and str(path) in str(exc), exc
            return
    said = [r.getMessage() for r in caplog.records if "normalTexture" in r.getMessage()]
    assert len(said) == 1 and str(path) in said[0] and "not used" in said[0] and "\n" not in said[0], said
    assert "normal_map" not in mesh.metadata
    assert said[0] in mesh.metadata["notes"]


def test_a_truncated_embedded_texture_names_the_file(tmp_path, caplog):
    """The texture's bufferView reaches past the binary chunk: the warning names the file and says truncated."""
    png = _map_png(tmp_path)
    path = _gltf(tmp_path, {"bufferView": 3}, glb_image=png)
    data = bytearray(path.read_bytes())
    # make bufferView 3 claim more bytes than the chunk holds (the JSON keeps its length: same digits)
    js = bytes(data[20:20 + struct.unpack_from("<I", data, 12)[0]])
    doc = json.loads(js)
    doc["bufferViews"][3]["byteLength"] += 1000
    new = json.dumps(doc).encode()
    new += b" " * (-len(new) % 4)
    rest = bytes(data[20 + len(js):])
    body = struct.pack("<I4s", len(new), b"JSON") + new + rest
    path.write_bytes(b"glTF" + struct.pack("<II", 2, 12 + len(body)) + body)
    with caplog.at_level(logging.WARNING):
        try:
            mesh = read_mesh(path)
        except CDBRDFError as exc:  # trimesh's reader refuses it first: one line naming the file
            assert "\n" not in str(exc) and str(path) in str(exc), exc
            return
    said = [r.getMessage() for r in caplog.records if "normalTexture" in r.getMessage()]
    assert len(said) == 1 and "truncated" in said[0] and str(path) in said[0], said
    assert "normal_map" not in mesh.metadata


# -- item 3: a map on UVs spanning 1e8 ------------------------------------------------------------------------
@pytest.mark.parametrize("span", [1e6, 1e8, 1e30])
def test_a_map_on_huge_uvs_is_its_mean_and_fast(span):
    """UVs spanning 1e8 put millions of repeats in the neighbourhood: the level read is the coarsest (the map's
    mean: slopes and curvature of a periodic map average to 0), the vertices' curvature is the mesh's own, and the
    bake is bounded by the map's size (no filter over 2e7 texels)."""
    import time

    nmap_px = sine_normals(256)
    from cdbrdf.mesh.normalmap import normal_map_from_normals

    nmap = normal_map_from_normals(nmap_px)
    v0, f0, uv0 = sheet(n=21)
    t0 = time.perf_counter()
    mapped = prepare_mesh(Mesh(v0, f0, None, uv0 * span), neighbourhood_mm=5.0,
                          maps=SurfaceMaps(normal_map=nmap, bake="vertex"))
    took = time.perf_counter() - t0
    bare = prepare_mesh(Mesh(v0, f0, None, uv0 * span), neighbourhood_mm=5.0)
    np.testing.assert_allclose(mapped.attributes["curvature"], bare.attributes["curvature"], atol=1e-6)
    texel = prepare_mesh(Mesh(v0, f0, None, uv0 * span), neighbourhood_mm=5.0, maps=SurfaceMaps(normal_map=nmap))
    cmap = texel.metadata["curvature_map"]
    assert cmap.texels == (1, 1)  # the coarsest level only: the map's mean
    np.testing.assert_allclose(cmap.levels[0].reshape(-1)[2:], 0.0, atol=1e-6)  # a periodic map's mean curvature
    assert took < 30.0  # generous (a CPU shared with others); measured well under a second
    assert os.environ.get("CDBRDF_MAX_IMAGE_PIXELS") is None
