#!/usr/bin/env bash
# Runs the Blender add-on's tests (tests/blender/) headless with the `bpy` module from PyPI.
# bpy is pinned; its wheel (~370 MB) and the virtual environment are cached under
# ~/.cache/refrakt, so only the first run on a machine downloads anything.
# Uses target/debug/refrakt (built by `cargo test`) or $REFRAKT_BIN for the tests that need
# the real refrakt; they skip, saying why, when it is missing.
set -euo pipefail
cd "$(dirname "$0")/.."

# Blender 4.5 LTS (needs CPython 3.11); BPY_VERSION=4.2.0 or 5.0.0 tests another Blender.
BPY_VERSION="${BPY_VERSION:-4.5.15}"
PYTEST_VERSION=9.2.0
# OpenEXR's own bindings, for the tests to read EXRs independently of the add-on's reader;
# without its dependencies, so bpy's numpy stays as bpy ships it.
OPENEXR_VERSION=3.4.4
# NVIDIA's FLIP, the perceptual metric of the Cycles parity suite (tests/blender/test_parity.py).
FLIP_VERSION=1.7
CACHE="${XDG_CACHE_HOME:-$HOME/.cache}/refrakt"
WHEELS="$CACHE/wheels"
VENV="$CACHE/venv-bpy-$BPY_VERSION"

as_root() { if [ "$(id -u)" = 0 ]; then "$@"; else sudo "$@"; fi; }

find_python311() {
  for p in python3.11 python3; do
    if command -v "$p" >/dev/null 2>&1 && "$p" -c 'import sys; sys.exit(sys.version_info[:2] != (3, 11))'; then
      command -v "$p"; return 0
    fi
  done
  return 1
}

if ! "$VENV/bin/python" -c 'import bpy, pytest' >/dev/null 2>&1; then
  PYTHON="$(find_python311)" || {
    echo "test_blender: bpy $BPY_VERSION needs Python 3.11 (install python3.11, e.g. apt-get install python3.11 python3.11-venv)" >&2
    exit 1
  }
  echo "test_blender: setting up $VENV (bpy $BPY_VERSION, pytest $PYTEST_VERSION)" >&2
  rm -rf "$VENV"
  if ! "$PYTHON" -m venv "$VENV" 2>/dev/null; then
    # Debian's Python keeps venv in a separate package.
    as_root env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq python3.11-venv >/dev/null
    "$PYTHON" -m venv "$VENV"
  fi
  mkdir -p "$WHEELS"
  if ! ls "$WHEELS"/bpy-"$BPY_VERSION"-*.whl >/dev/null 2>&1; then
    "$VENV/bin/pip" download -q --no-deps --only-binary=:all: -d "$WHEELS" "bpy==$BPY_VERSION"
  fi
  "$VENV/bin/pip" install -q --find-links "$WHEELS" "bpy==$BPY_VERSION" "pytest==$PYTEST_VERSION"
fi
if ! "$VENV/bin/python" -c 'import OpenEXR' >/dev/null 2>&1; then
  "$VENV/bin/pip" install -q --no-deps "openexr==$OPENEXR_VERSION"
fi
if ! "$VENV/bin/python" -c 'import flip_evaluator' >/dev/null 2>&1; then
  "$VENV/bin/pip" install -q --no-deps "flip-evaluator==$FLIP_VERSION"
fi

if [ -z "${REFRAKT_BIN:-}" ] && [ -x target/debug/refrakt ]; then
  export REFRAKT_BIN="$PWD/target/debug/refrakt"
fi
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-$(mktemp -d)}"

set +e
"$VENV/bin/python" -m pytest tests/blender -q -rs -p no:cacheprovider "$@"
status=$?
set -e
if [ "$status" = 5 ]; then
  # pytest's "no tests collected": the suite is missing or a filter matched nothing.
  echo "test_blender: pytest collected no tests in tests/blender" >&2
  exit 1
fi
exit "$status"
