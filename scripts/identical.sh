#!/usr/bin/env bash
# Answers of one build, recorded so that two builds can be compared byte for byte: a change
# that means no change in behaviour (a file split, a rename) must leave every answer as it was.
# For each dev set (the first IMAGES images of its BOP'19 targets) with GT masks and without,
# and for the embedded sample, it builds the template caches with this build's
# g6d-build-templates, runs g6d-bench-dataset on one thread, and keeps its answers without
# their timing columns: the BOP CSV (object, S, R, t) and, with GT masks, the per-instance
# records (success, S_A, confidence, errors, stage counts). Then, with BASE_OUT, it compares the caches (cmp) and the
# records (cmp) with another run's.
#
#   BUILD_DIR=build-before OUT=out/identical/before bash scripts/identical.sh
#   BUILD_DIR=build OUT=out/identical/after BASE_OUT=out/identical/before bash scripts/identical.sh
#
# Environment:
#   DATA_DIR=../shared/data   DATASETS="lmo ycbv_real ycbv_clutter synth_dev"   IMAGES=5
#   SAMPLE_FRAMES=6 (0 = no sample)   SAMPLE_WORK=out/identical/sample   THREADS=1   K=18
# Exit status 0 when every run finished and, with BASE_OUT, everything compared equal.
set -euo pipefail
cd "$(dirname "$0")/.."
DATA_DIR="${DATA_DIR:-../shared/data}"
DATASETS="${DATASETS:-lmo ycbv_real ycbv_clutter synth_dev}"
IMAGES="${IMAGES:-5}"
SAMPLE_FRAMES="${SAMPLE_FRAMES:-6}"
THREADS="${THREADS:-1}"
K="${K:-18}"
BUILD_DIR="${BUILD_DIR:-build}"
OUT="${OUT:?set OUT, e.g. out/identical/after}"
mkdir -p "${OUT}"

# The records without the columns that hold times (their names end in _ms or are "ms").
strip_times() {
  python3 - "$1" "$2" <<'PY'
import csv, sys
with open(sys.argv[1], newline="") as f:
    rows = list(csv.reader(f))
keep = [i for i, name in enumerate(rows[0]) if not (name == "ms" or name.endswith("_ms") or "time" in name)]
with open(sys.argv[2], "w", newline="") as f:
    writer = csv.writer(f, lineterminator="\n")
    for row in rows:
        writer.writerow([row[i] for i in keep])
PY
}

# A dataset's BOP'19 targets on its first IMAGES images (by scene, then image id).
subset_targets() {
  python3 - "$1/test_targets_bop19.json" "$2" "${IMAGES}" <<'PY'
import json, sys
targets = json.load(open(sys.argv[1]))
images = sorted({(t["scene_id"], t["im_id"]) for t in targets})[: int(sys.argv[3])]
json.dump([t for t in targets if (t["scene_id"], t["im_id"]) in images], open(sys.argv[2], "w"), indent=1)
PY
}

# Runs the bench on one dataset with masks gt and none; records stripped of times.
run_bench() {  # name dataset caches targets
  local name="$1" dataset="$2" caches="$3" targets="$4" adds_ids
  adds_ids="$(python3 -c 'import json, sys; print(",".join(k for k, e in json.load(open(sys.argv[1])).items() if e.get("name") in ("002_master_chef_can", "061_foam_brick")))' "${dataset}/models/models_info.json")"
  for mode in gt none; do
    local run="${OUT}/${name}_${mode}"
    local extra=()
    [[ "${mode}" == "gt" ]] && extra+=(--records "${run}.records.csv")  # (--masks none has no records)
    echo "[identical] ${name}, masks ${mode}"
    "${BUILD_DIR}/bench/g6d-bench-dataset" --dataset "${dataset}" --caches "${caches}" --targets "${targets}" \
      --threads "${THREADS}" --hypotheses "${K}" ${adds_ids:+--adds-ids "${adds_ids}"} --masks "${mode}" \
      --out "${run}.bop.csv" "${extra[@]}" > "${run}.txt" 2> "${run}.log"
    [[ "${mode}" == "gt" ]] && strip_times "${run}.records.csv" "${run}.answers.csv"
    strip_times "${run}.bop.csv" "${run}.bop_answers.csv"
  done
}

for name in ${DATASETS}; do
  dataset="${DATA_DIR}/${name}"
  caches="${OUT}/caches/${name}"
  targets="${OUT}/${name}_targets.json"
  mkdir -p "${caches}"
  subset_targets "${dataset}" "${targets}"
  python3 - "${dataset}/models/models_info.json" "${targets}" <<'PY' | while IFS=$'\t' read -r id mesh units; do
import json, sys
wanted = {t["obj_id"] for t in json.load(open(sys.argv[2]))}
for key, entry in sorted(json.load(open(sys.argv[1])).items(), key=lambda kv: int(kv[0])):
    if int(key) in wanted:
        print(f"obj_{int(key):06d}\t{entry.get('mesh', f'obj_{int(key):06d}.ply')}\t{entry.get('units', 'mm')}")
PY
    if [[ ! -f "${caches}/${id}.g6dcache" ]]; then
      "${BUILD_DIR}/tools/g6d-build-templates" --mesh "${dataset}/models/${mesh}" --units "${units}" --object-id "${id}" \
        --out "${caches}/${id}.g6dcache" --models-info "${dataset}/models/models_info.json" --threads "${THREADS}" \
        > "${caches}/${id}.log" 2>&1
    fi
  done
  run_bench "${name}" "${dataset}" "${caches}" "${targets}"
done

if [[ "${SAMPLE_FRAMES}" != "0" ]]; then
  # Made in one folder for every build, then copied: a cache records its mesh's path.
  work="${SAMPLE_WORK:-out/identical/sample}"
  sample="${OUT}/sample"
  echo "[identical] the embedded sample (${SAMPLE_FRAMES} frames, seed 1)"
  "${BUILD_DIR}/tools/g6d-make-sample" --out "${work}" --frames "${SAMPLE_FRAMES}" --seed 1 --threads "${THREADS}" \
    --no-log > "${OUT}/sample.log" 2>&1
  rm -rf "${sample}"
  cp -r "${work}" "${sample}"
  run_bench sample "${sample}" "$(dirname "$(find "${sample}" -name '*.g6dcache' | head -1)")" \
    "${sample}/test_targets_bop19.json"
fi

if [[ -z "${BASE_OUT:-}" ]]; then exit 0; fi
status=0
compared=0
while IFS= read -r file; do
  relative="${file#"${BASE_OUT}"/}"
  if cmp -s "${file}" "${OUT}/${relative}"; then
    compared=$((compared + 1))
  else
    echo "[identical] DIFFERENT: ${relative}"
    status=1
  fi
done < <(find "${BASE_OUT}" \( -name '*.g6dcache' -o -name '*answers.csv' \) | sort)
echo "[identical] ${compared} files equal byte for byte (caches and answers without times)"
exit "${status}"
