#!/usr/bin/env bash
# Instructions per frame of the aarch64 build, counted by qemu-aarch64 with the counting
# plugin in scripts/qemu/insn_count.c (every executed guest instruction, exact for this
# kind of program), setup excluded the same way as scripts/instructions.sh:
# (count for 11 frames − count for 1 frame) / 10.
#   scripts/instructions-aarch64.sh [fixed|float] [WIDTH HEIGHT] [idle|press] [no-temperature]
set -euo pipefail
cd "$(dirname "$0")/.."
imp=${1:-fixed}; w=${2:-640}; h=${3:-480}; mode=${4:-press}; temp=${5:-}
target=aarch64-unknown-linux-gnu
bash scripts/cross-setup.sh >/dev/null
plugin=target/qemu-plugins/insn_count.so
mkdir -p "$(dirname "$plugin")"
if [ ! -f "$plugin" ] || [ scripts/qemu/insn_count.c -nt "$plugin" ]; then
  gcc -O2 -shared -fPIC -fvisibility=hidden -o "$plugin" scripts/qemu/insn_count.c
fi
cargo build --release -q --target "$target" -p vistaf-tests --bin pipeline-frames
bin=target/$target/release/pipeline-frames
count() {
  qemu-aarch64 -L /usr/aarch64-linux-gnu -plugin "$plugin" -d plugin \
    "$bin" "$imp" "$1" "$w" "$h" "$mode" $temp 2>&1 \
    | sed -n 's/^guest instructions: \([0-9]*\)$/\1/p'
}
one=$(count 1); eleven=$(count 11)
if [ -z "$one" ] || [ -z "$eleven" ]; then
  echo "instructions-aarch64: qemu printed no count (is qemu-user built with plugin support?)" >&2
  exit 1
fi
echo "aarch64 $imp ${w}x${h} $mode ${temp:-with-temperature}: $(( (eleven - one) / 10 )) instructions per frame"
