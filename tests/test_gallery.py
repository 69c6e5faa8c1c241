"""The gallery's examples (``examples/plot_*.py``) run to the end.

The reference site executes them when it is built (``bash scripts/docs.sh``);
this runs them as scripts, one after the other in one child process (as the
site's build does) with matplotlib's non-interactive backend, each in its own
namespace and empty working folder, so an example that an API change breaks
fails the test command too. The RGL example reads the shared data when present
(``CDBRDF_SHARED_DATA``, the rule of ``tests/shared_data.py``) and writes a
small file of its own otherwise. About 10 s on 2 cores.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from .shared_data import shared_data

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
SCRIPTS = sorted(EXAMPLES.glob("plot_*.py"))

# Runs each script given on the command line; prints {script: traceback or null} as JSON.
DRIVER = """
import json, os, runpy, sys, tempfile, traceback
import matplotlib.pyplot as plt
results = {}
for script in sys.argv[1:]:
    with tempfile.TemporaryDirectory() as work:
        os.chdir(work)
        try:
            runpy.run_path(script, run_name="__main__")
            left = os.listdir(work)
            results[script] = f"left files in its working folder: {left}" if left else None
        except BaseException:
            results[script] = traceback.format_exc()
        finally:
            os.chdir("/")
            plt.close("all")
print(json.dumps(results))
"""


@pytest.fixture(scope="module")
def results():
    env = dict(os.environ, MPLBACKEND="Agg")
    data = shared_data()
    if data.is_dir() and "CDBRDF_SHARED_DATA" not in env:
        env["CDBRDF_SHARED_DATA"] = str(data)
    done = subprocess.run([sys.executable, "-c", DRIVER, *map(str, SCRIPTS)], env=env, capture_output=True,
                          text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-4000:]
    return json.loads(done.stdout.strip().splitlines()[-1])


def test_gallery_has_its_examples():
    assert len(SCRIPTS) >= 6
    assert (EXAMPLES / "README.rst").is_file()  # sphinx-gallery's index of the folder
    for script in SCRIPTS:  # sphinx-gallery takes the title from the docstring's first lines
        head = script.read_text(encoding="utf-8").split('"""')[1].strip().splitlines()
        assert len(head) >= 2 and set(head[1]) == {"="} and len(head[1]) >= len(head[0]), script.name


@pytest.mark.parametrize("script", SCRIPTS, ids=lambda p: p.stem)
def test_example_runs(script, results):
    assert results[str(script)] is None, f"{script.name}:\n{results[str(script)]}"
