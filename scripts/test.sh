#!/usr/bin/env bash
# Runs every test (Rust unit and integration tests, on lavapipe when there is no GPU), setting
# up the machine first. CI runs exactly this.
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/setup.sh
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-$(mktemp -d)}"
cargo test --locked --no-fail-fast 2>&1
