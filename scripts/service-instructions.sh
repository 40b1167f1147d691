#!/usr/bin/env bash
# Instructions per frame of the whole service (`vistaf-skin run`), under callgrind with one
# count per thread, setup excluded: two runs on the same recorded scene that stop after
# FEW and MANY processed frames, and (count(MANY) − count(FEW)) / (frames between them).
#
#   processing thread: reference management, pipeline, temperature, summary, framing, link;
#   capture thread:    the frame source (here decoding the recorded PNGs, which a V4L2
#                      camera's driver does instead), per captured frame.
#
#   scripts/service-instructions.sh [SCENE] [FEW MANY]    (default: press-sphere 10 40)
set -euo pipefail
cd "$(dirname "$0")/.."
scene=${1:-press-sphere}; few=${2:-10}; many=${3:-40}
cargo build --release -q -p vistaf-firmware
skin=target/release/vistaf-skin
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
# Totals of each thread (01 = main/processing, 02 = capture) and the service's own counts.
measure() { # set-dir frames tag
  valgrind --tool=callgrind --separate-threads=yes --callgrind-out-file="$tmp/$3.cg" \
    "$skin" run --source "set:$1" --link "file:$tmp/$3.bin" --force-calibration \
    --frames "$2" 2>"$tmp/$3.log" >/dev/null
  local main cap processed captured
  main=$(sed -n 's/^summary: //p' "$tmp/$3.cg-01")
  cap=$(sed -n 's/^summary: //p' "$tmp/$3.cg-02")
  processed=$(sed -n 's/.* \([0-9]*\) processed.*/\1/p' "$tmp/$3.log")
  captured=$(sed -n 's/.*: \([0-9]*\) frames captured.*/\1/p' "$tmp/$3.log")
  echo "$main $cap $processed $captured"
}
printf '| camera | working size | scene | processing thread, instructions per frame | capture thread (PNG decode), per frame | summary bytes per frame |\n|---|---|---|---|---|---|\n'
for size in "640 480" "1280 960"; do
  set -- $size
  w=$1; h=$2
  $skin simulate --scene "$scene" --frames $((many + 20)) --seed 4 --out "$tmp/set" \
    --width "$w" --height "$h" --no-truth >/dev/null 2>&1
  read -r m1 c1 p1 k1 < <(measure "$tmp/set" "$few" few)
  read -r m2 c2 p2 k2 < <(measure "$tmp/set" "$many" many)
  bytes=$(stat -c %s "$tmp/many.bin")
  python3 - "$w" "$h" "$scene" "$m1" "$c1" "$p1" "$k1" "$m2" "$c2" "$p2" "$k2" "$bytes" <<'PY'
import sys
w, h, scene = sys.argv[1:4]
m1, c1, p1, k1, m2, c2, p2, k2, size = map(int, sys.argv[4:])
main = (m2 - m1) / (p2 - p1)
cap = (c2 - c1) / max(k2 - k1, 1)
print(f"| {w}×{h} | {int(w)//2}×{int(h)//2} | {scene} | {main/1e6:.1f} M | {cap/1e6:.1f} M | {size/p2:.0f} |")
PY
  rm -rf "$tmp/set"
done
