#!/bin/sh
# Soak test (issue 7): lane-server under `lane-client bench` at about half its
# maximum throughput for DURATION, with the server's resident memory sampled
# from /proc every RSS_EVERY seconds.
#
#   1. a closed-loop probe (PROBE long) measures the maximum throughput;
#   2. an open loop at HALF of it (percent, default 50) spread over CAMERAS
#      cameras runs for WARMUP + DURATION, with a latency timeline every
#      INTERVAL;
#   3. the report ($OUT/report.md, also printed) gives RSS after the warm-up
#      and at the end, the errors, and p50/p99 per interval.
#
# Passes (exit 0) when RSS grew less than MAX_RSS_GROWTH_PCT (5) after the
# warm-up and no frame failed, was dropped or went unsent; exit 1 otherwise.
#
# usage: scripts/soak.sh [BUILD_DIR]                       (default: build)
# environment: DURATION (10m), WARMUP (60s), INTERVAL (30s), PROBE (10s),
#              CAMERAS (8), HALF (50), RSS_EVERY (5), MAX_RSS_GROWTH_PCT (5),
#              PORT (50071), OUT (out/soak)
set -eu

BUILD=${1:-build}
CLIENT=$BUILD/client/lane-client
SERVER=$BUILD/server/lane-server
DURATION=${DURATION:-10m}
WARMUP=${WARMUP:-60s}
INTERVAL=${INTERVAL:-30s}
PROBE=${PROBE:-10s}
CAMERAS=${CAMERAS:-8}
HALF=${HALF:-50}
RSS_EVERY=${RSS_EVERY:-5}
MAX_RSS_GROWTH_PCT=${MAX_RSS_GROWTH_PCT:-5}
PORT=${PORT:-50071}
OUT=${OUT:-out/soak}
TARGET=127.0.0.1:$PORT
PY=/usr/bin/python3

for exe in "$CLIENT" "$SERVER"; do
  [ -x "$exe" ] || { echo "soak: $exe is missing; build lane-client and lane-server" >&2; exit 1; }
done
mkdir -p "$OUT"
rm -f "$OUT/rss.csv" "$OUT/probe.json" "$OUT/soak.json" "$OUT/report.md"

"$SERVER" --address="$TARGET" --metrics_address= 2>"$OUT/server.log" &
SERVER_PID=$!
SAMPLER_PID=
cleanup() {
  [ -z "$SAMPLER_PID" ] || kill "$SAMPLER_PID" 2>/dev/null || true
  kill "$SERVER_PID" 2>/dev/null || true
  wait "$SERVER_PID" 2>/dev/null || true
}
trap cleanup EXIT INT TERM
tries=0
until "$CLIENT" health --target "$TARGET" >/dev/null 2>&1; do
  tries=$((tries + 1))
  [ "$tries" -lt 100 ] || { echo "soak: the server did not start" >&2; cat "$OUT/server.log" >&2; exit 1; }
  sleep 0.1
done

echo "soak: probing the maximum throughput for $PROBE (closed loop)" >&2
"$CLIENT" bench --target "$TARGET" --cameras 2 --window 4 --warmup 2s --duration "$PROBE" \
  --json --output "$OUT/probe.json"
PER_CAMERA=$($PY -c "import json,sys; r=json.load(open(sys.argv[1]))['runs'][0]; \
print(round(r['achieved_fps'] * $HALF / 100 / $CAMERAS, 3))" "$OUT/probe.json")

# RSS samples: Unix time, resident kB.
START=$(date +%s.%N)
(
  while kill -0 "$SERVER_PID" 2>/dev/null; do
    rss=$(awk '/^VmRSS:/ {print $2}' "/proc/$SERVER_PID/status" 2>/dev/null || true)
    [ -z "$rss" ] || echo "$(date +%s.%N),$rss" >>"$OUT/rss.csv"
    sleep "$RSS_EVERY"
  done
) &
SAMPLER_PID=$!

echo "soak: $CAMERAS cameras x $PER_CAMERA fps ($HALF % of the maximum) for $WARMUP + $DURATION" >&2
status=0
"$CLIENT" bench --target "$TARGET" --cameras "$CAMERAS" --fps "$PER_CAMERA" --warmup "$WARMUP" \
  --duration "$DURATION" --timeline "$INTERVAL" --json --output "$OUT/soak.json" || status=$?
