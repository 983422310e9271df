#!/usr/bin/env bash
# Tracking tables of issue 14:
#   calibration  TrackPose from the GT moved at random (g6d-bench-tracking --perturb) on
#                LM-O (rendered depth) and the real YCB-V sets: S_A of tracked-correct vs
#                tracked-wrong poses, and what each loss threshold keeps and refuses;
#   sequences    per-frame ADD(-S) with tracking vs solving every frame, answers by mode,
#                tracked-solve and frame times, wrong poses around the abrupt move, on the
#                sample's moving-camera sequence and the two real 5-frame sequences; and
#                the tracking variants (no constant velocity, re-detection in the frame);
#   service      g6d-service under g6d-replay --mode realtime (the log's own 30 Hz) on the
#                sample sequence, tracking on and off: answered frames per second, latency,
#                CPU of the service process, answers by mode, ADD(-S) of what it published.
# Timings need a quiet machine: run nothing else meanwhile (the tables say the load).
#
#   bash scripts/tracking.sh [calibration] [sequences] [service]     (default: all three)
#
# Environment: DATA_DIR=../shared/data, OUT=out/tracking, BUILD_DIR=build (G6D_SKIP_BUILD=1
# uses it as it is), THREADS=2, CACHES=<OUT>/caches (template caches of the datasets, built
# when missing), SEQUENCE=<OUT>/sequence (the sample sequence, made when missing),
# SERVICE_ARGS="..." (more g6d-service flags for the service section).
set -euo pipefail
cd "$(dirname "$0")/.."
# shellcheck source=scripts/lib_g6d.sh
source scripts/lib_g6d.sh
DATA_DIR="${DATA_DIR:-../shared/data}"
OUT="${OUT:-out/tracking}"
BUILD_DIR="${BUILD_DIR:-build}"
THREADS="${THREADS:-2}"
CACHES="${CACHES:-${OUT}/caches}"
SEQUENCE="${SEQUENCE:-${OUT}/sequence}"
SECTIONS=("$@")
[[ ${#SECTIONS[@]} -eq 0 ]] && SECTIONS=(calibration sequences service)
if [[ "${G6D_SKIP_BUILD:-0}" != "1" ]]; then
  BUILD_DIR="${BUILD_DIR}" bash scripts/setup.sh
fi
BENCH="${BUILD_DIR}/bench/g6d-bench-tracking"
mkdir -p "${OUT}/runs"
have_data=1
for d in lmo ycbv_clutter ycbv_real; do
  if [[ ! -f "${DATA_DIR}/${d}/test_targets_bop19.json" ]]; then
    echo "[tracking] ${DATA_DIR}/${d} is missing (set DATA_DIR): only the sample sequence is measured" >&2
    have_data=0
  fi
done
if ((have_data)); then
  for d in lmo ycbv_clutter ycbv_real; do
    g6d_build_missing_caches "${BUILD_DIR}/tools/g6d-build-templates" "${DATA_DIR}/${d}" "${CACHES}/${d}" "${THREADS}"
  done
fi
"${BUILD_DIR}/tools/g6d-make-sample" --sequence --out "${SEQUENCE}" --threads "${THREADS}" --reuse > /dev/null
ABRUPT="$(python3 -c 'import json,sys; print(json.load(open(sys.argv[1])).get("abrupt_frame", -1))' "${SEQUENCE}/sample.json")"
FPS="$(python3 -c 'import json,sys; print(json.load(open(sys.argv[1]))["options"].get("fps", 30))' "${SEQUENCE}/sample.json" 2> /dev/null || echo 30)"

# run NAME DATASET_DIR CACHE_DIR [g6d-bench-tracking flags]: one run, its report in runs/NAME.txt.
run() {
  local name=$1 dataset=$2 caches=$3
  shift 3
  local adds=()
  # BOP's YCB-V evaluation scores the master chef can and the foam brick with ADD-S.
  [[ $(basename "${dataset}") == ycbv_* ]] && adds=(--adds-ids 1,21)
  echo "[tracking] ${name}: $(basename "${dataset}") $* (load $(cut -d' ' -f1 /proc/loadavg))"
  "${BENCH}" --dataset "${dataset}" --caches "${caches}" --threads "${THREADS}" "${adds[@]}" \
    --records "${OUT}/runs/${name}.csv" "$@" > "${OUT}/runs/${name}.txt" 2> "${OUT}/runs/${name}.log"
}

for section in "${SECTIONS[@]}"; do
  case "${section}" in
    calibration)
      if ((have_data)); then
        run perturb_lmo "${DATA_DIR}/lmo" "${CACHES}/lmo" --perturb 6
        run perturb_ycbv_clutter "${DATA_DIR}/ycbv_clutter" "${CACHES}/ycbv_clutter" --perturb 40
        run perturb_ycbv_real "${DATA_DIR}/ycbv_real" "${CACHES}/ycbv_real" --perturb 60
      fi
      run perturb_sequence "${SEQUENCE}" "${SEQUENCE}/caches" --perturb 2
      ;;
    sequences)
      for variant in "default|" "no constant velocity|--no-constant-velocity" \
                     "periodic re-detection in the frame|--redetect-in-frame" "no periodic re-detection|--redetect-every 0"; do
        name="${variant%%|*}"
        flags="${variant#*|}"
        tag="$(echo "${name}" | tr ' ' '_')"
        # shellcheck disable=SC2086
        run "seq_${tag}_sample" "${SEQUENCE}" "${SEQUENCE}/caches" --fps "${FPS}" --abrupt-frame "${ABRUPT}" ${flags}
        if ((have_data)); then
          # shellcheck disable=SC2086
          run "seq_${tag}_ycbv_real" "${DATA_DIR}/ycbv_real" "${CACHES}/ycbv_real" ${flags}
          # shellcheck disable=SC2086
          run "seq_${tag}_ycbv_clutter" "${DATA_DIR}/ycbv_clutter" "${CACHES}/ycbv_clutter" ${flags}
        fi
      done
      ;;
    service)
      URL="$(g6d_lcm_url)"
      trap 'g6d_stop_service || true' EXIT
      for tracking in on off; do
        dir="${OUT}/service_${tracking}"
        rm -rf "${dir}"
        mkdir -p "${dir}"
        # shellcheck disable=SC2086  # SERVICE_ARGS is a list of words
        g6d_start_service "${BUILD_DIR}/service/g6d-service" "${SEQUENCE}/caches" "${URL}" "${dir}/service.log" \
          --workers "${THREADS}" --tracking "${tracking}" ${SERVICE_ARGS:-}
        # The service's CPU over the replay only: from when it serves (caches loaded).
        for _ in $(seq 600); do
          grep -q "serving" "${dir}/service.log" 2> /dev/null && break
          sleep 0.1
        done
        ticks_before="$(awk '{print $14 + $15}' "/proc/${G6D_SERVICE_PID}/stat")"
        start_ns="$(date +%s%N)"
        echo "[tracking] service, tracking ${tracking}: realtime replay (load $(cut -d' ' -f1 /proc/loadavg))"
        "${BUILD_DIR}/replay/g6d-replay" --log "${SEQUENCE}/sample.lcmlog" --lcm-url "${URL}" --mode realtime \
          --wait-for-service-ms 10000 --results-csv "${dir}/results.csv" --summary-json "${dir}/summary.json" \
          --estimates-jsonl "${dir}/estimates.jsonl" > "${dir}/replay.txt" 2> "${dir}/replay.log" || true
        end_ns="$(date +%s%N)"
        ticks_after="$(awk '{print $14 + $15}' "/proc/${G6D_SERVICE_PID}/stat")"
        g6d_stop_service
        python3 -c "import sys; print((int(sys.argv[2]) - int(sys.argv[1])) / $(getconf CLK_TCK), (int(sys.argv[4]) - int(sys.argv[3])) / 1e9)" \
          "${ticks_before}" "${ticks_after}" "${start_ns}" "${end_ns}" > "${dir}/cpu.txt"
        "${BUILD_DIR}/tools/g6d-eval" --dataset "${SEQUENCE}" --results "${dir}/results.csv" --json "${dir}/eval.json" \
          --per-instance --estimated-only --threads "${THREADS}" > "${dir}/eval.txt" || true
      done
      ;;
    *)
      echo "[tracking] unknown section '${section}' (calibration, sequences, service)" >&2
      exit 2
      ;;
  esac
done

python3 scripts/tracking_report.py "${OUT}" "${SECTIONS[@]}"
