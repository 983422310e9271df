#!/usr/bin/env bash
# Detection without masks (issue 23): the BOP localization task (per image only the ids of
# the target objects and their instance counts) on every BOP dataset in ../shared/data (or
# DATA_DIR) and on the embedded sample, by g6d-bench-dataset --masks none at K = 18 on 2
# threads; then one markdown table: per dataset the targets, ADD(-S)@0.1d, BOP AR (VSD,
# MSSD, MSPD) and the latency per image, plus the real YCB-V sets pooled (the issue's bar).
#
#   bash scripts/detect.sh [extra g6d-bench-dataset args]     e.g. --every 3
#
# Environment:
#   DATA_DIR=../shared/data   datasets (folders with models/models_info.json and test_targets_bop19.json)
#   DATASETS="ycbv_real ycbv_clutter"   which of them (default: every folder with targets)
#   SAMPLE=1                  also the embedded sample (g6d-make-sample --seed 1, 12 frames; 0 = no)
#   OUT=out/detect            <dataset>.txt (report), .log (per image), .csv (BOP results), pictures/, table.md
#   CACHES=$OUT/caches        template caches, <dataset>/<obj>.g6dcache (missing ones are built)
#   BUILD_DIR=build           the build (G6D_SKIP_BUILD=1 to use it as it is; else scripts/setup.sh runs)
#   K=18 THREADS=2            --hypotheses and --threads
#   PICTURES=0                1: DrawDetectionPicture per image into $OUT/pictures/<dataset>/
# ADD-S: objects with symmetries in models_info.json, plus the YCB-V master chef can and
# foam brick (by name), which BOP's YCB-V evaluation treats as symmetric (as scripts/accuracy.sh).
# LM-O is reported but says little: its depth holds only the annotated objects (no table,
# no clutter), which makes proposals unrealistically easy.
set -euo pipefail
cd "$(dirname "$0")/.."
# shellcheck source=scripts/lib_g6d.sh
source scripts/lib_g6d.sh
DATA_DIR="${DATA_DIR:-../shared/data}"
OUT="${OUT:-out/detect}"
CACHES="${CACHES:-${OUT}/caches}"
BUILD_DIR="${BUILD_DIR:-build}"
K="${K:-18}"
THREADS="${THREADS:-2}"
SAMPLE="${SAMPLE:-1}"
PICTURES="${PICTURES:-0}"

if [[ "${G6D_SKIP_BUILD:-0}" != "1" ]]; then
  BUILD_DIR="${BUILD_DIR}" bash scripts/setup.sh
fi
mkdir -p "${OUT}"
declare -a NAMES PATHS
if [[ -d "${DATA_DIR}" ]]; then
  if [[ -z "${DATASETS:-}" ]]; then DATASETS="$(g6d_bop_datasets "${DATA_DIR}")"; fi
  for name in ${DATASETS}; do
    NAMES+=("${name}")
    PATHS+=("${DATA_DIR}/${name}")
  done
else
  echo "[detect] ${DATA_DIR} does not exist (set DATA_DIR): only the sample"
fi
if [[ "${SAMPLE}" == "1" ]]; then
  "${BUILD_DIR}/tools/g6d-make-sample" --out "${OUT}/sample" --frames 12 --seed 1 --threads "${THREADS}" --reuse \
    > "${OUT}/sample.make.log" 2>&1
  NAMES+=("sample")
  PATHS+=("${OUT}/sample")
