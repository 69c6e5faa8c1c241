"""The table as a differentiable Mitsuba parameter: traverse, parameters_changed, gradients, fitting.

``mi.traverse`` exposes ``values`` (the table, a tensor of its shape) and
``scale``; ``parameters_changed`` re-uploads the table and rebuilds the
sampler; with a gradient enabled the table is held as float32 packets
computed in Dr.Jit from the tensor (differentiable), and a render is linear in
the table: the gradient of the image sum dotted with the table is the image
sum (Euler's identity). The slow test fits a table to renders of a target.
"""

from __future__ import annotations

import numpy as np
import pytest

import cdbrdf

from .render_helpers import dr, glossy_table, local_si, mi, needs_llvm, vec

pytestmark = needs_llvm


@pytest.fixture
def cr():
    import cdbrdf.render as cr

    cr.set_variant("llvm_ad_rgb")
    yield cr
    cr.set_variant("llvm_ad_rgb")


def small_table(seed=0, **kw):
    return glossy_table(theta_step=25.0, phi_step=45.0, ks=0.3, kappa=(-0.2, 0.2), **kw)


def sheet_scene(cr, table, *, sampling="cosine", size=(16, 12), spp=4, view=(40.0, -90.0), light=(30.0, 20.0)):
    from cdbrdf.mesh import SineSheet
    from cdbrdf.render import Camera, Light, RenderSpec
    from cdbrdf.render.scenes import sine_scene

    sheet = SineSheet(width_mm=20, depth_mm=20, vertices_per_wavelength=16)
    spec = RenderSpec(surface=sheet, size=size, spp=spp, max_depth=2, camera=Camera(view=view),
                      light=Light(direction=light))
    return sine_scene(table, spec, bsdf={"type": "cdbrdf", "table": table, "sampling": sampling})


def test_traverse_exposes_values_and_scale(cr):
    t = small_table()
    params = mi.traverse(sheet_scene(cr, t))
    v = params["object.bsdf.values"]
    assert tuple(v.shape) == t.values.shape
    np.testing.assert_allclose(np.array(v), t.values, rtol=1e-6)
    assert not (params.flags("object.bsdf.values") & mi.ParamFlags.NonDifferentiable.value)
    assert float(params["object.bsdf.scale"][0]) == 1.0


def test_parameters_changed_reuploads_and_rebuilds_the_sampler(cr):
    t = small_table()
    b = cr.make_bsdf(t, curvature=0.1)
    other = small_table(tint=(0.2, 0.9, 0.4), exponent=10.0)
    params = mi.traverse(b)
    mass = b.sampler_tables.mass.copy()
    params["values"] = mi.TensorXf(other.values.astype(np.float32))
    params.update()
    rng = np.random.default_rng(0)
    wi, wo = rng.normal(size=(2, 500, 3))
    wi[:, 2], wo[:, 2] = np.abs(wi[:, 2]), np.abs(wo[:, 2])
    wi /= np.linalg.norm(wi, axis=1, keepdims=True)
    wo /= np.linalg.norm(wo, axis=1, keepdims=True)
    got = np.array(b.eval(mi.BSDFContext(), local_si(wi), vec(wo))).T
    from cdbrdf.frames import angles_from_direction

    tv, pv = angles_from_direction(wi)
    tl, pl = angles_from_direction(wo)
    np.testing.assert_allclose(got, other.evaluate(tv, pv, tl, pl, 0.1) * wo[:, 2:3], rtol=3e-5, atol=1e-6)
    assert not np.allclose(b.sampler_tables.mass, mass)
    np.testing.assert_allclose(b.sampler_tables.mass,
                               cdbrdf.render._sampling.build_sampler(other.lookup_grid()).mass, rtol=1e-6)
    params["values"] = mi.TensorXf(np.zeros((2, 3), dtype=np.float32))
    with pytest.raises(cdbrdf.TableError, match="shape"):
        params.update()
    bad = other.values.astype(np.float32).copy()
    bad[0, 0, 1, 0, 1, 0] = np.nan
    params["values"] = mi.TensorXf(bad)
    with pytest.raises(cdbrdf.TableError, match="finite"):
        params.update()


