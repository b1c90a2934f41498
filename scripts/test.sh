#!/usr/bin/env bash
# Runs every test (Rust unit and integration tests, on lavapipe when there is no GPU), setting
# up the machine first. CI runs exactly this.
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/setup.sh
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-$(mktemp -d)}"
status=0
cargo test --locked --no-fail-fast 2>&1 || status=$?
# The Blender add-on, headless with the bpy module (uses the refrakt binary cargo test built).
bash scripts/test_blender.sh 2>&1 || status=$?
# refrakt-farm (farm/): unit tests and a local Ray cluster rendering with the same binary.
bash scripts/test_farm.sh 2>&1 || status=$?
# refrakt serve's page in headless Chromium (installed by the script when missing).
bash scripts/test_browser.sh 2>&1 || status=$?
exit "$status"
