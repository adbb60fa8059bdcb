#!/bin/sh
# The service's performance targets on this machine, client and server on the
# same cores (docs/client.md, "Measured"):
#   1. service throughput vs the in-process decode + detect (target >= 80 %),
#   2. open-loop p99 latency at half the maximum throughput (target <= 10 ms),
#   3. raw vs JPEG throughput (target >= 1.5x),
#   4. 1640x590 JPEG (configs/culane-driver161.json; the clip's own frames
#      when ../shared/data/culane-driver161-a is there, else frames rendered
#      by its camera): the default fast decode (only the rows the detector
#      reads) and --full-decode side by side, each against its in-process
#      reference (issue 14).
#
# usage: scripts/bench-client.sh [BUILD_DIR]        (default: build)
# environment: PORT (50051), WARMUP (2s), DURATION (10s), CAMERAS (2),
#              INFLIGHT (4), OPEN_CAMERAS (8), OUT (out/bench-client)
set -eu

BUILD=${1:-build}
CLIENT=$BUILD/client/lane-client
SERVER=$BUILD/server/lane-server
PORT=${PORT:-50051}
WARMUP=${WARMUP:-2s}
DURATION=${DURATION:-10s}
CAMERAS=${CAMERAS:-2}
INFLIGHT=${INFLIGHT:-4}
OPEN_CAMERAS=${OPEN_CAMERAS:-8}
OUT=${OUT:-out/bench-client}
TARGET=127.0.0.1:$PORT

for exe in "$CLIENT" "$SERVER"; do
  [ -x "$exe" ] || { echo "bench-client: $exe is missing; build lane-client and lane-server" >&2; exit 1; }
done
mkdir -p "$OUT"

# One worker per core (the default), no metrics endpoint.
"$SERVER" --address="$TARGET" --metrics_address= 2>"$OUT/server.log" &
SERVER_PID=$!
trap 'kill "$SERVER_PID" 2>/dev/null; wait "$SERVER_PID" 2>/dev/null || true' EXIT INT TERM
tries=0
until "$CLIENT" health --target "$TARGET" >/dev/null 2>&1; do
  tries=$((tries + 1))
  [ "$tries" -lt 100 ] || { echo "bench-client: the server did not start" >&2; cat "$OUT/server.log" >&2; exit 1; }
  sleep 0.1
done

field() {  # field FILE PYTHON-EXPRESSION-ON-r  (r = the report)
  /usr/bin/python3 -c "import json,sys; r=json.load(open(sys.argv[1])); print($2)" "$1"
}

run() {  # run NAME ARGS...: one bench, JSON report in $OUT/NAME.json
  name=$1
  shift
  echo "+ lane-client bench --target $TARGET $* --warmup $WARMUP --duration $DURATION" >&2
  status=0
  "$CLIENT" bench --target "$TARGET" "$@" --warmup "$WARMUP" --duration "$DURATION" \
    --json --output "$OUT/$name.json" || status=$?
  [ "$status" -eq 0 ] || [ "$status" -eq 3 ] || exit "$status"
}

# 1 and 3: maximum throughput (closed loop), JPEG with the in-process
# reference, then raw.
run jpeg-closed --cameras "$CAMERAS" --window "$INFLIGHT" --inprocess
run raw-closed --cameras "$CAMERAS" --window "$INFLIGHT" --raw --inprocess
# 2: open loop at half the maximum JPEG throughput, spread over OPEN_CAMERAS.
MAX=$(field "$OUT/jpeg-closed.json" "r['runs'][0]['achieved_fps']")
PER_CAMERA=$(/usr/bin/python3 -c "print(round($MAX / 2 / $OPEN_CAMERAS, 2))")
run jpeg-open-half --cameras "$OPEN_CAMERAS" --fps "$PER_CAMERA" --slo-p99-ms 10

# 4: 1640x590 JPEG, fast and full decode.
CULANE_DATA=${LANE_DATA_DIR:-$(dirname "$0")/../../shared/data}/culane-driver161-a
set --
[ -d "$CULANE_DATA" ] && set -- "$CULANE_DATA"
run culane-fast --cameras "$CAMERAS" --window "$INFLIGHT" --inprocess \
  --config "$(dirname "$0")/../configs/culane-driver161.json" "$@"
run culane-full --cameras "$CAMERAS" --window "$INFLIGHT" --inprocess --full-decode \
  --config "$(dirname "$0")/../configs/culane-driver161.json" "$@"

/usr/bin/python3 - "$OUT" <<'EOF'
import json, os, sys
out = sys.argv[1]
load = lambda name: json.load(open(os.path.join(out, name + ".json")))
jpeg, raw, half = load("jpeg-closed"), load("raw-closed"), load("jpeg-open-half")
j, r, h = jpeg["runs"][0], raw["runs"][0], half["runs"][0]
print("1. service vs in-process (JPEG): %.1f / %.1f frames/s = %.1f %%  (target >= 80 %%)"
      % (j["achieved_fps"], jpeg["inprocess"]["fps"], 100 * j["service_vs_inprocess"]))
print("   raw: %.1f / %.1f frames/s = %.1f %%"
      % (r["achieved_fps"], raw["inprocess"]["fps"], 100 * r["service_vs_inprocess"]))
print("2. open loop at %.1f frames/s (%d cameras x %g fps; achieved %.1f): p50 %.2f p99 %.2f "
      "p99.9 %.2f max %.2f ms  (target p99 <= 10 ms)"
      % (h["target_fps"], h["cameras"], half["fps_per_camera"], h["achieved_fps"],
         h["latency_ms"]["p50"], h["latency_ms"]["p99"], h["latency_ms"]["p999"],
         h["latency_ms"]["max"]))
print("3. raw / JPEG: %.1f / %.1f frames/s = %.2fx  (target >= 1.5x)"
      % (r["achieved_fps"], j["achieved_fps"], r["achieved_fps"] / j["achieved_fps"]))
fast, full = load("culane-fast"), load("culane-full")
f, g = fast["runs"][0], full["runs"][0]
print("4. 1640x590 JPEG, fast decode: %.1f / %.1f frames/s in-process = %.1f %%; "
      "full decode: %.1f / %.1f = %.1f %%; fast / full service: %.2fx"
      % (f["achieved_fps"], fast["inprocess"]["fps"], 100 * f["service_vs_inprocess"],
         g["achieved_fps"], full["inprocess"]["fps"], 100 * g["service_vs_inprocess"],
         f["achieved_fps"] / g["achieved_fps"]))
for name, run in (("jpeg-closed", j), ("raw-closed", r), ("jpeg-open-half", h),
                  ("culane-fast", f), ("culane-full", g)):
    print("   %-15s sent %d ok %d errors %d dropped %d unsent %d"
          % (name, run["frames_sent"], run["frames_ok"], run["errors_total"], run["dropped"],
             run["unsent"]))
EOF
