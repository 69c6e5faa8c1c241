"""Hostile input, third round continued: fuzzed CD-BTF files, pile and woven ``--set`` values, normal maps named
by meshes (issue 38; ``docs/reliability.md``).

Each input is built from ``(seed, index)`` by a target run in a child process
(``tests/fuzzing.py``: hangs and crashes are caught and counted):

- **CD-BTF files** (:func:`target_btf_files`): a small CD-BTF of either schema
  (PCA, neural) saved, then one to three of its global attributes or variables
  forged (empty, text, NaN, infinite, tiny or huge numbers, wrong lengths, a
  group or a scalar for a variable, values scaled by 1e20, a texel axis of
  2^33) with the digest recomputed (mostly), so that the checks behind the
  digest are reached: :func:`cdbrdf.btf.load` gives a one-line error naming the
  file, or a CD-BTF whose every value (random positions up to 1e300, footprints,
  directions) is finite and within the table bound, and ``cdbrdf info`` exits 0
  or 2 with one line;
- **synth --set** (:func:`target_synth_set`): a preset with one parameter set to
  a hostile value (0, 1e-300, 5e-324, 1e300, inf, nan, -1, text, a 400-digit
  integer): exit 2 with one line naming the parameter, or exit 0 and a file of
  finite values;
- **normal maps named by meshes** (:func:`target_mesh_maps`): an OBJ's MTL
  ``norm``/``map_Bump`` or a glTF's ``normalTexture`` naming a missing,
  damaged, truncated, grey, huge (declared 10^10 pixels), non-image
  (``/etc/passwd``), ``file://``, ``..`` or bad base64 map, or a good one,
  embedded or beside it: the good map is used, any other is one warning naming
  it (the mesh shaded without it) or one error line naming the mesh.
"""

from __future__ import annotations

import base64
import logging
import struct
import zlib
from pathlib import Path

import numpy as np
import pytest

from .fuzzing import fuzz_generated
from .test_fuzz_hostile3 import _run_cli

#: Seconds one input may take (a hang otherwise).
PER_INPUT_S = 60.0

# -- CD-BTF files ---------------------------------------------------------------------------------------------
_CACHE: dict[str, object] = {}

_ATTRS = ("btf_repeat_mm", "btf_rank", "btf_residual_rank", "btf_method", "btf_format_version", "btf_max_error",
          "btf_relative_rms_error", "btf_relative_rms_error_per_kappa", "btf_compression_ratio",
          "btf_truncated_from", "btf_neural_relative_rms_error", "btf_fit_seconds", "btf_latent_levels",
          "btf_decoder_layers", "btf_decoder_constants", "btf_sha256")
_VARIABLES = ("texel_u", "texel_v", "btf_weights", "btf_basis", "btf_latents", "btf_decoder")


def _btf(kind: str):
    """A small CD-BTF of ``kind`` (``"pca"`` or ``"neural"``), made once per worker process."""
    if kind not in _CACHE:
        from cdbrdf import CDBTF, Grid

        g = Grid(kappa=[-0.1, 0.0, 0.2], theta_l=[0, 40, 80], phi_l=[0, 180], theta_v=[0, 40, 80], phi_v=[0, 180])
        vals = np.random.default_rng(1).uniform(0.05, 0.4, (3, 4) + g.shape + (3,))
        if kind == "pca":
            _CACHE[kind] = CDBTF.from_values(vals, g, repeat_mm=(2.0, 1.5), max_error=0.01)
        else:
            from cdbrdf.btf._neural import FitOptions

            _CACHE[kind] = CDBTF.from_values(vals, g, repeat_mm=(2.0, 1.5), method="neural", max_error=0.9,
                                             fit=FitOptions(steps=10, latent_dims=3, hidden=(8,)))
    return _CACHE[kind]


def _hostile_number(rng: np.random.Generator, like: np.ndarray):
    """A hostile value for an attribute that holds ``like``."""
    import h5py

    size = max(int(np.size(like)), 1)
    choice = int(rng.integers(0, 16))
    if choice == 0:
        return h5py.Empty("f8")
    if choice == 1:
        return "x" * int(rng.integers(1, 8))
    if choice == 2:
        return np.array([np.nan] * size)
    if choice == 3:
        return np.array([np.inf] * size)
    if choice == 4:
        return np.array([1e-300] * size)
    if choice == 5:
        return np.array([1e300] * size)
    if choice == 6:
        return np.array([-1.0] * size)
    if choice == 7:
        return np.zeros(size)
    if choice == 8:
        return np.array([2**62] * size, np.int64)
    if choice == 9:
        return np.ones(size + int(rng.integers(1, 4)))  # a wrong length
    if choice == 10:
        return np.zeros(0)
    if choice == 11:
        return np.array([True] * size)
    if choice == 12:
        return np.array([0.5] * size)  # not whole where integers are expected
    if choice == 13 and np.asarray(like).dtype.kind in "iuf":
        return np.asarray(like) * float(rng.choice([1e-20, 1e20, -1.0]))
    if choice == 14:
        return np.array([5e-324] * size)
    return np.array(["a"] * size, dtype="S1")


