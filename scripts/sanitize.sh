#!/usr/bin/env bash
# Sanitizer builds and test runs (issue 7), a step of the test command:
#
#   asan: clang, -fsanitize=address,undefined plus libFuzzer's coverage
#         instrumentation (-DLANE_FUZZ=ON) in build-asan: every test (core,
#         server, client, deploy), then each fuzz target for FUZZ_SECONDS
#         (default 20) through scripts/fuzz.sh. Any ASan, LSan or UBSan
#         report fails the run (UBSan halts on the first error in tests).
#   tsan: the server and client tests built with -fsanitize=thread in
#         build-tsan. Debian's gRPC and Abseil are not TSan-instrumented:
#         what TSan cannot see in them (absl::Mutex, gRPC's lock; the order
#         of a gRPC batch's start and completion; a call's OnDone) is
#         modelled by interposition (tests/sanitizers/tsan_absl_sync.cc,
#         tsan_grpc_sync.cc), and only the uninstrumented
#         libraries' own interceptor calls and a lock cycle inside GDAL are
#         suppressed (tests/sanitizers/tsan.supp, with the reasoning); any
#         other report fails the run (TSan exit code 66). A canary with a
#         deliberate race on a gRPC thread (tests/sanitizers/tsan_canary.cc)
#         must be reported first.
#
#   scripts/sanitize.sh [asan|tsan|all]      (default: all)
#
# Both builds are unity builds (CMAKE_UNITY_BUILD: each target's sources
# compiled in batches of 8): most of a sanitizer build's time is the same
# OpenCV, Eigen, gRPC and GoogleTest headers parsed again for every file.
# The plain gcc build of the test command stays one file at a time, so a
# missing #include still fails there (docs/hardening.md, "CI time").
#
# JOBS (default: nproc) bounds compile jobs.
set -euo pipefail
cd "$(dirname "$0")/.."
which="${1:-all}"
jobs="${JOBS:-$(nproc)}"

# A build directory made by another compiler is started afresh. The
# pattern is an extended regex on the compiler's path: gcc's is /usr/bin/c++
# or g++, and "clang++" contains both "c++" and "g++", hence the anchors
# (until 2026-12-06 the TSan tree matched nothing and was rebuilt whole on
# every run).
fresh_if_not() {  # dir compiler-regex
  if [ -f "$1/CMakeCache.txt" ] && ! grep -qE "^CMAKE_CXX_COMPILER:[^=]*=(.*/)?$2\$" "$1/CMakeCache.txt"; then
    rm -rf "$1"
  fi
}

run_asan() {
  echo "== sanitize: ASan+UBSan build with clang (build-asan)"
  fresh_if_not build-asan 'clang\+\+(-[0-9]+)?'
  CC=clang CXX=clang++ cmake -S . -B build-asan -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DLANE_FUZZ=ON -DLANE_BUILD_TESTS=ON -DLANE_BUILD_BENCH=OFF -DLANE_BUILD_SERVICE=ON \
    -DLANE_LINE_TABLES=ON -DCMAKE_UNITY_BUILD=ON >/dev/null
  cmake --build build-asan -j "$jobs"
  # Tests labelled slow (the 300-frame rendered drive) and the four longest
  # accuracy runs (all of cordova1; 4 random cameras x 50 rendered frames;
  # the 180-frame pitch drift; cordova1's vanishing point; 50 cameras x 24
  # cluttered frames) run in the plain
  # build only: under ASan they add minutes of code paths that shorter tests
  # (CULane clip, cordova1 fast decode, the HTTP endpoint's auto-calibrating
  # session, the CULane clip's vanishing point) already cover. So do the
  # CULane clip's accuracy run (FastDecodeTest.DevClipGivesTheSameLanes
  # detects the same frames) and the local cluster behind nginx (its servers
  # are the binaries the service tests run under ASan; what it adds is
  # routing). Label install: a consumer built without ASan cannot link its
  # instrumented libraries (and the fuzz build registers no such test).
  echo "== sanitize: ASan+UBSan tests (label slow and the longest accuracy runs left out)"
  (cd build-asan &&
    ASAN_OPTIONS=detect_leaks=1:abort_on_error=0:strict_string_checks=1:detect_stack_use_after_return=1 \
      UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1 \
      ctest --output-on-failure -j "$(nproc)" --timeout 1800 -LE 'slow|install' \
        -E 'deploy_local_cluster|EvalRegressionTest.CulaneDriver161AllLanes|EvalRegressionTest.CaltechCordova1AllLanes|CalibrationClutterTest.FiftyRandomCamerasInClutter|CalibrationTest.RandomCamerasAreRecoveredFromRenderedDrives|CalibrationTest.OnlineRefinementFollowsAPitchDrift|CalibrationTest.CaltechCordova1VanishingPoint')
  echo "== sanitize: fuzzers, ${FUZZ_SECONDS:-20} s each"
  FUZZ_BUILD_DIR=build-asan ./scripts/fuzz.sh "${FUZZ_SECONDS:-20}"
}

run_tsan() {
  echo "== sanitize: TSan build of the server and client tests with gcc (build-tsan)"
  fresh_if_not build-tsan '(c|g)\+\+(-[0-9]+)?'
  cmake -S . -B build-tsan -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DLANE_SANITIZE=thread \
    -DLANE_WERROR=ON -DLANE_BUILD_TESTS=ON -DLANE_BUILD_BENCH=OFF -DLANE_BUILD_SERVICE=ON \
    -DLANE_LINE_TABLES=ON -DCMAKE_UNITY_BUILD=ON >/dev/null
  cmake --build build-tsan -j "$jobs" --target server_test client_test tsan_canary
  # First the canary: a deliberate race between a gRPC callback thread and a
  # worker must be reported, or the model and the suppressions hide races.
  echo "== sanitize: TSan canary (must report its race)"
  local canary=0
  (cd build-tsan && ./tests/tsan_canary) >build-tsan/tsan_canary.log 2>&1 || canary=$?
  if [ "$canary" -ne 66 ] || ! grep -q "CanaryWriteOn" build-tsan/tsan_canary.log; then
    cat build-tsan/tsan_canary.log >&2
    echo "== sanitize: TSan did not report the canary's race (exit $canary)" >&2
    exit 1
  fi
  echo "== sanitize: TSan canary reported ($(grep -c 'WARNING: ThreadSanitizer' build-tsan/tsan_canary.log) report)"
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
