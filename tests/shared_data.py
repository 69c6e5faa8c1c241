"""Where the real third-party test data are: ``../shared/data`` beside the repository (see its README).

One rule for every test that reads them (measured BRDFs, meshes): ``$CDBRDF_SHARED_DATA`` when
set, else ``shared/data`` beside the repository's root, else (in a git worktree) beside the main
checkout's root. The data are never copied into the project; a test that needs an absent file is
skipped, and the skip names the path (reported by ``-ra``).
"""

from __future__ import annotations

import functools
import os
import subprocess
from pathlib import Path

import pytest

__all__ = ["shared_data", "shared_file"]

ROOT = Path(__file__).resolve().parents[1]


@functools.cache
def _candidates() -> tuple[Path, ...]:
    env = os.environ.get("CDBRDF_SHARED_DATA")
    if env:
        return (Path(env),)
    roots = [ROOT]
    try:
        common = subprocess.run(["git", "rev-parse", "--git-common-dir"], cwd=ROOT, capture_output=True,
                                text=True, timeout=10).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        common = ""
    if common:
        main = (ROOT / common).resolve().parent
        if main != ROOT:
            roots.append(main)
    return tuple(r.parent / "shared" / "data" for r in roots)


def shared_data() -> Path:
    """The shared data folder (the first candidate that exists, else the first candidate)."""
    cands = _candidates()
    return next((c for c in cands if c.is_dir()), cands[0])


def shared_file(relative: str) -> Path:
    """A file of the shared data (e.g. ``"meshes/spot.obj"``); skips the test when it is absent."""
    for c in _candidates():
        p = (c / relative).resolve()
        if p.is_file():
            return p
    pytest.skip(f"shared test data absent: {_candidates()[0] / relative}")