def _hostile_variable(rng: np.random.Generator, ds) -> object:
    a = np.asarray(ds[()]) if getattr(ds, "size", None) is not None and ds.size <= 1 << 24 else np.zeros(4)
    choice = int(rng.integers(0, 9))
    if choice == 0:
        return "group"
    if choice == 1:
        return np.float64(0.5)  # a scalar
    if choice == 2:
        return a.reshape(-1)[: max(a.size - 1, 0)]  # one value short
    if choice == 3:
        return (a.astype(np.float64) * 1e20).astype(a.dtype if a.dtype.kind == "f" else np.float64)
    if choice == 4:
        b = a.astype(np.float64).copy()
        b.reshape(-1)[0] = np.nan
        return b
    if choice == 5:
        return a.astype(np.int32)
    if choice == 6:
        return np.zeros((0,) + a.shape[1:])
    if choice == 7:
        return "huge"
    return np.full(a.shape, 1e300)


def _forge(rng: np.random.Generator, path: Path) -> list[str]:
    import h5py

    from .test_btf_hostile import _digest

    done = []
    with h5py.File(path, "r+") as f:
        for _ in range(int(rng.integers(1, 4))):
            if rng.random() < 0.6:
                name = str(rng.choice(_ATTRS))
                like = np.asarray(f.attrs[name]) if name in f.attrs else np.zeros(1)
                value = _hostile_number(rng, like)
                f.attrs[name] = value
                done.append(f"{name}={str(value)[:40]}")
            else:
                name = str(rng.choice([v for v in _VARIABLES if v in f] or ["texel_u"]))
                value = _hostile_variable(rng, f[name]) if name in f else "group"
                del f[name]
                if isinstance(value, str) and value == "group":
                    f.create_group(name)
                elif isinstance(value, str):  # declared huge, never written
                    f.create_dataset(name, shape=(1 << 33,), dtype="f8", chunks=(1 << 16,))
                else:
                    f.create_dataset(name, data=value)
                done.append(f"{name} <- {str(value)[:30]}")
        if rng.random() < 0.85:
            f.attrs["btf_sha256"] = _digest(f)
    return done


def _btf_values_ok(b) -> bool:
    """Finite, bounded values at random queries, positions up to 1e300 included; repeat within range."""
    from cdbrdf.btf.file import REPEAT_MM_RANGE
    from cdbrdf.table import MAX_ABS_VALUE

    lo, hi = REPEAT_MM_RANGE
    if not all(lo <= r <= hi for r in b.repeat_mm):
        return False
    rng = np.random.default_rng(0)
    n = 64
    u = np.concatenate([rng.uniform(-10, 10, n - 4), [3.3e38, 1e300, -1e300, 1e30]])
    vals = b.evaluate(u, rng.uniform(-10, 10, n), rng.uniform(0, 90, n), rng.uniform(0, 360, n),
                      rng.uniform(0, 90, n), rng.uniform(0, 360, n), rng.uniform(-1, 1, n),
                      footprint_mm=rng.uniform(0, 5, n))
    return bool(np.all(np.isfinite(vals)) and np.abs(vals).max() <= MAX_ABS_VALUE)


def target_btf_files(rng: np.random.Generator, workdir: Path) -> str:
    """A forged CD-BTF file, loaded and described (module docstring)."""
    from cdbrdf.btf import load
    from cdbrdf.errors import CDBRDFError

    kind = "neural" if rng.random() < 0.4 else "pca"
    path = workdir / "b.h5"
    _btf(kind).save(path)
    _forge(rng, path)
    try:
        b = load(path)
    except CDBRDFError as exc:
        msg = str(exc)
        if "\n" in msg or str(path) not in msg:
            return "bad"
    else:
        if not _btf_values_ok(b):
            return "bad"
    if rng.random() < 0.25:  # the command line too
        status, err = _run_cli(["info", str(path)])
        if status not in (0, 2) or (status == 2 and err.count("\n") != 1) or "Traceback" in err:
            return "bad"
    return "ok"


