#!/bin/sh
# Entry point of the lane-server image (deploy/Dockerfile).
#
# Builds lane-server's flags from the environment, then appends the
# container's arguments, so that `docker run IMAGE --max_sessions=128` adds a
# flag and an argument given twice wins over the environment (abseil flags:
# the last occurrence counts). A first argument that does not start with "-"
# is run as a command instead (`docker run IMAGE lane-client info --target
# host:50051`).
#
#   LANE_GRPC_PORT          gRPC port (lane service, health, reflection)  50051
#   LANE_METRICS_PORT       Prometheus /metrics port; empty = no endpoint  9464
#   LANE_DEFAULT_CONFIG     config of the default session; empty = none    /etc/lane/default.json
#   LANE_DEFAULT_CAMERA_ID  camera id of that session                      default
#   LANE_WORKERS            worker threads; 0 = one per core the process   0
#                           may run on (see below)
#   LANE_SHUTDOWN_DEADLINE  drain deadline after SIGTERM                   10s
#
# lane-server itself reads LANE_AUTH_TOKENS (Bearer tokens) and
# LANE_RESUME_STATE_KEYS (the replicas' shared resume-state key, hex;
# "NEW,OLD" while rotating) from the environment; neither is a flag, so
# neither shows in ps.
#
# lane-server's "one per core" is std::thread::hardware_concurrency(), the
# CPUs of the affinity mask. A CPU quota (docker --cpus, a Kubernetes CPU
# limit) does not change it, so with a quota set LANE_WORKERS to it.
set -eu

if [ "$#" -gt 0 ] && [ "${1#-}" = "$1" ]; then
  exec "$@"
fi

set -- \
  "--address=0.0.0.0:${LANE_GRPC_PORT:-50051}" \
  "--workers=${LANE_WORKERS:-0}" \
  "--shutdown_deadline=${LANE_SHUTDOWN_DEADLINE:-10s}" \
  "--default_camera_id=${LANE_DEFAULT_CAMERA_ID:-default}" \
  "$@"
if [ -n "${LANE_METRICS_PORT-9464}" ]; then
  set -- "--metrics_address=0.0.0.0:${LANE_METRICS_PORT-9464}" "$@"
else
  set -- "--metrics_address=" "$@"
fi
if [ -n "${LANE_DEFAULT_CONFIG-/etc/lane/default.json}" ]; then
  set -- "--default_config=${LANE_DEFAULT_CONFIG-/etc/lane/default.json}" "$@"
fi
exec /usr/local/bin/lane-server "$@"
