#!/usr/bin/env bash
# Every dev set with GT masks and without masks, for one build or two side by side (the
# point-pair-feature work: bench/RESULTS.md, "Geometry first"). Builds the missing caches
# per build (the cache format differs between versions), runs g6d-bench-dataset, and prints
# one table: per dataset and input, ADD(-S)@0.1d, BOP AR (no masks), answers wrong with
# confidence >= 0.9, and the latency p50 (per instance with masks, per image without).
#
#   bash scripts/geometry.sh                                  # this checkout's build
#   bash scripts/geometry.sh --every 3                        # extra flags go to every run
#   BASE_BUILD=../g6d-base/build bash scripts/geometry.sh     # and an older build, alternating
#
# Environment:
#   DATA_DIR=../shared/data   DATASETS="synth_dev lmo ycbv_clutter ycbv_real"
#   MODES="gt none"           OUT=out/geometry   BUILD_DIR=build   THREADS=2   K=18
#   ABSENT=1 (requests for objects not in the image, per image, without masks; 0 = none)
# ADD-S: models_info's symmetric objects, plus YCB-V's can and foam brick (by name).
set -euo pipefail
cd "$(dirname "$0")/.."
DATA_DIR="${DATA_DIR:-../shared/data}"
DATASETS="${DATASETS:-synth_dev lmo ycbv_clutter ycbv_real}"
MODES="${MODES:-gt none}"
OUT="${OUT:-out/geometry}"
BUILD_DIR="${BUILD_DIR:-build}"
THREADS="${THREADS:-2}"
K="${K:-18}"
ABSENT="${ABSENT:-1}"
if [[ ! -d "${DATA_DIR}" ]]; then
  echo "[geometry] ${DATA_DIR} does not exist (set DATA_DIR)" >&2
  exit 2
fi
declare -A BUILDS=([new]="${BUILD_DIR}")
LABELS="new"
if [[ -n "${BASE_BUILD:-}" ]]; then
  BUILDS[base]="${BASE_BUILD}"
  LABELS="base new"
fi
mkdir -p "${OUT}"
for label in ${LABELS}; do
  build="${BUILDS[$label]}"
  for name in ${DATASETS}; do
    dataset="${DATA_DIR}/${name}"
    caches="${OUT}/${label}/caches/${name}"
    mkdir -p "${caches}"
    python3 - "${dataset}/models/models_info.json" <<'PY' | while IFS=$'\t' read -r id mesh units; do
import json, sys
for key, entry in sorted(json.load(open(sys.argv[1])).items(), key=lambda kv: int(kv[0])):
    print(f"obj_{int(key):06d}\t{entry.get('mesh', f'obj_{int(key):06d}.ply')}\t{entry.get('units', 'mm')}")
PY
      if [[ ! -f "${caches}/${id}.g6dcache" ]]; then
        "${build}/tools/g6d-build-templates" --mesh "${dataset}/models/${mesh}" --units "${units}" --object-id "${id}" \
          --out "${caches}/${id}.g6dcache" --models-info "${dataset}/models/models_info.json" --threads "${THREADS}" |
          tail -1
      fi
    done
  done
done
for name in ${DATASETS}; do
  dataset="${DATA_DIR}/${name}"
  adds_ids="$(python3 -c 'import json, sys; print(",".join(k for k, e in json.load(open(sys.argv[1])).items() if e.get("name") in ("002_master_chef_can", "061_foam_brick")))' "${dataset}/models/models_info.json")"
  for mode in ${MODES}; do
    for label in ${LABELS}; do  # alternating, so that the two builds see the same machine
      build="${BUILDS[$label]}"
      run="${OUT}/${label}/${name}_${mode}"
      extra=(--masks "${mode}")
      # Answers' records without masks, and requests for absent objects (ABSENT per image),
      # where the build has them (older builds, as a BASE_BUILD, do not).
      if [[ "${mode}" == "gt" ]] || "${build}/bench/g6d-bench-dataset" --help | grep -q -- --absent-requests; then
        extra+=(--records "${run}.records.csv")
        [[ "${mode}" == "none" && "${ABSENT}" != "0" ]] && extra+=(--absent-requests "${ABSENT}")
      fi
      echo "[geometry] ${label}: ${name}, masks ${mode}"
      "${build}/bench/g6d-bench-dataset" --dataset "${dataset}" --caches "${OUT}/${label}/caches/${name}" \
        --threads "${THREADS}" --hypotheses "${K}" ${adds_ids:+--adds-ids "${adds_ids}"} --out "${run}.csv" \
        "${extra[@]}" "$@" > "${run}.txt" 2> "${run}.log"
    done
  done
done
python3 - "${OUT}" "${DATASETS}" "${MODES}" "${LABELS}" <<'PY' | tee "${OUT}/table.md"
import csv, re, sys
out, datasets, modes, labels = sys.argv[1], sys.argv[2].split(), sys.argv[3].split(), sys.argv[4].split()
print("| dataset | masks | build | ADD(-S)@0.1d | BOP AR | answers | wrong, conf >= 0.9 | p50 ms |")
print("|---|---|---|---|---|---|---|---|")
for name in datasets:
    for mode in modes:
        for label in labels:
            run = f"{out}/{label}/{name}_{mode}"
            text = open(run + ".txt").read()
            row = [l for l in text.splitlines() if l.startswith("| **all**")][0].split("|")
            if mode == "gt":
                add, ar = row[-2].strip(), ""
                records = list(csv.DictReader(open(run + ".records.csv")))
                answers = sum(1 for r in records if r["success"] == "1")
                wrong = sum(1 for r in records if r["success"] == "1" and r["correct"] == "0" and float(r["confidence"]) >= 0.9)
                p50 = re.search(r"^\| total \| ([\d.]+)", text, re.M).group(1)
            else:
                add, ar = row[4].strip(), row[5].strip()
                answers = int(row[3])
                try:
                    records = list(csv.DictReader(open(run + ".records.csv")))
                    wrong = sum(1 for r in records if r["absent"] == "0" and r["correct"] == "0" and float(r["confidence"]) >= 0.9)
                except FileNotFoundError:  # an older build: its log names the wrong answers
                    wrong = len(re.findall(r"conf (0\.9\d|1\.00)[^\n]*WRONG", open(run + ".log").read()))
                absent = re.search(r"requests for absent objects: (\d+); answered NO_SOLUTION \d+ \(([\d.]+)%\)", text)
                if absent:
                    answers = f"{answers}; absent {absent.group(1)}: {absent.group(2)}% NO_SOLUTION"
                p50 = re.search(r"latency per image \(ms\): p50 ([\d.]+)", text).group(1)
            print(f"| {name} | {mode} | {label} | {add} | {ar} | {answers} | {wrong} | {p50} |")
PY
