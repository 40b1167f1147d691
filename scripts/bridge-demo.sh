#!/usr/bin/env bash
# A simulated skin streaming over a pseudo-terminal, as over USB, and the bridge reading it
# live, publishing on ROS 2 (DDS) and recording MCAP and JSON lines; a Cyclone DDS
# subscriber (a DDS we did not write, the one behind rmw_cyclonedds) says what it received,
# and the MCAP file is read back by the official Python readers (what Foxglove and ROS 2
# tools see). Needs scripts/install-deps.sh (socat, the interop venv).
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-target/bridge-demo}
seconds=${SECONDS_TO_RUN:-8}
cargo build --release -q -p vistaf-firmware
cargo build --release -q -p vistaf-host --features ros2
rm -rf "$out" && mkdir -p "$out"
socat -d -d pty,raw,echo=0,link="$out/skin" pty,raw,echo=0,link="$out/host" 2>"$out/socat.log" &
socat_pid=$!
trap 'kill $socat_pid 2>/dev/null || true' EXIT
for _ in $(seq 50); do [ -e "$out/host" ] && break; sleep 0.1; done
target/release/vistaf-skin run --source sim:demo --fps 60 --sim-frames 600 \
  --serial VSK-DEMO --link "serial:$out/skin" 2>"$out/skin.log" &
skin_pid=$!
target/interop-venv/bin/python tests/interop/dds_listen.py VSK_DEMO $((seconds + 5)) 100000 \
  > "$out/cyclone.jsonl" &
listener_pid=$!
sleep 1
target/release/vistaf-host bridge "serial:$out/host" --duration-s "$seconds" --ros2 \
  --maps depth,temperature --mcap "$out/demo.mcap" --jsonl "$out/demo.jsonl"
sleep 1
kill $listener_pid 2>/dev/null || true
python3 - "$out/cyclone.jsonl" <<'PY'
import json, sys
rows = [json.loads(l) for l in open(sys.argv[1]) if l.startswith("{")]
w = [r for r in rows if r["topic"] == "wrench"]
t = [r for r in rows if r["topic"] != "wrench"]
print(f"what a Cyclone DDS subscriber received on ROS 2: {len(w)} WrenchStamped on rt/vistaf/VSK_DEMO/wrench, {len(t)} Temperature on .../skin_temperature")
if w:
    p = min(w, key=lambda r: r["force"][2])
    print(f"  strongest: force z {p['force'][2]:.2f} N at {p['sec']}.{p['nanosec']:09d} in frame {p['frame_id']}")
PY
kill $skin_pid 2>/dev/null || true
wait $skin_pid 2>/dev/null || true
target/interop-venv/bin/python - "$out/demo.mcap" <<'PY'
import collections, sys
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
counts, peak, last = collections.Counter(), None, {}
with open(sys.argv[1], "rb") as f:
    ros = DecoderFactory()
    for schema, channel, message in make_reader(f).iter_messages():
        counts[(channel.topic, schema.name)] += 1
        if channel.message_encoding == "cdr":
            m = ros.decoder_for("cdr", schema)(message.data)
            last[channel.topic] = m
            if channel.topic.endswith("/wrench") and (peak is None or m.wrench.force.z < peak.wrench.force.z):
                peak = m
print("what a ROS 2 reader of the MCAP file sees:")
for (topic, schema), n in sorted(counts.items()):
    print(f"  {topic:42} {schema:38} {n:5} messages")
if peak is not None:
    s = peak.header.stamp
    print(f"strongest press: {-peak.wrench.force.z:.2f} N at {s.sec}.{s.nanosec:09d} (host clock) in frame {peak.header.frame_id}")
PY
echo "recording: $out/demo.mcap (open it in Foxglove with docs/foxglove-layout.json)"
