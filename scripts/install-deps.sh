#!/usr/bin/env bash
# Installs the Debian packages the workspace's tests need on a fresh machine (the demo and
# the host need none: `cargo run --release -p vistaf-demo` builds without them).
#
#   libclang-dev  the V4L2 camera (v4l → v4l2-sys-mit runs bindgen at build time)
#   socat         a second pseudo-terminal implementation the tests use
#
# Then the Python packages of the interop tests (tests/interop/requirements.txt: the
# official MCAP readers) into a venv, target/interop-venv, which the tests run.
#
# Safe to run more than once. Installs as root, or with sudo when not root; a machine that
# already has every package skips apt entirely.
set -euo pipefail

packages=(libclang-dev socat)

venv() {
  local dir=target/interop-venv
  local want=tests/interop/requirements.txt
  if [ -x "$dir/bin/python" ] && cmp -s "$want" "$dir/requirements.txt"; then
    echo "install-deps: $dir is up to date"
    return
  fi
  python3 -m venv "$dir"
  "$dir/bin/pip" install -q --disable-pip-version-check -r "$want"
  cp "$want" "$dir/requirements.txt"
  echo "install-deps: $dir made"
}

cd "$(dirname "$0")/.."
python3 -c 'import venv, ensurepip' 2>/dev/null || packages+=(python3-venv)

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all packages present (${packages[*]})"
  venv
  exit 0
fi

SUDO=""
if [ "$(id -u)" -ne 0 ]; then
  command -v sudo >/dev/null 2>&1 || { echo "install-deps: not root and no sudo: install ${missing[*]} as root, then run this again" >&2; exit 1; }
  SUDO="sudo"
fi

echo "install-deps: installing ${missing[*]}"
# A mirror warning from apt-get update must not stop the build.
$SUDO apt-get update -q || echo "install-deps: apt-get update reported a problem; trying the install anyway" >&2
DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -q --no-install-recommends "${missing[@]}"
venv
