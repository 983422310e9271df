#!/usr/bin/env bash
# Sets up (packages + build) and runs every test with ctest.
#   bash scripts/test.sh [extra ctest args]
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
BUILD_DIR="${BUILD_DIR:-build}"
cd "${BUILD_DIR}"
test_start=$(date +%s)
status=0
ctest --output-on-failure -j"${JOBS:-2}" "$@" || status=$?
echo "[test] tests ${BUILD_DIR}: $(($(date +%s) - test_start)) s (ctest exit ${status})"
exit "${status}"
