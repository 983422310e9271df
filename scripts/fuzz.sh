#!/usr/bin/env bash
# Builds the libFuzzer targets with clang (build-fuzz/, G6D_FUZZ=ON: ASan + UBSan) and
# runs each for SECONDS, then prints one line per target and fails when any found
# something (a crash, a leak, a sanitizer report, a timeout or running out of memory).
#
#   bash scripts/fuzz.sh [SECONDS]        (default 600 per target)
#
# Environment:
#   TARGETS="frame_message bop_csv"  targets to run (default: all, see tests/fuzz/)
#   JOBS=2                            targets fuzzed at the same time (default 1)
#   BUILD_JOBS=2                      compile jobs (default 2)
#   BUILD_DIR=build-fuzz              build folder (default build-fuzz)
#   FUZZ_ARGS="-max_len=65536"        extra libFuzzer flags for every target
#
# Each target starts from build-fuzz/corpus/<name>/: the committed seeds
# (tests/fuzz/corpus/<name>/) are copied into it, and what the fuzzer adds stays there for
# the next run, so the committed corpus stays small. (Regression inputs are not copied:
# ctest replays them, and a big one would raise libFuzzer's default -max_len.) Findings go to build-fuzz/artifacts/<name>/ (crash-*, leak-*,
# timeout-*, oom-*; only this run's count), logs to build-fuzz/logs/<name>.log. Reproduce one with
#   build-fuzz/tests/fuzz/g6d-fuzz-<name> build-fuzz/artifacts/<name>/crash-...
# then fix the code and keep the input as tests/fuzz/regressions/<name>/<short-name>.
set -euo pipefail
cd "$(dirname "$0")/.."

SECONDS_PER_TARGET="${1:-600}"
if ! [[ "${SECONDS_PER_TARGET}" =~ ^[0-9]+$ ]] || [[ "${SECONDS_PER_TARGET}" -lt 1 ]]; then
  echo "usage: bash scripts/fuzz.sh [SECONDS]  (a whole number of seconds per target)" >&2
  exit 2
fi
ALL_TARGETS="frame_message image_decode template_cache bop_json bop_csv"
TARGETS="${TARGETS:-${ALL_TARGETS}}"
JOBS="${JOBS:-1}"
BUILD_JOBS="${BUILD_JOBS:-2}"
BUILD_DIR="${BUILD_DIR:-build-fuzz}"
read -r -a EXTRA_ARGS <<<"${FUZZ_ARGS:-}"
for target in ${TARGETS}; do
  if [[ " ${ALL_TARGETS} " != *" ${target} "* ]]; then
    echo "[fuzz] unknown target '${target}' (known: ${ALL_TARGETS})" >&2
    exit 2
  fi
done

export CCACHE_BASEDIR="${CCACHE_BASEDIR:-$PWD}" CCACHE_NOHASHDIR="${CCACHE_NOHASHDIR:-true}"
echo "[fuzz] configuring ${BUILD_DIR} (clang, G6D_FUZZ=ON)" >&2
CC=clang CXX=clang++ cmake -S . -B "${BUILD_DIR}" -DG6D_FUZZ=ON -DG6D_BUILD_TESTS=OFF \
  -DG6D_BUILD_BENCH=OFF -DCMAKE_BUILD_TYPE=RelWithDebInfo >"${BUILD_DIR}.configure.log" 2>&1 || {
  cat "${BUILD_DIR}.configure.log" >&2
  exit 1
}
rm -f "${BUILD_DIR}.configure.log"
build_targets=()
for target in ${TARGETS}; do build_targets+=("g6d-fuzz-${target}"); done
echo "[fuzz] building ${build_targets[*]}" >&2
cmake --build "${BUILD_DIR}" -j"${BUILD_JOBS}" --target "${build_targets[@]}"

mkdir -p "${BUILD_DIR}/logs"
# UBSan already aborts (-fno-sanitize-recover); the stack trace says where.
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1}"

run_target() {
  local target="$1"
  local corpus="${BUILD_DIR}/corpus/${target}" artifacts="${BUILD_DIR}/artifacts/${target}"
  mkdir -p "${corpus}" "${artifacts}"
  cp -f tests/fuzz/corpus/"${target}"/* "${corpus}/"
  touch "${BUILD_DIR}/logs/${target}.start"  # artifacts newer than this are this run's
  local status=0
  "${BUILD_DIR}/tests/fuzz/g6d-fuzz-${target}" "${corpus}" \
    -max_total_time="${SECONDS_PER_TARGET}" -rss_limit_mb=2048 -timeout=25 \
    -artifact_prefix="${artifacts}/" -print_final_stats=1 "${EXTRA_ARGS[@]}" \
    >"${BUILD_DIR}/logs/${target}.log" 2>&1 || status=$?
  echo "${status}" >"${BUILD_DIR}/logs/${target}.status"
}

running=0
for target in ${TARGETS}; do
  echo "[fuzz] ${target}: ${SECONDS_PER_TARGET} s, log ${BUILD_DIR}/logs/${target}.log" >&2
  run_target "${target}" &
  running=$((running + 1))
  if [[ "${running}" -ge "${JOBS}" ]]; then
    wait -n || true
    running=$((running - 1))
  fi
done
wait

# One line per target from its log and folders.
found_any=0
printf '%-15s %12s %8s %18s %16s  %s\n' target executions exec/s corpus coverage result
for target in ${TARGETS}; do
  log="${BUILD_DIR}/logs/${target}.log"
  corpus="${BUILD_DIR}/corpus/${target}"
  artifacts="${BUILD_DIR}/artifacts/${target}"
  executions="$(grep -oE 'stat::number_of_executed_units: +[0-9]+' "${log}" | tail -1 | awk '{print $2}')"
  rate="$(grep -oE 'stat::average_exec_per_sec: +[0-9]+' "${log}" | tail -1 | awk '{print $2}')"
  coverage="$(grep -o 'cov: [0-9]* ft: [0-9]*' "${log}" | tail -1 | awk '{print "cov " $2 " ft " $4}')"
  files="$(find "${corpus}" -type f | wc -l)"
  bytes="$(find "${corpus}" -type f -printf '%s\n' | awk '{s += $1} END {print s + 0}')"
  findings="$(find "${artifacts}" -type f -newer "${BUILD_DIR}/logs/${target}.start" \( -name 'crash-*' -o -name 'leak-*' -o -name 'timeout-*' \
    -o -name 'oom-*' \) | wc -l)"
  status="$(cat "${BUILD_DIR}/logs/${target}.status" 2>/dev/null || echo '?')"
  result=ok
  if grep -qE '==ERROR|SUMMARY: |runtime error:|deadly signal|out-of-memory|ERROR: libFuzzer' "${log}" ||
    [[ "${findings}" -gt 0 ]] || [[ "${status}" != 0 ]]; then
    result="FOUND SOMETHING (exit ${status}, ${findings} artifacts in ${artifacts}/; see ${log})"
    found_any=1
  fi
  printf '%-15s %12s %8s %18s %16s  %s\n' "${target}" "${executions:-?}" "${rate:-?}" \
    "${files} files ${bytes} B" "${coverage:-?}" "${result}"
done
exit "${found_any}"
