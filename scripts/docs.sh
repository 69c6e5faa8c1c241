#!/usr/bin/env bash
# Build the reference site into docs/_build/html: the guides (docs/*.md), the API
# reference generated from the docstrings and the gallery (examples/, every example
# run). Offline (no intersphinx), warnings are errors. Extra arguments go to
# sphinx-build. The RGL example imports a real file from the shared test data when
# they are found (CDBRDF_SHARED_DATA, else shared/data beside the repository) and a
# small file it writes itself otherwise. About 2 minutes on 2 cores.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
if ! .venv/bin/python -c 'import sphinx, numpydoc, sphinx_gallery, pydata_sphinx_theme, myst_parser' 2>/dev/null; then
  bash "$ROOT/scripts/setup.sh"
  echo "[docs] installing the documentation tools into .venv" >&2
  .venv/bin/python -m pip install -q --disable-pip-version-check -e ".[docs]"
fi
export MPLBACKEND=Agg
# the project's shared test data (as tests/shared_data.py finds them): beside the
# repository, or beside the main checkout of a git worktree
if [ -z "${CDBRDF_SHARED_DATA:-}" ]; then
  COMMON="$(git -C "$ROOT" rev-parse --path-format=absolute --git-common-dir 2>/dev/null || true)"
  for cand in "$ROOT/../shared/data" ${COMMON:+"$(dirname "$COMMON")/../shared/data"}; do
    if [ -d "$cand/rgl" ]; then export CDBRDF_SHARED_DATA="$(cd "$cand" && pwd)"; break; fi
  done
fi
# the generated pages are rebuilt from the docstrings each time
rm -rf docs/api/generated docs/gallery docs/sg_execution_times.rst
.venv/bin/python -m sphinx -b html -W --keep-going -q -j 1 docs docs/_build/html "$@"
echo "[docs] site: $ROOT/docs/_build/html/index.html" >&2
