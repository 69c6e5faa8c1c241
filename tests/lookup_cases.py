"""Tables, implementations and cases of the lookup conformance suite (``tests/test_lookup_conformance.py``).

Implementations, each forced explicitly:

- ``reference``: :func:`cdbrdf.interp.evaluate_reference`, the readable rule;
- ``numba_rgb`` / ``numba_generic``: :func:`cdbrdf.interp.evaluate` with
  ``kernel="rgb"`` / ``kernel="generic"`` (the RGB kernel only where
  ``LookupGrid.rgb_kernel`` holds);
- ``drjit``: the renderer's :func:`cdbrdf.render._lookup_jit.lookup_jit` in
  ``llvm_ad_rgb`` (float32 arithmetic, 21-bit packed RGB);
- ``drjit_float`` / ``drjit_linear``: the same lookup on the float32 packet
  layout, uploaded from the prepared grid / computed in Dr.Jit from the raw
  values by the differentiable sparse maps (``packet_maps``);
- ``drjit_records``: the same lookup on the ``"records"`` layout (one float32
  record per sample: the CD-BTF's texels in spectral variants);
- ``scalar_rgb``: the plug-in's ``eval`` in Mitsuba's ``scalar_rgb`` variant,
  from directions (only where directions are well defined);
- ``glsl_gltf``: the GLSL lookup of the browser renderers (``view/assets/lookup.js``,
  shared by the viewer and the glTF renderer) in headless Chromium, through
  the glTF renderer's three.js plugin on a ``cdbrdf export`` asset (the
  table as its 16-bit lookup texture), on :data:`GLSL_TABLES`.

Each implementation evaluates all the queries of one table in one call
(:func:`results`, memoised); each test checks its case's slice. The tables
of one kind per kernel path (:func:`kernel_tables`) also feed the lookup
fuzzer (``tests/test_fuzz_lookup.py``).
"""

from __future__ import annotations

import functools
import zlib
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import pytest
from scipy.interpolate import RegularGridInterpolator

from cdbrdf import CDBRDF, Grid
from cdbrdf.interp import evaluate, evaluate_reference, snap_tolerance

from .conftest import make_table

F32_MAX = float(np.finfo(np.float32).max)


# -- tables ------------------------------------------------------------------------------------
def _kappas(n: int) -> np.ndarray:
    """``n`` unevenly spaced curvatures in [-0.3, 0.3] (mm^-1)."""
    if n == 1:
        return np.array([0.1])
    return -0.3 + 0.6 * (np.arange(n) / (n - 1)) ** 1.5


def kernel_tables() -> dict[str, CDBRDF]:
    """One table per kernel path: RGB, generic 1-channel, > 8 curvatures, uneven elevations, 1 kappa, isotropic.

    Also the tables of the lookup fuzzer (``tests/test_fuzz_lookup.py``).
    """
    paper = Grid.paper()
    many_k = Grid.paper(kappa=np.linspace(-0.3, 0.3, 11))
    uneven = Grid(kappa=[-0.2, 0.0, 0.2], theta_l=[0.0, 10.0, 35.0, 70.0], phi_l=np.arange(0.0, 360.0, 45.0),
                  theta_v=[5.0, 20.0, 60.0], phi_v=np.arange(0.0, 360.0, 72.0) + 10.0)
    return {
        "rgb": make_table(paper, seed=11),
        "rgb_float32": make_table(paper, seed=12, dtype=np.float32),
        "one_channel": make_table(paper, seed=13, channels=1),
        "many_kappa": make_table(many_k, seed=14),
        "uneven_theta": make_table(uneven, seed=15),
        "single_kappa": make_table(Grid.paper(kappa=[0.0]), seed=16),
        "fine_azimuth": make_table(Grid(kappa=[0.0], theta_l=[0.0, 30.0, 60.0], phi_l=np.arange(720) * 0.5,
                                        theta_v=[0.0, 30.0, 60.0], phi_v=np.arange(720) * 0.5), seed=17),
        # isotropic: phi_l = [0], phi_v is the azimuth difference (RGB kernel, then the generic one)
        "iso_rgb": make_table(Grid.paper(symmetry="isotropic"), seed=40),
        "iso_uneven": make_table(Grid(kappa=[-0.2, 0.1], theta_l=[5.0, 20.0, 60.0], phi_l=[0.0],
                                      theta_v=[0.0, 30.0, 60.0, 80.0], phi_v=np.arange(0.0, 360.0, 72.0) + 10.0,
                                      symmetry="isotropic"), seed=41, channels=1, dtype=np.float32),
    }


