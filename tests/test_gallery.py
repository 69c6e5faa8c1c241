"""The gallery's examples (``examples/plot_*.py``) run to the end.

The reference site executes them when it is built (``bash scripts/docs.sh``);
this runs each one as a script in its own process, with matplotlib's
non-interactive backend, so an example that an API change breaks fails the
test command too. The RGL example reads the shared data when present
(``CDBRDF_SHARED_DATA``, the rule of ``tests/shared_data.py``) and writes a
small file of its own otherwise. About 20 s of CPU in all (40 s on one worker of an idle 2-core machine).
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from .shared_data import shared_data

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
SCRIPTS = sorted(EXAMPLES.glob("plot_*.py"))


def test_gallery_has_its_examples():
    assert len(SCRIPTS) >= 6
    assert (EXAMPLES / "README.rst").is_file()  # sphinx-gallery's index of the folder
    for script in SCRIPTS:  # sphinx-gallery takes the title from the docstring's first lines
        head = script.read_text(encoding="utf-8").split('"""')[1].strip().splitlines()
        assert len(head) >= 2 and set(head[1]) == {"="} and len(head[1]) >= len(head[0]), script.name


@pytest.mark.parametrize("script", SCRIPTS, ids=lambda p: p.stem)
def test_example_runs(script, tmp_path):
    env = dict(os.environ, MPLBACKEND="Agg")
    data = shared_data()
    if data.is_dir() and "CDBRDF_SHARED_DATA" not in env:
        env["CDBRDF_SHARED_DATA"] = str(data)
    done = subprocess.run([sys.executable, str(script)], cwd=tmp_path, env=env, capture_output=True, text=True,
                          timeout=300)
    assert done.returncode == 0, f"{script.name} failed:\n{done.stderr[-4000:]}"
    assert not list(tmp_path.iterdir()), f"{script.name} left files in its working folder"
