#!/usr/bin/env bash
# Runs refrakt-farm's tests (farm/tests/): unit tests, mypy --strict, and a local Ray cluster
# (head + two worker nodes) rendering with the real refrakt on lavapipe. Ray, pytest, tqdm and
# mypy are pinned; the virtual environment and the wheels are cached under ~/.cache/refrakt,
# so only the first run on a machine downloads anything (about 70 MB for Ray).
# Uses target/debug/refrakt (built by `cargo test`) or $REFRAKT_BIN; the cluster tests skip,
# saying why, when it is missing.
set -euo pipefail
cd "$(dirname "$0")/.."

RAY_VERSION="${RAY_VERSION:-2.60.0}"
PINS=("ray==$RAY_VERSION" "tqdm==4.70.1" "pytest==9.2.0" "mypy==2.4.1")
CACHE="${XDG_CACHE_HOME:-$HOME/.cache}/refrakt"
WHEELS="$CACHE/wheels"
VENV="$CACHE/venv-farm-ray-$RAY_VERSION"

as_root() { if [ "$(id -u)" = 0 ]; then "$@"; else sudo "$@"; fi; }

if ! "$VENV/bin/python" -c 'import ray, tqdm, pytest, mypy' >/dev/null 2>&1; then
  PYTHON="$(command -v python3.11 || command -v python3)"
  echo "test_farm: setting up $VENV (${PINS[*]})" >&2
  rm -rf "$VENV"
  if ! "$PYTHON" -m venv "$VENV" 2>/dev/null; then
    as_root env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq python3-venv >/dev/null
    "$PYTHON" -m venv "$VENV"
  fi
  mkdir -p "$WHEELS"
  "$VENV/bin/pip" download -q --only-binary=:all: -d "$WHEELS" "${PINS[@]}"
  "$VENV/bin/pip" install -q --no-index --find-links "$WHEELS" "${PINS[@]}"
fi
"$VENV/bin/pip" install -q --no-deps --no-build-isolation -e farm >/dev/null 2>&1 \
  || "$VENV/bin/pip" install -q --no-deps -e farm

if [ -z "${REFRAKT_BIN:-}" ] && [ -x target/debug/refrakt ]; then
  export REFRAKT_BIN="$PWD/target/debug/refrakt"
fi
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-$(mktemp -d)}"
# Ray's usage reporting would try to reach the network.
export RAY_USAGE_STATS_ENABLED=0

status=0
(cd farm && "$VENV/bin/mypy") || status=$?
"$VENV/bin/python" -m pytest farm/tests -q -rs -p no:cacheprovider "$@" || status=$?
exit "$status"