def _build_tables() -> dict[str, CDBRDF]:
    even = np.arange(0.0, 76.0, 15.0)
    small_even = {"theta_l": even, "phi_l": np.arange(0.0, 360.0, 45.0), "theta_v": even,
                  "phi_v": np.arange(0.0, 360.0, 45.0)}
    tables = dict(kernel_tables())
    for n in range(1, 10):
        tables[f"kappa_{n}"] = make_table(Grid(kappa=_kappas(n), **small_even), seed=20 + n)
    tables["small"] = make_table(Grid(kappa=[-0.2, 0.0, 0.05, 0.3], theta_l=[0.0, 20.0, 50.0],
                                      phi_l=[0.0, 90.0, 180.0, 270.0], theta_v=[0.0, 30.0, 60.0],
                                      phi_v=[0.0, 120.0, 240.0]), seed=3)
    tables["virtual_pole"] = make_table(Grid(kappa=[0.0], theta_l=[10.0, 40.0], phi_l=[0.0, 180.0],
                                             theta_v=[10.0, 40.0], phi_v=[0.0, 180.0]), seed=5)
    tables["five_channel"] = make_table(Grid(kappa=[-0.1, 0.2], theta_l=[0.0, 20.0, 50.0], phi_l=[0.0, 120.0, 240.0],
                                             theta_v=[0.0, 30.0, 60.0], phi_v=[0.0, 90.0, 180.0, 270.0]),
                                        seed=8, channels=5)
    tables["single_azimuth"] = make_table(Grid(kappa=[-0.1, 0.1], theta_l=[0.0, 30.0, 60.0], phi_l=[0.0],
                                               theta_v=[0.0, 45.0, 70.0], phi_v=[40.0]), seed=7)
    tables["single_elevation"] = make_table(Grid(kappa=[-0.1, 0.0, 0.1], theta_l=[30.0], phi_l=[0.0, 120.0, 240.0],
                                                 theta_v=[0.0], phi_v=[0.0, 90.0, 180.0, 270.0]), seed=9)
    tables["iso_fine"] = make_table(Grid.regular(theta_step_deg=5.0, phi_step_deg=2.0, theta_max_deg=85.0,
                                                 kappa=[0.0], symmetry="isotropic"), seed=42, dtype=np.float32)
    tables["iso_five_channel"] = make_table(Grid(kappa=[0.0, 0.2], theta_l=[0.0, 45.0], phi_l=[0.0],
                                                 theta_v=[10.0, 40.0, 70.0], phi_v=[0.0, 120.0, 240.0],
                                                 symmetry="isotropic"), seed=43, channels=5)
    tables["uneven_float32"] = make_table(Grid(kappa=[-0.2, 0.0, 0.2], theta_l=[0.0, 10.0, 35.0, 70.0],
                                               phi_l=np.arange(0.0, 360.0, 45.0), theta_v=[5.0, 20.0, 60.0],
                                               phi_v=np.arange(0.0, 360.0, 72.0) + 10.0), seed=18, dtype=np.float32)
    return tables


@functools.cache
def tables() -> dict[str, CDBRDF]:
    return _build_tables()


TABLE_NAMES = list(tables())


# -- implementations -----------------------------------------------------------------------------
@functools.cache
def _llvm_ok() -> tuple[bool, str]:
    from cdbrdf.render import _llvm

    info = _llvm.find_llvm()
    return info.ok, ("" if info.ok else _llvm.llvm_message(info))


def need_mitsuba() -> None:
    """Skip (with the reason) when Mitsuba's llvm variant cannot load libLLVM 19, as tests/test_render.py does."""
    ok, why = _llvm_ok()
    if not ok:
        pytest.skip(why)


def run_reference(t: CDBRDF, q: np.ndarray) -> np.ndarray:
    """The readable reference at every column of the queries ``q`` (5, n)."""
    return np.array([evaluate_reference(t, *q[:, i]) for i in range(q.shape[1])]).reshape(-1, t.n_channels)


def _run_numba(kernel: str) -> Callable[[CDBRDF, np.ndarray], np.ndarray]:
    def run(t: CDBRDF, q: np.ndarray) -> np.ndarray:
        return evaluate(t, *q, on_invalid="nan", kernel=kernel)

    return run


def _drjit(layout: str) -> Callable[[CDBRDF, np.ndarray], np.ndarray]:
    """The renderer's lookup in ``llvm_ad_rgb`` with the table uploaded in one of its layouts."""

    def run(t: CDBRDF, q: np.ndarray) -> np.ndarray:
        import mitsuba as mi

        import cdbrdf.render as cr
        from cdbrdf.render import _lookup_jit as lj

        cr.set_variant("llvm_ad_rgb")
        lg = t.lookup_grid()
        record = "rgb" if t.n_channels == 3 else "one"
        if layout == "packed":
            up = lj.pack_table(mi, lg)
        elif layout == "float":
            up = lj.float_table(mi, lg, record)
        elif layout == "records":
            up = lj.record_table(mi, lg, record)
        else:  # the differentiable upload: raw values through the sparse maps
            maps = lj.packet_maps(t.values.shape, t.grid.theta_l, t.grid.theta_v, record, isotropic=lg.isotropic)
            up = lj.linear_upload(mi, mi.Float(np.asarray(t.values, dtype=np.float32).reshape(-1)), maps, record)
        args = [mi.Float(np.ascontiguousarray(x, dtype=np.float32)) for x in q]
        got = np.array(lj.lookup_jit(mi, lg, up, *args), dtype=np.float64).T
        return got[:, : t.n_channels]

    return run


