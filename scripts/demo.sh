#!/usr/bin/env bash
# The README's first command: g6d end to end, through LCM, as a robot stack would use it.
#   1. set up: install the Debian packages and build (scripts/setup.sh)
#   2. make the embedded sample with g6d-make-sample (textured objects, their template
#      caches, an RGB-D sequence with ground truth as a BOP folder and as an LCM log);
#      kept when it is already there and current
#   3. start g6d-service on a private loopback LCM URL with the sample's caches
#   4. replay the log one frame at a time (g6d-replay --mode wait)
#   5. score the answers against the ground truth (g6d-eval), draw overlays (g6d-overlay)
#   6. print one line per instance and a summary, stop the service
#   7. no masks: the same images again with only object ids and counts (detection
#      requests); the service finds the objects; accuracy printed
#   8. tracking: make the moving-camera sequence (g6d-make-sample --sequence), serve it
#      with tracking on, replay it in real time (its own 30 Hz), print a timeline per
#      object (detected / tracked / re-detected / wrong / dropped), counts, times, accuracy
#
#   bash scripts/demo.sh                        # the embedded sample
#   DATASET=path/to/bop bash scripts/demo.sh    # the same on a BOP dataset folder
#
# Environment:
#   DATASET=DIR        a BOP folder (models/models_info.json, test_targets_bop19.json,
#                      test/NNNNNN/) instead of the sample; missing caches are built
#   IMAGES=LIST        with DATASET: only these image ids, e.g. 0-20 (scored on them only)
#   OUT=DIR            outputs (default out/demo, or out/demo/<dataset name> with DATASET)
#   BUILD_DIR=build    build folder;  G6D_SKIP_APT=1: no apt-get;  G6D_SKIP_BUILD=1: no setup
#   FRAMES=12 SEED=1   the sample's length and seed
#   K=                 hypotheses N_H of the service (default: the service's own, 18)
#   WORKERS=2          solver threads of the service (and template build threads)
#   TRACKING=off       g6d-service --tracking: every sample image (and BOP image) is a new
#                      arrangement, scored on its own; on: tracks across the images
#   EVAL_ARGS="..."    extra g6d-eval arguments, e.g. "--adds-ids 21" (YCB-V's foam brick)
#   SEQUENCE_FRAMES=90 the tracking sequence's length (0: no tracking part; never with DATASET)
#   NO_MASKS=1         0: skip the run without masks
# Exit status 0 only when every step ran and every image was answered.
set -euo pipefail
cd "$(dirname "$0")/.."
# shellcheck source=scripts/lib_g6d.sh
source scripts/lib_g6d.sh

BUILD_DIR="${BUILD_DIR:-build}"
WORKERS="${WORKERS:-2}"
FRAMES="${FRAMES:-12}"
SEED="${SEED:-1}"
SEQUENCE_FRAMES="${SEQUENCE_FRAMES:-90}"
[[ -n "${DATASET:-}" ]] && SEQUENCE_FRAMES=0
if [[ -n "${DATASET:-}" ]]; then
  DATASET="${DATASET%/}"
  for f in "${DATASET}/models/models_info.json" "${DATASET}/test_targets_bop19.json"; do
    if [[ ! -f "${f}" ]]; then
      echo "[demo] ${f} is missing: DATASET must be a BOP folder with models and BOP'19 targets" >&2
      exit 2
    fi
  done
  OUT="${OUT:-out/demo/$(basename "$(cd "${DATASET}" && pwd)")}"
else
  OUT="${OUT:-out/demo}"
fi

if [[ "${G6D_SKIP_BUILD:-0}" != "1" ]]; then
  BUILD_DIR="${BUILD_DIR}" bash scripts/setup.sh
