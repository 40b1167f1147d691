#!/usr/bin/env bash
# Throughput of the whole service (capture thread decoding recorded PNG frames, pipeline,
# framing, link) at two camera sizes, as fast as it goes: frames per second processed,
# the pipeline's latency per frame (from the summaries), and the serial bytes per second
# the summaries need at 30 frames/s.
#   scripts/throughput.sh
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release -q -p vistaf-firmware -p vistaf-host
skin=target/release/vistaf-skin
host=target/release/vistaf-host
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
printf '| camera | working size | frames/s processed | pipeline latency p50 / p95 (ms) | summary bytes per frame | serial bytes/s at 30 frames/s |\n|---|---|---|---|---|---|\n'
for size in "640 480" "1280 960"; do
  set -- $size
  w=$1; h=$2
  $skin simulate --scene press-sphere --frames 60 --seed 4 --out "$tmp/set-$w" --width "$w" --height "$h" --no-truth >/dev/null 2>&1
  start=$(date +%s.%N)
  $skin run --source "set:$tmp/set-$w" --link "file:$tmp/out-$w.bin" --force-calibration 2>"$tmp/log-$w" >/dev/null
  end=$(date +%s.%N)
  processed=$(sed -n 's/.* \([0-9]*\) processed.*/\1/p' "$tmp/log-$w")
  $host decode "$tmp/out-$w.bin" 2>/dev/null > "$tmp/dec-$w.jsonl"
  python3 - "$tmp/dec-$w.jsonl" "$tmp/out-$w.bin" "$processed" "$start" "$end" "$w" "$h" <<'PY'
import json, os, sys
dec, binf, processed, start, end, w, h = sys.argv[1:]
lat = sorted(json.loads(l)["latency_us"] / 1000 for l in open(dec) if '"type":"summary"' in l)
n = len(lat)
size = os.path.getsize(binf)
per = size / max(n, 1)
fps = int(processed) / (float(end) - float(start))
p = lambda q: lat[min(n - 1, int(q * n))] if n else float("nan")
print(f"| {w}×{h} | {int(w)//2}×{int(h)//2} | {fps:.0f} | {p(0.5):.1f} / {p(0.95):.1f} | {per:.0f} (all messages) | {per*30:.0f} |")
PY
done