def _run_scalar(t: CDBRDF, q: np.ndarray) -> np.ndarray:
    import mitsuba as mi

    import cdbrdf.render as cr
    from cdbrdf.frames import direction_from_angles

    cr.set_variant("scalar_rgb")
    try:
        bsdfs: dict[float, object] = {}
        out = np.empty((q.shape[1], t.n_channels))
        wi = direction_from_angles(q[0], q[1])
        wo = direction_from_angles(q[2], q[3])
        for i in range(q.shape[1]):
            k = float(q[4, i])
            b = bsdfs.get(k)
            if b is None:
                b = bsdfs[k] = cr.make_bsdf(t, curvature=k, sampling="cosine")  # eval only: no sampler
            si = mi.SurfaceInteraction3f()
            si.wi = mi.Vector3f(*map(float, wi[i]))
            f = np.array(b.eval(mi.BSDFContext(), si, mi.Vector3f(*map(float, wo[i]))), dtype=np.float64)
            out[i] = (f / wo[i, 2])[: t.n_channels]
        return out
    finally:
        cr.set_variant("llvm_ad_rgb")


@functools.cache
def _gltf_page():
    """One page of the glTF renderer in headless Chromium (software WebGL2), kept for every table of a module."""
    from playwright.sync_api import sync_playwright

    from cdbrdf.view.gltf_page import gltf_viewer_files
    from cdbrdf.view.server import ViewerServer

    from .test_viewer import CHROMIUM, CHROMIUM_ARGS

    opts = {"camera": {"position": [0.0, 0.05, 0.0], "target": [0.0, 0.0, 0.0], "up": [0.0, 0.0, -1.0],
                       "fov_deg": 30.0}, "light": [45.0, 0.0, 3.14159], "exposure_ev": 0.0, "width": 16,
            "height": 16, "environment": False}
    first = tables()["small"]
    server = ViewerServer(gltf_viewer_files(quad_asset(first), name="table.glb", options=opts)).start()
    pw = sync_playwright().start()
    browser = pw.chromium.launch(executable_path=CHROMIUM, headless=True, args=CHROMIUM_ARGS)
    page = browser.new_page()
    messages: list[str] = []
    page.on("console", lambda m: messages.append(m.text))
    page.on("pageerror", lambda e: messages.append(str(e)))
    page.goto(server.url)
    page.evaluate("window.cdbrdfGltf.ready")
    _GLTF_SESSION.append((browser, pw, server))
    return page, messages


#: The browser session of :func:`_gltf_page` while it is open (closed by :func:`close_gltf_page`).
_GLTF_SESSION: list = []


def close_gltf_page() -> None:
    """Close the glTF renderer's browser (the conformance module's teardown): a Playwright session left open
    would keep its event loop running in the worker, and the next module's browser could not start."""
    while _GLTF_SESSION:
        browser, pw, server = _GLTF_SESSION.pop()
        browser.close()
        pw.stop()
        server.close()
    _gltf_page.cache_clear()


def need_gltf_renderer() -> None:
    """Skip without Chromium or the built glTF renderer (scripts/setup.sh builds it), except in CI."""
    import os

    from cdbrdf.view.gltf_page import bundle_missing

    from .test_viewer import CHROMIUM

    if os.environ.get("CI"):
        return
    if CHROMIUM is None:
        pytest.skip("Debian's chromium is not installed (scripts/setup.sh --test installs it)")
    if bundle_missing():
        pytest.skip("the glTF renderer is not built (scripts/setup.sh builds it with npm)")


def quad_asset(t: CDBRDF) -> bytes:
    """A GLB of ``t`` on a flat 10 mm square (the lookup is what is tested; a fixed fallback material)."""
    from cdbrdf.export.fallback import FallbackFit
    from cdbrdf.export.gltf import ExportedMesh, build_gltf

    pos = np.array([[-5.0, -5.0, 0.0], [5.0, -5.0, 0.0], [5.0, 5.0, 0.0], [-5.0, 5.0, 0.0]])
    mesh = ExportedMesh(positions=pos, normals=np.tile([0.0, 0.0, 1.0], (4, 1)),
                        tangents=np.tile([1.0, 0.0, 0.0, 1.0], (4, 1)), uv=(pos[:, :2] + 5.0) / 10.0,
                        faces=np.array([[0, 1, 2], [0, 2, 3]]), attributes={"curvature": np.zeros(4),
                                                                          "curvature_dir": np.zeros(4)},
                        direction=np.tile([1.0, 0.0, 0.0], (4, 1)), name="quad")
    fallback = FallbackFit((0.5, 0.5, 0.5), 0.8, (0.0, 0.0, 0.0), 0.5, 0.0, 0.0, 0.0, 0.0, 0)
    return build_gltf(t, mesh, fallback=fallback).glb()


