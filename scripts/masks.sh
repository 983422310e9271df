#!/usr/bin/env bash
# Solver accuracy and speed with degraded masks (issue 22): every BOP dataset in
# ../shared/data (or DATA_DIR) with test_targets_bop19.json, run by g6d-bench-dataset at
# K = 18 on 2 threads once per mask degradation (--degrade-masks: none, erode, dilate,
# jitter, cut, merge, box; 6 px), then one markdown table: per mode and dataset the
# ADD(-S)@0.1d recall, BOP AR (g6d-eval), the p50 latency per instance and the mean IoU of the masks the
# solver got with the GT visible masks, plus the YCB-Video recall pooled over ycbv_real
# and ycbv_clutter.
#
#   bash scripts/masks.sh [extra g6d-bench-dataset args]     e.g. --every 4
#
# Environment:
#   DATA_DIR=../shared/data   datasets (folders with models/models_info.json and test_targets_bop19.json)
#   DATASETS="ycbv_real ycbv_clutter"   which of them (default: every folder with targets)
#   MODES="none erode dilate jitter cut merge box"   the --degrade-masks modes, rows of the table
#   DEGRADE_PX=6              --degrade-px
#   OUT=out/masks             <dataset>_<mode>.txt (report), .log (per instance), .csv (BOP results), table.md
#   CACHES=$OUT/caches        template caches, <dataset>/<obj>.g6dcache (missing ones are built)
#   BUILD_DIR=build           the build (G6D_SKIP_BUILD=1 to use it as it is; else scripts/setup.sh runs)
#   K=18 THREADS=2            --hypotheses and --threads
# ADD-S: objects with symmetries in models_info.json, plus the YCB-V master chef can and
# foam brick (by name), which BOP's YCB-V evaluation treats as symmetric (as scripts/accuracy.sh).
set -euo pipefail
cd "$(dirname "$0")/.."
# shellcheck source=scripts/lib_g6d.sh
source scripts/lib_g6d.sh
DATA_DIR="${DATA_DIR:-../shared/data}"
OUT="${OUT:-out/masks}"
CACHES="${CACHES:-${OUT}/caches}"
BUILD_DIR="${BUILD_DIR:-build}"
MODES="${MODES:-none erode dilate jitter cut merge box}"
DEGRADE_PX="${DEGRADE_PX:-6}"
K="${K:-18}"
THREADS="${THREADS:-2}"
if [[ ! -d "${DATA_DIR}" ]]; then
  echo "[masks] ${DATA_DIR} does not exist (set DATA_DIR): nothing to measure, skipped"
  exit 0
fi
if [[ "${G6D_SKIP_BUILD:-0}" != "1" ]]; then
  BUILD_DIR="${BUILD_DIR}" bash scripts/setup.sh
fi
if [[ -z "${DATASETS:-}" ]]; then DATASETS="$(g6d_bop_datasets "${DATA_DIR}")"; fi
if [[ -z "${DATASETS// /}" ]]; then
  echo "[masks] no dataset with test_targets_bop19.json in ${DATA_DIR}: nothing to measure, skipped"
  exit 0
fi
mkdir -p "${OUT}"
start_all=$(date +%s)
for name in ${DATASETS}; do
  dataset="${DATA_DIR}/${name}"
  if [[ ! -f "${dataset}/test_targets_bop19.json" ]]; then
    echo "[masks] ${dataset} has no test_targets_bop19.json" >&2
    exit 2
  fi
  g6d_build_missing_caches "${BUILD_DIR}/tools/g6d-build-templates" "${dataset}" "${CACHES}/${name}" "${THREADS}"
  # BOP's YCB-V evaluation scores these with ADD-S although models_info has no symmetries.
  adds_ids="$(python3 -c 'import json, sys; print(",".join(k for k, e in json.load(open(sys.argv[1])).items() if e.get("name") in ("002_master_chef_can", "061_foam_brick")))' "${dataset}/models/models_info.json")"
  for mode in ${MODES}; do
    run="${OUT}/${name}_${mode}"
    start=$(date +%s)
    if ! "${BUILD_DIR}/bench/g6d-bench-dataset" --dataset "${dataset}" --caches "${CACHES}/${name}" \
        --hypotheses "${K}" --threads "${THREADS}" ${adds_ids:+--adds-ids "${adds_ids}"} \
        --degrade-masks "${mode}" --degrade-px "${DEGRADE_PX}" --out "${run}.csv" "$@" \
        > "${run}.txt" 2> "${run}.log"; then
      echo "[masks] ${name} ${mode}: g6d-bench-dataset failed (${run}.log):" >&2
      tail -5 "${run}.log" >&2
      exit 1
    fi
    echo "$(($(date +%s) - start))" > "${run}.seconds"
    # BOP AR (VSD, MSSD, MSPD) of the answers.
    if ! "${BUILD_DIR}/tools/g6d-eval" --dataset "${dataset}" --results "${run}.csv" --json "${run}.eval.json" \
        ${adds_ids:+--adds-ids "${adds_ids}"} > "${run}.eval.txt" 2>&1; then
      echo "[masks] ${name} ${mode}: g6d-eval failed (${run}.eval.txt):" >&2
      tail -5 "${run}.eval.txt" >&2
      exit 1
    fi
    echo "[masks] ${name} ${mode}: $(awk -F' *[|] *' '/^[|] [*][*]all[*][*]/ {print "n " $3 ", ADD(-S) " $8 " %"; exit}' "${run}.txt") in $(cat "${run}.seconds") s"
  done
