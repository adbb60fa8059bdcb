#!/usr/bin/env bash
# Runs the test command (.ci/run) RUNS times in a row while stress-ng keeps
# every core busy, as a shared CI machine may be (issue 40). Each run's log
# and exit status go to LOG_DIR; the script stops at the first failure.
#
#   scripts/loaded-ci.sh [RUNS] [LOG_DIR]      (defaults: 3, out/loaded-ci)
#
# LOADED_CMD runs another command under the same load instead of .ci/run,
# e.g. LOADED_CMD="./scripts/sanitize.sh tsan" for the TSan step alone.
#
# The first run builds everything; later runs reuse the build trees, so they
# time the tests under load. Installs stress-ng if needed.
set -euo pipefail
cd "$(dirname "$0")/.."
runs=${1:-3}
logs=${2:-out/loaded-ci}
mkdir -p "$logs"
command -v stress-ng >/dev/null || {
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq && apt-get install -y -qq --no-install-recommends stress-ng
}
stress-ng --cpu "$(nproc)" --cpu-method matrixprod --timeout 0 --quiet &
burner=$!
trap 'kill $burner 2>/dev/null || true' EXIT
for i in $(seq 1 "$runs"); do
  start=$(date +%s)
  rc=0
  ${LOADED_CMD:-./.ci/run} >"$logs/run$i.log" 2>&1 || rc=$?
  echo "run $i (${LOADED_CMD:-.ci/run}): exit $rc in $(( $(date +%s) - start )) s (load: stress-ng --cpu $(nproc))" | tee -a "$logs/summary.txt"
  [ "$rc" -eq 0 ] || exit "$rc"
done
