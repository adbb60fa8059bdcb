#!/usr/bin/env bash
# Bearer tokens end to end, with the real binaries (issue 7): lane-server takes
# its tokens from --auth_tokens_file and LANE_AUTH_TOKENS, never from a
# command-line literal; lane-client sends one from --token-file or LANE_TOKEN.
# Checks, in order:
#   1. lane-server refuses a token on the command line (--auth_tokens=...);
#   2. health needs no token;
#   3. no token and a wrong token: UNAUTHENTICATED; the file's token and the
#      environment's token: served;
#   4. no token appears in anything either program printed, with gRPC's own
#      logging at its most verbose (GRPC_VERBOSITY=DEBUG), nor in the server's
#      command line.
#
# usage: token_secrecy_test.sh LANE_SERVER LANE_CLIENT
set -euo pipefail
server=$1
client=$2
dir=$(mktemp -d)
server_pid=
cleanup() {
  [ -z "$server_pid" ] || kill -9 "$server_pid" 2>/dev/null || true
  rm -rf "$dir"
}
trap cleanup EXIT
fail() {
  echo "FAIL: $*" >&2
  exit 1
}

random() { od -An -N12 -tx1 /dev/urandom | tr -d ' \n'; }
file_token="file-$(random)"
env_token="env-$(random)"
wrong_token="wrong-$(random)"
printf '# tokens of the test fleet\n%s\n' "$file_token" >"$dir/tokens"
chmod 600 "$dir/tokens"
printf '%s\n' "$file_token" >"$dir/good"
printf '%s\n' "$wrong_token" >"$dir/wrong"
export GRPC_VERBOSITY=DEBUG

# 1. No token literal on the command line.
if "$server" --address=127.0.0.1:0 --metrics_address= --auth_tokens="$file_token" \
    >"$dir/literal.out" 2>&1; then
  fail "lane-server accepted --auth_tokens on the command line"
fi
grep -q "auth_tokens" "$dir/literal.out" || fail "no error naming the refused flag"
echo "ok: a token on the command line is refused"

LANE_AUTH_TOKENS="$env_token" "$server" --address=127.0.0.1:0 --metrics_address= \
  --auth_tokens_file="$dir/tokens" >"$dir/server.out" 2>"$dir/server.err" &
server_pid=$!
port=
for _ in $(seq 1 200); do
  port=$(sed -n 's/.*gRPC on port \([0-9]*\).*/\1/p;T;q' "$dir/server.err")
  [ -n "$port" ] && break
  kill -0 "$server_pid" 2>/dev/null || { cat "$dir/server.err" >&2; fail "lane-server exited"; }
  sleep 0.05
done
[ -n "$port" ] || fail "lane-server did not report its port"
grep -q "2 Bearer token(s)" "$dir/server.err" || fail "the server did not load both tokens"
target=127.0.0.1:$port

# What a failed check shows: the client's own lines (gRPC's debug lines
# left out) and the end of the server's log, with whether it still runs.
explain() {
  local name=$1
  echo "-- lane-client ($name), its own lines:" >&2
  grep -v -E '^[DIWE][0-9]{4} ' "$dir/$name.err" | tail -20 >&2 || true
  if kill -0 "$server_pid" 2>/dev/null; then
    echo "-- lane-server still runs; the end of its log:" >&2
  else
    echo "-- lane-server has exited; the end of its log:" >&2
  fi
  grep -v -E '^[DIWE][0-9]{4} ' "$dir/server.err" | tail -20 >&2 || true
}

# run NAME EXPECTED_EXIT ARGS...: a lane-client command, its output kept.
# A call that met a transport failure (UNAVAILABLE) while the server still
# runs is tried once more, as a fleet client would; the first attempt's
# error is printed.
run() {
  local name=$1 want=$2 got=0
  shift 2
  "$client" "$@" --target "$target" >"$dir/$name.out" 2>"$dir/$name.err" || got=$?
  if [ "$got" -ne 0 ] && grep -q "UNAVAILABLE" "$dir/$name.err" &&
    kill -0 "$server_pid" 2>/dev/null; then
    echo "note: $name met UNAVAILABLE; once more:"
    grep -v -E '^[DIWE][0-9]{4} ' "$dir/$name.err" | tail -3 || true
    mv "$dir/$name.err" "$dir/$name.first-attempt.err"
    got=0
    "$client" "$@" --target "$target" >"$dir/$name.out" 2>"$dir/$name.err" || got=$?
  fi
  if [ "$want" = ok ] && [ "$got" -ne 0 ]; then
    explain "$name"
    fail "$name: exit $got, expected success"
  fi
  if [ "$want" = fail ] && [ "$got" -eq 0 ]; then fail "$name: succeeded, expected a failure"; fi
  echo "ok: $name (exit $got)"
}

# unauthenticated NAME: the failed call NAME was refused as UNAUTHENTICATED.
unauthenticated() {
  grep -q UNAUTHENTICATED "$dir/$1.err" && return 0
  explain "$1"
  fail "$1: not UNAUTHENTICATED"
}

# 2. Health is open.
run health ok health
# 3. Tokens.
run no-token fail session list
unauthenticated no-token
run wrong-token fail session list --token-file "$dir/wrong"
unauthenticated wrong-token
run file-token ok session list --token-file "$dir/good"
LANE_TOKEN="$env_token" run env-token ok session list
LANE_TOKEN="$wrong_token" run wrong-env-token fail session list
unauthenticated wrong-env-token

# 4. Secrecy: the command line, then everything printed (after a clean stop).
for token in "$file_token" "$env_token"; do
  grep -qF "$token" <<<"$(tr '\0' ' ' <"/proc/$server_pid/cmdline")" && fail "a token in the command line"
done
kill -TERM "$server_pid"
wait "$server_pid" || fail "lane-server did not stop cleanly"
server_pid=
for token in "$file_token" "$env_token" "$wrong_token"; do
  if grep -lF "$token" "$dir"/*.out "$dir"/*.err; then fail "a token appears in the output above"; fi
done
echo "ok: no token in $(cat "$dir"/*.out "$dir"/*.err | wc -l) lines printed by lane-server and lane-client"
