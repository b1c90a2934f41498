#!/usr/bin/env bash
# Installs what refrakt needs on a fresh machine: a Rust toolchain (if missing) and, when no
# Vulkan driver is present, Mesa's software Vulkan driver (lavapipe), so refrakt runs without a GPU.
set -euo pipefail

as_root() { if [ "$(id -u)" = 0 ]; then "$@"; else sudo "$@"; fi; }

if ! command -v cargo >/dev/null 2>&1; then
  if [ -x "$HOME/.cargo/bin/cargo" ]; then
    export PATH="$HOME/.cargo/bin:$PATH"
  else
    echo "setup: installing Rust with rustup" >&2
    curl --proto '=https' --tlsv1.2 -sSf https://sh.rustup.rs | sh -s -- -y --profile minimal >&2
    export PATH="$HOME/.cargo/bin:$PATH"
  fi
fi

# (grep reads all of ldconfig's output: with `grep -q` and pipefail, ldconfig's SIGPIPE would
# count as no driver; and one ICD folder with a JSON file is enough.)
have_vulkan_driver() {
  ldconfig -p 2>/dev/null | grep 'libvulkan\.so\.1' >/dev/null || return 1
  local dir
  for dir in /usr/share/vulkan/icd.d /etc/vulkan/icd.d /usr/local/share/vulkan/icd.d; do
    compgen -G "$dir/*.json" >/dev/null && return 0
  done
  return 1
}

if ! have_vulkan_driver; then
  if command -v apt-get >/dev/null 2>&1; then
    echo "setup: no Vulkan driver found; installing Mesa's lavapipe (mesa-vulkan-drivers)" >&2
    as_root env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq mesa-vulkan-drivers libvulkan1 >/dev/null \
      || { as_root apt-get update -qq && as_root env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq mesa-vulkan-drivers libvulkan1 >/dev/null; }
  elif command -v dnf >/dev/null 2>&1; then
    as_root dnf install -y mesa-vulkan-drivers vulkan-loader
  else
    echo "setup: no Vulkan driver found and no apt-get/dnf to install one; install your GPU's Vulkan driver or Mesa's lavapipe" >&2
    exit 1
  fi
fi
