#!/usr/bin/env bash
# The live view's cost (issue 50): `lane-client bench` (2 cameras, closed
# loop, synthetic 640x480 JPEG frames) against a real lane-server with one
# worker on this machine, in four settings, interleaved round by round:
#
#   off      lane-server without --live_view
#   on       --live_view, nobody watching
#   viewer   --live_view, one viewer asking as the camera page does
#            (bench/live_viewer.py page: data every second, pictures 5/s)
#   stalled  --live_view, one viewer that reads nothing (live_viewer.py
#            stalled: a new request every second, never read, 1 KiB
#            receive buffer; its requests keep bench-0 watched and drawn)
#
# Prints each run, then the medians, and each setting's median frames per
# second over off's (docs/performance.md quotes them). During the stalled
# runs it also times a /metrics scrape.
#
#   bench/live-view-bench.sh [BUILD_DIR] [ROUNDS] [SECONDS]   (defaults build 3 20)
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
rounds=${2:-3}
seconds=${3:-20}
dir=$(mktemp -d)
server_pid=
viewer_pid=
cleanup() {
  [ -z "$viewer_pid" ] || kill "$viewer_pid" 2>/dev/null || true
  [ -z "$server_pid" ] || kill "$server_pid" 2>/dev/null || true
  rm -rf "$dir"
}
trap cleanup EXIT

run() {  # name round server-flags viewer-mode
  local name=$1 round=$2 flags=$3 viewer=$4 grpc="" http="" scrape="" scrape_pid=""
  # shellcheck disable=SC2086
  "$build/server/lane-server" --address=127.0.0.1:0 --metrics_address=127.0.0.1:0 --workers=1 \
    $flags 2>"$dir/server.err" >/dev/null &
  server_pid=$!
  for _ in $(seq 1 200); do
    grpc=$(sed -n 's/.*gRPC on port \([0-9]*\).*/\1/p' "$dir/server.err")
    http=$(sed -n 's/.*metrics on port \([0-9]*\).*/\1/p' "$dir/server.err")
    [ -n "$grpc" ] && [ -n "$http" ] && break
    sleep 0.05
  done
  if [ "$viewer" != none ]; then
    /usr/bin/python3 bench/live_viewer.py "$http" bench-0 $((seconds + 3)) "$viewer" \
      >"$dir/viewer.out" 2>&1 &
    viewer_pid=$!
  fi
  if [ "$viewer" = stalled ]; then
    (sleep $((seconds / 2 + 2)); curl -s -m 10 -o /dev/null -w '%{http_code} %{time_total}' \
      "http://127.0.0.1:$http/metrics" >"$dir/scrape.txt" || echo "failed" >"$dir/scrape.txt") &
    scrape_pid=$!
  fi
  "$build/client/lane-client" bench --target "127.0.0.1:$grpc" --cameras 2 --warmup 2s \
    --duration "${seconds}s" --json >"$dir/run.json" 2>/dev/null
  if [ -n "$viewer_pid" ]; then
    wait "$viewer_pid" || true
    viewer_pid=
  fi
  if [ -n "$scrape_pid" ]; then
    wait "$scrape_pid" || true
    scrape=$(cat "$dir/scrape.txt")
  fi
  kill "$server_pid" 2>/dev/null || true
  wait "$server_pid" 2>/dev/null || true
  server_pid=
  /usr/bin/python3 - "$dir/run.json" "$name" "$round" "$dir/results.txt" \
    "$(cat "$dir/viewer.out" 2>/dev/null | tr '\n' ' ')" "$scrape" <<'EOF'
import json, sys
run = json.load(open(sys.argv[1]))["runs"][0]
line = "%s %s %.1f %.2f %.3f" % (sys.argv[2], sys.argv[3], run["achieved_fps"],
                                 run["latency_ms"]["p99"], run.get("server_cpu_ms_per_frame") or 0)
print("%-8s round %s: %7.1f frames/s, p99 %6.2f ms, server CPU %.3f ms/frame  %s%s" % (
    sys.argv[2], sys.argv[3], run["achieved_fps"], run["latency_ms"]["p99"],
    run.get("server_cpu_ms_per_frame") or 0, sys.argv[5],
    ("/metrics during the stall: " + sys.argv[6]) if sys.argv[6] else ""))
open(sys.argv[4], "a").write(line + "\n")
EOF
  rm -f "$dir/viewer.out"
}

for round in $(seq 1 "$rounds"); do
  run off "$round" "" none
  run on "$round" "--live_view" none
  run viewer "$round" "--live_view" page
  run stalled "$round" "--live_view" stalled
done
/usr/bin/python3 - "$dir/results.txt" <<'EOF'
import statistics, sys
rows = [l.split() for l in open(sys.argv[1])]
by = {}
for name, _, fps, p99, cpu in rows:
    by.setdefault(name, []).append((float(fps), float(p99), float(cpu)))
off = statistics.median(f for f, _, _ in by["off"])
print("\nmedians over %d rounds:" % len(by["off"]))
for name in ["off", "on", "viewer", "stalled"]:
    runs = by[name]
    fps = statistics.median(f for f, _, _ in runs)
    print("  %-8s %7.1f frames/s (%.3f of off), p99 %6.2f ms, server CPU %.3f ms/frame" % (
        name, fps, fps / off, statistics.median(p for _, p, _ in runs),
        statistics.median(c for _, _, c in runs)))
EOF