fi
for bin in tools/g6d-make-sample tools/g6d-build-templates tools/g6d-eval tools/g6d-overlay \
           service/g6d-service replay/g6d-bop2lcm replay/g6d-replay; do
  if [[ ! -x "${BUILD_DIR}/${bin}" ]]; then
    echo "[demo] ${BUILD_DIR}/${bin} is not built (run scripts/setup.sh, or set BUILD_DIR)" >&2
    exit 2
  fi
done
start_time=${SECONDS}

mkdir -p "${OUT}"
rm -rf "${OUT}/replay" "${OUT}/overlays" "${OUT}/logs"
rm -f "${OUT}/results.csv" "${OUT}/estimates.jsonl" "${OUT}/eval.json" "${OUT}/eval.txt"
mkdir -p "${OUT}/replay" "${OUT}/logs"

# 1. The data: the sample (made or reused), or the dataset's caches and logs.
declare -a SCENES LOGS
if [[ -z "${DATASET:-}" ]]; then
  DATASET="${OUT}/sample"
  "${BUILD_DIR}/tools/g6d-make-sample" --out "${DATASET}" --frames "${FRAMES}" --seed "${SEED}" \
    --threads "${WORKERS}" --reuse
  CACHE_DIR="${DATASET}/caches"
  SCENES=(1)
  LOGS=("${DATASET}/sample.lcmlog")
  SCORE_ARGS=()
else
  CACHE_DIR="${CACHE_DIR:-${OUT}/caches}"
  g6d_build_missing_caches "${BUILD_DIR}/tools/g6d-build-templates" "${DATASET}" "${CACHE_DIR}" "${WORKERS}"
  read -r -a SCENES <<< "$(g6d_target_scenes "${DATASET}")"
  LOGS=()
  frame_args=()
  SCORE_ARGS=()
  if [[ -n "${IMAGES:-}" ]]; then
    frame_args=(--frames "${IMAGES}")
    SCORE_ARGS=(--estimated-only)
  fi
  for scene in "${SCENES[@]}"; do
    log="${OUT}/logs/$(printf '%06d' "${scene}").lcmlog"
    "${BUILD_DIR}/replay/g6d-bop2lcm" --dataset "${DATASET}" --scene "${scene}" --out "${log}" "${frame_args[@]}"
    LOGS+=("${log}")
  done
fi

# 2. The service on a loopback multicast port of this run only.
URL="$(g6d_lcm_url)"
service_args=(--workers "${WORKERS}" --tracking "${TRACKING:-off}")
if [[ -n "${K:-}" ]]; then service_args+=(--hypotheses "${K}"); fi
trap 'g6d_stop_service || true' EXIT
trap 'exit 130' INT TERM
g6d_start_service "${BUILD_DIR}/service/g6d-service" "${CACHE_DIR}" "${URL}" "${OUT}/service.log" "${service_args[@]}"

# 3. Replay, one frame at a time; the first replay waits for the service's status.
estimates_args=()
if "${BUILD_DIR}/replay/g6d-replay" --help 2>&1 | grep -q -- '--estimates-jsonl'; then
  estimates_args=(--estimates-jsonl)
