#!/usr/bin/env bash
# CPU cost of the bridge: four skins' captures of a minute at 60 summaries per second each
# (the simulated demo's stream, repeated), bridged to MCAP and to JSON lines as fast as they
# can be read. The CPU time over the minute they cover is the share of one core a live
# bridge needs (reading the ports adds a read per burst of bytes, not counted here).
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-target/bridge-cost}
cargo build --release -q -p vistaf-firmware
cargo build --release -q -p vistaf-host --features ros2
rm -rf "$out" && mkdir -p "$out"
target/release/vistaf-skin run --source sim:demo --sim-frames 120 --frames 120 \
  --link "file:$out/one.bin" 2>/dev/null
links=()
for skin in 1 2 3 4; do
  for _ in $(seq 30); do cat "$out/one.bin"; done > "$out/skin$skin.bin"
  links+=("file:$out/skin$skin.bin")
done
measure() {
  local what=$1; shift
  /usr/bin/time -f "%U %S" -o "$out/time" target/release/vistaf-host bridge "${links[@]}" "$@" 2>/dev/null
  read -r user sys < "$out/time"
  python3 -c "import sys; u,s=float(sys.argv[2]),float(sys.argv[3]); print(f'| {sys.argv[1]} | {u+s:.2f} s | {100*(u+s)/60:.2f} % |')" "$what" "$user" "$sys"
}
echo "| 4 skins × 60 Hz × 60 s (14 400 summaries) to | CPU time | share of one core |"
echo "|---|---|---|"
measure "MCAP" --mcap "$out/run.mcap"
measure "JSON lines" --jsonl "$out/run.jsonl"
measure "MCAP and JSON lines" --mcap "$out/run.mcap" --jsonl "$out/run.jsonl"
measure "ROS 2 (DDS, no subscriber)" --ros2
measure "ROS 2, MCAP and JSON lines" --ros2 --mcap "$out/run.mcap" --jsonl "$out/run.jsonl"
