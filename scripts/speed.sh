#!/usr/bin/env bash
# Speed tables of issue 13, all with g6d-bench-dataset (GT visible masks, no LCM):
#   ablation  every speed change of the solver switched off in turn (and the two that are
#             off by default switched on), on LM-O (rendered depth) and the real-depth
#             YCB-V sets: recall, per-stage p50/p95, work counts;
#   K         the accuracy / time trade-off over K = N_H on LM-O;
#   budget    SolverOptions::budget_ms of 20, 50 and 100 ms on LM-O: actual time, recall,
#             answers cut short.
# Timings need a quiet machine: run nothing else meanwhile (the tables say the load).
#
#   bash scripts/speed.sh [ablation] [K] [budget]      (default: all three)
#
# Environment: DATA_DIR=../shared/data, OUT=out/speed, BUILD_DIR=build (G6D_SKIP_BUILD=1
# uses it as it is), THREADS=2, CACHES=<OUT>/caches (template caches, built when missing),
# EVERY=1 (LM-O targets: every Nth).
set -euo pipefail
cd "$(dirname "$0")/.."
DATA_DIR="${DATA_DIR:-../shared/data}"
OUT="${OUT:-out/speed}"
BUILD_DIR="${BUILD_DIR:-build}"
THREADS="${THREADS:-2}"
CACHES="${CACHES:-${OUT}/caches}"
EVERY="${EVERY:-1}"
SECTIONS=("$@")
[[ ${#SECTIONS[@]} -eq 0 ]] && SECTIONS=(ablation K budget)
for d in lmo ycbv_clutter ycbv_real; do
  if [[ ! -f "${DATA_DIR}/${d}/test_targets_bop19.json" ]]; then
    echo "[speed] ${DATA_DIR}/${d} is missing (set DATA_DIR)" >&2
    exit 2
  fi
done
if [[ "${G6D_SKIP_BUILD:-0}" != "1" ]]; then
  BUILD_DIR="${BUILD_DIR}" bash scripts/setup.sh
fi
BENCH="${BUILD_DIR}/bench/g6d-bench-dataset"
mkdir -p "${OUT}/runs"

# Template caches of every object of the three datasets (built once).
for d in lmo ycbv_clutter ycbv_real; do
  mkdir -p "${CACHES}/${d}"
  python3 - "${DATA_DIR}/${d}/models/models_info.json" <<'EOF' | while IFS=$'\t' read -r id mesh units; do
import json, sys
for key, entry in sorted(json.load(open(sys.argv[1])).items(), key=lambda kv: int(kv[0])):
    print(f"obj_{int(key):06d}\t{entry.get('mesh', f'obj_{int(key):06d}.ply')}\t{entry.get('units', 'mm')}")
EOF
    if [[ ! -f "${CACHES}/${d}/${id}.g6dcache" ]]; then
      echo "[speed] building ${CACHES}/${d}/${id}.g6dcache"
      "${BUILD_DIR}/tools/g6d-build-templates" --mesh "${DATA_DIR}/${d}/models/${mesh}" --units "${units}" \
        --object-id "${id}" --out "${CACHES}/${d}/${id}.g6dcache" \
        --models-info "${DATA_DIR}/${d}/models/models_info.json" --threads "${THREADS}" | tail -1
    fi
  done
done

# run NAME DATASET [g6d-bench-dataset flags]: one benchmark run, its report in runs/NAME.txt.
run() {
  local name=$1 dataset=$2
  shift 2
  local adds=()
  # BOP's YCB-V evaluation scores the master chef can and the foam brick with ADD-S.
  [[ ${dataset} == ycbv_* ]] && adds=(--adds-ids 1,21)
  local every=1
  [[ ${dataset} == lmo ]] && every="${EVERY}"
  echo "[speed] ${name}: ${dataset} $* (load $(cut -d' ' -f1 /proc/loadavg))"
  "${BENCH}" --dataset "${DATA_DIR}/${dataset}" --caches "${CACHES}/${dataset}" --threads "${THREADS}" \
    --every "${every}" "${adds[@]}" --records "${OUT}/runs/${name}.csv" "$@" \
    > "${OUT}/runs/${name}.txt" 2> "${OUT}/runs/${name}.log"
}

# The speed changes of issue 13 and the flag that undoes each (or enables it).
ABLATIONS=(
  "default|"
  "issue-12 pipeline (all changes off)|--no-simd-match --no-merge-pnp --no-cull --full-selection-mesh --icp-coarse-points 0 --icp-point-to-point --icp-stall 0 --mhpo-min-rounds 0"
  "portable matching loop (no AVX-512)|--no-simd-match"
  "PnP poses not merged|--no-merge-pnp"
  "no back-face culling|--no-cull"
  "online mesh for selection|--full-selection-mesh"
  "ICP source not coarse-to-fine|--icp-coarse-points 0"
  "point-to-point ICP (paper)|--icp-point-to-point"
  "no ICP stall rule|--icp-stall 0"
  "MHPO may stop before a round|--mhpo-min-rounds 0"
  "+ ICP probing (6 it., finish 6 best)|--icp-probe 6"
  "+ ICP source inside the mask only|--icp-source-in-mask"
  "+ PnP only on sets with Q_j >= 0.5 Q_1|--pnp-min-quality 0.5"
)

for section in "${SECTIONS[@]}"; do
  case "${section}" in
    ablation)
      for i in "${!ABLATIONS[@]}"; do
        flags="${ABLATIONS[$i]#*|}"
        # shellcheck disable=SC2086
        for d in lmo ycbv_clutter ycbv_real; do run "ablation${i}_${d}" "${d}" ${flags}; done
      done
      ;;
    K)
      for k in 2 4 8 18 36; do run "k${k}_lmo" lmo --hypotheses "${k}"; done
      ;;
    budget)
      for b in 0 100 50 20; do run "budget${b}_lmo" lmo --budget-ms "${b}"; done
      ;;
    *)
      echo "[speed] unknown section '${section}' (ablation, K, budget)" >&2
      exit 2
      ;;
  esac
