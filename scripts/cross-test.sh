#!/usr/bin/env bash
# The protocol, pipeline and frame-set tests for a Pi-class target, under qemu-user (the
# runner in .cargo/config.toml), in release mode: fixed-point arithmetic, endianness and
# alignment exercised on the target ISA. Long property tests run with fewer cases
# (PROPTEST_CASES), the libFuzzer-style fuzz test stays ignored, and the CLI tests (which
# spawn the binary) stay native.
#
#   scripts/cross-test.sh [aarch64-unknown-linux-gnu|armv7-unknown-linux-gnueabihf]
set -euo pipefail
cd "$(dirname "$0")/.."
target=${1:-aarch64-unknown-linux-gnu}
bash scripts/cross-setup.sh
export PROPTEST_CASES=${PROPTEST_CASES:-64}
cargo test --release --target "$target" \
  -p vistaf-protocol --lib --test golden --test corruption --test roundtrip --test sizes
cargo test --release --target "$target" \
  -p vistaf-hardware --lib
cargo test --release --target "$target" \
  -p vistaf-sim --lib --test frameset --test sources
cargo test --release --target "$target" \
  -p vistaf-pipeline --lib --test flags --test paths_agree
echo "cross-test: $target passed"
