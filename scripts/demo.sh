#!/usr/bin/env bash
# The main job on the simulated skin, end to end and blind: render a unit's calibration
# kit, calibrate it, render a scene with other noise, and measure it against its labels.
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-target/demo}
unit=${UNIT_SEED:-0}
cargo build --release -q -p vistaf-firmware
skin=target/release/vistaf-skin
rm -rf "$out" && mkdir -p "$out"
echo "== simulated unit $unit: calibration kit"
$skin simulate --calibration-kit --unit-seed "$unit" --seed 1 --no-truth --out "$out/kit"
echo "== calibrating"
$skin calibrate --set "$out/kit/depth" --set "$out/kit/force" --out "$out/calibration.json"
echo "== a press of the 10 mm sphere, new noise, measured blind"
$skin simulate --scene sweep-depth --frames 7 --unit-seed "$unit" --seed 99 --out "$out/press"
$skin analyze --set "$out/press" --calibration "$out/calibration.json" --out "$out/analysis" > "$out/press.jsonl"
python3 - "$out" <<'PY'
import json, sys
out = sys.argv[1]
frames = json.load(open(f"{out}/press/set.json"))["frames"]
print(f"{'truth mm':>9} {'measured mm':>12} {'truth N':>8} {'measured N':>11}  flags")
for f, line in zip(frames, open(f"{out}/press.jsonl")):
    r = json.loads(line)
    print(f"{f['depth_mm']:9.3f} {r['depth_mm']:12.3f} {f['force_n']:8.2f} {r['force_n']:11.2f}  {','.join(r['flags']) or 'ok'}")
PY
echo "depth maps and summary: $out/analysis"
