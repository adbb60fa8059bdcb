#!/usr/bin/env bash
# The main job on an embedded default: installs dependencies, builds, renders
# synthetic road frames with known lanes, starts lane-server with its default
# session, streams the frames through it with lane-client, and writes the
# results (JSON Lines) and overlays under out/demo/. Also runs the detector
# directly (lane detect) on the same frames for comparison.
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/install-deps.sh
./scripts/build.sh -DLANE_BUILD_TESTS=OFF -DLANE_BUILD_BENCH=OFF -DLANE_BUILD_SERVICE=ON
OUT=out/demo
PORT=${LANE_DEMO_PORT:-50551}
rm -rf "$OUT" && mkdir -p "$OUT"
build/cli/lane render --config configs/synthetic.json --count 20 --seed 1 --output "$OUT/frames" --format jpg

build/server/lane-server --address="127.0.0.1:$PORT" --metrics_address= \
  --default_config=configs/synthetic.json > "$OUT/server.log" 2>&1 &
SERVER=$!
trap 'kill -TERM $SERVER 2>/dev/null || true; wait $SERVER 2>/dev/null || true' EXIT
for _ in $(seq 1 100); do
  build/client/lane-client health --target "127.0.0.1:$PORT" >/dev/null 2>&1 && break
  sleep 0.1
done
build/client/lane-client stream --target "127.0.0.1:$PORT" --camera default \
  --output "$OUT/service-results.jsonl" --overlay "$OUT/service-overlays" "$OUT/frames"
build/cli/lane detect --config configs/synthetic.json --output "$OUT/results.jsonl" \
  --overlay "$OUT/overlays" "$OUT/frames"
echo "demo: service results in $OUT/service-results.jsonl (overlays $OUT/service-overlays/)," \
     "direct results in $OUT/results.jsonl (overlays $OUT/overlays/)"