[ "$status" -eq 0 ] || { echo "soak: lane-client bench failed ($status)" >&2; exit 1; }
kill "$SAMPLER_PID" 2>/dev/null || true
wait "$SAMPLER_PID" 2>/dev/null || true
SAMPLER_PID=

$PY - "$OUT" "$MAX_RSS_GROWTH_PCT" "$HALF" "$START" <<'EOF'
import json, os, sys
out, max_growth, half, start = sys.argv[1], float(sys.argv[2]), sys.argv[3], float(sys.argv[4])
probe = json.load(open(os.path.join(out, "probe.json")))["runs"][0]
report = json.load(open(os.path.join(out, "soak.json")))
run = report["runs"][0]
warmup, duration = report["warmup_s"], report["duration_s"]
samples = []
for line in open(os.path.join(out, "rss.csv")):
    t, kb = line.strip().split(",")
    samples.append((float(t) - start, int(kb)))
after = [s for s in samples if s[0] >= warmup]
if not after:
    sys.exit("soak: no RSS sample after the warm-up")
start_t, start_kb = after[0]
end_t, end_kb = after[-1]
peak_kb = max(kb for _, kb in after)
growth = 100.0 * (end_kb - start_kb) / start_kb
errors = run["errors_total"] + run["dropped"] + run["unsent"]
lines = [
    "# Soak report",
    "",
    "maximum (closed-loop probe): %.1f frames/s; soak: %s %% of it, %d cameras x %g fps = %.1f "
    "frames/s target, %.1f achieved" % (probe["achieved_fps"], half, run["cameras"],
                                        report["fps_per_camera"], run["target_fps"],
                                        run["achieved_fps"]),
    "warm-up %g s, measured %g s; frames sent %d, ok %d" % (warmup, duration, run["frames_sent"],
                                                           run["frames_ok"]),
    "",
    "| | value | target |",
    "|---|---|---|",
    "| RSS after warm-up (t=%.0f s) | %.1f MiB | |" % (start_t, start_kb / 1024),
    "| RSS at the end (t=%.0f s) | %.1f MiB | |" % (end_t, end_kb / 1024),
    "| RSS peak after warm-up | %.1f MiB | |" % (peak_kb / 1024),
    "| RSS growth | %+.2f %% | < %g %% |" % (growth, max_growth),
    "| errors (failed + dropped + unsent) | %d %s | 0 |" % (errors, json.dumps(run["errors"])),
    "| stream failures | %d | |" % run["stream_failures"],
    "| latency p50 / p99 / max, whole run | %.2f / %.2f / %.2f ms | |" % (
        run["latency_ms"]["p50"], run["latency_ms"]["p99"], run["latency_ms"]["max"]),
    "",
    "| interval (s) | frames ok | errors | p50 ms | p99 ms | max ms | RSS MiB at end |",
    "|---|---|---|---|---|---|---|",
]
for p in run.get("timeline", []):
    end_abs = warmup + p["end_s"]
    rss = [kb for t, kb in samples if t <= end_abs]
    lines.append("| %.0f-%.0f | %d | %d | %.2f | %.2f | %.2f | %s |" % (
        p["start_s"], p["end_s"], p["frames_ok"], p["errors"], p["latency_ms"]["p50"],
        p["latency_ms"]["p99"], p["latency_ms"]["max"],
        "%.1f" % (rss[-1] / 1024) if rss else "-"))
p99s = [p["latency_ms"]["p99"] for p in run.get("timeline", []) if p["frames_ok"] > 0]
if p99s:
    lines += ["", "p99 over the intervals: min %.2f, median %.2f, max %.2f ms" % (
        min(p99s), sorted(p99s)[len(p99s) // 2], max(p99s))]
ok = growth < max_growth and errors == 0
lines += ["", "result: %s" % ("PASS" if ok else "FAIL")]
text = "\n".join(lines) + "\n"
open(os.path.join(out, "report.md"), "w").write(text)
print(text, end="")
sys.exit(0 if ok else 1)
EOF
