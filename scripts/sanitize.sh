#!/usr/bin/env bash
# Sanitizer builds and test runs (issue 7), a step of the test command:
#
#   asan: clang, -fsanitize=address,undefined plus libFuzzer's coverage
#         instrumentation (-DLANE_FUZZ=ON) in build-asan: every test (core,
#         server, client, deploy), then each fuzz target for FUZZ_SECONDS
#         (default 20) through scripts/fuzz.sh. Any ASan, LSan or UBSan
#         report fails the run (UBSan halts on the first error in tests).
#   tsan: the server and client tests built with -fsanitize=thread in
#         build-tsan. Debian's gRPC and Abseil are not TSan-instrumented, so
#         accesses made wholly inside them are suppressed
#         (tests/server/tsan.supp, with the reasoning); a report that touches
#         our code, protobuf or OpenCV fails the run (TSan exit code 66).
#
#   scripts/sanitize.sh [asan|tsan|all]      (default: all)
#
# JOBS (default: nproc) bounds compile jobs.
set -euo pipefail
cd "$(dirname "$0")/.."
which="${1:-all}"
jobs="${JOBS:-$(nproc)}"

# A build directory made by another compiler is started afresh.
fresh_if_not() {  # dir compiler-pattern
  if [ -f "$1/CMakeCache.txt" ] && ! grep -q "^CMAKE_CXX_COMPILER:.*$2" "$1/CMakeCache.txt"; then
    rm -rf "$1"
  fi
}

run_asan() {
  echo "== sanitize: ASan+UBSan build with clang (build-asan)"
  fresh_if_not build-asan clang
  CC=clang CXX=clang++ cmake -S . -B build-asan -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DLANE_FUZZ=ON -DLANE_BUILD_TESTS=ON -DLANE_BUILD_BENCH=OFF -DLANE_BUILD_SERVICE=ON >/dev/null
  cmake --build build-asan -j "$jobs"
  echo "== sanitize: ASan+UBSan tests"
  (cd build-asan &&
    ASAN_OPTIONS=detect_leaks=1:abort_on_error=0:strict_string_checks=1:detect_stack_use_after_return=1 \
      UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1 \
      ctest --output-on-failure -j "$(nproc)" --timeout 1800)
  echo "== sanitize: fuzzers, ${FUZZ_SECONDS:-20} s each"
  FUZZ_BUILD_DIR=build-asan ./scripts/fuzz.sh "${FUZZ_SECONDS:-20}"
}

run_tsan() {
  echo "== sanitize: TSan build of the server and client tests with gcc (build-tsan)"
  fresh_if_not build-tsan "g++"
  cmake -S . -B build-tsan -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DLANE_SANITIZE=thread \
    -DLANE_WERROR=ON -DLANE_BUILD_TESTS=ON -DLANE_BUILD_BENCH=OFF -DLANE_BUILD_SERVICE=ON >/dev/null
  cmake --build build-tsan -j "$jobs" --target server_test client_test
  local t
  for t in tests/server/server_test tests/client/client_test; do
    echo "== sanitize: TSan $t"
    (cd build-tsan && TSAN_OPTIONS=second_deadlock_stack=1 "./$t" --gtest_brief=1)
  done
}

case "$which" in
  asan) run_asan ;;
  tsan) run_tsan ;;
  all) run_asan; run_tsan ;;
  *) echo "usage: $0 [asan|tsan|all]" >&2; exit 2 ;;
esac