fi
failed=0
wait_ms=120000
for i in "${!SCENES[@]}"; do
  scene="${SCENES[$i]}"
  extra=("${estimates_args[@]}")
  if ((${#extra[@]})); then extra+=("${OUT}/replay/${scene}.jsonl"); fi
  if ! "${BUILD_DIR}/replay/g6d-replay" --log "${LOGS[$i]}" --lcm-url "${URL}" --mode wait \
      --wait-for-service-ms "${wait_ms}" --results-csv "${OUT}/replay/${scene}.csv" \
      --summary-json "${OUT}/replay/${scene}.json" "${extra[@]}"; then
    echo "[demo] the replay of scene ${scene} did not complete (see ${OUT}/service.log)" >&2
    failed=1
  fi
  wait_ms=10000
  if ! g6d_service_alive; then
    echo "[demo] g6d-service died; the end of its log:" >&2
    tail -20 "${OUT}/service.log" >&2
    exit 1
  fi
done
if ! g6d_stop_service; then
  echo "[demo] g6d-service did not stop cleanly (see ${OUT}/service.log)" >&2
  failed=1
fi
{
  echo "scene_id,im_id,obj_id,score,R,t,time"
  for scene in "${SCENES[@]}"; do
    if [[ -f "${OUT}/replay/${scene}.csv" ]]; then tail -n +2 "${OUT}/replay/${scene}.csv"; fi
  done
} > "${OUT}/results.csv"
if ((${#estimates_args[@]})); then cat "${OUT}/replay/"*.jsonl > "${OUT}/estimates.jsonl"; fi

# 4. Score and draw.
# shellcheck disable=SC2086  # EVAL_ARGS is a list of words
if ! "${BUILD_DIR}/tools/g6d-eval" --dataset "${DATASET}" --results "${OUT}/results.csv" \
    --json "${OUT}/eval.json" --per-instance --threads "${WORKERS}" "${SCORE_ARGS[@]}" ${EVAL_ARGS:-} \
    > "${OUT}/eval.txt"; then
  echo "[demo] g6d-eval failed:" >&2
  cat "${OUT}/eval.txt" >&2
  exit 1
fi
"${BUILD_DIR}/tools/g6d-overlay" --dataset "${DATASET}" --results "${OUT}/results.csv" --out "${OUT}/overlays" \
  --caches "${CACHE_DIR}" > /dev/null

# 5. The table and the summary.
echo
echo "g6d on $(basename "$(cd "${DATASET}" && pwd)"), through g6d-service over LCM:"
python3 scripts/demo_report.py "${OUT}" "${DATASET}"
echo "overlays (estimate green, ground truth blue): ${OUT}/overlays/ ($(find "${OUT}/overlays" -name '*.png' | wc -l) PNGs)"
echo "per-target BOP table: ${OUT}/eval.txt; answers: ${OUT}/results.csv; service log: ${OUT}/service.log"

# 6. No masks: the same images once more, each instance only an object id and a count (a
#    detection request); the service finds the objects itself (learning-free proposals).
if [[ "${NO_MASKS:-1}" == "1" ]]; then
  RUN_NM="${OUT}/no_masks"
  rm -rf "${RUN_NM}"
  mkdir -p "${RUN_NM}/logs"
  g6d_start_service "${BUILD_DIR}/service/g6d-service" "${CACHE_DIR}" "${URL}" "${RUN_NM}/service.log" "${service_args[@]}"
  nm_failed=0
  for scene in "${SCENES[@]}"; do
    log="${RUN_NM}/logs/$(printf '%06d' "${scene}").lcmlog"
    "${BUILD_DIR}/replay/g6d-bop2lcm" --dataset "${DATASET}" --scene "${scene}" --instances none --out "${log}" \
      "${frame_args[@]+"${frame_args[@]}"}" > /dev/null
    if ! "${BUILD_DIR}/replay/g6d-replay" --log "${log}" --lcm-url "${URL}" --mode wait --wait-for-service-ms 120000 \
        --results-csv "${RUN_NM}/${scene}.csv" --summary-json "${RUN_NM}/${scene}.json" > "${RUN_NM}/replay_${scene}.txt" 2>&1; then
      echo "[demo] no masks: the replay of scene ${scene} did not complete (see ${RUN_NM}/service.log)" >&2
      nm_failed=1
    fi
  done
  g6d_stop_service || nm_failed=1
  {
    echo "scene_id,im_id,obj_id,score,R,t,time"
    for scene in "${SCENES[@]}"; do
      if [[ -f "${RUN_NM}/${scene}.csv" ]]; then tail -n +2 "${RUN_NM}/${scene}.csv"; fi
    done
  } > "${RUN_NM}/results.csv"
  # shellcheck disable=SC2086  # EVAL_ARGS is a list of words
  if ((nm_failed == 0)) && "${BUILD_DIR}/tools/g6d-eval" --dataset "${DATASET}" --results "${RUN_NM}/results.csv" \
      --json "${RUN_NM}/eval.json" --threads "${WORKERS}" "${SCORE_ARGS[@]+"${SCORE_ARGS[@]}"}" ${EVAL_ARGS:-} \
      > "${RUN_NM}/eval.txt"; then
    python3 - "${RUN_NM}" "${SCENES[@]}" <<'PYEOF'
import json, sys
run, scenes = sys.argv[1], sys.argv[2:]
overall = json.load(open(f"{run}/eval.json"))["overall"]
latencies = []
for scene in scenes:
    summary = json.load(open(f"{run}/{scene}.json"))
    latencies.append(summary["latency_s"]["p50"])
print(f"\nWithout masks (object ids and counts only; the service finds the objects): "
      f"ADD(-S)@0.1d {100.0 * overall['add_recall']:.1f}% of {overall['targets']} targets, BOP AR {overall['ar']:.3f}, "
      f"p50 {max(latencies):.2f} s per image through LCM")
PYEOF
    echo "no-mask answers: ${RUN_NM}/results.csv; BOP table: ${RUN_NM}/eval.txt; service log: ${RUN_NM}/service.log"
  else
    echo "[demo] no masks: the replay or g6d-eval failed (see ${RUN_NM}/)" >&2
    failed=1
  fi
fi

# 7. Tracking: the moving-camera sequence at its own frame rate, the service tracking.
if ((SEQUENCE_FRAMES > 0)); then
  SEQUENCE="${OUT}/sequence"
  RUN="${OUT}/tracking"
  rm -rf "${RUN}"
  mkdir -p "${RUN}"
  "${BUILD_DIR}/tools/g6d-make-sample" --sequence --out "${SEQUENCE}" --frames "${SEQUENCE_FRAMES}" --seed "${SEED}" \
    --threads "${WORKERS}" --reuse
  sequence_args=(--workers "${WORKERS}" --tracking on)
  if [[ -n "${K:-}" ]]; then sequence_args+=(--hypotheses "${K}"); fi
  g6d_start_service "${BUILD_DIR}/service/g6d-service" "${SEQUENCE}/caches" "${URL}" "${RUN}/service.log" \
    "${sequence_args[@]}"
  # Real time: frames the service cannot take while busy are dropped, as from a camera
  # (g6d-replay then says that some were not answered; that is the point here).
  "${BUILD_DIR}/replay/g6d-replay" --log "${SEQUENCE}/sample.lcmlog" --lcm-url "${URL}" --mode realtime \
    --wait-for-service-ms 120000 --results-csv "${RUN}/results.csv" --summary-json "${RUN}/summary.json" \
    --estimates-jsonl "${RUN}/estimates.jsonl" > "${RUN}/replay.txt" 2>&1 || true
  if ! g6d_stop_service; then
    echo "[demo] g6d-service did not stop cleanly (see ${RUN}/service.log)" >&2
    failed=1
  fi
  if [[ ! -s "${RUN}/estimates.jsonl" ]]; then
    echo "[demo] the sequence got no answers (see ${RUN}/replay.txt, ${RUN}/service.log)" >&2
    failed=1
  elif ! "${BUILD_DIR}/tools/g6d-eval" --dataset "${SEQUENCE}" --results "${RUN}/results.csv" --json "${RUN}/eval.json" \
      --per-instance --estimated-only --threads "${WORKERS}" > "${RUN}/eval.txt"; then
    echo "[demo] g6d-eval failed on the sequence:" >&2
    cat "${RUN}/eval.txt" >&2
    failed=1
  else
    python3 scripts/demo_tracking_report.py "${RUN}" "${SEQUENCE}"
    echo "sequence answers: ${RUN}/estimates.jsonl; service log: ${RUN}/service.log"
  fi
fi
echo "[demo] done in $((SECONDS - start_time)) s after the build"
exit "${failed}"
