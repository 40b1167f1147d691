#!/usr/bin/env bash
# Instructions per frame of the aarch64 build, counted by qemu-aarch64 with the counting
# plugin in scripts/qemu/insn_count.c (every executed guest instruction, exact for this
# kind of program), setup excluded the same way as scripts/instructions.sh:
# (count for 11 frames − count for 1 frame) / 10.
#   scripts/instructions-aarch64.sh [fixed|float] [WIDTH HEIGHT] [idle|press]
#       [no-temperature|with-temperature] [chromatic]
# `chromatic`: the unit's lens puts its colours' gratings apart, so the pipeline turns each
# colour onto one grating (what that costs).
set -euo pipefail
cd "$(dirname "$0")/.."
imp=${1:-fixed}; w=${2:-640}; h=${3:-480}; mode=${4:-press}; temp=${5:-with-temperature}
lens=${6:-}
source scripts/qemu-count.sh
cargo build --release -q --target "$target" -p vistaf-tests --bin pipeline-frames
bin=target/$target/release/pipeline-frames
count() {
  qemu_count "$bin" "$imp" "$1" "$w" "$h" "$mode" "$temp" auto matched when-needed 2d $lens
}
one=$(count 1); eleven=$(count 11)
if [ -z "$one" ] || [ -z "$eleven" ]; then
  echo "instructions-aarch64: qemu printed no count (is qemu-user built with plugin support?)" >&2
  exit 1
fi
echo "aarch64 $imp ${w}x${h} $mode $temp${lens:+ $lens}: $(( (eleven - one) / 10 )) instructions per frame"
