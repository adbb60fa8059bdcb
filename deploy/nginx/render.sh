#!/bin/sh
# Fills deploy/nginx/lane-proxy.conf.template and runs nginx in the
# foreground: the lane-proxy image's entry point (compose.proxy.yaml,
# kubernetes.yaml). deploy/proxy_cluster.py fills the same template itself.
#
# environment:
#   LANE_PROXY_LISTEN   address:port to listen on (default 0.0.0.0:50051)
#   LANE_PROXY_SERVERS  the replicas, host:port, comma-separated (default
#                       lane-server:50051). A name that resolves to several
#                       addresses (a compose service with replicas, a
#                       Kubernetes headless Service) counts as all of them,
#                       resolved when nginx starts.
#   LANE_PROXY_PREFIX   writable folder for nginx's pid and temporary files
#                       (default /tmp/lane-proxy)
set -eu
template=${LANE_PROXY_TEMPLATE:-/etc/lane-proxy/lane-proxy.conf.template}
listen=${LANE_PROXY_LISTEN:-0.0.0.0:50051}
servers=${LANE_PROXY_SERVERS:-lane-server:50051}
prefix=${LANE_PROXY_PREFIX:-/tmp/lane-proxy}
mkdir -p "$prefix"
lines=$(echo "$servers" | tr ',' '\n' | sed '/^$/d; s/.*/    server & max_fails=1 fail_timeout=2s;/')
conf="$prefix/nginx.conf"
awk -v listen="$listen" -v prefix="$prefix" -v servers="$lines" '
  /@SERVERS@/ { print servers; next }
  { gsub(/@LISTEN@/, listen); gsub(/@PREFIX@/, prefix); print }' "$template" > "$conf"
nginx -t -q -c "$conf" -p "$prefix"
exec nginx -c "$conf" -p "$prefix" -g "daemon off;"
