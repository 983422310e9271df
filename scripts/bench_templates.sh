#!/usr/bin/env bash
# Builds template caches for every object of the shared datasets at N_T = 324 with
# 2 threads and prints a Markdown table (seconds, size, keypoints per template).
#   bash scripts/bench_templates.sh [OUT_DIR]
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD_DIR="${BUILD_DIR:-build}"
OUT="${1:-out/caches}"
DATA="${DATA:-../shared/data}"
mkdir -p "${OUT}"
echo "| object | mesh | units | seconds | size (MB) | keypoints min / median / max |"
echo "|---|---|---|---|---|---|"
run() {  # id mesh units [extra args]
  local id=$1 mesh=$2 units=$3
  shift 3
  local log
  log=$("${BUILD_DIR}/tools/g6d-build-templates" --mesh "${mesh}" --units "${units}" --object-id "${id}" \
        --out "${OUT}/${id}.g6dcache" --threads 2 "$@" 2>&1 | tail -3)
  local kp secs size
  kp=$(echo "${log}" | sed -n 's/.*min \([0-9]*\) \/ median \([0-9]*\) \/ max \([0-9]*\).*/\1 \/ \2 \/ \3/p')
  secs=$(echo "${log}" | sed -n 's/.* in \([0-9.]*\) s$/\1/p')
  size=$(echo "${log}" | sed -n 's/.*(\([0-9.]*\) MB).*/\1/p')
  echo "| ${id} | $(basename "${mesh}") | ${units} | ${secs} | ${size} | ${kp} |"
}
for mesh in "${DATA}"/lmo/models/obj_*.ply; do
  id=$(basename "${mesh}" .ply)
  run "${id}" "${mesh}" mm --models-info "${DATA}/lmo/models/models_info.json"
done
run obj_000021 "${DATA}/ycbv_real/models/061_foam_brick/textured.obj" m
