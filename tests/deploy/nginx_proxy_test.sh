#!/usr/bin/env bash
# deploy_nginx_proxy: deploy/nginx's configuration through Debian's nginx in
# front of two real lane-server replicas on loopback. render.sh fills the
# template and nginx accepts it; every camera's session calls, made through
# the proxy, reach one replica (each camera's session exists on exactly one
# of them, and asking again through the proxy finds it UNCHANGED); both
# replicas get cameras. deploy/proxy-cluster.sh is the full test (streams,
# faults, a new replica); this is its CI-sized part.
# usage: nginx_proxy_test.sh LANE_SERVER LANE_CLIENT SOURCE_DIR
set -euo pipefail
server=$1 client=$2 src=$3
nginx=${NGINX:-/usr/sbin/nginx}
[ -x "$nginx" ] || { echo "nginx is missing (scripts/install-deps.sh): skipped"; exit 77; }
work=$(mktemp -d)
pids=()
cleanup() { for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done; wait 2>/dev/null || true; rm -rf "$work"; }
trap cleanup EXIT
port() { python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1])'; }
a=$(port) b=$(port) p=$(port)
"$server" --address=127.0.0.1:$a --metrics_address= --workers=1 >"$work/a.log" 2>&1 & pids+=($!)
"$server" --address=127.0.0.1:$b --metrics_address= --workers=1 >"$work/b.log" 2>&1 & pids+=($!)
LANE_PROXY_TEMPLATE=$src/deploy/nginx/lane-proxy.conf.template LANE_PROXY_LISTEN=127.0.0.1:$p \
  LANE_PROXY_SERVERS=127.0.0.1:$a,127.0.0.1:$b LANE_PROXY_PREFIX=$work/nginx NGINX=$nginx \
  PATH=$(dirname "$nginx"):$PATH "$src/deploy/nginx/render.sh" >"$work/nginx.log" 2>&1 & pids+=($!)
for t in 127.0.0.1:$a 127.0.0.1:$b 127.0.0.1:$p; do
  for _ in $(seq 50); do "$client" health --target "$t" --timeout 1s >/dev/null 2>&1 && break; sleep 0.2; done
  "$client" health --target "$t" --timeout 2s >/dev/null || { echo "FAIL: $t not serving"; cat "$work"/*.log; exit 1; }
done
config=$src/configs/synthetic.json
for i in $(seq 1 20); do
  "$client" session create --target 127.0.0.1:$p --camera "cam-$i" --config "$config" >/dev/null
done
"$client" session list --target 127.0.0.1:$a >"$work/a.json"
"$client" session list --target 127.0.0.1:$b >"$work/b.json"
on_a=0 on_b=0
for i in $(seq 1 20); do
  ina=$(grep -c "\"cam-$i\"" "$work/a.json" || true) inb=$(grep -c "\"cam-$i\"" "$work/b.json" || true)
  if [ "$((ina + inb))" -ne 1 ]; then echo "FAIL: cam-$i has $ina session(s) on A and $inb on B"; exit 1; fi
  on_a=$((on_a + ina)) on_b=$((on_b + inb))
  out=$("$client" session create --target 127.0.0.1:$p --camera "cam-$i" --config "$config")
  grep -q UNCHANGED <<<"$out" || { echo "FAIL: cam-$i again through the proxy: $out"; exit 1; }
done
[ "$on_a" -gt 0 ] && [ "$on_b" -gt 0 ] || { echo "FAIL: cameras all on one replica ($on_a / $on_b)"; exit 1; }
echo "deploy_nginx_proxy: 20 cameras, $on_a on replica A and $on_b on B, each on one; asked again, each UNCHANGED"