done

ABLATION_NAMES="$(printf '%s\n' "${ABLATIONS[@]}" | cut -d'|' -f1)" \
python3 - "${OUT}/runs" "${SECTIONS[@]}" <<'EOF'
import os, re, sys
runs, sections = sys.argv[1], sys.argv[2:]

def report(name):
    path = os.path.join(runs, name + ".txt")
    if not os.path.exists(path):
        return None
    text = open(path).read()
    r = {}
    m = re.search(r"^\| \*\*all\*\* \| (\d+)((?: \| [\d.]+)+)", text, re.M)
    if m:
        r["n"] = int(m.group(1))
        r["recall"] = float(m.group(2).split("|")[-1])
    for stage, p50, p95 in re.findall(r"^\| (\w+) \| ([\d.]+) \| ([\d.]+) \|$", text, re.M):
        r[stage] = (float(p50), float(p95))
    m = re.search(r"^\| ICP iterations \| (\d+) \| (\d+) \|", text, re.M)
    if m:
        r["icp_it"] = int(m.group(1))
    m = re.search(r"(\d+) of (\d+) answers cut short", text)
    r["cut"] = f"{m.group(1)} / {m.group(2)}" if m else "0"
    return r

def cell(r, key):
    return f"{r[key][0]:.1f} / {r[key][1]:.1f}" if r and key in r else "-"

if "ablation" in sections:
    names = os.environ["ABLATION_NAMES"].splitlines()
    print("\n### Ablation: each speed change on / off (K = 18, 2 threads)\n")
    print("| variant | LM-O ADD(-S) | ycbv_clutter | ycbv_real | PnP | selection | ICP | MHPO | total p50 / p95 ms | ICP it. p50 |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for i, name in enumerate(names):
        l, c, e = (report(f"ablation{i}_{d}") for d in ("lmo", "ycbv_clutter", "ycbv_real"))
        if not l:
            continue
        rec = lambda r: f"{r['recall']:.1f}%" if r and "recall" in r else "-"
        print(f"| {name} | {rec(l)} | {rec(c)} | {rec(e)} | {cell(l, 'pnp')} | {cell(l, 'observable')} | "
              f"{cell(l, 'icp')} | {cell(l, 'mhpo')} | **{cell(l, 'total')}** | {l.get('icp_it', '-')} |")
    print("\nStage cells: LM-O p50 / p95 ms. ycbv_clutter total p50 / p95 by variant:",
          ", ".join(f"{n}: {cell(report(f'ablation{i}_ycbv_clutter'), 'total')}" for i, n in enumerate(names)))
if "K" in sections:
    print("\n### K = N_H sweep on LM-O (2 threads)\n")
    print("| K | ADD(-S) | total p50 / p95 ms | ICP p50 / p95 | MHPO p50 / p95 |")
    print("|---|---|---|---|---|")
    for k in (2, 4, 8, 18, 36):
        r = report(f"k{k}_lmo")
        if r:
            print(f"| {k} | {r['recall']:.1f}% | {cell(r, 'total')} | {cell(r, 'icp')} | {cell(r, 'mhpo')} |")
if "budget" in sections:
    print("\n### Budget per instance on LM-O (K = 18, 2 threads)\n")
    print("| budget | ADD(-S) | total p50 / p95 ms | answers cut short |")
    print("|---|---|---|---|")
    for b in (0, 100, 50, 20):
        r = report(f"budget{b}_lmo")
        if r:
            print(f"| {'none' if b == 0 else f'{b} ms'} | {r['recall']:.1f}% | {cell(r, 'total')} | {r['cut']} |")
EOF
