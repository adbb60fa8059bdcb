#!/usr/bin/env bash
# The accuracy figures of the README and docs/accuracy-log.md: lane eval over
# 5 RANSAC seeds on the two real clips in ../shared/data, all-lanes (both
# clips) and 2-lanes (cordova1). One summary line per run; the full tables go
# to out/accuracy/<run>/table.md.
#
#   scripts/accuracy.sh [BUILD_DIR]
#   CALTECH=configs/caltech.json CULANE=configs/culane-driver161.json \
#   CALTECH2=configs/caltech-2lanes.json SEEDS=5 scripts/accuracy.sh
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD=${1:-build}
LANE=$BUILD/cli/lane
DATA=${LANE_DATA_DIR:-../shared/data}
SEEDS=${SEEDS:-5}
CALTECH=${CALTECH:-configs/caltech.json}
CULANE=${CULANE:-configs/culane-driver161.json}
CALTECH2=${CALTECH2:-configs/caltech-2lanes.json}
OUT=${OUT:-out/accuracy}

run() {  # name dataset config mode
  local name=$1 dataset=$2 config=$3 mode=$4
  if [[ ! -d $DATA/$dataset ]]; then
    echo "$name: $DATA/$dataset not found, skipped"
    return
  fi
  mkdir -p "$OUT/$name"
  "$LANE" eval "$DATA/$dataset" --config "$config" --mode "$mode" --seeds "$SEEDS" \
    --output "$OUT/$name" --no-progress >/dev/null 2>"$OUT/$name/stderr.txt"
  printf '%-16s %s\n' "$name" "$(grep 'over .* seeds' "$OUT/$name/stderr.txt" | sed 's/^lane eval: //')"
}

run cordova1-all caltech-cordova1 "$CALTECH" all
run d161-all culane-driver161-a "$CULANE" all
run cordova1-two caltech-cordova1 "$CALTECH2" two
