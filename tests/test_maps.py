"""Curvature maps (mesh side): baking from normal maps, height maps and high-resolution meshes; the UV scale; checks.

Known answers: the sine wrinkles of :mod:`tests.maps_helpers` (period 10 mm, amplitude 0.4 mm: peak
curvature 0.158 / mm) as a normal map, a height map and a displaced grid; UVs that are lengths (a quad
whose UVs are its millimetres, the shared CAD-like garments); the pyramid's means.
"""

from __future__ import annotations

import logging

import numpy as np
import pytest

from cdbrdf.errors import MeshError
from cdbrdf.images import write_png
from cdbrdf.mesh import (
    CurvatureMap,
    Mesh,
    SurfaceMaps,
    bake_height_map,
    bake_normal_map,
    detect_uv_scale,
    height_map_from_values,
    normal_map_from_normals,
    prepare_mesh,
    read_mesh,
)
from cdbrdf.mesh.curvature_map import lookup, neighbourhood_level, principal, pyramid, shape_operator

from .maps_helpers import PEAK, A, K, S, quad, sine_heights, sine_normals, wrinkled_grid, write_normal_png
from .mesh_helpers import write_obj
from .shared_data import shared_file


def _along_u(cmap, level=0.0, lo=20.0, hi=80.0, n=601):
    """``x`` (mm) and ``(p, q, kxx, kxy, kyy)`` along the quad's middle row (UV scale 100)."""
    x = np.linspace(lo, hi, n)
    return x, shape_operator(lookup(cmap, x / S, np.full(n, 0.5), level), (S, S))


def test_the_baked_sine_wrinkle_map_has_the_analytic_curvature():
    cmap = bake_normal_map(normal_map_from_normals(sine_normals(512)))
    x, (p, q, kxx, kxy, kyy) = _along_u(cmap)
    assert kxx.max() == pytest.approx(PEAK, rel=0.01)  # 0.158 / mm at the crests, convex
    assert kxx.min() == pytest.approx(-PEAK, rel=0.01)  # the troughs concave
    assert np.abs(kxx - PEAK * np.sin(K * x)).max() < 0.01 * PEAK  # everywhere: A k^2 sin(k x)
    assert np.abs(p + A * K * np.cos(K * x)).max() < 0.005 * A * K  # the slope -dh/dx
    assert np.abs(kxy).max() < 1e-6 and np.abs(kyy).max() < 1e-6 and np.abs(q).max() < 1e-6
    assert principal(kxx, kxy, kyy).max() == pytest.approx(PEAK, rel=0.01)
    # the directional axis: the same wrinkles along v give kyy, not kxx
    cv = bake_normal_map(normal_map_from_normals(sine_normals(512, along="v")))
    g = lookup(cv, np.full(601, 0.5), x / S, 0.0)
    _, _, kxx_v, _, kyy_v = shape_operator(g, (S, S))
    assert kyy_v.max() == pytest.approx(PEAK, rel=0.01) and np.abs(kxx_v).max() < 1e-6


def test_the_uv_scale_and_a_repeat_scale_the_curvature():
    cmap = bake_normal_map(normal_map_from_normals(sine_normals(512)))
    _, (_, _, kxx, _, _) = _along_u(cmap)
    g = lookup(cmap, np.linspace(0.2, 0.8, 601), np.full(601, 0.5), 0.0)
    assert shape_operator(g, (2 * S, 2 * S))[2].max() == pytest.approx(kxx.max() / 2, rel=1e-9)  # folds twice as long
    twice = bake_normal_map(normal_map_from_normals(sine_normals(512)), transform=(2.0, 2.0, 0.0, 0.0))
    g2 = lookup(twice, np.linspace(0.1, 0.4, 601), np.full(601, 0.5), 0.0)
    assert shape_operator(g2, (2 * S, 2 * S))[2].max() == pytest.approx(PEAK, rel=0.01)  # two repeats over 200 mm


