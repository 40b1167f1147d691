#!/usr/bin/env bash
# Fuzzes what the skin reads from outside: the wire decoder (both directions), the
# calibration loader and the frame-set manifest. Installs cargo-fuzz on first use; with a
# nightly toolchain it runs under AddressSanitizer, on stable without a sanitizer.
#
#   bash scripts/fuzz.sh [DECODER_RUNS] [SECONDS_PER_OTHER_TARGET]    (default: 10000000 60)
#
# Prints one line per target; a crash stops the script with the input that caused it under
# the target's fuzz/artifacts/.
set -euo pipefail
cd "$(dirname "$0")/.."
runs=${1:-10000000}
secs=${2:-60}
command -v cargo-fuzz >/dev/null 2>&1 || cargo install cargo-fuzz --locked
if cargo +nightly --version >/dev/null 2>&1; then
  fuzz=(cargo +nightly fuzz run)
  mode="nightly, AddressSanitizer"
else
  fuzz=(cargo fuzz run -s none)
  mode="stable, no sanitizer"
fi
seed() { # corpus-dir files...
  mkdir -p "$1"; shift
  for f in "$@"; do cp -f "$f" "$1/" 2>/dev/null || true; done
}
run() { # dir target libfuzzer-args...
  local dir=$1 target=$2; shift 2
  local log
  log=$(mktemp)
  (cd "$dir" && "${fuzz[@]}" "$target" corpus/"$target" -- "$@" 2>"$log") || {
    tail -30 "$log" >&2
    echo "fuzz: $target FAILED (see $dir/artifacts/$target)" >&2
    exit 1
  }
  local done_runs
  done_runs=$(grep -Eo 'Done [0-9]+ runs' "$log" | tail -1 | grep -Eo '[0-9]+' || echo "?")
  echo "fuzz: $target: $done_runs inputs, 0 crashes ($mode)"
  rm -f "$log"
}
seed protocol/fuzz/corpus/decode protocol/tests/golden/*.bin
seed firmware/pipeline/fuzz/corpus/calibration firmware/pipeline/calibration/default.json
seed hardware/fuzz/corpus/manifest tests/fixtures/*/set.json 2>/dev/null || true
for d in tests/fixtures/*/; do cp -f "$d/set.json" "hardware/fuzz/corpus/manifest/$(basename "$d").json"; done
run protocol/fuzz decode -runs="$runs" -max_len=4096
run firmware/pipeline/fuzz calibration -max_total_time="$secs" -max_len=65536
run hardware/fuzz manifest -max_total_time="$secs" -max_len=16384
