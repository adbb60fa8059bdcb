#!/usr/bin/env bash
# Builds the libFuzzer targets of fuzz/ with clang (ASan + UBSan) in
# FUZZ_BUILD_DIR (default build-fuzz) and runs each for SECONDS (default 60)
# from its seed corpus in fuzz/corpus/<target>/. New inputs go to
# <build>/corpus/<target>/ (the repo's seeds are not modified); crashes to
# <build>/artifacts/. Exits 1 when a target crashed. A build directory already
# configured with -DLANE_FUZZ=ON (scripts/sanitize.sh's build-asan) is reused
# as it is.
#
#   scripts/fuzz.sh [SECONDS]
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${1:-60}"
build="${FUZZ_BUILD_DIR:-build-fuzz}"
if ! grep -q "^LANE_FUZZ:BOOL=ON" "$build/CMakeCache.txt" 2>/dev/null; then
  CC=clang CXX=clang++ cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DLANE_FUZZ=ON -DLANE_BUILD_TESTS=OFF -DLANE_BUILD_BENCH=OFF >/dev/null
fi
cmake --build "$build" -j"${JOBS:-$(nproc)}" --target frame_decode_fuzzer config_fuzzer resume_state_fuzzer \
  frame_request_fuzzer
mkdir -p "$build/artifacts"
total_runs=0
status=0
for target in frame_decode config frame_request resume_state; do
  mkdir -p "$build/corpus/$target"
  echo "== ${target}_fuzzer: ${seconds}s"
  if ! ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1 \
      "$build/fuzz/${target}_fuzzer" -max_total_time="$seconds" -rss_limit_mb=4096 \
      -max_len=1048576 -artifact_prefix="$build/artifacts/${target}-" \
      "$build/corpus/$target" "fuzz/corpus/$target" 2>&1 |
      tee "$build/${target}.log" | grep -E "^(#[0-9]+ +DONE|Done|==[0-9]+==ERROR|SUMMARY)"; then
    :
  fi
  if grep -qE "ERROR: (AddressSanitizer|UndefinedBehaviorSanitizer|libFuzzer)|runtime error" \
      "$build/${target}.log"; then
    echo "== ${target}_fuzzer: CRASH (see $build/${target}.log, $build/artifacts/)"
    status=1
  fi
  runs=$(sed -n 's/^Done \([0-9]*\) runs.*/\1/p' "$build/${target}.log" | tail -1)
  total_runs=$((total_runs + ${runs:-0}))
done
echo "== fuzz: ${total_runs} executions in total"
exit "$status"
