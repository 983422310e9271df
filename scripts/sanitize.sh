#!/usr/bin/env bash
# The sanitizer suites: the test suite built with -fsanitize and run under the sanitizers'
# runtime checks, failing on the first report.
#   bash scripts/sanitize.sh          # both suites
#   bash scripts/sanitize.sh asan     # AddressSanitizer + UndefinedBehaviorSanitizer: every test
#   bash scripts/sanitize.sh tsan     # ThreadSanitizer: the service and thread-pool tests
#   bash scripts/sanitize.sh ci       # what .ci/run runs: ASan + UBSan on the tests of the code
#                                     # that parses untrusted bytes or does geometry in raw loops
#                                     # (ASAN_CI_TESTS below, the fuzz corpora), then tsan
# Build folders: build-asan/ and build-tsan/ (Release with G6D_SANITIZE_FLAGS, -O1 -g1 by default). Extra arguments after the suite
# go to ctest, e.g. `bash scripts/sanitize.sh asan -R cache_test`.
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT="$PWD"
SUITE="${1:-all}"
if [[ $# -gt 0 ]]; then shift; fi
case "${SUITE}" in
  all | asan | tsan | ci) ;;
  *) echo "usage: bash scripts/sanitize.sh [all|asan|tsan|ci] [ctest args]" >&2; exit 2 ;;
esac

# Tests under ThreadSanitizer: everything that runs threads of ours (the service, its LCM
# thread, scheduler and worker pool, and the thread pool itself). The rest of the suite is
# single-threaded or reaches threads only through these. pipeline_test is left to ASan: its
# threaded stages (ICP, MHPO and the vote on the worker pool) run under TSan in service_test
# and service_detect_test through the service's own pool, and its 3 shards cost 165 s of a
# cold CI run here (2432 s against the 40-minute aim on a slower machine). frame_codec_test
# and service_options_test start no thread (a parser, the YAML options): ASan keeps the
# first; the cold run was 2444 s with them (2026-11-29).
TSAN_TESTS=(service_test service_process_test mailbox_test
  template_store_test executor_test template_bank_test lcm_loop_test
  service_adapters_test background_detector_test tracker_test debug_images_test
  frame_sources_test status_tool_test cache_watcher_test service_reload_test service_input_test
  service_detect_test)
TSAN_TARGETS=("${TSAN_TESTS[@]}" g6d-service g6d-status)

# The ASan subset of the CI run (a cold build of every test under ASan took about 40 of CI's
# 90 minutes on 2 cores): the message, image, cache and BOP parsers with their fuzz corpora,
# the mesh, symmetry, appearance, rasterizer and solver stages, and the service end to end.
# pipeline_test is left to `sanitize.sh all`: its stages run under ASan in their own tests
# (raster, match, pnp, icp, mhpo, score, region, segments) and end to end in service_test
# and tracker_test, and its 3 shards took 195 s of ASan time in a cold run (2444 s in all).
ASAN_CI_TESTS=(cache_test frame_codec_test bop_test bop_csv_test mesh_test symmetry_test appearance_test
  raster_test match_test pnp_test icp_test mhpo_test score_test region_test segments_test
  template_bank_test service_test tracker_test)
FUZZ_TARGETS=(frame_message image_decode template_cache bop_json bop_csv)

# The runtime options of both ASan runs: leaks, stop at the first report, suppressions.
asan_environment() {
  export ASAN_OPTIONS="detect_leaks=1:halt_on_error=1:check_initialization_order=1:strict_init_order=1:detect_stack_use_after_return=1:print_summary=1"
  export UBSAN_OPTIONS="halt_on_error=1:print_stacktrace=1:suppressions=${ROOT}/tests/ubsan_suppressions.txt"
  export LSAN_OPTIONS="suppressions=${ROOT}/tests/lsan_suppressions.txt:print_suppressions=0"
}
# The input adapters' fuzz target (issue 15), and its unit test in the ASan CI list.
FUZZ_TARGETS+=(foreign_message)
ASAN_CI_TESTS+=(input_adapters_test)

START=$(date +%s)
run_asan_ci() {
  echo "[sanitize] AddressSanitizer + UndefinedBehaviorSanitizer: build-asan, ${ASAN_CI_TESTS[*]} and the fuzz corpora"
  local targets=("${ASAN_CI_TESTS[@]}")
  for name in "${FUZZ_TARGETS[@]}"; do targets+=("g6d-fuzz-replay-${name}"); done
  BUILD_DIR=build-asan CMAKE_ARGS="-DG6D_SANITIZE=address,undefined -DG6D_BUILD_BENCH=OFF" \
    BUILD_TARGETS="${targets[*]}" G6D_SKIP_APT=1 bash scripts/setup.sh
  local regex
  regex="^(($(IFS='|'; echo "${ASAN_CI_TESTS[*]}"))\\.|fuzz_corpus\\.)"
  (
    cd build-asan
    asan_environment
    local test_start status=0
    test_start=$(date +%s)
    ctest --output-on-failure -j"${JOBS:-2}" -R "${regex}" "$@" || status=$?
    echo "[sanitize] asan tests: $(($(date +%s) - test_start)) s (ctest exit ${status})"
    exit "${status}"
  )
}

run_asan() {
  echo "[sanitize] AddressSanitizer + UndefinedBehaviorSanitizer: build-asan, every test"
  BUILD_DIR=build-asan CMAKE_ARGS="-DG6D_SANITIZE=address,undefined -DG6D_BUILD_BENCH=OFF" \
    G6D_SKIP_APT=1 bash scripts/setup.sh
  (
    cd build-asan
    asan_environment
    ctest --output-on-failure -j"${JOBS:-2}" "$@"
  )
}

run_tsan() {
  echo "[sanitize] ThreadSanitizer: build-tsan, ${TSAN_TESTS[*]}"
  BUILD_DIR=build-tsan CMAKE_ARGS="-DG6D_SANITIZE=thread -DG6D_BUILD_BENCH=OFF" \
    BUILD_TARGETS="${TSAN_TARGETS[*]}" G6D_SKIP_APT=1 bash scripts/setup.sh
  local regex
  regex="^($(IFS='|'; echo "${TSAN_TESTS[*]}"))\\."
  (
    cd build-tsan
    export TSAN_OPTIONS="suppressions=${ROOT}/tests/tsan_suppressions.txt:ignore_noninstrumented_modules=1:halt_on_error=1:second_deadlock_stack=1"
    local test_start status=0
    test_start=$(date +%s)
    ctest --output-on-failure -j"${JOBS:-2}" -R "${regex}" "$@" || status=$?
    echo "[sanitize] tsan tests: $(($(date +%s) - test_start)) s (ctest exit ${status})"
    exit "${status}"
  )
}

# The Debian packages once (setup.sh is idempotent); the suites below only build.
if [[ "${G6D_SKIP_APT:-0}" != "1" ]]; then G6D_SKIP_BUILD=1 bash scripts/setup.sh; fi
if [[ "${SUITE}" == all || "${SUITE}" == asan ]]; then run_asan "$@"; fi
if [[ "${SUITE}" == ci ]]; then run_asan_ci "$@"; fi
ASAN_END=$(date +%s)
if [[ "${SUITE}" == all || "${SUITE}" == tsan || "${SUITE}" == ci ]]; then run_tsan "$@"; fi
END=$(date +%s)
echo "[sanitize] passed (${SUITE}): $((END - START)) s in all" \
  "(asan $((ASAN_END - START)) s, tsan $((END - ASAN_END)) s)"
