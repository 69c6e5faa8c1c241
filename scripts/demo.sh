#!/usr/bin/env bash
# Set everything up (idempotent) and run the main job: the paper end to end on
# the bundled fabrics (plan, simulated photographs, measurement, mosaics,
# renders, report). Quick form by default (coarse grid, a few minutes);
# `bash scripts/demo.sh --full` runs the paper's full 72 x 72 x 5 grid.
# The output folder is demo-output/ (or $CDBRDF_DEMO_DIR).
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bash "$ROOT/scripts/setup.sh"
cd "$ROOT"
MODE="--quick"
if [ "${1:-}" = "--full" ]; then MODE=""; shift; fi
exec .venv/bin/cdbrdf demo -o "${CDBRDF_DEMO_DIR:-demo-output}" $MODE "$@"
