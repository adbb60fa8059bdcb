#!/usr/bin/env bash
# A second lane-server on a port that one already holds must fail at start
# with a clear message and exit status 1 (hardening, round 2, class 7): gRPC
# enables SO_REUSEPORT by default, and the kernel would then split the
# connections between the two servers.
#
# usage: busy_port_test.sh LANE_SERVER LANE_CLIENT
set -euo pipefail
server=$1
client=$2
dir=$(mktemp -d)
first_pid=
cleanup() {
  [ -z "$first_pid" ] || kill -9 "$first_pid" 2>/dev/null || true
  rm -rf "$dir"
}
trap cleanup EXIT
fail() {
  echo "FAIL: $*" >&2
  exit 1
}

# --version and --help read as a user expects (one version for the three
# binaries; no doubled program name, no build machine's path).
# No pipes into grep -q or head here: with pipefail, a reader that stops early
# makes the writer die of SIGPIPE and the whole check fail (CI saw it once).
version=$("$server" --version)
grep -Eq '^lane-server [0-9]+\.[0-9]+\.[0-9]+ \(git [^,]+, ' <<<"$version" || fail "--version: $version"
help=$("$server" --help 2>&1 || true)
header=${help%%$'\n'*}
[[ $header == "lane-server: lane-marker"* ]] || fail "--help header: $header"
grep -q 'lane-server: lane-server' <<<"$help" && fail "--help repeats the program name"
grep -q 'Flags from server/main.cc:' <<<"$help" || fail "--help shows a build path"

# A free port: bind port 0 with the first server and read it from its log.
"$server" --address=127.0.0.1:0 --metrics_address= 2>"$dir/first.log" &
first_pid=$!
for _ in $(seq 100); do
  grep -q "gRPC on port" "$dir/first.log" && break
  sleep 0.1
done
port=$(sed -n 's/.*gRPC on port \([0-9]*\).*/\1/p' "$dir/first.log")
[ -n "$port" ] || fail "the first server did not start: $(cat "$dir/first.log")"

set +e
timeout 20 "$server" --address="127.0.0.1:$port" --metrics_address= 2>"$dir/second.log"
status=$?
set -e
[ "$status" -eq 1 ] || fail "the second server exited with $status, expected 1: $(cat "$dir/second.log")"
grep -q "cannot listen on 127.0.0.1:$port: the port is in use" "$dir/second.log" ||
  fail "no clear message: $(cat "$dir/second.log")"
"$client" health --target "127.0.0.1:$port" >/dev/null || fail "the first server stopped serving"
echo "busy port: the second server exited 1 with: $(grep 'cannot listen' "$dir/second.log")"