def test_a_height_map_of_the_same_wrinkles_agrees_with_the_normal_map(tmp_path):
    normal = bake_normal_map(normal_map_from_normals(sine_normals(512)))
    png = tmp_path / "wrinkles_height.png"
    write_png(png, np.round(sine_heights(512) * 65535).astype(np.uint16))
    mesh = prepare_mesh(quad(), neighbourhood_mm=1.0,
                        maps=SurfaceMaps(height_map=png, height_scale_mm=2 * A))  # codes 0..1 span 2 A
    height = mesh.metadata["curvature_map"]
    assert height.source == "height map" and height.uv_scale == (S, S)
    x, (p_h, _, k_h, _, _) = _along_u(height)
    _, (p_n, _, k_n, _, _) = _along_u(normal)
    assert np.abs(k_h - k_n).max() < 0.01 * PEAK
    assert np.abs(p_h - p_n).max() < 0.01 * A * K
    with pytest.raises(MeshError, match="needs its height scale"):
        prepare_mesh(quad(), maps=SurfaceMaps(height_map=png))
    with pytest.raises(MeshError, match="height scale"):
        bake_height_map(height_map_from_values(sine_heights(8)), height_scale_mm=0.0, uv_scale=(1.0, 1.0))


def test_a_high_resolution_mesh_baked_onto_the_quad_gives_the_analytic_curvature():
    low = prepare_mesh(quad(), neighbourhood_mm=1.0, maps=SurfaceMaps(hires_mesh=wrinkled_grid(201, 201)))
    cmap = low.metadata["curvature_map"]
    assert cmap.source == "high-resolution mesh" and cmap.uv_scale == (S, S)
    x, (p, q, kxx, kxy, kyy) = _along_u(cmap)
    slope = A * K * np.cos(K * x)
    geometric = PEAK * np.sin(K * x) / (1 + slope**2) ** 1.5  # the curvature of the surface along x
    assert kxx.max() == pytest.approx(PEAK, rel=0.03)  # the crests: 0.158 / mm, signed (convex)
    assert kxx.min() == pytest.approx(-PEAK, rel=0.03)
    assert np.abs(kxx - geometric).max() < 0.05 * PEAK
    assert np.abs(p + slope).max() < 0.05 * A * K  # the high mesh's normal in the quad's frame
    assert np.abs(kyy).max() < 0.01 * PEAK and np.abs(kxy).max() < 0.01 * PEAK


def test_a_mesh_bake_is_the_difference_to_the_low_meshs_own_curvature():
    # the low mesh is the wrinkled grid itself, coarsely: what the bake adds is what the coarse fit misses
    grid = wrinkled_grid(121, 121)
    low = prepare_mesh(grid, neighbourhood_mm=1.0, maps=SurfaceMaps(hires_mesh=grid))
    _, (_, _, kxx, _, _) = _along_u(low.metadata["curvature_map"])
    assert np.abs(kxx).max() < 0.02 * PEAK  # the same surface: no difference


def test_the_pyramid_keeps_the_mean_and_ends_at_one_texel():
    rng = np.random.default_rng(1)
    for shape in ((64, 64), (37, 50), (1, 9)):
        base = rng.normal(size=shape + (6,))
        levels = pyramid(base)
        assert levels[-1].shape[:2] == (1, 1)
        for lv in levels:
            np.testing.assert_allclose(lv.mean(axis=(0, 1)), base.mean(axis=(0, 1)), atol=0.02 * base.std())
    base = rng.normal(size=(16, 16, 6))
    cmap = CurvatureMap(pyramid(base))
    ij = np.array([[3, 5], [0, 15], [15, 0]])
    u, v = (ij[:, 1] + 0.5) / 16, 1 - (ij[:, 0] + 0.5) / 16
    np.testing.assert_allclose(lookup(cmap, u, v, 0.0), base[ij[:, 0], ij[:, 1]], rtol=1e-6)  # texel centres
    np.testing.assert_allclose(lookup(cmap, u + 3, v - 2, 0.0), base[ij[:, 0], ij[:, 1]], rtol=1e-5)  # periodic
    np.testing.assert_allclose(lookup(cmap, 0.3, 0.7, cmap.n_levels - 1), base.mean(axis=(0, 1)), atol=1e-6)


def test_uvs_that_are_lengths_are_detected_with_their_unit():
    mm = detect_uv_scale(quad().vertices, quad().faces, quad(uv_scale=S).uv, units="mm")
    assert mm.pair == (1.0, 1.0) and "lengths in mm" in mm.rule
    cm = detect_uv_scale(quad().vertices, quad().faces, quad(uv_scale=S / 10).uv, units="mm")
    assert cm.pair == (10.0, 10.0) and "lengths in cm" in cm.rule
    unit = detect_uv_scale(quad().vertices / 1000, quad().faces, quad(uv_scale=S / 1000).uv, units="m")
    assert unit.pair == (1000.0, 1000.0) and "the mesh's unit" in unit.rule
    norm = detect_uv_scale(quad().vertices, quad().faces, quad().uv, units="mm")
    assert norm.pair == pytest.approx((S, S)) and "median" in norm.rule
    with pytest.raises(MeshError, match="no scale"):
        detect_uv_scale(quad().vertices, quad().faces, np.zeros((4, 2)), units="mm")


