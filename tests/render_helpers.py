"""Tables and Mitsuba helpers shared by the plug-in's tests (``tests/test_render*.py``)."""

from __future__ import annotations

import os

import numpy as np
import pytest

import cdbrdf

mi = pytest.importorskip("mitsuba")
dr = pytest.importorskip("drjit")


def needs_llvm_marker():
    """Skip without a usable LLVM, except in CI: the test command installs it there, so a missing one must fail."""
    from cdbrdf.render import _llvm

    info = _llvm.find_llvm()
    return pytest.mark.skipif(not info.ok and not os.environ.get("CI"), reason=_llvm.llvm_message(info))


def require_llvm_module() -> None:
    """At a test module's top: skip the module without a usable LLVM (the rig renders with Mitsuba's llvm
    variants), except in CI, where the missing library is the error it is (the test command installs it)."""
    from cdbrdf.render import LLVMError, check_llvm

    try:
        check_llvm()
    except LLVMError as exc:
        if os.environ.get("CI"):
            raise
        pytest.skip(f"Mitsuba's LLVM backend unavailable: {exc}", allow_module_level=True)


needs_llvm = needs_llvm_marker()


def unit(theta_deg, phi_deg):
    t, p = np.radians(theta_deg), np.radians(phi_deg)
    return np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], axis=-1)


def glossy_table(*, theta_step=10.0, phi_step=20.0, kappa=(-0.2, 0.0, 0.2), exponent=60.0, ks=2.0, kd=0.02,
                 tint=(1.0, 0.8, 0.6), dtype=np.float64, symmetry="anisotropic"):
    """A strong Blinn-Phong lobe around the mirror direction, brighter on convex curvature.

    Peak / diffuse about ``ks * (n + 2) / (2 pi) / kd`` (~ 1000 by default): a
    sampler with a wrong density is rejected by the chi-square test. The
    anisotropic table adds a weak cos^2 of the light azimuth; the isotropic
    one (``phi_l = [0]``, ``phi_v`` the azimuth difference) has the lobe only.
    """
    iso = symmetry == "isotropic"
    th = np.arange(0.0, 90.0 - 1e-9, theta_step)
    ph = np.arange(0.0, 360.0 - 1e-9, phi_step)
    g = cdbrdf.Grid(kappa=list(kappa), theta_l=th, phi_l=[0.0] if iso else ph, theta_v=th, phi_v=ph,
                    symmetry=symmetry)
    m = g.mesh()
    h = unit(m["theta_l"], m["phi_l"]) + unit(m["theta_v"], m["phi_v"])
    h /= np.linalg.norm(h, axis=-1, keepdims=True)
    lobe = ks * (exponent + 2) / (2 * np.pi) * np.clip(h[..., 2], 0, 1) ** exponent * (1 + 2 * m["kappa"])
    f = kd + lobe + (0.0 if iso else 0.05 * np.cos(np.radians(m["phi_l"])) ** 2)
    v = f[..., None] * np.asarray(tint)
    return cdbrdf.CDBRDF(v.astype(dtype), **g.axes(), symmetry=symmetry)


def constant_table(rgb, grid=None):
    g = grid or cdbrdf.Grid.paper()
    return cdbrdf.CDBRDF(np.broadcast_to(np.asarray(rgb, dtype=np.float64), g.shape + (3,)).copy(), g)


def vec(a):
    return mi.Vector3f(np.ascontiguousarray(np.asarray(a).T, dtype=np.float32))


def local_si(wi):
    si = dr.zeros(mi.SurfaceInteraction3f, wi.shape[0])
    si.wi = vec(wi)
    si.sh_frame = mi.Frame3f(mi.Vector3f(0, 0, 1))
    return si


def hemisphere_quadrature(n=200):
    """Midpoint rule on the upper hemisphere: directions (m, 3) and solid angles (m,)."""
    th = (np.arange(n) + 0.5) / n * np.pi / 2
    ph = (np.arange(2 * n) + 0.5) / (2 * n) * 2 * np.pi
    T, P = np.meshgrid(th, ph, indexing="ij")
    d = np.stack([np.sin(T) * np.cos(P), np.sin(T) * np.sin(P), np.cos(T)], -1).reshape(-1, 3)
    dw = (np.pi / 2 / n) * (2 * np.pi / (2 * n)) * np.sin(T).ravel()
    return d, dw


def sheet_scene_dict(tmp_path, bsdf, *, emitter, size=(16, 12), spp=16, max_depth=2, width_mm=20.0):
    """A small sine sheet (its curvature stored) seen from 40 degrees above -y, with ``bsdf`` and ``emitter``."""
    from cdbrdf.mesh import SineSheet, sine_sheet_mesh, write_ply

    ply = tmp_path / "sheet.ply"
    write_ply(ply, sine_sheet_mesh(SineSheet(width_mm=width_mm, depth_mm=width_mm, vertices_per_wavelength=16)))
    d = 1.6 * width_mm
    e = np.radians(40.0)
    return {
        "type": "scene",
        "integrator": {"type": "path", "max_depth": max_depth},
        "sensor": {"type": "perspective", "fov": 40.0,
                   "to_world": mi.ScalarTransform4f().look_at(origin=[0.0, -d * np.cos(e), d * np.sin(e)],
                                                              target=[0, 0, 0], up=[0, 0, 1]),
                   "film": {"type": "hdrfilm", "width": size[0], "height": size[1], "rfilter": {"type": "box"}},
                   "sampler": {"type": "independent", "sample_count": spp}},
        "sheet": {"type": "ply", "filename": str(ply), "bsdf": bsdf},
        "light": emitter,
    }
