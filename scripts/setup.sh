#!/usr/bin/env bash
# Set up everything cdbrdf needs, idempotently: Debian packages (when missing),
# a virtual environment at .venv and the package with its dependencies.
# Quick when already done. Usage: bash scripts/setup.sh [--test]
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
WITH_TESTS=0
[ "${1:-}" = "--test" ] && WITH_TESTS=1

log() { printf '[setup] %s\n' "$*" >&2; }

# --- Python ---------------------------------------------------------------
PY="${PYTHON:-}"
if [ -z "$PY" ]; then
  for cand in python3.11 python3.12 python3.13 python3; do
    if command -v "$cand" >/dev/null 2>&1 && "$cand" -c 'import sys; sys.exit(sys.version_info < (3, 11))'; then
      PY="$cand"; break
    fi
  done
fi
[ -n "$PY" ] || { log "Python >= 3.11 is needed; none was found"; exit 1; }

# --- Debian packages ------------------------------------------------------
# libllvm19: Mitsuba 3's LLVM variants (vectorised CPU rendering) need libLLVM 19.
DEB_PKGS="libllvm19"
# chromium: the tests open the demo's report in a headless browser (Playwright).
[ "$WITH_TESTS" = 1 ] && DEB_PKGS="$DEB_PKGS chromium"
# node and npm: the glTF renderer's build (three.js) and the glTF validator (js/); Debian's, unless one is there
if ! command -v node >/dev/null 2>&1 || ! command -v npm >/dev/null 2>&1; then DEB_PKGS="$DEB_PKGS nodejs npm"; fi
missing=""
for p in $DEB_PKGS; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing="$missing $p"
done
if [ -n "$missing" ]; then
  if ! command -v apt-get >/dev/null 2>&1; then
    log "missing system packages:$missing (no apt-get here: install them by hand)"; exit 1
  fi
  SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO="sudo"
  log "installing Debian packages:$missing"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends $missing >/dev/null
fi

# --- virtual environment ---------------------------------------------------
if [ ! -x .venv/bin/python ]; then
  log "creating .venv with $PY"
  "$PY" -m venv .venv
fi
STAMP=".venv/.cdbrdf-installed"
WANT="$(sha256sum pyproject.toml | cut -d' ' -f1)"
if [ "$(cat "$STAMP" 2>/dev/null)" != "$WANT" ] || ! .venv/bin/python -c 'import cdbrdf' 2>/dev/null; then
  log "installing cdbrdf and its dependencies into .venv (first time: a few minutes)"
  .venv/bin/python -m pip install -q --disable-pip-version-check --upgrade pip >/dev/null
  .venv/bin/python -m pip install -q --disable-pip-version-check -e ".[test]"
  echo "$WANT" > "$STAMP"
fi
# --- JavaScript (js/) -------------------------------------------------------------
# The npm packages pinned by js/package-lock.json (three.js, fast-png; for the tests and the build: esbuild,
# the Khronos glTF validator, MikkTSpace), installed once (npm's cache serves later installs offline), and
# the glTF renderer bundled into the package data (src/cdbrdf/view/assets/gltf/), rebuilt when its sources change.
if command -v npm >/dev/null 2>&1; then
  JS_STAMP="js/node_modules/.cdbrdf-installed"
  JS_WANT="$(cat js/package.json js/package-lock.json | sha256sum | cut -d' ' -f1)"
  if [ "$(cat "$JS_STAMP" 2>/dev/null)" != "$JS_WANT" ]; then
    log "installing the npm packages of js/ (npm ci)"
    (cd js && npm ci --prefer-offline --no-audit --no-fund --ignore-scripts --loglevel=error >/dev/null)
    echo "$JS_WANT" > "$JS_STAMP"
  fi
  BUNDLE="src/cdbrdf/view/assets/gltf"
  BUILD_WANT="$(cat js/package-lock.json js/build.mjs js/src/*.js | sha256sum | cut -d' ' -f1)"
  if [ "$(cat "$BUNDLE/.built" 2>/dev/null)" != "$BUILD_WANT" ] || [ ! -f "$BUNDLE/renderer.js" ] \
      || [ ! -f "$BUNDLE/three-plain.js" ]; then
    log "building the glTF renderer (js/build.mjs)"
    (cd js && node build.mjs)
    echo "$BUILD_WANT" > "$BUNDLE/.built"
  fi
else
  log "npm not found: the glTF renderer is not built and the glTF checks are skipped (install node and npm)"
fi

# the numba kernels into their on-disk cache (a few seconds once cached; about 25 s the first time)
.venv/bin/python -m cdbrdf._precompile >&2
log "ready: $ROOT/.venv"
