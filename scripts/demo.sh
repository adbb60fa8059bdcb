#!/usr/bin/env bash
# The main job on an embedded default: installs dependencies, builds, renders
# synthetic road frames with known lanes, detects the lanes and writes overlays
# and JSON Lines results under out/demo/.
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/install-deps.sh
./scripts/build.sh -DLANE_BUILD_TESTS=OFF -DLANE_BUILD_BENCH=OFF -DLANE_BUILD_SERVICE=ON
OUT=out/demo
rm -rf "$OUT" && mkdir -p "$OUT"
build/tools/lane render --config configs/synthetic.json --count 20 --seed 1 --out "$OUT/frames"
build/tools/lane detect --config configs/synthetic.json --output "$OUT/results.jsonl" \
  --overlay "$OUT/overlays" "$OUT/frames"
echo "demo: results in $OUT/results.jsonl, overlays in $OUT/overlays/"
