#!/usr/bin/env bash
# Set everything up (idempotent) and run the main job: the paper end to end on
# the bundled fabrics (plan, simulated photographs, measurement, mosaics,
# renders, report) on the paper's 72 x 72 x 5 grid, about 3 minutes on a
# 2-core machine. `bash scripts/demo.sh --quick` runs a coarse grid in about a
# minute. Output: demo-output/ (or $CDBRDF_DEMO_DIR); open its report.html.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bash "$ROOT/scripts/setup.sh"
cd "$ROOT"
exec .venv/bin/cdbrdf demo -o "${CDBRDF_DEMO_DIR:-demo-output}" "$@"
