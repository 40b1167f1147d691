#!/usr/bin/env bash
# Instructions per frame of the pipeline under callgrind, setup excluded:
# (Ir of 11 frames − Ir of 1 frame) / 10. Repeatable on a noisy machine.
# Usage: scripts/instructions.sh [fixed|float] [WIDTH HEIGHT] [idle|press] [no-temperature]
set -euo pipefail
cd "$(dirname "$0")/.."
imp=${1:-fixed}; w=${2:-640}; h=${3:-480}; mode=${4:-press}; temp=${5:-}
cargo build --release -q -p vistaf-tests --bin pipeline-frames
bin=target/release/pipeline-frames
ir() {
  valgrind --tool=callgrind --callgrind-out-file=/dev/null "$bin" "$imp" "$1" "$w" "$h" "$mode" $temp 2>&1 \
    | sed -n 's/.*Collected : \([0-9]*\).*/\1/p'
}
one=$(ir 1); eleven=$(ir 11)
echo "$imp ${w}x${h} $mode ${temp:-with-temperature}: $(( (eleven - one) / 10 )) instructions per frame"