def _run_gltf(t: CDBRDF, q: np.ndarray) -> np.ndarray:
    """The glTF renderer's lookup (lookup.js through its three.js plugin, from the asset's 16-bit texture)."""
    import base64

    page, messages = _gltf_page()
    glb = base64.b64encode(quad_asset(t)).decode("ascii")
    got = np.array(page.evaluate("([g, q]) => cdbrdfGltf.evaluateAsset(g, q)", [glb, q.T.tolist()]), dtype=np.float64)
    assert messages == [], messages
    return got[:, : t.n_channels]


@dataclass(frozen=True)
class Impl:
    """One implementation of the rule and what the suite may ask of it."""

    name: str
    run: Callable[[CDBRDF, np.ndarray], np.ndarray]
    #: precision of the query arithmetic ("float64" or "float32")
    precision: str
    #: agreement with the reference: relative, and as a fraction of the table's largest value
    rtol: float
    #: nodes, clamps and snapped queries reproduced bit for bit
    exact: bool
    #: invalid queries give NaN rows (else: caller masks; values stay in the table)
    nan_rows: bool
    needs_mitsuba: bool = False
    #: runs in headless Chromium (the glTF renderer)
    needs_browser: bool = False
    #: the only cases it runs (None: all)
    cases: tuple[str, ...] | None = None

    #: the only tables it runs on, by name (None: all it applies to)
    only_tables: tuple[str, ...] | None = None

    def applies(self, t: CDBRDF) -> bool:
        if self.name == "numba_rgb":
            return t.lookup_grid().rgb_kernel
        if self.only_tables is not None and not any(tables()[n] is t for n in self.only_tables):
            return False
        if self.needs_mitsuba or self.needs_browser:
            return t.n_channels in (1, 3)
        return True


#: The tables the renderer's other layouts run on: every axis kind (pole at 0 and virtual, single
#: azimuth and elevation, uneven elevations, > 8 curvatures, one channel, float32, isotropic). Not
#: the 720-azimuth tables: their index math is the packed layout's, and their packets are huge.
LAYOUT_TABLES = ("rgb", "one_channel", "many_kappa", "uneven_float32", "virtual_pole", "single_azimuth",
                 "single_elevation", "kappa_1", "iso_rgb", "iso_uneven")


#: The tables the browser's lookup runs on (a page each): every axis kind of LAYOUT_TABLES, an isotropic
#: table at 2 degrees, uneven elevations, nine curvatures.
GLSL_TABLES = LAYOUT_TABLES + ("iso_fine", "uneven_theta", "kappa_9", "small")


IMPLS = {
    i.name: i
    for i in (
        Impl("reference", run_reference, "float64", 0.0, True, True),
        Impl("numba_rgb", _run_numba("rgb"), "float64", 1e-12, True, True),
        Impl("numba_generic", _run_numba("generic"), "float64", 1e-12, True, True),
        Impl("drjit", _drjit("packed"), "float32", 3e-5, False, False, needs_mitsuba=True),
        Impl("drjit_float", _drjit("float"), "float32", 3e-5, False, False, needs_mitsuba=True,
             only_tables=LAYOUT_TABLES),
        Impl("drjit_records", _drjit("records"), "float32", 3e-5, False, False, needs_mitsuba=True,
             only_tables=LAYOUT_TABLES),
        Impl("drjit_linear", _drjit("linear"), "float32", 3e-5, False, False, needs_mitsuba=True,
             only_tables=LAYOUT_TABLES),
        Impl("scalar_rgb", _run_scalar, "float32", 3e-5, False, True, needs_mitsuba=True,
             cases=("pole", "directions")),
        # the glTF renderer's GLSL (lookup.js, shared with the viewer) on the asset's 16-bit texture: within
        # half a 16-bit step of the range (7.6e-6) plus float32 arithmetic
        Impl("glsl_gltf", _run_gltf, "float32", 3e-5, False, True, needs_browser=True, only_tables=GLSL_TABLES),
    )
}


# -- cases -----------------------------------------------------------------------------------------
def _stack(*cols) -> np.ndarray:
    cols = np.broadcast_arrays(*(np.asarray(c, dtype=np.float64) for c in cols))
    return np.stack([c.reshape(-1) for c in cols])


