#!/usr/bin/env bash
# Streams across replicas through a real proxy: 3 lane-server replicas behind
# Debian's nginx (deploy/nginx/lane-proxy.conf.template, consistent hashing of
# the x-camera-id header), 6 cameras streaming rendered drives with tracking;
# one replica stopped with SIGTERM, another killed with SIGKILL, a fourth
# added. Checks exactly-once answers, camera affinity, lane ids kept across
# the reconnections (resume state) and how many cameras the new replica
# takes. The logic is deploy/proxy_cluster.py (--help lists its options).
#
# usage: deploy/proxy-cluster.sh [--cameras N] [--frames N] [--out DIR] ...
# environment: BUILD_DIR (build), LANE_SERVER, LANE_CLIENT, LANE_CLI, NGINX.
# About 90 s on 2 cores; docs/deployment.md quotes a run.
set -euo pipefail
HERE=$(cd "$(dirname "$0")" && pwd)
PYTHON=/usr/bin/python3
[ -x "$PYTHON" ] || PYTHON=python3
command -v curl >/dev/null || { echo "proxy-cluster: curl is missing (scripts/install-deps.sh)" >&2; exit 2; }
exec "$PYTHON" "$HERE/proxy_cluster.py" "$@"
