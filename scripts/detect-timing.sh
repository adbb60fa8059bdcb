#!/usr/bin/env bash
# Median detection time (timing_ms.total of lane detect, decoding excluded)
# on the two real clips, 3 passes each, the median over all frames of all
# passes.   scripts/detect-timing.sh [BUILD_DIR]
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD=${1:-build}
DATA=${LANE_DATA_DIR:-../shared/data}
CALTECH=${CALTECH:-configs/caltech.json}
CULANE=${CULANE:-configs/culane-driver161.json}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
median() {  # config dataset
  for pass in 1 2 3; do
    "$BUILD/cli/lane" detect --config "$1" --output "$tmp/r$pass.jsonl" "$DATA/$2" 2>/dev/null
  done
  cat "$tmp"/r*.jsonl | python3 -c '
import json, statistics, sys
t = [json.loads(l)["timing_ms"]["total"] for l in sys.stdin if "timing_ms" in l]
print("%.3f ms median over %d detections" % (statistics.median(t), len(t)))'
  rm -f "$tmp"/r*.jsonl
}
echo "cordova1 640x480:    $(median "$CALTECH" caltech-cordova1)"
echo "driver161 1640x590:  $(median "$CULANE" culane-driver161-a)"