def _off_pole(axis: np.ndarray) -> np.ndarray:
    """Indices of the stored elevations above 0."""
    return np.flatnonzero(axis > 0.0) if np.any(axis > 0.0) else np.array([0])


def _spacing(axis: np.ndarray, i: int) -> float:
    """The spacing of the cells around node ``i`` (the smaller one)."""
    d = np.diff(axis)
    if d.size == 0:
        return 1.0
    return float(min(d[max(i - 1, 0)], d[min(i, d.size - 1)]))


@dataclass
class Case:
    """Queries ``(5, n)`` (theta_v, phi_v, theta_l, phi_l, kappa) and what the check needs to know."""

    q: np.ndarray
    info: dict


def _node_case(t: CDBRDF, precision: str, rng: np.random.Generator) -> Case:
    g = t.grid
    tol = snap_tolerance(precision)
    il, iv = _off_pole(g.theta_l), _off_pole(g.theta_v)
    m = 60
    idx = np.stack([rng.integers(0, g.kappa.size, m), rng.integers(0, g.phi_l.size, m), rng.choice(il, m),
                    rng.integers(0, g.phi_v.size, m), rng.choice(iv, m)])
    # the first and last node of every axis too
    ends = np.array([[0, 0, il[0], 0, iv[0]], [g.kappa.size - 1, g.phi_l.size - 1, il[-1], g.phi_v.size - 1, iv[-1]]])
    idx = np.concatenate([idx, ends.T], axis=1)
    base = _stack(g.theta_v[idx[4]], g.phi_v[idx[3]], g.theta_l[idx[2]], g.phi_l[idx[1]], g.kappa[idx[0]])
    want = t.values[tuple(idx[[0, 1, 2, 3, 4]])].astype(np.float64)
    qs, kinds = [base], ["node"]
    turns = (1.0, -3.0) + ((1e6,) if precision == "float64" else ())
    for s in turns:
        q = base.copy()
        q[1] += 360.0 * s
        q[3] -= 360.0 * s
        qs.append(q)
        kinds.append(f"turns {s:g}")
    # within the snap tolerance of the node, on either side, axis by axis
    axes = {0: (g.theta_v, 4), 2: (g.theta_l, 2), 4: (g.kappa, 0)}
    for row in range(5):
        for side in (-1.0, 1.0):
            q = base.copy()
            if row in axes:
                axis, which = axes[row]
                step = np.array([_spacing(axis, i) for i in idx[which]])
            else:
                # isotropic: moving phi_l moves the query along the azimuth difference axis
                n = (g.phi_v if (row == 1 or g.isotropic) else g.phi_l).size
                step = np.full(base.shape[1], 360.0 / n)
            q[row] = base[row] + side * 0.3 * tol * step
            if precision == "float32":
                # rounded to float32 the offset may grow beyond the tolerance: keep the node there
                b32 = base[row].astype(np.float32).astype(np.float64)
                q32 = q[row].astype(np.float32).astype(np.float64)
                q[row] = np.where(np.abs(q32 - b32) <= 0.5 * tol * step, q32, b32)
            qs.append(q)
            kinds.append(f"axis {row} {'below' if side < 0 else 'above'}")
    return Case(np.concatenate(qs, axis=1), {"want": want, "kinds": kinds, "m": base.shape[1]})


def _pole_case(t: CDBRDF, precision: str) -> Case:
    g = t.grid
    lg = t.lookup_grid()
    phis = np.linspace(-180.0, 540.0, 37)
    groups = [
        _stack(0.0, phis, g.theta_l[-1], g.phi_l[0], g.kappa[-1]),  # view pole
        _stack(g.theta_v[-1], g.phi_v[0], 0.0, phis, g.kappa[0]),  # light pole
        _stack(0.0, phis, 0.0, phis[::-1], 0.0),  # both
        _stack(0.0, phis, 35.0, 123.0, g.kappa.mean()),  # between nodes elsewhere
    ]
    # the ring means the pole node holds (the first stored ring, at theta 0 or above); where the
    # other direction is at its pole too (an elevation axis of one sample at 0), its ring's mean as well
    v = t.values.astype(np.float64)
    light_at_pole = lg.theta_l.size == 1
    view_at_pole = lg.theta_v.size == 1
    want_v = v[-1, :, -1, :, 0].mean(axis=1)
    want_v = want_v.mean(axis=0) if light_at_pole else want_v[0]
    if g.isotropic:  # the light pole holds the mean over the azimuth difference ring
        want_l = v[0, 0, 0, :, -1].mean(axis=0)
    else:
        want_l = v[0, :, 0, :, -1].mean(axis=0)
        want_l = want_l.mean(axis=0) if view_at_pole else want_l[0]
    near = [1e-9, 1e-6] if precision == "float64" else [1e-7, 1e-5]
    groups.append(_stack(np.array(near)[:, None], np.array([0.0, 77.0, 200.0]), g.theta_l[-1], g.phi_l[0],
                         g.kappa[-1]))
    info: dict = {"want_v": want_v, "want_l": want_l, "near": near}
    if lg.theta_v.size > 1:
        # halfway between the pole and the next elevation node, at a stored azimuth
        j = g.phi_v.size - 1
        iv = 1 if g.theta_v[0] == 0.0 else 0
        groups.append(_stack(0.5 * lg.theta_v[1], g.phi_v[j], g.theta_l[-1], g.phi_l[0], g.kappa[-1]))
        ring = v[-1, :, -1, j, iv].mean(axis=0) if light_at_pole else v[-1, 0, -1, j, iv]
        info["half"] = 0.5 * (want_v + ring)
    if g.isotropic and lg.theta_l.size > 1:
        # halfway between the light pole and the next light elevation, at a stored azimuth difference
        j = g.phi_v.size - 1
        il = 1 if g.theta_l[0] == 0.0 else 0
        a = 37.0
        groups.append(_stack(g.theta_v[-1], g.phi_v[j] + a, 0.5 * lg.theta_l[1], a, g.kappa[0]))
        info["half_l"] = 0.5 * (want_l + v[0, 0, il, j, -1])
    info["sizes"] = [x.shape[1] for x in groups]
    return Case(np.concatenate(groups, axis=1), info)


