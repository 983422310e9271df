#!/usr/bin/env bash
# Solver accuracy on every BOP dataset in ../shared/data (or DATA_DIR), GT visible masks,
# no LCM: builds the missing template caches, runs g6d-bench-dataset with --score-gt and
# --records on each, and prints each dataset's recall table, the misses by cause (search
# vs score failure) and the per-stage latency. Then fits and measures the confidence
# (scripts/calibrate_confidence.py, leave-one-dataset-out).
#
#   bash scripts/accuracy.sh [extra g6d-bench-dataset args]     e.g. --hypotheses 8, --no-appearance
#
# Environment:
#   DATA_DIR=../shared/data   datasets (folders with models/models_info.json and test_targets_bop19.json)
#   DATASETS="lmo ycbv_clutter ycbv_real"   which of them (default: every folder with targets)
#   OUT=out/accuracy          caches/<dataset>/, <dataset>.txt (the report), <dataset>.csv (records)
#   BUILD_DIR=build           the build (G6D_SKIP_BUILD=1 to use it as it is; else scripts/setup.sh runs)
#   THREADS=2
#   SAMPLE_FRAMES=40          also the project's own sample (g6d-make-sample, seed 7); 0 = skip
# ADD-S: objects with symmetries in models_info.json, plus the YCB-V master chef can and
# foam brick (by name), which BOP's YCB-V evaluation treats as symmetric.
set -euo pipefail
cd "$(dirname "$0")/.."
# shellcheck source=scripts/lib_g6d.sh
source scripts/lib_g6d.sh
DATA_DIR="${DATA_DIR:-../shared/data}"
OUT="${OUT:-out/accuracy}"
BUILD_DIR="${BUILD_DIR:-build}"
THREADS="${THREADS:-2}"
if [[ ! -d "${DATA_DIR}" ]]; then
  echo "[accuracy] ${DATA_DIR} does not exist (set DATA_DIR)" >&2
  exit 2
fi
if [[ "${G6D_SKIP_BUILD:-0}" != "1" ]]; then
  BUILD_DIR="${BUILD_DIR}" bash scripts/setup.sh
fi
if [[ -z "${DATASETS:-}" ]]; then DATASETS="$(g6d_bop_datasets "${DATA_DIR}")"; fi
mkdir -p "${OUT}"
CALIBRATION=()
for name in ${DATASETS}; do
  dataset="${DATA_DIR}/${name}"
  caches="${OUT}/caches/${name}"
  mkdir -p "${caches}"
  python3 - "${dataset}/models/models_info.json" > "${OUT}/${name}.objects" <<'EOF'
import json, sys
for key, entry in sorted(json.load(open(sys.argv[1])).items(), key=lambda kv: int(kv[0])):
    obj_id = int(key)
    print(f"obj_{obj_id:06d}\t{entry.get('mesh', f'obj_{obj_id:06d}.ply')}\t{entry.get('units', 'mm')}")
EOF
  # BOP's YCB-V evaluation scores these with ADD-S although models_info has no symmetries.
  adds_ids="$(python3 -c 'import json, sys; print(",".join(k for k, e in json.load(open(sys.argv[1])).items() if e.get("name") in ("002_master_chef_can", "061_foam_brick")))' "${dataset}/models/models_info.json")"
  while IFS=$'\t' read -r id mesh units; do
    if [[ ! -f "${caches}/${id}.g6dcache" ]]; then
      echo "[accuracy] ${name}: building ${caches}/${id}.g6dcache"
      "${BUILD_DIR}/tools/g6d-build-templates" --mesh "${dataset}/models/${mesh}" --units "${units}" \
        --object-id "${id}" --out "${caches}/${id}.g6dcache" --models-info "${dataset}/models/models_info.json" \
        --threads "${THREADS}" | tail -1
    fi
  done < "${OUT}/${name}.objects"
  echo "[accuracy] ${name}: g6d-bench-dataset $*"
  "${BUILD_DIR}/bench/g6d-bench-dataset" --dataset "${dataset}" --caches "${caches}" --threads "${THREADS}" \
    ${adds_ids:+--adds-ids "${adds_ids}"} --score-gt --records "${OUT}/${name}.csv" --out "${OUT}/${name}_results.csv" \
    "$@" > "${OUT}/${name}.txt" 2> "${OUT}/${name}.log"
  sed -n '/ADD(-S)@0.1d recall/,$p' "${OUT}/${name}.txt"
  echo "BOP'19 metrics (g6d-eval):"
  "${BUILD_DIR}/tools/g6d-eval" --dataset "${dataset}" --results "${OUT}/${name}_results.csv" \
    ${adds_ids:+--adds-ids "${adds_ids}"} | grep -E '^[|] (object|all) '

  CALIBRATION+=("${name}=${OUT}/${name}.csv")
done
# The project's own rendered sample (textured objects, printed box flips), a longer sequence
# than the demo's: a fourth dataset for the confidence fit. SAMPLE_FRAMES=0 skips it.
SAMPLE_FRAMES="${SAMPLE_FRAMES:-40}"
if [[ "${SAMPLE_FRAMES}" != "0" ]]; then
  if ! "${BUILD_DIR}/tools/g6d-make-sample" --out "${OUT}/sample" --frames "${SAMPLE_FRAMES}" --seed 7 --reuse \
      > "${OUT}/sample_make.log" 2>&1; then
    cat "${OUT}/sample_make.log" >&2
    exit 1
  fi
  echo "[accuracy] sample (${SAMPLE_FRAMES} frames, seed 7): g6d-bench-dataset $*"
  "${BUILD_DIR}/bench/g6d-bench-dataset" --dataset "${OUT}/sample" --caches "${OUT}/sample/caches" --threads "${THREADS}" \
    --score-gt --records "${OUT}/sample.csv" "$@" > "${OUT}/sample.txt" 2> "${OUT}/sample.log"
  sed -n '/ADD(-S)@0.1d recall/,$p' "${OUT}/sample.txt"
  CALIBRATION+=("sample=${OUT}/sample.csv")
fi
echo
echo "[accuracy] confidence (scripts/calibrate_confidence.py)"
python3 scripts/calibrate_confidence.py "${CALIBRATION[@]}" | tee "${OUT}/calibration.txt"