# -- synth --set ------------------------------------------------------------------------------------------------
_PILE_PARAMS = ("pile_height_mm", "strand_diameter_mm", "strands_per_mm2", "loop_width_mm", "lean_deg", "brush_deg",
                "spread_deg", "fibre_gloss_deg", "fibre_specular", "ior", "correlation_mm", "layers", "azimuths",
                "rings", "kind", "scattering", "fibre_rgb", "ground_rgb", "name")
_WOVEN_PARAMS = ("warp_pitch_mm", "weft_pitch_mm", "warp_width_mm", "weft_width_mm", "warp_height_mm",
                 "weft_height_mm", "thickness_mm", "ior", "warp_gloss_deg", "weft_gloss_deg", "warp_sheen_deg",
                 "weft_sheen_deg", "warp_specular", "footprint_mm", "crimp_transition", "warp_twist_deg",
                 "neutral_fraction", "warp_rgb", "name")
_SET_VALUES = ("0", "-0", "1e-300", "5e-324", "1e-30", "1e-6", "1e300", "inf", "-inf", "nan", "-1", "abc", "",
               "1,2", "0.5,0.5,2", "1e999", "9" * 400, "0x10", "1_000", "90", "89.999", "1e6")


def target_synth_set(rng: np.random.Generator, workdir: Path) -> str:
    """``cdbrdf synth PRESET --set NAME=VALUE`` on a small grid (module docstring)."""
    import cdbrdf

    pile = rng.random() < 0.7
    preset = str(rng.choice(["velvet", "towel"] if pile else ["denim", "shot"]))
    name = str(rng.choice(_PILE_PARAMS if pile else _WOVEN_PARAMS))
    value = str(rng.choice(_SET_VALUES))
    out = workdir / "s.h5"
    status, err = _run_cli(["synth", preset, "--set", f"{name}={value}", "--grid", "regular:45,180", "--kappa",
                            "0,0.2", "-o", str(out)])
    if "Traceback" in err:
        return "bad"
    if status == 2:
        return "ok" if err.count("\n") == 1 and (name in err or "--set" in err) and not out.exists() else "bad"
    if status != 0:
        return "bad"
    t = cdbrdf.load(out)
    return "ok" if np.all(np.isfinite(t.values)) else "bad"


# -- normal maps named by meshes -----------------------------------------------------------------------------------
_MAP_KINDS = ("good", "missing", "garbage", "passwd", "file-uri", "dotdot", "huge-header", "truncated", "grey",
              "empty", "bad-base64", "embedded-good", "embedded-garbage", "embedded-truncated")


def _png(rgb: np.ndarray, path: Path) -> bytes:
    from cdbrdf.images import write_png

    write_png(path, rgb)
    return path.read_bytes()


def _good_map(workdir: Path) -> bytes:
    x = np.linspace(0, 2 * np.pi, 16, endpoint=False)
    n = np.zeros((16, 16, 3))
    n[..., 0] = 0.3 * np.cos(x)[None, :]
    n[..., 2] = np.sqrt(1 - n[..., 0] ** 2)
    return _png(np.round((n + 1) / 2 * 255).astype(np.uint8), workdir / "_good.png")


def _map_bytes(kind: str, workdir: Path) -> bytes | None:
    if kind in ("good", "dotdot", "embedded-good"):
        return _good_map(workdir)
    if kind in ("garbage", "embedded-garbage"):
        return b"garbage!" * 16
    if kind == "huge-header":
        ihdr = struct.pack(">IIBBBBB", 100000, 100000, 8, 2, 0, 0, 0)
        return (b"\x89PNG\r\n\x1a\n" + struct.pack(">I", 13) + b"IHDR" + ihdr
                + struct.pack(">I", zlib.crc32(b"IHDR" + ihdr)) + b"\0" * 64)
    if kind in ("truncated", "embedded-truncated"):
        return _good_map(workdir)[:70]
    if kind == "grey":
        return _png(np.zeros((4, 4), np.uint8), workdir / "_grey.png")
    if kind == "empty":
        return b""
    return None


