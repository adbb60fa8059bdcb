#!/usr/bin/env bash
# Scale-out proof on one machine: 3 lane-server replicas on 127.0.0.1,
# `lane-client bench` and exactly-once `lane-client stream` runs over all of
# them with round_robin, one replica stopped with SIGTERM mid-run, another
# killed with SIGKILL and restarted; checks every stream frame was answered
# exactly once, in order, and that each replica's /metrics shows its share.
# Prints a report; exit status 1 on a lost or duplicated frame (or another
# failed check), 2 on a bad command line or missing binaries.
#
# usage: deploy/local-cluster.sh [--short] [--duration S] [--streams N] [--out DIR] ...
#        (--help lists every option; the logic is deploy/local_cluster.py)
# environment: BUILD_DIR (build) holds server/lane-server, client/lane-client
#              and cli/lane; LANE_SERVER, LANE_CLIENT, LANE_CLI override one;
#              BASE_PORT=P uses ports P..P+5 instead of free ones; OUT.
#
# Traffic stays on 127.0.0.1. The full run takes about a minute, --short
# (CI, ctest deploy_local_cluster) about 25 s; both keep 2 cores busy.
set -euo pipefail
HERE=$(cd "$(dirname "$0")" && pwd)
PYTHON=/usr/bin/python3
[ -x "$PYTHON" ] || PYTHON=python3
command -v curl >/dev/null || { echo "local-cluster: curl is missing (scripts/install-deps.sh)" >&2; exit 2; }
exec "$PYTHON" "$HERE/local_cluster.py" "$@"
