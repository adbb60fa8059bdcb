#!/usr/bin/env bash
# The live view's cost (issue 50), as ratios from one run: two lane-servers
# side by side on this machine, one worker each, one without --live_view
# (off) and one with it (on), and ONE `lane-client bench` run whose cameras
# alternate between them (--target OFF,ON: bench-0 on the first target,
# bench-1 on the second; 2 cameras, closed loop, synthetic 640x480 JPEG
# frames). Both servers see the same moment of this shared machine, so the
# ratio of their OK frames in the measured window (ok_by_target) is the
# live view's cost, free of the drift between runs (1.3-2x here from one
# minute to the next); so is the ratio of each server's CPU time over its
# frames (/proc/PID/stat, lanesvc_frames_received_total), which the
# scheduler's share between the two does not move. Three settings of the
# `on` server:
#
#   on       --live_view, nobody watching
#   viewer   one viewer asking as the camera page does (bench/live_viewer.py
#            page: data every second, pictures 5/s)
#   stalled  one viewer that reads nothing (live_viewer.py stalled: a new
#            request every second, never read, 1 KiB receive buffer; its
#            requests keep the camera watched and drawn); a /metrics scrape
#            of the `on` server is timed half-way
#
# Every setting runs in both orders (OFF,ON and ON,OFF) each round, to
# cancel what the order of the cameras does. Prints each run, then per
# setting the median ratios on/off of frames per second and of CPU per
# frame (docs/performance.md quotes them).
#
#   bench/live-view-bench.sh [BUILD_DIR] [ROUNDS] [SECONDS] [SETTINGS]
#   (defaults build 2 20 "on viewer stalled"; e.g. 1 60 stalled: a viewer
#   that reads nothing for a minute)
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
rounds=${2:-2}
seconds=${3:-20}
settings=${4:-on viewer stalled}
dir=$(mktemp -d)
pids=()
cleanup() {
  for pid in "${pids[@]}"; do kill "$pid" 2>/dev/null || true; done
  rm -rf "$dir"
}
trap cleanup EXIT

# start NAME FLAGS: a server; sets grpc_port and http_port.
start() {
  local name=$1 flags=$2
  # shellcheck disable=SC2086
  "$build/server/lane-server" --address=127.0.0.1:0 --metrics_address=127.0.0.1:0 --workers=1 \
    $flags 2>"$dir/$name.err" >/dev/null &
  pids+=($!)
  grpc_port=
  http_port=
  for _ in $(seq 1 200); do
    grpc_port=$(sed -n 's/.*gRPC on port \([0-9]*\).*/\1/p' "$dir/$name.err")
    http_port=$(sed -n 's/.*metrics on port \([0-9]*\).*/\1/p' "$dir/$name.err")
    [ -n "$grpc_port" ] && [ -n "$http_port" ] && return 0
    sleep 0.05
  done
  echo "lane-server did not start: $(cat "$dir/$name.err")" >&2
  exit 1
}

