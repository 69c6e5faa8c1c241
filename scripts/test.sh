#!/usr/bin/env bash
# Set everything up (idempotent) and run the test suite. Extra arguments go to pytest,
# e.g. `bash scripts/test.sh -m slow` for the slow tests only. The tests run in
# CDBRDF_TEST_WORKERS processes (pytest-xdist; default: one per CPU).
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bash "$ROOT/scripts/setup.sh" --test
cd "$ROOT"
# Static checks first (seconds): the layer contracts, lint, types (pyproject.toml,
# docs/architecture.md). Then the test suite.
echo "[test] layers: lint-imports" >&2
.venv/bin/lint-imports --no-cache >/dev/null || { .venv/bin/lint-imports --no-cache; exit 1; }
echo "[test] lint: ruff" >&2
.venv/bin/ruff check src tests benchmarks scripts examples docs
echo "[test] types: mypy" >&2
.venv/bin/mypy
echo "[test] pytest" >&2
.venv/bin/python -m pytest -n "${CDBRDF_TEST_WORKERS:-auto}" --dist loadfile "$@"
# The tests that promise exact results, again on a baseline CPU: numba compiling for a
# generic x86-64 and NumPy without its AVX-512 loops (a CPU without AVX-512 rounds some
# functions differently). Only for the default run (no arguments), as CI runs it.
if [ "$#" -eq 0 ]; then
  echo "[test] portability: exact results on a baseline CPU" >&2
  NPY_OFF="$(.venv/bin/python -c 'try:
    from numpy._core._multiarray_umath import __cpu_dispatch__ as d
except ImportError:
    from numpy.core._multiarray_umath import __cpu_dispatch__ as d
print(" ".join(f for f in d if "AVX512" in f or f == "X86_V4"))')"
  NUMBA_CPU_NAME=generic NPY_DISABLE_CPU_FEATURES="$NPY_OFF" .venv/bin/python -m pytest -q -n "${CDBRDF_TEST_WORKERS:-auto}" \
    tests/test_fill_provenance.py tests/test_interp.py tests/test_measure_fill.py
fi
