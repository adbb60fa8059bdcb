#!/usr/bin/env bash
# Back-fill throughput (issue 38): frames per second of one `lane backfill`
# shard on one core (taskset -c 0, --jobs 1: its reader and its worker share
# that core) and on every core (--jobs J, J the cores), on rendered
# drives at 640x480 (configs/synthetic.json) and 1640x590
# (configs/culane-driver161.json's camera), JPEG frames as recorded.
# Rounds alternate the two settings; the medians and their ratio are
# printed (docs/backfill.md quotes them).
#
#   bench/backfill-bench.sh [BUILD_DIR] [ROUNDS] [FRAMES]
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
rounds=${2:-5}
frames=${3:-300}
lane=$build/cli/lane
jobs=$(nproc)
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT

median() { sort -g | awk '{a[NR]=$1} END {print (NR%2 ? a[(NR+1)/2] : (a[NR/2]+a[NR/2+1])/2)}'; }

for set in synthetic:640x480 culane-driver161:1640x590; do
  config=configs/${set%%:*}.json
  size=${set##*:}
  manifest=$dir/$size.jsonl
  : >"$manifest"
  for d in 1 2 3; do
    "$lane" render --config "$config" --sequence --count $((frames / 3)) --seed "$d" --format jpg \
      --output "$dir/$size-$d" >/dev/null 2>&1
    echo "{\"recording\": \"$size-$d\", \"config\": \"$PWD/$config\", \"output\": \"$size-$d\"}" \
      >>"$manifest"
  done
  : >"$dir/one.txt"
  : >"$dir/all.txt"
  for r in $(seq 1 "$rounds"); do
    for j in 1 "$jobs"; do
      rm -rf "$dir/out"
      pin=()
      [ "$j" = 1 ] && pin=(taskset -c 0)
      "${pin[@]}" "$lane" backfill --manifest "$manifest" --output-dir "$dir/out" --jobs "$j" \
        --quiet
      fps=$(python3 -c 'import json,sys; print(json.load(open(sys.argv[1]))["frames_per_s"])' \
        "$dir/out/summary-shard-0-of-1.json")
      if [ "$j" = 1 ]; then echo "$fps" >>"$dir/one.txt"; else echo "$fps" >>"$dir/all.txt"; fi
    done
  done
  one=$(median <"$dir/one.txt")
  all=$(median <"$dir/all.txt")
  python3 - "$size" "$one" "$all" "$jobs" "$rounds" <<'PY'
import sys
size, one, many, jobs, rounds = sys.argv[1], float(sys.argv[2]), float(sys.argv[3]), int(sys.argv[4]), sys.argv[5]
print(f"backfill {size}: one core {one:.0f} frames/s; --jobs {jobs} {many:.0f} frames/s "
      f"({many / jobs:.0f} per core); ratio {many / one:.2f}x (medians of {rounds} rounds)")
PY
done
