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

# Live: four skins on pseudo-terminals, each sending the same stream at 60 summaries per
# second, bridged for 30 s to ROS 2, MCAP and JSON lines; the bridge's CPU time over those
# 30 s, reads of the ports and DDS's own threads included.
secs=30
pids=()
for skin in 1 2 3 4; do
  socat pty,raw,echo=0,link="$out/skin$skin" pty,raw,echo=0,link="$out/host$skin" 2>/dev/null &
  pids+=($!)
done
trap 'kill "${pids[@]}" 2>/dev/null || true' EXIT
for _ in $(seq 50); do [ -e "$out/host4" ] && break; sleep 0.1; done
python3 - "$out" $((secs + 3)) <<'PY' &
import sys, time
out, secs = sys.argv[1], float(sys.argv[2])
frames = [b"\0" + f + b"\0" for f in open(f"{out}/one.bin", "rb").read().split(b"\0") if f]
ports = [open(f"{out}/skin{i}", "wb", buffering=0) for i in range(1, 5)]
t0, i = time.monotonic(), 0
while time.monotonic() - t0 < secs:
    for p in ports:
        p.write(frames[i % len(frames)])
    i += 1
    time.sleep(max(0.0, t0 + i / 60 - time.monotonic()))
PY
pacer=$!
sleep 1
/usr/bin/time -f "%U %S" -o "$out/time" target/release/vistaf-host bridge \
  "serial:$out/host1" "serial:$out/host2" "serial:$out/host3" "serial:$out/host4" \
  --no-handshake --duration-s $secs --ros2 --mcap "$out/live.mcap" --jsonl "$out/live.jsonl" \
  2>"$out/live.log"
wait $pacer || true
read -r user sys < "$out/time"
n=$(grep -c '"type":"summary"' "$out/live.jsonl" || true)
python3 -c "import sys; u,s,n,t=map(float,sys.argv[1:]); print(f'\nlive: 4 skins over pseudo-terminals, {n/t:.0f} summaries/s received in {t:.0f} s, to ROS 2, MCAP and JSON lines: {u+s:.2f} s CPU, {100*(u+s)/t:.2f} % of one core')" "$user" "$sys" "$n" "$secs"
