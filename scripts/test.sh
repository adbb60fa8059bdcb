#!/usr/bin/env bash
# The test command: installs dependencies, builds everything with warnings as
# errors, and runs the whole test suite with ctest.
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/install-deps.sh
BUILD_DIR=${BUILD_DIR:-build} ./scripts/build.sh -DLANE_WERROR=ON -DLANE_BUILD_TESTS=ON -DLANE_BUILD_BENCH=ON -DLANE_BUILD_SERVICE=ON
cd "${BUILD_DIR:-build}"
ctest --output-on-failure -j "$(nproc)" --timeout 900