done

python3 - "${OUT}" "${DEGRADE_PX}" "${K}" "${THREADS}" "${DATASETS}" "${MODES}" <<'EOF' | tee "${OUT}/table.md"
import json, os, re, sys
out, px, k, threads = sys.argv[1:5]
datasets, modes = sys.argv[5].split(), sys.argv[6].split()

def report(name, mode):
    base = os.path.join(out, f"{name}_{mode}")
    text = open(base + ".txt").read()
    all_row = re.search(r"^\| \*\*all\*\* \| (\d+)((?: \| [\d.]+)+)", text, re.M)
    total = re.search(r"^\| total \| ([\d.]+) \| ([\d.]+) \|$", text, re.M)
    iou = re.search(r"mean IoU with the GT visible mask ([\d.]+) over \d+ instances, (\d+) empty", text)
    if not (all_row and total and iou):
        sys.exit(f"[masks] {base}.txt: no recall, latency or mask IoU summary (format changed?)")
    return {"n": int(all_row.group(1)), "recall": float(all_row.group(2).split("|")[-1]),
            "p50": float(total.group(1)), "iou": float(iou.group(1)), "empty": int(iou.group(2)),
            "ar": json.load(open(base + ".eval.json"))["overall"]["ar"],
            "seconds": int(open(base + ".seconds").read())}

runs = {(d, m): report(d, m) for d in datasets for m in modes}
ycbv = [d for d in ("ycbv_real", "ycbv_clutter") if d in datasets]
print(f"\n### Degraded masks, {px} px: ADD(-S)@0.1d recall, BOP AR, p50 ms per instance, mean mask IoU with the GT visible mask (K = {k}, {threads} threads)\n")
header = ["mode"]
for d in datasets:
    n = runs[(d, modes[0])]["n"]
    header += [f"{d} (n = {n}) ADD(-S) %", f"{d} AR", f"{d} p50 ms", f"{d} mask IoU"]
if len(ycbv) == 2:
    header += ["ycbv pooled ADD(-S) %", "ycbv pooled AR"]
header.append("run s")
print("| " + " | ".join(header) + " |")
print("|" + "---|" * len(header))
for m in modes:
    row = [m]
    for d in datasets:
        r = runs[(d, m)]
        empty = f" ({r['empty']} empty)" if r["empty"] else ""
        row += [f"{r['recall']:.1f}", f"{r['ar']:.3f}", f"{r['p50']:.0f}", f"{r['iou']:.3f}{empty}"]
    if len(ycbv) == 2:
        # Pooled over the targets of both sets (AR as a target-weighted mean).
        n = sum(runs[(d, m)]["n"] for d in ycbv)
        correct = sum(runs[(d, m)]["n"] * runs[(d, m)]["recall"] / 100.0 for d in ycbv)
        ar = sum(runs[(d, m)]["n"] * runs[(d, m)]["ar"] for d in ycbv)
        row += [f"{100.0 * correct / max(1, n):.1f}", f"{ar / max(1, n):.3f}"]
    row.append(str(sum(runs[(d, m)]["seconds"] for d in datasets)))
    print("| " + " | ".join(row) + " |")
EOF
echo "[masks] ${OUT}/table.md; all runs $(($(date +%s) - start_all)) s"