def _clamp_case(t: CDBRDF, precision: str, rng: np.random.Generator) -> Case:
    g = t.grid
    big = 1e308 if precision == "float64" else 3e38
    m = 8
    base = _stack(rng.uniform(0, g.theta_v[-1], m), rng.uniform(0, 360, m), rng.uniform(0, g.theta_l[-1], m),
                  rng.uniform(0, 360, m), rng.uniform(g.kappa[0], g.kappa[-1], m))
    pairs = []  # (beyond, end)
    for row, beyond, end in ((0, 89.0, g.theta_v[-1]), (0, 90.0, g.theta_v[-1]), (2, 90.0, g.theta_l[-1]),
                             (2, 0.5 * (90.0 + g.theta_l[-1]), g.theta_l[-1]),
                             (4, g.kappa[-1] + 5.0, g.kappa[-1]), (4, big, g.kappa[-1]),
                             (4, g.kappa[0] - 5.0, g.kappa[0]), (4, -big, g.kappa[0])):
        a, b = base.copy(), base.copy()
        a[row], b[row] = beyond, end
        pairs.append((a, b))
    q = np.concatenate([np.concatenate(p, axis=1) for p in pairs], axis=1)
    return Case(q, {"m": m, "n_pairs": len(pairs)})


def _wrap_case(t: CDBRDF, precision: str, rng: np.random.Generator) -> Case:
    g = t.grid
    m = 24
    tv = rng.uniform(1.0, 85.0, m)
    tl = rng.uniform(1.0, 85.0, m)
    k = rng.uniform(g.kappa[0] - 0.05, g.kappa[-1] + 0.05, m)
    # dyadic azimuths: phi + 360 k is exact, so any difference is the lookup's
    a, b = np.round(rng.uniform(0, 360, (2, m)) * 64) / 64
    a[:4] = [0.0, 30.0, 330.0, 359.0]
    base = _stack(tv, a, tl, b, k)
    shifts = (1.0, 2.0, -1.0, -3.0)
    qs = [base]
    for s in shifts:
        for row in (1, 3):
            q = base.copy()
            q[row] += 360.0 * s
            qs.append(q)
    # halfway between the last and the first azimuth, everything else at nodes
    info: dict = {"m": m, "n_variants": 2 * len(shifts)}
    iv, il = _off_pole(g.theta_v)[-1], _off_pole(g.theta_l)[-1]
    if g.phi_v.size > 1 and g.theta_v[iv] > 0.0 and g.theta_l[il] > 0.0:
        step = 360.0 / g.phi_v.size
        qs.append(_stack(g.theta_v[iv], g.phi_v[-1] + 0.5 * step, g.theta_l[il], g.phi_l[0], g.kappa[-1]))
        v = t.values.astype(np.float64)
        info["seam"] = 0.5 * (v[-1, 0, il, -1, iv] + v[-1, 0, il, 0, iv])
    return Case(np.concatenate(qs, axis=1), info)


def _random_case(t: CDBRDF, precision: str, rng: np.random.Generator) -> Case:
    g = t.grid
    n = 200
    q = _stack(rng.uniform(0, 90, n), rng.uniform(-720, 720, n), rng.uniform(0, 90, n), rng.uniform(-720, 720, n),
               rng.uniform(g.kappa[0] - 0.1, g.kappa[-1] + 0.1, n))
    q[0, :10] = 0.0
    q[2, 10:20] = 0.0
    return Case(q, {})


