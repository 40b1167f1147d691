#!/usr/bin/env bash
# Installs what the cross builds for Raspberry Pi-class boards need (see .cargo/config.toml):
#   Rust targets aarch64-unknown-linux-gnu and armv7-unknown-linux-gnueabihf (rustup),
#   Debian's cross gcc and C libraries for both, and qemu-user to run the tests.
# Safe to run more than once. Needs root (or sudo) for apt-get.
set -euo pipefail
cd "$(dirname "$0")/.."

targets=(aarch64-unknown-linux-gnu armv7-unknown-linux-gnueabihf)
packages=(gcc-aarch64-linux-gnu libc6-dev-arm64-cross gcc-arm-linux-gnueabihf libc6-dev-armhf-cross qemu-user libclang-dev)

installed=$(rustup target list --installed 2>/dev/null || true)
for t in "${targets[@]}"; do
  if ! grep -qx "$t" <<<"$installed"; then
    echo "cross-setup: adding Rust target $t"
    rustup target add "$t" || { echo "cross-setup: rustup could not add $t (is the rustup server reachable?)" >&2; exit 1; }
  fi
done

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  SUDO=""
  if [ "$(id -u)" -ne 0 ]; then
    command -v sudo >/dev/null 2>&1 || { echo "cross-setup: need root or sudo to install: ${missing[*]}" >&2; exit 1; }
    SUDO="sudo"
  fi
  echo "cross-setup: installing ${missing[*]}"
  $SUDO apt-get update -q || echo "cross-setup: apt-get update reported a problem; trying the install anyway" >&2
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -q --no-install-recommends "${missing[@]}"
fi
echo "cross-setup: ready (${targets[*]})"
