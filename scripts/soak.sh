#!/usr/bin/env bash
# Soak benchmark of g6d-service: the real service binary (a child process of
# g6d-bench-soak, on a private loopback LCM bus) under a fixed-rate replay of the embedded
# sample's frames mixed with every kind of bad frame, for SECONDS (default 600): crashes,
# answers and error answers per kind, mailbox drops, and the service's resident memory,
# threads, file descriptors and CPU every second.
#
#   bash scripts/soak.sh [SECONDS]
#
# Environment:
#   OUT=out/soak          outputs; the sample is made in OUT/sample when missing
#   BUILD_DIR=build       build folder;  G6D_SKIP_BUILD=1: build nothing
#   RATE_HZ=30            messages per second (good and bad together)
#   BAD_EVERY=2           every Nth message is bad (0 = none)
#   WORKERS=2             --workers of the service (and the sample's cache threads)
#   K=                    --hypotheses of the service (default: the service's own)
#   SOAK_ARGS="..."       more g6d-bench-soak arguments, e.g.
#                         "--service-arg=--subscription-queue=16 --max-rss-growth-pct 3"
#
# Writes OUT/summary.json, OUT/samples.csv (one row per second), OUT/service.log,
# OUT/soak.png (RSS, threads, fds over time) and OUT/soak.txt (the printed summary).
# Exit status of g6d-bench-soak: 0 pass, 1 a criterion failed (soak.txt says which), 2 it
# could not run. A run shorter than 2 min measures memory growth from 20% of the run
# instead of from 1 min.
set -euo pipefail
cd "$(dirname "$0")/.."

DURATION="${1:-600}"
if ! [[ "${DURATION}" =~ ^[0-9]+$ ]] || [[ "${DURATION}" -lt 1 ]]; then
  echo "usage: bash scripts/soak.sh [SECONDS]  (a whole number of seconds, default 600)" >&2
  exit 2
fi
OUT="${OUT:-out/soak}"
BUILD_DIR="${BUILD_DIR:-build}"
RATE_HZ="${RATE_HZ:-30}"
BAD_EVERY="${BAD_EVERY:-2}"
WORKERS="${WORKERS:-2}"

if [[ "${G6D_SKIP_BUILD:-0}" != "1" ]]; then
  # Configure first: an existing build folder may predate the g6d-bench-soak target.
  echo "[soak] building g6d-service, g6d-make-sample, g6d-bench-soak in ${BUILD_DIR}" >&2
  cmake -S . -B "${BUILD_DIR}" > /dev/null
  cmake --build "${BUILD_DIR}" -j2 --target g6d-service g6d-make-sample g6d-bench-soak > /dev/null
fi
for bin in service/g6d-service tools/g6d-make-sample bench/g6d-bench-soak; do
  if [[ ! -x "${BUILD_DIR}/${bin}" ]]; then
    echo "[soak] ${BUILD_DIR}/${bin} is not built (run scripts/setup.sh, or set BUILD_DIR)" >&2
    exit 2
  fi
done

# The embedded sample: template caches and an LCM log of its frames (kept when current).
mkdir -p "${OUT}"
"${BUILD_DIR}/tools/g6d-make-sample" --out "${OUT}/sample" --threads "${WORKERS}" --reuse >&2

args=(--service-bin "${BUILD_DIR}/service/g6d-service"
      --templates "${OUT}/sample/caches" --log "${OUT}/sample/sample.lcmlog"
      --duration-s "${DURATION}" --rate-hz "${RATE_HZ}" --bad-every "${BAD_EVERY}"
      --workers "${WORKERS}"
      --service-log "${OUT}/service.log" --summary-json "${OUT}/summary.json"
      --samples-csv "${OUT}/samples.csv" --plot "${OUT}/soak.png")
if [[ -n "${K:-}" ]]; then args+=(--hypotheses "${K}"); fi
# shellcheck disable=SC2206  # SOAK_ARGS is a list of words
if [[ -n "${SOAK_ARGS:-}" ]]; then args+=(${SOAK_ARGS}); fi

status=0
"${BUILD_DIR}/bench/g6d-bench-soak" "${args[@]}" | tee "${OUT}/soak.txt" || status=${PIPESTATUS[0]}
echo "[soak] ${OUT}/{summary.json,samples.csv,service.log,soak.png,soak.txt} (exit ${status})" >&2
exit "${status}"