def _directions_case(t: CDBRDF, precision: str, rng: np.random.Generator) -> Case:
    """Well-defined directions (elevations 5 to 85 degrees) at a few curvatures: for the plug-in's eval."""
    g = t.grid
    n = 60
    k = rng.choice(np.linspace(g.kappa[0] - 0.1, g.kappa[-1] + 0.1, 6), n)
    return Case(_stack(rng.uniform(5, 85, n), rng.uniform(-180, 180, n), rng.uniform(5, 85, n),
                       rng.uniform(-180, 180, n), k), {})


def _scipy_case(t: CDBRDF, precision: str, rng: np.random.Generator) -> Case:
    """Off the pole (both elevations at or above the first stored one above 0), kappa in range."""
    g = t.grid
    n = 300
    tl0 = g.theta_l[_off_pole(g.theta_l)[0]]
    tv0 = g.theta_v[_off_pole(g.theta_v)[0]]
    q = _stack(rng.uniform(tv0, g.theta_v[-1], n), rng.uniform(-720, 720, n), rng.uniform(tl0, g.theta_l[-1], n),
               rng.uniform(-720, 720, n), rng.uniform(g.kappa[0], g.kappa[-1], n))
    return Case(q, {})


def _bad_case(t: CDBRDF, precision: str) -> Case:
    valid = np.array([30.0, 100.0, 20.0, 200.0, 0.05])
    rows = []
    specials = [np.nan, np.inf, -np.inf]
    for col in range(5):
        for s in specials:
            r = valid.copy()
            r[col] = s
            rows.append(r)
    bad_elev = [-1.0, 91.0, -1e-30, 90.0 + 1e-5] + ([-5e-324, 90.0 + 1e-13] if precision == "float64" else [])
    for col in (0, 2):
        for e in bad_elev:
            r = valid.copy()
            r[col] = e
            rows.append(r)
    return Case(np.array(rows).T, {"nonfinite_azimuth_only": [c in (1, 3) for c in range(5) for _ in specials]
                                   + [False] * (2 * len(bad_elev))})


_HUGE_F64 = [1e15, 1e16, 1e23, -1e23, 1e30, -1e30, 3.4e38, -3.4e38, 1e300, 1e308, -1.7976931348623157e308,
             5e-324, -5e-324, -0.0, 360.0 - 1e-13, -360.0 + 1e-13, 720.0, -720.0, 2.0**53 + 1.0, 2.0**63]
_HUGE_F32 = [F32_MAX, -F32_MAX, 3e38, 1e30, -1e30, 1e20, 2.0**24 + 3.0, 1e-45, -0.0, 359.99997, 720.0, -1e-30]


def _huge_case(t: CDBRDF, precision: str) -> Case:
    a = np.array(_HUGE_F64 if precision == "float64" else _HUGE_F32)
    tiny, big = (1e-300, 1e308) if precision == "float64" else (1e-38, 3e38)
    top = 89.999999 if precision == "float64" else 89.99999
    q = np.concatenate([
        _stack(40.0, a, 30.0, 270.0, 0.1),
        _stack(40.0, 100.0, 30.0, a, -0.1),
        _stack(tiny, a, top, a[::-1], big),
        # elevations at and near the ends of [0, 90]
        _stack([0.0, tiny, 90.0 - 1e-5, 90.0], 10.0, [90.0, 89.9999, 0.0, tiny], 370.0, 0.0),
    ], axis=1)
    return Case(q, {})


def _rotation_case(t: CDBRDF, precision: str, rng: np.random.Generator) -> Case:
    """Queries turned about the normal by several angles (every table; the isotropic ones must not change)."""
    g = t.grid
    m = 40
    base = _stack(rng.uniform(0, 89, m), rng.uniform(-180, 180, m), rng.uniform(0, 89, m), rng.uniform(-180, 180, m),
                  rng.uniform(g.kappa[0], g.kappa[-1], m))
    base[0, :4] = 0.0  # view along the normal
    base[2, 4:8] = 0.0  # light along the normal
    turns = (17.0, -95.5, 180.0, 359.0)
    qs = [base]
    for a in turns:
        q = base.copy()
        q[1] += a
        q[3] += a
        qs.append(q)
    return Case(np.concatenate(qs, axis=1), {"m": m, "n_turns": len(turns)})


CASES = ("nodes", "pole", "clamps", "wrap", "random", "directions", "scipy", "bad", "huge", "rotation")


@functools.cache
def _cases(table: str, precision: str) -> dict[str, Case]:
    t = tables()[table]
    rng = np.random.default_rng(zlib.crc32(f"{table} {precision}".encode()))
    cases = {
        "nodes": _node_case(t, precision, rng),
        "pole": _pole_case(t, precision),
        "clamps": _clamp_case(t, precision, rng),
        "wrap": _wrap_case(t, precision, rng),
        "random": _random_case(t, precision, rng),
        "directions": _directions_case(t, precision, rng),
        "scipy": _scipy_case(t, precision, rng),
        "bad": _bad_case(t, precision),
        "huge": _huge_case(t, precision),
        "rotation": _rotation_case(t, precision, rng),
    }
    if precision == "float32":
        with np.errstate(over="ignore"):
            for c in cases.values():
                c.q = c.q.astype(np.float32).astype(np.float64)
    return cases


