#!/usr/bin/env bash
# `refrakt serve` in a real browser: installs Debian's chromium and chromium-driver when they
# are missing (CI runs as root on a fresh machine), then runs scripts/test_browser.py (the
# WebDriver protocol over plain HTTP from Python's standard library: nothing else to install).
# Uses target/debug/refrakt (built by `cargo test`) or $REFRAKT_BIN. Bounded to a few minutes.
set -euo pipefail
cd "$(dirname "$0")/.."

as_root() { if [ "$(id -u)" = 0 ]; then "$@"; else sudo "$@"; fi; }

if ! command -v chromedriver >/dev/null 2>&1 || ! { command -v chromium >/dev/null 2>&1 || command -v chromium-browser >/dev/null 2>&1; }; then
  if ! command -v apt-get >/dev/null 2>&1; then
    echo "test_browser: SKIPPED: no chromium/chromedriver and no apt-get to install them" >&2
    exit 0
  fi
  echo "test_browser: installing chromium and chromium-driver" >&2
  as_root env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium chromium-driver >/dev/null \
    || { as_root apt-get update -qq && as_root env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium chromium-driver >/dev/null; }
fi

BIN="${REFRAKT_BIN:-target/debug/refrakt}"
if [ ! -x "$BIN" ]; then
  cargo build --locked >&2
fi
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-$(mktemp -d)}"
timeout 300 python3 scripts/test_browser.py "$BIN" "$@"
