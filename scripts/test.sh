#!/usr/bin/env bash
# The test command (CI runs it through .ci/run):
#   1. installs dependencies, builds everything with gcc and warnings as
#      errors, and runs the whole test suite with ctest;
#   2. scripts/package-test.sh: the .deb built, checked (contents, computed
#      Depends, lintian, the systemd unit), installed, run and purged
#      (as root only: CI);
#   3. scripts/sanitize.sh: every test under ASan+UBSan (clang), each libFuzzer
#      target for FUZZ_SECONDS (default 20), the server and client tests
#      under TSan (gcc).
#
#   scripts/test.sh [--quick]        --quick: step 1 only
set -euo pipefail
cd "$(dirname "$0")/.."
quick=0
case "${1:-}" in
  "") ;;
  --quick) quick=1 ;;
  *) echo "usage: $0 [--quick]" >&2; exit 2 ;;
esac
./scripts/install-deps.sh
BUILD_DIR=${BUILD_DIR:-build} ./scripts/build.sh -DLANE_WERROR=ON -DLANE_BUILD_TESTS=ON -DLANE_BUILD_BENCH=ON -DLANE_BUILD_SERVICE=ON \
  -DLANE_LINE_TABLES=ON
(cd "${BUILD_DIR:-build}" && ctest --output-on-failure -j "$(nproc)" --timeout 900)
[ "$quick" -eq 1 ] || ./scripts/package-test.sh "${BUILD_DIR:-build}"
[ "$quick" -eq 1 ] || ./scripts/sanitize.sh all
