#!/usr/bin/env bash
# Set everything up (idempotent) and run the test suite. Extra arguments go to pytest,
# e.g. `bash scripts/test.sh -m slow` for the slow tests only.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bash "$ROOT/scripts/setup.sh" --test
cd "$ROOT"
# Static checks first (seconds): the layer contracts, lint, types (pyproject.toml,
# docs/architecture.md). Then the test suite.
echo "[test] layers: lint-imports" >&2
.venv/bin/lint-imports --no-cache >/dev/null || { .venv/bin/lint-imports --no-cache; exit 1; }
echo "[test] lint: ruff" >&2
.venv/bin/ruff check src tests benchmarks scripts
echo "[test] types: mypy" >&2
.venv/bin/mypy
exec .venv/bin/python -m pytest "$@"