@pytest.mark.parametrize(("name", "unit", "rule"), [
    ("garments/codim_ipc_dress_knife/stage.obj", 1000.0, "lengths in m"),
    ("garments/pattern_generator_tee_sim/tee_sim.obj", 10.0, "lengths in cm"),
])
def test_the_shared_cad_garments_have_uvs_in_their_length_unit(name, unit, rule):
    mesh = read_mesh(shared_file(name))
    # the dress in metres, the tee in cm (its header): their UV and 3-D edge lengths agree in that unit
    uvs = detect_uv_scale(mesh.vertices, mesh.faces, mesh.uv, units="m" if unit == 1000.0 else "cm")
    assert uvs.pair == (unit, unit) and rule in uvs.rule


def test_a_map_that_does_nothing_at_the_scale_is_one_warning_that_says_what_to_change(caplog):
    nmap = normal_map_from_normals(sine_normals(512))
    cad = quad(uv_scale=S)  # UVs in mm: the map repeats every millimetre
    with caplog.at_level(logging.WARNING, logger="cdbrdf.mesh.maps"):
        mesh = prepare_mesh(cad, neighbourhood_mm=5.0, maps=SurfaceMaps(normal_map=nmap))
    said = [n for n in mesh.metadata["notes"] if "does nothing" in n]
    assert len(said) == 1 and len(caplog.records) == 1
    assert "repeats every 1 x 1 mm" in said[0] and "--map-size" in said[0] and "lengths in mm" in said[0]
    assert not any("coarse for" in n for n in mesh.metadata["notes"])  # no second, contradictory note
    sized = prepare_mesh(cad, neighbourhood_mm=5.0, maps=SurfaceMaps(normal_map=nmap, map_size_mm=S))
    assert not any("does nothing" in n for n in sized.metadata["notes"])
    cmap = sized.metadata["curvature_map"]
    lv = neighbourhood_level(cmap, sized.metadata["uv_scale"], 5.0)
    g = lookup(cmap, np.linspace(20, 80, 601), np.full(601, 50.0), lv)
    assert shape_operator(g, (1.0, 1.0))[2].max() == pytest.approx(PEAK, rel=0.1)  # the wrinkles are back


def test_per_vertex_baking_is_an_explicit_option():
    nmap = normal_map_from_normals(sine_normals(512))
    texel = prepare_mesh(quad(), neighbourhood_mm=1.0, maps=SurfaceMaps(normal_map=nmap))
    assert "curvature_map" in texel.metadata and np.abs(texel.attributes["curvature"]).max() == 0
    vertex = prepare_mesh(_flat_grid(101), neighbourhood_mm=1.0,
                          maps=SurfaceMaps(normal_map=nmap, bake="vertex"))
    assert "curvature_map" not in vertex.metadata
    x = vertex.vertices[:, 0]
    inner = (x > 20) & (x < 80)
    assert np.abs(vertex.attributes["curvature_dir"][inner] - PEAK * np.sin(K * x[inner])).max() < 0.05 * PEAK
    with pytest.raises(MeshError, match="per texel"):
        SurfaceMaps(hires_mesh=quad(), bake="vertex")


def _flat_grid(n):
    g = wrinkled_grid(n, n)
    g.vertices[:, 2] = 0.0
    return g


def test_surface_maps_refuse_what_cannot_be():
    with pytest.raises(MeshError, match="bake"):
        SurfaceMaps(bake="pixel")
    with pytest.raises(MeshError, match="not both"):
        SurfaceMaps(normal_map="a.png", height_map="b.png")
    with pytest.raises(MeshError, match="uv_scale"):
        SurfaceMaps(uv_scale=(1.0, -2.0))
    with pytest.raises(MeshError, match="convention"):
        SurfaceMaps(normal_map_convention="vulkan")
    with pytest.raises(MeshError, match="own UV"):
        prepare_mesh(Mesh(quad().vertices, quad().faces), maps=SurfaceMaps(uv_scale=10.0))


