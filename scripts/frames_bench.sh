#!/usr/bin/env bash
# `refrakt render --frames` end to end on the seed scene (the bunny): frames on disk per second
# under each flow and EXR codec, where the time goes, and each codec's encode cost on one core
# (refrakt bench --scenes frames), then docs/performance.md's tables. For the H200 machine:
#
#   bash scripts/frames_bench.sh [BUNNY.obj] [OUT.json] [FRAMES]
#
# Frames are written to a temporary folder ($TMPDIR, else /tmp): put it on the disk that
# matters (TMPDIR=/path/on/disk), as a page cache or tmpfs flatters the write times.
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/setup.sh
cargo build --release --quiet
mesh=${1:-../shared/assets/bunny.obj}
out=${2:-frames.json}
frames=${3:-240}
target/release/refrakt bench --mesh "$mesh" --scenes seed,frames --frames "$frames" --out "$out" >/dev/null
python3 scripts/bench_table.py "$out"