@functools.cache
def _results(impl: str, table: str, precision: str | None = None) -> dict[str, np.ndarray]:
    """Every case of ``table`` through ``impl`` (one call), by case name.

    ``precision`` picks the query set (default: the implementation's own);
    the reference runs on the float32 set to judge the float32 implementations.
    """
    im = IMPLS[impl]
    prec = precision or im.precision
    t = tables()[table]
    names = [c for c in CASES if im.cases is None or c in im.cases]
    cases = _cases(table, prec)
    q = np.concatenate([cases[c].q for c in names], axis=1)
    with np.errstate(invalid="ignore", over="ignore"):
        got = im.run(t, q)
    assert got.shape == (q.shape[1], t.n_channels), got.shape
    out, s = {}, 0
    for c in names:
        n = cases[c].q.shape[1]
        out[c] = got[s:s + n]
        s += n
    return out


#: (implementation, table) pairs too slow for the default tier.
_SLOW_PAIRS = frozenset({("scalar_rgb", "fine_azimuth")})


def pairs(case: str, *, skip_reference: bool = False, where: Callable[[CDBRDF], bool] | None = None):
    """``(implementation, table)`` parameters of one case: where the implementation applies (and ``where``)."""
    params = []
    for name, im in IMPLS.items():
        if (skip_reference and name == "reference") or (im.cases is not None and case not in im.cases):
            continue
        for table in TABLE_NAMES:
            t = tables()[table]
            if im.applies(t) and (where is None or where(t)):
                # the scalar plug-in renders one query per call: on the 720-azimuth table that is
                # seconds per case, so it runs in the slow tier (every other table runs by default)
                marks = [pytest.mark.slow] if (name, table) in _SLOW_PAIRS else []
                params.append(pytest.param(name, table, id=f"{name}-{table}", marks=marks))
    return params


def is_isotropic(t: CDBRDF) -> bool:
    """Whether the table is isotropic (its phi_v axis is the azimuth difference)."""
    return t.isotropic


def has_off_pole(t: CDBRDF) -> bool:
    """Whether the table stores samples with both elevations above 0 (nodes the pole rule leaves alone)."""
    return bool(np.any(t.grid.theta_l > 0) and np.any(t.grid.theta_v > 0))


def get_run(impl: str, table: str, case: str):
    im = IMPLS[impl]
    if im.needs_mitsuba:
        need_mitsuba()
    if im.needs_browser:
        need_gltf_renderer()
    t = tables()[table]
    got = _results(impl, table)[case]
    ref = _results("reference", table, im.precision)[case]
    c = _cases(table, im.precision)[case]
    scale = float(np.abs(t.values).max())
    return im, t, c, got, ref, scale


def close(im: Impl, got, want, scale, msg=""):
    if im.exact and im.rtol == 0.0:
        np.testing.assert_array_equal(got, want, err_msg=msg)
    else:
        np.testing.assert_allclose(got, want, rtol=max(im.rtol, 1e-14), atol=im.rtol * scale, err_msg=msg)


def scipy_multilinear(t: CDBRDF, q: np.ndarray) -> np.ndarray:
    """An independent multilinear interpolator: scipy's, azimuths padded by one period, singleton axes dropped.

    Isotropic tables: the query is turned to light azimuth 0 first (phi_v - phi_l on the phi_v axis).
    """
    g = t.grid
    if g.isotropic:
        q = q.copy()
        q[1] = q[1] - q[3]
        q[3] = 0.0
    v = t.values.astype(np.float64)
    v = np.concatenate([v, v[:, :1]], axis=1)
    v = np.concatenate([v, v[:, :, :, :1]], axis=3)
    axes = [g.kappa, np.append(g.phi_l, g.phi_l[0] + 360.0), g.theta_l, np.append(g.phi_v, g.phi_v[0] + 360.0),
            g.theta_v]
    pts = [q[4], g.phi_l[0] + np.mod(q[3] - g.phi_l[0], 360.0), q[2], g.phi_v[0] + np.mod(q[1] - g.phi_v[0], 360.0),
           q[0]]
    keep = [i for i, a in enumerate(axes) if a.size > 1]
    v = v.reshape(tuple(a.size for a in axes if a.size > 1) + (t.n_channels,))
    rgi = RegularGridInterpolator([axes[i] for i in keep], v)
    return rgi(np.stack([np.clip(pts[i], axes[i][0], axes[i][-1]) for i in keep], axis=-1))
