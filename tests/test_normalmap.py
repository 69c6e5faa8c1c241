"""Wrinkles from textures: the curvature of a tangent-space normal map, against the same folds as geometry.

Known answer: sine folds h = A sin(2 pi x / L) (A = 1 mm, L = 20 mm: 0.0987 mm^-1 at the crests), once
modelled in a flat sheet's normal map (a 16-bit PNG, read as data) and once as the sheet's geometry; the
curvature baked from the map must be that of the geometry within 5 % (measured: about 1.2 %).
"""

from __future__ import annotations

import numpy as np
import pytest

from cdbrdf.errors import MeshError
from cdbrdf.images import write_png
from cdbrdf.mesh import Mesh, SurfaceMaps, prepare_mesh
from cdbrdf.mesh.normalmap import normal_map_from_normals, read_normal_map

from .mesh_helpers import write_obj

A, L, S = 1.0, 20.0, 60.0  # mm: amplitude, wavelength, sheet size


def sheet(n=121, folded=False):
    x, y = np.meshgrid(np.linspace(0, S, n), np.linspace(0, S, n), indexing="ij")
    z = A * np.sin(2 * np.pi * x / L) if folded else np.zeros_like(x)
    q = (np.arange(n - 1)[:, None] * n + np.arange(n - 1)[None, :]).ravel()
    f = np.concatenate([np.c_[q, q + n, q + n + 1], np.c_[q, q + n + 1, q + 1]])
    return np.c_[x.ravel(), y.ravel(), z.ravel()], f, np.c_[x.ravel(), y.ravel()] / S


def sine_normals(texels=600, *, along="u"):
    t = (np.arange(texels) + 0.5) / texels
    slope = A * 2 * np.pi / L * np.cos(2 * np.pi * t * S / L)  # dh/dx
    n = np.zeros((texels, texels, 3))
    n[..., 2] = 1.0
    if along == "u":
        n[..., 0] = -slope[None, :]  # columns run along u
    else:
        n[..., 1] = -slope[::-1, None]  # rows run down, v up
    return n / np.linalg.norm(n, axis=-1, keepdims=True)


def write_normal_png(path, normals):
    write_png(path, np.round((normals + 1.0) / 2.0 * 65535).astype(np.uint16))
    return path


def crests(mesh, kappa):
    v = mesh.vertices
    inner = (v[:, 0] > 10) & (v[:, 0] < 50) & (v[:, 1] > 10) & (v[:, 1] < 50)
    return inner & (np.abs(kappa) > 0.8 * np.abs(kappa[inner]).max())


def test_a_sine_normal_map_bends_like_the_same_folds_in_the_geometry(tmp_path):
    v, f, uv = sheet(n=81, folded=True)
    geo = prepare_mesh(Mesh(v, f, None, uv), neighbourhood_mm=5.0)
    png = write_normal_png(tmp_path / "folds.png", sine_normals(400))
    v0, f0, uv0 = sheet(n=81)
    mapped = prepare_mesh(Mesh(v0, f0, None, uv0), neighbourhood_mm=5.0,
                          maps=SurfaceMaps(normal_map=png, bake="vertex"))
    kg, kn = geo.attributes["curvature"], mapped.attributes["curvature"]
    at = crests(geo, kg)
    assert at.sum() > 100
    assert np.all(np.sign(kn[at]) == np.sign(kg[at]))  # crests convex, troughs concave, as the geometry
    assert np.median(np.abs(kn[at] - kg[at]) / np.abs(kg[at])) < 0.05
    assert np.abs(kn[at]).mean() == pytest.approx(np.abs(kg[at]).mean(), rel=0.05)
    # the directional curvature along u (across the folds) is the map's too
    assert np.median(np.abs(mapped.attributes["curvature_dir"][at] - kg[at]) / np.abs(kg[at])) < 0.05
    assert any(n.startswith(str(png)) for n in mapped.metadata["notes"])


def test_an_obj_material_names_the_normal_map(tmp_path):
    v0, f0, uv0 = sheet(n=61)
    write_normal_png(tmp_path / "folds.png", sine_normals(200))
    obj = write_obj(tmp_path / "cloth.obj", v0, f0, uv0)
    obj.write_text("mtllib cloth.mtl\nusemtl cloth\n" + obj.read_text())
    (tmp_path / "cloth.mtl").write_text("newmtl cloth\nKd 0.5 0.5 0.5\nnorm folds.png\n")
    mesh = prepare_mesh(obj, neighbourhood_mm=5.0, maps=SurfaceMaps(bake="vertex"))
    assert np.abs(mesh.attributes["curvature"]).max() == pytest.approx(A * (2 * np.pi / L) ** 2, rel=0.15)


def test_the_green_convention_and_bad_maps():
    up = normal_map_from_normals(sine_normals(64, along="v"))
    down = normal_map_from_normals(sine_normals(64, along="v"), convention="directx")
    assert np.allclose(up.normals[..., 1], -down.normals[..., 1])
    with pytest.raises(MeshError, match="convention"):
        normal_map_from_normals(sine_normals(8), convention="vulkan")
    with pytest.raises(MeshError, match="RGB image"):
        normal_map_from_normals(np.zeros((4, 4)))


def test_a_normal_map_needs_the_meshs_uvs(tmp_path):
    v0, f0, _ = sheet(n=11)
    with pytest.raises(MeshError, match="needs the mesh's own UV"):
        prepare_mesh(Mesh(v0, f0), maps=SurfaceMaps(normal_map=normal_map_from_normals(sine_normals(8))))
    grey = tmp_path / "grey.png"
    write_png(grey, np.zeros((4, 4), np.uint8))
    with pytest.raises(MeshError, match="RGB image"):
        read_normal_map(grey)


def test_a_gltf_normal_texture_is_read(tmp_path):
    trimesh = pytest.importorskip("trimesh")
    from PIL import Image

    from cdbrdf.mesh import read_mesh

    v0, f0, uv0 = sheet(n=61)
    img = Image.fromarray(np.round((sine_normals(200) + 1) / 2 * 255).astype(np.uint8))
    mat = trimesh.visual.material.PBRMaterial(normalTexture=img)
    tm = trimesh.Trimesh(v0 / 1000.0, f0, visual=trimesh.visual.TextureVisuals(uv=uv0, material=mat), process=False)
    tm.export(tmp_path / "cloth.glb")
    mesh = prepare_mesh(read_mesh(tmp_path / "cloth.glb"), neighbourhood_mm=5.0,  # glTF: metres
                        maps=SurfaceMaps(bake="vertex"))
    assert np.abs(mesh.attributes["curvature"]).max() == pytest.approx(A * (2 * np.pi / L) ** 2, rel=0.15)
    assert any("normalTexture" in n for n in mesh.metadata["notes"])


def test_a_mesh_too_coarse_for_the_maps_folds_gets_a_note():
    nmap = normal_map_from_normals(sine_normals(200))  # folds 20 mm long
    for n, coarse in ((61, False), (7, True)):  # 1 mm and 10 mm edges
        v0, f0, uv0 = sheet(n=n)
        notes = prepare_mesh(Mesh(v0, f0, None, uv0), neighbourhood_mm=5.0,
                             maps=SurfaceMaps(normal_map=nmap, bake="vertex")).metadata["notes"]
        said = [x for x in notes if "coarse for normal map's folds" in x]
        assert bool(said) == coarse, notes
        if coarse:
            assert "about 20 mm long" in said[0]
