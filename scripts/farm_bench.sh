#!/usr/bin/env bash
# Frames/s of one renderer against two, on this machine:
#   1. refrakt alone: `render --frames` (one renderer), then `--gpus 0,0` (two renderers sharing
#      adapter 0: on a one-GPU machine, what two farm workers on it would do); needs only the
#      refrakt binary.
#   2. refrakt-farm on a local Ray cluster of 1 then 2 worker nodes (each one "refrakt" slot,
#      sharing this machine's GPU); only when $FARM_PYTHON (default: the venv of
#      scripts/test_farm.sh) has Ray and refrakt_farm installed, else skipped with a note.
# Every run's frames must equal the first run's, byte for byte (checked, reported).
#
# Offline machines (the H200 box): carry the release binary (REFRAKT_BIN=path) and, for part 2,
# a venv made on a machine of the same OS and Python (bash scripts/test_farm.sh makes one in
# ~/.cache/refrakt/venv-farm-ray-*; Ray's wheel alone is ~80 MB). Without it, part 1 is the
# measurement.
#
#   REFRAKT_BIN=target/release/refrakt bash scripts/farm_bench.sh [SCENE] [FRAMES] -- [refrakt options]
# Defaults: examples/turntable.lua, 0..47, and on a CPU adapter tiny sizes (--size 64x36
# --volume 32 --photons 0); pass options after -- for a GPU (e.g. --size 1920x1080).
set -euo pipefail
cd "$(dirname "$0")/.."

SCENE="${1:-examples/turntable.lua}"
FRAMES="${2:-0..47}"
shift $(( $# >= 2 ? 2 : $# ))
[ "${1:-}" = "--" ] && shift
BIN="${REFRAKT_BIN:-}"
if [ -z "$BIN" ]; then
  # The newest build (a stale release build would lack --gpus).
  BIN="$(ls -t target/release/refrakt target/debug/refrakt 2>/dev/null | head -1)"
  [ -n "$BIN" ] && BIN="$PWD/$BIN"
fi
[ -x "$BIN" ] || { echo "farm_bench: no refrakt binary (cargo build --release, or REFRAKT_BIN=path)" >&2; exit 1; }
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-$(mktemp -d)}"
OPTS=("$@")
if [ ${#OPTS[@]} -eq 0 ]; then
  if "$BIN" info 2>/dev/null | grep -q '^adapter:.*Cpu'; then OPTS=(--size 64x36 --volume 32 --photons 0); fi
fi
WORK="$(mktemp -d)"
trap 'rm -rf "$WORK"' EXIT
first=${FRAMES%..*}; last=${FRAMES#*..}; count=$(( last - first + 1 ))
"$BIN" info | head -1

timed() {  # label, out folder, refrakt render options…
  local label="$1" out="$2"; shift 2
  local t0 t1
  t0=$(date +%s.%N)
  "$BIN" render "$SCENE" --frames "$FRAMES" --out "$out" --format png --progress quiet "${OPTS[@]}" "$@"
  t1=$(date +%s.%N)
  local same="reference"
  if [ "$out" != "$WORK/one" ]; then
    if diff -rq "$WORK/one" "$out" >/dev/null; then same="identical to one renderer"; else same="DIFFERENT from one renderer"; fi
  fi
  awk -v l="$label" -v n="$count" -v a="$t0" -v b="$t1" -v s="$same" \
    'BEGIN { printf "%-34s %4d frames  %7.2f s  %7.3f frames/s  (%s)\n", l, n, b - a, n / (b - a), s }'
}

echo "== refrakt alone: $SCENE, frames $FRAMES, options: ${OPTS[*]:-the scene defaults}"
timed "one renderer" "$WORK/one"
timed "--gpus 0,0 (two renderers, one GPU)" "$WORK/two" --gpus 0,0 --chunk 4

PY="${FARM_PYTHON:-$(ls -d "${XDG_CACHE_HOME:-$HOME/.cache}"/refrakt/venv-farm-ray-*/bin/python 2>/dev/null | tail -1)}"
if [ -n "$PY" ] && "$PY" -c 'import ray, refrakt_farm' >/dev/null 2>&1; then
  echo "== refrakt-farm on a local Ray cluster ($PY)"
  RAY_USAGE_STATS_ENABLED=0 "$PY" -m refrakt_farm.bench "$SCENE" --frames "$FRAMES" --chunk 4 --workers 1,2 --refrakt "$BIN" -- "${OPTS[@]}"
else
  echo "== refrakt-farm skipped: no Python with Ray and refrakt_farm (set FARM_PYTHON, or run scripts/test_farm.sh once)"
fi
