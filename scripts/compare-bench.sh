#!/usr/bin/env bash
# Compares two detector_bench binaries on the same benchmarks, interleaved so
# that both see the same machine load, and prints each one's median of the
# per-run medians and the ratio new/old (the figure to quote on a shared,
# noisy machine):
#   scripts/compare-bench.sh OLD_BENCH NEW_BENCH [FILTER] [ROUNDS]
# FILTER defaults to BM_DetectClip (the real clips on the shipped configs).
set -euo pipefail
OLD=$1 NEW=$2 FILTER=${3:-BM_DetectClip} ROUNDS=${4:-5}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
for r in $(seq "$ROUNDS"); do
  for which in old new; do
    bin=$OLD; [ "$which" = new ] && bin=$NEW
    "$bin" --benchmark_filter="$FILTER" --benchmark_repetitions=3 \
      --benchmark_report_aggregates_only=true --benchmark_format=json \
      >"$tmp/$which.$r.json" 2>/dev/null
  done
done
python3 - "$tmp" "$ROUNDS" <<'PY'
import json, statistics, sys, collections
tmp, rounds = sys.argv[1], int(sys.argv[2])
res = {"old": collections.defaultdict(list), "new": collections.defaultdict(list)}
for which in res:
    for r in range(1, rounds + 1):
        for b in json.load(open(f"{tmp}/{which}.{r}.json"))["benchmarks"]:
            if b.get("aggregate_name") == "median":
                res[which][b["run_name"]].append(b["real_time"])
print(f"{'benchmark':32} {'old us':>10} {'new us':>10} {'new/old':>8}")
for name in res["old"]:
    o, n = statistics.median(res["old"][name]), statistics.median(res["new"].get(name, [float('nan')]))
    print(f"{name:32} {o:10.1f} {n:10.1f} {n / o:8.3f}")
PY
