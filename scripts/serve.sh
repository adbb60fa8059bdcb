#!/usr/bin/env bash
# Starts lane-server with a default session (camera id "default", the
# synthetic (Caltech) camera of configs/synthetic.json): gRPC on :50051,
# Prometheus metrics on :9464. Installs dependencies and builds first.
# Extra arguments go to lane-server (e.g. --default_config=configs/culane-driver161.json).
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/install-deps.sh
./scripts/build.sh -DLANE_BUILD_SERVICE=ON >/dev/null
exec build/server/lane-server --default_config=configs/synthetic.json "$@"
