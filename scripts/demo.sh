#!/usr/bin/env bash
# Set everything up (idempotent) and run the main job: the paper end to end on
# the bundled materials. Extra arguments go to `cdbrdf demo`.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bash "$ROOT/scripts/setup.sh"
cd "$ROOT"
exec .venv/bin/cdbrdf demo -o "${CDBRDF_DEMO_DIR:-demo-output}" "$@"