def test_an_mtl_bump_map_with_its_options_is_a_height_map(tmp_path):
    write_png(tmp_path / "bump.png", np.round(sine_heights(256) * 255).astype(np.uint8))
    g = _flat_grid(11)
    obj = write_obj(tmp_path / "cloth.obj", g.vertices, g.faces, g.uv)
    obj.write_text("mtllib cloth.mtl\nusemtl cloth\n" + obj.read_text())
    (tmp_path / "cloth.mtl").write_text(f"newmtl cloth\nmap_Bump -bm {2 * A} -s 2 2 1 bump.png\n")
    mesh = read_mesh(obj)
    assert mesh.metadata["height_map"].endswith("bump.png") and mesh.metadata["height_scale"] == pytest.approx(2 * A)
    assert mesh.metadata["map_transform"] == (2.0, 2.0, 0.0, 0.0)
    prepared = prepare_mesh(mesh, neighbourhood_mm=1.0)
    cmap = prepared.metadata["curvature_map"]
    assert cmap.source == "height map" and cmap.transform == (2.0, 2.0, 0.0, 0.0)
    g2 = lookup(cmap, np.linspace(0.1, 0.4, 601), np.full(601, 0.5), 0.0)  # two repeats: folds of 5 mm
    assert shape_operator(g2, (S, S))[2].max() == pytest.approx(4 * PEAK, rel=0.03)


def test_an_mtl_bump_that_is_a_normal_map_is_used_as_one(tmp_path):
    write_normal_png(tmp_path / "n.png", sine_normals(128))
    g = _flat_grid(11)
    obj = write_obj(tmp_path / "cloth.obj", g.vertices, g.faces, g.uv)
    obj.write_text("mtllib cloth.mtl\nusemtl cloth\n" + obj.read_text())
    (tmp_path / "cloth.mtl").write_text("newmtl cloth\nbump n.png\n")
    mesh = prepare_mesh(obj, neighbourhood_mm=1.0)
    assert mesh.metadata["curvature_map"].source == "normal map"
    assert any("named as a bump map, it is an RGB normal map" in n for n in mesh.metadata["notes"])


def test_a_gltf_normal_texture_is_read_in_16_bit_with_its_texture_transform():
    mesh = read_mesh(shared_file("garments/sheen_cloth/SheenCloth.gltf"))
    assert mesh.metadata["map_transform"] == (30.0, -30.0, 0.0, 31.0)  # KHR_texture_transform, v up
    nm = mesh.metadata["normal_map"]
    assert nm.normals.shape == (256, 256, 3)
    codes = np.unique(np.round((nm.normals[..., 0] + 1) / 2 * 65535))
    assert codes.size > 256  # 16-bit codes, not PIL's 8-bit


def test_a_map_far_beyond_the_tables_range_is_said(caplog, tmp_path):
    png = tmp_path / "steep.png"
    write_png(png, np.round(sine_heights(512) * 65535).astype(np.uint16))
    with caplog.at_level(logging.WARNING, logger="cdbrdf.mesh.maps"):
        mesh = prepare_mesh(quad(), neighbourhood_mm=1.0, kappa_range=(-0.22, 0.22),
                            maps=SurfaceMaps(height_map=png, height_scale_mm=40 * A))  # 20 x the wrinkles: 3 / mm
    said = [n for n in mesh.metadata["notes"] if "far beyond the table's range" in n]
    assert len(said) == 1 and "its height scale" in said[0] and len(caplog.records) == 1


def test_a_directx_normal_map_bakes_as_its_opengl_twin(tmp_path):
    n = sine_normals(256, along="v")
    dx = n.copy()
    dx[..., 1] = -dx[..., 1]  # green down
    write_normal_png(tmp_path / "dx.png", dx)
    write_normal_png(tmp_path / "gl.png", n)
    a = prepare_mesh(quad(), neighbourhood_mm=1.0, maps=SurfaceMaps(normal_map=tmp_path / "gl.png"))
    b = prepare_mesh(quad(), neighbourhood_mm=1.0,
                     maps=SurfaceMaps(normal_map=tmp_path / "dx.png", normal_map_convention="directx"))
    la, lb = a.metadata["curvature_map"].levels[0], b.metadata["curvature_map"].levels[0]
    np.testing.assert_allclose(la, lb, atol=1e-6)
    assert np.abs(la[..., 5]).max() / S == pytest.approx(PEAK, rel=0.02)  # dq/dv: the wrinkles along v