fi
if [[ ${#NAMES[@]} -eq 0 ]]; then
  echo "[detect] no dataset to measure: skipped"
  exit 0
fi

start_all=$(date +%s)
for i in "${!NAMES[@]}"; do
  name="${NAMES[$i]}"
  dataset="${PATHS[$i]}"
  if [[ "${name}" == "sample" ]]; then
    caches="${dataset}/caches"
  else
    caches="${CACHES}/${name}"
    g6d_build_missing_caches "${BUILD_DIR}/tools/g6d-build-templates" "${dataset}" "${caches}" "${THREADS}"
  fi
  adds_ids="$(python3 -c 'import json, sys; print(",".join(k for k, e in json.load(open(sys.argv[1])).items() if e.get("name") in ("002_master_chef_can", "061_foam_brick")))' "${dataset}/models/models_info.json")"
  picture_args=()
  if [[ "${PICTURES}" == "1" ]]; then
    mkdir -p "${OUT}/pictures/${name}"
    picture_args=(--detect-pictures "${OUT}/pictures/${name}")
  fi
  run="${OUT}/${name}"
  start=$(date +%s)
  if ! "${BUILD_DIR}/bench/g6d-bench-dataset" --dataset "${dataset}" --caches "${caches}" --masks none \
      --hypotheses "${K}" --threads "${THREADS}" ${adds_ids:+--adds-ids "${adds_ids}"} --out "${run}.csv" \
      "${picture_args[@]}" "$@" > "${run}.txt" 2> "${run}.log"; then
    echo "[detect] ${name}: g6d-bench-dataset failed (${run}.log):" >&2
    tail -5 "${run}.log" >&2
    exit 1
  fi
  echo "$(($(date +%s) - start))" > "${run}.seconds"
  echo "[detect] ${name}: $(awk -F' *[|] *' '/^[|] [*][*]all[*][*]/ {print "targets " $3 ", ADD(-S) " $5 " %, AR " $6; exit}' "${run}.txt") in $(cat "${run}.seconds") s"
done

python3 - "${OUT}" "${K}" "${THREADS}" "${NAMES[@]}" <<'EOF' | tee "${OUT}/table.md"
import os, re, sys
out, k, threads = sys.argv[1:4]
names = sys.argv[4:]

def report(name):
    text = open(os.path.join(out, name + ".txt")).read()
    row = re.search(r"^\| \*\*all\*\* \| (\d+) \| (\d+) \| ([\d.]+) \| ([\d.]+) \| ([\d.]+) \| ([\d.]+) \| ([\d.]+) \|$", text, re.M)
    latency = re.search(r"latency per image \(ms\): p50 ([\d.]+), p95 ([\d.]+)", text)
    if not (row and latency):
        sys.exit(f"[detect] {name}.txt: no summary row or latency (format changed?)")
    targets, answered = int(row.group(1)), int(row.group(2))
    add, ar, vsd, mssd, mspd = (float(row.group(i)) for i in range(3, 8))
    return dict(targets=targets, answered=answered, add=add, ar=ar, vsd=vsd, mssd=mssd, mspd=mspd,
                p50=float(latency.group(1)), p95=float(latency.group(2)))

runs = {n: report(n) for n in names}
print(f"\n### No masks: BOP localization (ids and counts given), K = {k}, {threads} threads\n")
print("| dataset | targets | answered | ADD(-S)@0.1d % | AR | AR_VSD | AR_MSSD | AR_MSPD | per image p50 / p95 ms |")
print("|---|---|---|---|---|---|---|---|---|")
for n in names:
    r = runs[n]
    print(f"| {n} | {r['targets']} | {r['answered']} | {r['add']:.1f} | {r['ar']:.3f} | {r['vsd']:.3f} | {r['mssd']:.3f} | "
          f"{r['mspd']:.3f} | {r['p50']:.0f} / {r['p95']:.0f} |")
ycbv = [n for n in ("ycbv_clutter", "ycbv_real") if n in runs]
if len(ycbv) == 2:
    t = sum(runs[n]["targets"] for n in ycbv)
    add = sum(runs[n]["add"] * runs[n]["targets"] for n in ycbv) / t
    ar = sum(runs[n]["ar"] * runs[n]["targets"] for n in ycbv) / t
    print(f"| **real YCB-V pooled** | {t} | | **{add:.1f}** | **{ar:.3f}** | | | | |")
EOF
echo "[detect] ${OUT}/table.md; all runs $(($(date +%s) - start_all)) s"
