#!/usr/bin/env bash
# Median detection time of two lane binaries on the same frames, runs
# interleaved so both see the same machine load:
#   scripts/compare-timing.sh OLD_LANE OLD_CALTECH_CFG OLD_CULANE_CFG NEW_LANE [PASSES]
# (the new binary uses configs/caltech.json and configs/culane-driver161.json).
set -euo pipefail
cd "$(dirname "$0")/.."
OLD=$1 OLD_C=$2 OLD_D=$3 NEW=$4 PASSES=${5:-5}
DATA=${LANE_DATA_DIR:-../shared/data}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
for pass in $(seq "$PASSES"); do
  "$OLD" detect --config "$OLD_C" --output "$tmp/old_c$pass.jsonl" "$DATA/caltech-cordova1" 2>/dev/null
  "$NEW" detect --config configs/caltech.json --output "$tmp/new_c$pass.jsonl" "$DATA/caltech-cordova1" 2>/dev/null
  "$OLD" detect --config "$OLD_D" --output "$tmp/old_d$pass.jsonl" "$DATA/culane-driver161-a" 2>/dev/null
  "$NEW" detect --config configs/culane-driver161.json --output "$tmp/new_d$pass.jsonl" "$DATA/culane-driver161-a" 2>/dev/null
done
for k in old_c new_c old_d new_d; do
  cat "$tmp"/$k*.jsonl | python3 -c '
import json, statistics, sys
t = [json.loads(l)["timing_ms"]["total"] for l in sys.stdin if "timing_ms" in l]
print("'$k'", "%.3f ms median over %d detections" % (statistics.median(t), len(t)))'
done
