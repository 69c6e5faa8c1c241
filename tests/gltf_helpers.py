"""The JavaScript side of the glTF tests: node with js/'s npm packages (the Khronos validator, MikkTSpace).

``scripts/setup.sh`` installs them (``npm ci`` in ``js/``) and builds the glTF renderer; without node or
the packages these tests are skipped, except in CI, where they must run.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
JS = ROOT / "js"
NODE = shutil.which("node")


def _js_ready() -> bool:
    return NODE is not None and (JS / "node_modules" / "gltf-validator").is_dir() and \
        (JS / "node_modules" / "mikktspace").is_dir()


needs_node = pytest.mark.skipif(not _js_ready() and not os.environ.get("CI"),
                                reason="node and js/'s npm packages are not installed (scripts/setup.sh installs them)")


def validate(*paths: Path) -> list[dict]:
    """The Khronos glTF validator's report of each file (``js/validate.mjs``)."""
    r = subprocess.run([NODE or "node", str(JS / "validate.mjs"), *map(str, paths)], capture_output=True, text=True,
                       timeout=300, check=False)
    assert r.returncode == 0, r.stderr
    return [json.loads(line)["report"] for line in r.stdout.splitlines() if line.strip()]


def errors(report: dict) -> list[dict]:
    """The report's issues of severity 0 (errors)."""
    return [m for m in report["issues"]["messages"] if m["severity"] == 0]


def mikktspace(position: np.ndarray, normal: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """The reference MikkTSpace tangents (npm ``mikktspace``) of unindexed triangles: ``(3 m, 4)``."""
    data = json.dumps({"position": position.astype(np.float32).ravel().tolist(),
                       "normal": normal.astype(np.float32).ravel().tolist(),
                       "uv": uv.astype(np.float32).ravel().tolist()})
    r = subprocess.run([NODE or "node", str(JS / "mikktspace.cjs")], input=data, capture_output=True, text=True,
                       timeout=300, check=False)
    assert r.returncode == 0, r.stderr
    return np.array(json.loads(r.stdout), dtype=np.float64).reshape(-1, 4)


def read_glb(path: Path) -> tuple[dict, bytes]:
    """The JSON and the binary chunk of a GLB, read by hand (the container's layout, independent of pygltflib)."""
    data = path.read_bytes()
    assert data[:4] == b"glTF" and int.from_bytes(data[4:8], "little") == 2
    assert int.from_bytes(data[8:12], "little") == len(data)
    n = int.from_bytes(data[12:16], "little")
    assert data[16:20] == b"JSON"
    doc = json.loads(data[20:20 + n])
    rest = data[20 + n:]
    m = int.from_bytes(rest[0:4], "little")
    assert rest[4:8] == b"BIN\0"
    return doc, rest[8:8 + m]


def accessor(doc: dict, blob: bytes, index: int) -> np.ndarray:
    """An accessor's values (float32 or unsigned indices), one row per element."""
    a = doc["accessors"][index]
    bv = doc["bufferViews"][a["bufferView"]]
    dtype = {5126: "<f4", 5125: "<u4", 5123: "<u2"}[a["componentType"]]
    width = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4}[a["type"]]
    start = bv.get("byteOffset", 0) + a.get("byteOffset", 0)
    return np.frombuffer(blob, dtype, a["count"] * width, start).reshape(a["count"], width)
