#!/usr/bin/env bash
# The test command of a fresh machine: installs what the tests need (Debian packages, as
# root or with sudo, whichever the machine has; see scripts/install-deps.sh), then runs
# every test of the workspace. Extra arguments go to `cargo test`.
#
#   bash scripts/test.sh
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
cargo test --workspace "$@"