def _sheet_obj(folder: Path, mtl_line: str) -> Path:
    n = 9
    x, y = np.meshgrid(np.linspace(0, 40, n), np.linspace(0, 40, n), indexing="ij")
    lines = ["mtllib a.mtl", "usemtl cloth"]
    lines += [f"v {a:.4f} {b:.4f} 0" for a, b in zip(x.ravel(), y.ravel())]
    lines += [f"vt {a / 40:.4f} {b / 40:.4f}" for a, b in zip(x.ravel(), y.ravel())]
    for i in range(n - 1):
        for j in range(n - 1):
            k = i * n + j + 1
            lines += [f"f {k}/{k} {k + n}/{k + n} {k + n + 1}/{k + n + 1}", f"f {k}/{k} {k + n + 1}/{k + n + 1} {k + 1}/{k + 1}"]
    (folder / "a.obj").write_text("\n".join(lines) + "\n")
    (folder / "a.mtl").write_text(f"newmtl cloth\n{mtl_line}\n")
    return folder / "a.obj"


def target_mesh_maps(rng: np.random.Generator, workdir: Path) -> str:
    """A mesh naming a normal map of a random kind, prepared with its maps (module docstring)."""
    from cdbrdf.errors import CDBRDFError
    from cdbrdf.mesh import prepare_mesh

    from .test_normalmap_hostile import _gltf

    kind = str(rng.choice(_MAP_KINDS))
    folder = workdir / "m"
    folder.mkdir()
    data = _map_bytes(kind, workdir)
    name = "n.png"
    if kind == "passwd":
        name = "/etc/passwd"
    elif kind == "file-uri":
        name = "file:///etc/passwd"
    elif kind == "dotdot":
        (workdir / "n.png").write_bytes(data)
        name = "../n.png"
    elif data is not None and not kind.startswith("embedded"):
        (folder / name).write_bytes(data)
    gltf = kind.startswith("embedded") or kind == "bad-base64" or rng.random() < 0.4
    if gltf:
        if kind == "bad-base64":
            image = {"uri": "data:image/png;base64,@@@"}
        elif kind.startswith("embedded"):
            image = {"uri": "data:image/png;base64," + base64.b64encode(data).decode()} if rng.random() < 0.5 \
                else {"bufferView": 3}
        else:
            image = {"uri": name}
        glb = data if image.get("bufferView") == 3 else None
        mesh_path = _gltf(folder, image, glb_image=glb)
    else:
        if kind == "bad-base64":
            return "ok"
        statement = str(rng.choice(["norm", "map_Bump -bm 0.2", "bump -bm 0.2"]))
        mesh_path = _sheet_obj(folder, f"{statement} {name}")
        if kind == "grey" and statement != "norm":
            kind = "good"  # a grey image is a height map (a flat one): used
    seen: list[str] = []

    class Catch(logging.Handler):
        def emit(self, record):
            if record.levelno >= logging.WARNING:
                seen.append(record.getMessage())

    handler = Catch()
    logging.getLogger("cdbrdf").addHandler(handler)
    try:
        mesh = prepare_mesh(mesh_path, neighbourhood_mm=5.0)
    except CDBRDFError as exc:
        msg = str(exc)
        return "ok" if "\n" not in msg and msg and kind not in ("good", "dotdot", "embedded-good") else "bad"
    finally:
        logging.getLogger("cdbrdf").removeHandler(handler)
    used = "curvature_map" in mesh.metadata
    warned = [m for m in seen if "not used" in m]
    if kind in ("good", "dotdot", "embedded-good"):
        return "ok" if used and not warned else "bad"
    return "ok" if not used and len(warned) == 1 and "\n" not in warned[0] else "bad"


def _run(target: str, n: int, seed: int):
    report = fuzz_generated(f"tests.test_fuzz_hostile4:{target}", n=n, seed=seed, per_input_s=PER_INPUT_S,
                            allowed=())
    print(report.summary())
    return report


def test_fuzz_btf_files_small():
    report = _run("target_btf_files", 60, seed=1)
    assert report.n == 60 and not report.bad, report.summary()


def test_fuzz_synth_set_small():
    report = _run("target_synth_set", 10, seed=1)
    assert report.n == 10 and not report.bad, report.summary()


def test_fuzz_mesh_normal_maps_small():
    report = _run("target_mesh_maps", 40, seed=1)
    assert report.n == 40 and not report.bad, report.summary()


@pytest.mark.slow
def test_fuzz_btf_files_1000():
    report = _run("target_btf_files", 1000, seed=2)
    assert report.n == 1000 and not report.bad, report.summary()


@pytest.mark.slow
def test_fuzz_synth_set_120():
    report = _run("target_synth_set", 120, seed=2)
    assert report.n == 120 and not report.bad, report.summary()


@pytest.mark.slow
def test_fuzz_mesh_normal_maps_600():
    report = _run("target_mesh_maps", 600, seed=2)
    assert report.n == 600 and not report.bad, report.summary()

