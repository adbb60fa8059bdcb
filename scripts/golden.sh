#!/usr/bin/env bash
# The detector's output, without timings, on the dev clips and synthetic
# frames: what a refactor must leave byte-identical.
#   scripts/golden.sh [BUILD_DIR] [OUT_DIR]       (defaults: build, out/golden)
# Writes OUT_DIR/{c1-all,c1-2lanes,c1-tracked,d161,d161-tracked,synthetic,
# synthetic-tracked}.jsonl; the clips are skipped when ../shared/data is
# absent. Compare two runs with `diff -r`.
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD=${1:-build}
OUT=${2:-out/golden}
DATA=${LANE_DATA_DIR:-../shared/data}
LANE="$BUILD/cli/lane"
mkdir -p "$OUT"
strip() { python3 -c '
import json, sys
for line in sys.stdin:
    r = json.loads(line)
    r.pop("timing_ms", None)
    print(json.dumps(r, sort_keys=True))'; }
run() {  # name config input [flags...]
  local name=$1 config=$2 input=$3
  shift 3
  "$LANE" detect --config "$config" "$@" "$input" 2>/dev/null | strip >"$OUT/$name.jsonl"
  echo "$name: $(wc -l <"$OUT/$name.jsonl") frames"
}
synth=$(mktemp -d)
trap 'rm -rf "$synth"' EXIT
"$LANE" render --config configs/synthetic.json --count 40 --seed 7 --output "$synth" >/dev/null 2>&1
run synthetic configs/synthetic.json "$synth"
run synthetic-tracked configs/synthetic.json "$synth" --track
if [ -d "$DATA/caltech-cordova1" ]; then
  run c1-all configs/caltech.json "$DATA/caltech-cordova1"
  run c1-2lanes configs/caltech-2lanes.json "$DATA/caltech-cordova1"
  run c1-tracked configs/caltech.json "$DATA/caltech-cordova1" --track
fi
if [ -d "$DATA/culane-driver161-a" ]; then
  run d161 configs/culane-driver161.json "$DATA/culane-driver161-a"
  run d161-tracked configs/culane-driver161.json "$DATA/culane-driver161-a" --track
fi
