#!/usr/bin/env bash
# Builds the libFuzzer targets of fuzz/ with clang (ASan + UBSan) in
# build-fuzz and runs each for SECONDS (default 60) from its seed corpus in
# fuzz/corpus/<target>/. New inputs go to build-fuzz/corpus/<target>/ (the
# repo's seeds are not modified); crashes to build-fuzz/artifacts/.
#
#   scripts/fuzz.sh [SECONDS]
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${1:-60}"
CC=clang CXX=clang++ cmake -S . -B build-fuzz -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DLANE_FUZZ=ON -DLANE_BUILD_TESTS=OFF -DLANE_BUILD_BENCH=OFF
cmake --build build-fuzz -j"${JOBS:-2}" --target frame_decode_fuzzer config_fuzzer \
  frame_request_fuzzer
mkdir -p build-fuzz/artifacts
status=0
for target in frame_decode config frame_request; do
  mkdir -p "build-fuzz/corpus/$target"
  echo "== ${target}_fuzzer: ${seconds}s"
  if ! ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1 \
      "build-fuzz/fuzz/${target}_fuzzer" -max_total_time="$seconds" -rss_limit_mb=4096 \
      -max_len=1048576 -artifact_prefix="build-fuzz/artifacts/${target}-" \
      "build-fuzz/corpus/$target" "fuzz/corpus/$target" 2>&1 |
      tee "build-fuzz/${target}.log" | grep -E "^(#[0-9]+ +DONE|Done|==[0-9]+==ERROR|SUMMARY)"; then
    :
  fi
  if grep -qE "ERROR: (AddressSanitizer|UndefinedBehaviorSanitizer|libFuzzer)|runtime error" \
      "build-fuzz/${target}.log"; then
    echo "== ${target}_fuzzer: CRASH (see build-fuzz/${target}.log, build-fuzz/artifacts/)"
    status=1
  fi
done
exit "$status"