def test_gradient_of_a_render_is_linear_in_the_table(cr):
    """Direct light only, cosine sampling: the image is linear in the table, so <grad, values> = image sum."""
    t = small_table()
    scene = sheet_scene(cr, t, spp=8)
    params = mi.traverse(scene)
    key = "object.bsdf.values"
    dr.enable_grad(params[key])
    params.update()
    bsdf = [s.bsdf() for s in scene.shapes()][0]
    assert bsdf.packed.layout == "float"  # a gradient asks for the differentiable storage
    integ = mi.load_dict({"type": "prb", "max_depth": 2})
    img = mi.render(scene, params, spp=8, seed=1, seed_grad=2, integrator=integ)
    dr.backward(dr.sum(img[..., :3], axis=None))  # RGB (the film may add alpha)
    g = np.array(dr.grad(params[key]))
    # the adjoint pass replays the paths of seed_grad: compare with the primal image of that seed
    with dr.suspend_grad():
        total = float(np.array(mi.render(scene, spp=8, seed=2, integrator=integ), dtype=np.float64)[..., :3].sum())
    assert total > 0
    assert float((g * t.values).sum()) == pytest.approx(total, rel=2e-3)
    # where no ray looks, nothing changes: the gradient is zero for most view directions of this camera
    assert (g == 0).mean() > 0.3


def test_scale_gradient(cr):
    t = small_table()
    scene = sheet_scene(cr, t, spp=8)
    params = mi.traverse(scene)
    key = "object.bsdf.scale"
    dr.enable_grad(params[key])
    params.update()
    integ = mi.load_dict({"type": "prb", "max_depth": 2})
    img = mi.render(scene, params, spp=8, seed=1, seed_grad=2, integrator=integ)
    dr.backward(dr.sum(img[..., :3], axis=None))
    with dr.suspend_grad():
        total = float(np.array(mi.render(scene, spp=8, seed=2, integrator=integ), dtype=np.float64)[..., :3].sum())
    # the image is linear in scale (= 1): d(sum)/d(scale) = sum
    assert float(np.array(dr.grad(params[key])).ravel()[0]) == pytest.approx(total, rel=1e-3)


def test_spectral_gradients_are_refused(cr):
    cr.set_variant("llvm_ad_spectral")
    b = cr.make_bsdf(small_table(), curvature=0.0)
    params = mi.traverse(b)
    dr.enable_grad(params["values"])
    with pytest.raises(ValueError, match="rgb and mono variants"):
        params.update()


@pytest.mark.slow
def test_fit_a_table_to_renders_of_a_target(cr):
    """Adam + prb: from a flat grey table to a glossy target, seen in four views of the sine sheet.

    Each view is rendered with the reference's seed, so the loss measures the
    table alone (no Monte Carlo noise floor) and can fall by orders of magnitude.
    """
    target = small_table()
    start = cdbrdf.CDBRDF(np.full(target.values.shape, float(target.values.mean())), target.grid)
    # (camera elevation, azimuth), (light elevation, azimuth): four photographs of the sheet
    views = [((40.0, -90.0), (30.0, 20.0)), ((60.0, 0.0), (45.0, 180.0)), ((30.0, 135.0), (20.0, -60.0)),
             ((70.0, -45.0), (60.0, 90.0))]
    kw = dict(size=(24, 18), spp=4)
    refs = [mi.render(sheet_scene(cr, target, view=v, light=li, **kw), seed=7 + i) for i, (v, li) in enumerate(views)]
    scenes = [sheet_scene(cr, start, view=v, light=li, **kw) for v, li in views]
    params = [mi.traverse(s) for s in scenes]
    key = "object.bsdf.values"
    opt = mi.ad.Adam(lr=0.05)
    opt[key] = params[0][key]
    integ = mi.load_dict({"type": "prb", "max_depth": 2})
    losses = []
    for it in range(100):
        total = 0.0
        for i, (s, p, ref) in enumerate(zip(scenes, params, refs, strict=True)):
            p[key] = opt[key]
            p.update()
            img = mi.render(s, p, seed=7 + i, seed_grad=100 + it, integrator=integ)
            loss = dr.mean(dr.square(img[..., :3] - ref[..., :3]), axis=None)
            dr.backward(loss)
            total += float(np.array(loss).ravel()[0])
        opt.step()
        opt[key] = dr.maximum(opt[key], 0.0)
        losses.append(total)
    assert losses[-1] < losses[0] / 100, (losses[0], losses[-1])
    fitted = np.array(opt[key])
    # where the views constrain the table, it approaches the target: the error weighted by how much the
    # renders depend on each sample (the gradient of the image sums)
    weight = np.zeros(target.values.shape)
    for s, p in zip(scenes, params, strict=True):
        dr.enable_grad(p[key])
        p.update()
        img = mi.render(s, p, seed=0, seed_grad=1, integrator=integ)
        dr.backward(dr.sum(img[..., :3], axis=None))
        weight += np.abs(np.array(dr.grad(p[key])))
    err_fit = (np.abs(fitted - target.values) * weight).sum() / weight.sum()
    err_start = (np.abs(start.values - target.values) * weight).sum() / weight.sum()
    print(f"loss {losses[0]:.4g} -> {losses[-1]:.4g}; weighted table error {err_start:.4g} -> {err_fit:.4g}")
    assert err_fit < 0.5 * err_start, (err_fit, err_start)
