#!/usr/bin/env bash
# Regenerates firmware/pipeline/calibration/default.json: the calibration kit (depth, force and
# temperature sets) of the simulated reference unit (unit seed 0), calibrated with the
# device pipeline.
set -euo pipefail
cd "$(dirname "$0")/.."
kit=$(mktemp -d)
trap 'rm -rf "$kit"' EXIT
cargo build --release -q -p vistaf-firmware
./target/release/vistaf-skin simulate --calibration-kit --unit-seed 0 --seed 1 --out "$kit"
./target/release/vistaf-skin calibrate --set "$kit/depth" --set "$kit/force" --set "$kit/temperature" --out firmware/pipeline/calibration/default.json
# The sets lived in a temporary directory: record them by what made them, not where.
python3 - <<'PY'
import json
p = "firmware/pipeline/calibration/default.json"
c = json.load(open(p))
for s in c["sets"]:
    s["path"] = "simulate --calibration-kit --unit-seed 0 --seed 1: " + s["path"].rsplit("/", 1)[-1]
open(p, "w").write(json.dumps(c, indent=2, ensure_ascii=False) + "\n")
PY
cargo build --release -q -p vistaf-firmware
echo "firmware/pipeline/calibration/default.json regenerated"
