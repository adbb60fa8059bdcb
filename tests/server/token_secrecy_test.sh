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
  port=$(sed -n 's/.*gRPC on port \([0-9]*\).*/\1/p' "$dir/server.err" | head -1)
  [ -n "$port" ] && break
  kill -0 "$server_pid" 2>/dev/null || { cat "$dir/server.err" >&2; fail "lane-server exited"; }
  sleep 0.05
done
[ -n "$port" ] || fail "lane-server did not report its port"
grep -q "2 Bearer token(s)" "$dir/server.err" || fail "the server did not load both tokens"
target=127.0.0.1:$port

# run NAME EXPECTED_EXIT ARGS...: a lane-client command, its output kept.
run() {
  local name=$1 want=$2 got=0
  shift 2
  "$client" "$@" --target "$target" >"$dir/$name.out" 2>"$dir/$name.err" || got=$?
  if [ "$want" = ok ] && [ "$got" -ne 0 ]; then
    cat "$dir/$name.err" >&2
    fail "$name: exit $got, expected success"
  fi
  if [ "$want" = fail ] && [ "$got" -eq 0 ]; then fail "$name: succeeded, expected a failure"; fi
  echo "ok: $name (exit $got)"
}

# 2. Health is open.
run health ok health
# 3. Tokens.
run no-token fail session list
grep -q UNAUTHENTICATED "$dir/no-token.err" || fail "no token: not UNAUTHENTICATED"
run wrong-token fail session list --token-file "$dir/wrong"
grep -q UNAUTHENTICATED "$dir/wrong-token.err" || fail "wrong token: not UNAUTHENTICATED"
run file-token ok session list --token-file "$dir/good"
LANE_TOKEN="$env_token" run env-token ok session list
LANE_TOKEN="$wrong_token" run wrong-env-token fail session list
grep -q UNAUTHENTICATED "$dir/wrong-env-token.err" || fail "wrong env token: not UNAUTHENTICATED"

# 4. Secrecy: the command line, then everything printed (after a clean stop).
for token in "$file_token" "$env_token"; do
  tr '\0' ' ' <"/proc/$server_pid/cmdline" | grep -qF "$token" && fail "a token in the command line"
done
kill -TERM "$server_pid"
wait "$server_pid" || fail "lane-server did not stop cleanly"
server_pid=
for token in "$file_token" "$env_token" "$wrong_token"; do
  if grep -lF "$token" "$dir"/*.out "$dir"/*.err; then fail "a token appears in the output above"; fi
done
echo "ok: no token in $(cat "$dir"/*.out "$dir"/*.err | wc -l) lines printed by lane-server and lane-client"