run() {  # setting round order(off-first|on-first)
  local setting=$1 round=$2 order=$3 viewer_pid="" scrape_pid="" scrape="" targets camera
  pids=()
  start off ""
  local off_target=127.0.0.1:$grpc_port off_http=$http_port
  start on "--live_view"
  local on_target=127.0.0.1:$grpc_port on_http=$http_port
  if [ "$order" = off-first ]; then
    targets=$off_target,$on_target
    camera=bench-1
  else
    targets=$on_target,$off_target
    camera=bench-0
  fi
  if [ "$setting" != on ]; then
    local mode=page
    [ "$setting" = stalled ] && mode=stalled
    /usr/bin/python3 bench/live_viewer.py "$on_http" "$camera" $((seconds + 3)) "$mode" \
      >"$dir/viewer.out" 2>&1 &
    viewer_pid=$!
  fi
  if [ "$setting" = stalled ]; then
    (sleep $((seconds / 2 + 2)); curl -s -m 10 -o /dev/null -w '%{http_code} in %{time_total} s' \
      "http://127.0.0.1:$on_http/metrics" >"$dir/scrape.txt" || echo "failed" >"$dir/scrape.txt") &
    scrape_pid=$!
  fi
  "$build/client/lane-client" bench --target "$targets" --cameras 2 --warmup 2s \
    --duration "${seconds}s" --json >"$dir/run.json" 2>/dev/null
  # Each server's CPU (user + system, clock ticks) and frames over its life.
  local cpu_off cpu_on frames_off frames_on
  cpu_off=$(awk '{print $14 + $15}' "/proc/${pids[0]}/stat")
  cpu_on=$(awk '{print $14 + $15}' "/proc/${pids[1]}/stat")
  frames_off=$(curl -s "http://127.0.0.1:$off_http/metrics" | awk '/^lanesvc_frames_received_total/ {print $2}')
  frames_on=$(curl -s "http://127.0.0.1:$on_http/metrics" | awk '/^lanesvc_frames_received_total/ {print $2}')
  [ -z "$viewer_pid" ] || wait "$viewer_pid" || true
  if [ -n "$scrape_pid" ]; then
    wait "$scrape_pid" || true
    scrape=$(cat "$dir/scrape.txt")
  fi
  for pid in "${pids[@]}"; do kill "$pid" 2>/dev/null || true; done
  for pid in "${pids[@]}"; do wait "$pid" 2>/dev/null || true; done
  pids=()
  /usr/bin/python3 - "$dir/run.json" "$setting" "$round" "$order" "$off_target" "$on_target" \
    "$dir/results.txt" "$(tr '\n' ' ' 2>/dev/null <"$dir/viewer.out")" "$scrape" \
    "$cpu_off" "$cpu_on" "$frames_off" "$frames_on" "$(getconf CLK_TCK)" <<'EOF'
import json, sys
(run_json, setting, rnd, order, off_t, on_t, out, viewer, scrape, cpu_off, cpu_on, frames_off,
 frames_on, tck) = sys.argv[1:]
run = json.load(open(run_json))["runs"][0]
ok = run["ok_by_target"]
s = run["measured_s"]
off_fps, on_fps = ok[off_t] / s, ok[on_t] / s
off_cpu = 1000.0 * float(cpu_off) / float(tck) / float(frames_off)
on_cpu = 1000.0 * float(cpu_on) / float(tck) / float(frames_on)
print("%-8s round %s %-9s: off %6.1f frames/s %.3f CPU ms/frame, on %6.1f frames/s %.3f CPU "
      "ms/frame; on/off %.3f frames/s, %.3f CPU  %s%s" % (
          setting, rnd, order, off_fps, off_cpu, on_fps, on_cpu, on_fps / off_fps,
          on_cpu / off_cpu, viewer,
          ("/metrics of `on` during the stall: " + scrape) if scrape else ""))
open(out, "a").write("%s %f %f\n" % (setting, on_fps / off_fps, on_cpu / off_cpu))
EOF
  rm -f "$dir/viewer.out"
}

for round in $(seq 1 "$rounds"); do
  for setting in $settings; do
    run "$setting" "$round" off-first
    run "$setting" "$round" on-first
  done
done
/usr/bin/python3 - "$dir/results.txt" <<'EOF'
import statistics, sys
by = {}
for line in open(sys.argv[1]):
    setting, fps, cpu = line.split()
    by.setdefault(setting, []).append((float(fps), float(cpu)))
print("\non / off, median of each setting's runs (each run both servers at once):")
for setting in [s for s in ["on", "viewer", "stalled"] if s in by]:
    fps = [f for f, _ in by[setting]]
    cpu = [c for _, c in by[setting]]
    print("  %-8s frames/s %.3f (%.3f .. %.3f), server CPU per frame %.3f (%.3f .. %.3f), %d runs"
          % (setting, statistics.median(fps), min(fps), max(fps), statistics.median(cpu),
             min(cpu), max(cpu), len(fps)))
EOF
