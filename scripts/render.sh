#!/usr/bin/env bash
# Renders the default example to render/default.png (and .exr), setting up the machine first.
# Extra arguments go to `refrakt render` (e.g. --size 1920x1080).
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/setup.sh
cargo run --release --quiet -- render examples/default.lua --out render "$@"
echo "wrote render/default.png and render/default.exr"
