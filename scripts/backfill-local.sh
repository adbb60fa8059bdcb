#!/usr/bin/env bash
# A back-fill on one machine: SHARDS processes of `lane backfill`, shard
# 0/N .. N-1/N of MANIFEST, each with its share of the cores (--jobs), the
# same thing a Kubernetes Indexed Job runs on N pods (deploy/k8s/backfill,
# docs/backfill.md). Re-running it resumes: finished recordings are skipped.
#
#   scripts/backfill-local.sh MANIFEST OUTPUT_DIR [SHARDS] [LANE]
#
# SHARDS defaults to the number of cores; LANE to build/cli/lane. Exit 0
# when every shard succeeded, 1 when one reported a failed recording or
# frame (see OUTPUT_DIR/summary-shard-*.json), 2 for a usage error.
set -euo pipefail
if [ $# -lt 2 ] || [ $# -gt 4 ]; then
  sed -n '2,12p' "$0" >&2
  exit 2
fi
manifest=$1
out=$2
cores=$(nproc)
shards=${3:-$cores}
lane=${4:-$(dirname "$0")/../build/cli/lane}
[ -x "$lane" ] || { echo "backfill-local: $lane is not built (scripts/build.sh)" >&2; exit 2; }
jobs=$(( cores / shards ))
[ "$jobs" -ge 1 ] || jobs=1
pids=()
for ((i = 0; i < shards; i++)); do
  "$lane" backfill --manifest "$manifest" --output-dir "$out" --shard "$i/$shards" \
    --jobs "$jobs" --quiet &
  pids+=($!)
done
status=0
for pid in "${pids[@]}"; do
  wait "$pid" || status=$(( $? > status ? $? : status ))
done
for ((i = 0; i < shards; i++)); do
  summary=$out/summary-shard-$i-of-$shards.json
  if [ -f "$summary" ]; then
    python3 - "$summary" <<'PY' || true
import json, sys
s = json.load(open(sys.argv[1]))
print(f"backfill-local: shard {s['shard']}/{s['shards']}: {s['done']} done, "
      f"{s.get('redone', 0)} redone, {s['skipped']} skipped, "
      f"{s['failed']} failed; {s['frames']} frames ({s['failed_frames']} failed), "
      f"{s['frames_per_s']:.1f} frames/s")
PY
  fi
done
exit "$status"
