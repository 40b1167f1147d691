#!/usr/bin/env bash
# Builds the .deb of the on-device service for a Pi-class board (default: 64-bit OS).
#   scripts/package.sh [aarch64-unknown-linux-gnu|armv7-unknown-linux-gnueabihf]
# Installs cargo-deb on first use. The package lands in target/debian/.
set -euo pipefail
cd "$(dirname "$0")/.."
target=${1:-aarch64-unknown-linux-gnu}
bash scripts/cross-setup.sh
command -v cargo-deb >/dev/null 2>&1 || cargo install cargo-deb --locked
cargo deb -p vistaf-firmware --target "$target" --profile deb
ls -l target/debian/vistaf-skin_*.deb
