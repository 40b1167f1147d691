#!/usr/bin/env bash
# Installs the Debian packages the workspace needs to build and test on a fresh machine.
#
#   libudev-dev   serialport's libudev feature (USB VID/PID/serial of ports)
#   libclang-dev  v4l → v4l2-sys-mit runs bindgen at build time
#   pkg-config    finds libudev
#   socat         optional second pseudo-terminal implementation used by tests
#
# Safe to run more than once. Needs root (or sudo) for apt-get; a machine that already has
# every package skips apt entirely.
set -euo pipefail

packages=(libudev-dev libclang-dev pkg-config socat)

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all packages present (${packages[*]})"
  exit 0
fi

SUDO=""
if [ "$(id -u)" -ne 0 ]; then
  command -v sudo >/dev/null 2>&1 || { echo "install-deps: need root or sudo to install: ${missing[*]}" >&2; exit 1; }
  SUDO="sudo"
fi

echo "install-deps: installing ${missing[*]}"
# A mirror warning from apt-get update must not stop the build.
$SUDO apt-get update -q || echo "install-deps: apt-get update reported a problem; trying the install anyway" >&2
DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -q --no-install-recommends "${missing[@]}"
