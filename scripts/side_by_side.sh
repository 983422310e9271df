#!/usr/bin/env bash
# Item 5's speeds for several builds side by side: each round runs every build in turn on the
# same workloads, so that a machine whose speed drifts (VMs here drift by up to 35% within
# minutes) compares builds within a round. p50 of g6d-bench-dataset, K = 18, 2 threads:
#   ycbv_none   YCB-V clutter without masks (3 objects per 640x480 image), per image
#   bins_none   synth_dev's bins with 10 or more target parts, without masks, per image
#   lmo_gt      LM-O every 4th target, GT masks, per instance
#   synth_gt    synth_dev every 3rd target, GT masks, per instance
#   ycbv_gt     YCB-V clutter, GT masks, per instance
#
#   bash scripts/side_by_side.sh NAME=BENCH_BINARY:CACHE_ROOT [NAME=...] [-- extra bench flags]
#   e.g. bash scripts/side_by_side.sh base=/tmp/base/g6d-bench-dataset:out/caches \
#            new=build/bench/g6d-bench-dataset:out/caches
#   (CACHE_ROOT/<dataset>/obj_XXXXXX.g6dcache, built by that build's g6d-build-templates,
#   e.g. with scripts/detect.sh's CACHES; a build of another cache format needs its own.)
#
# Environment: DATA_DIR=../shared/data, ROUNDS=2, WORKLOADS="ycbv_none bins_none lmo_gt synth_gt ycbv_gt".
# Prints one line per round, build and workload, then a markdown table of the p50s in ms.
set -euo pipefail
cd "$(dirname "$0")/.."
DATA_DIR="${DATA_DIR:-../shared/data}"
ROUNDS="${ROUNDS:-2}"
WORKLOADS="${WORKLOADS:-ycbv_none bins_none lmo_gt synth_gt ycbv_gt}"
builds=()
extra=()
while (($#)); do
  if [[ "$1" == "--" ]]; then shift; extra=("$@"); break; fi
  [[ "$1" == *=*:* ]] || { echo "side_by_side: '$1' is not NAME=BENCH_BINARY:CACHE_ROOT" >&2; exit 2; }
  builds+=("$1")
  shift
done
((${#builds[@]})) || { echo "side_by_side: no build given (NAME=BENCH_BINARY:CACHE_ROOT)" >&2; exit 2; }
for set in ycbv_clutter synth_dev lmo; do
  [[ -f "${DATA_DIR}/${set}/test_targets_bop19.json" ]] || { echo "side_by_side: ${DATA_DIR}/${set} is missing (set DATA_DIR)" >&2; exit 2; }
done
work="$(mktemp -d)"
trap 'rm -rf "${work}"' EXIT
# The bins' images with 10 or more target parts.
python3 - "${DATA_DIR}/synth_dev/test_targets_bop19.json" "${work}/bins10.json" <<'EOF'
import collections, json, sys
targets = json.load(open(sys.argv[1]))
count = collections.Counter()
for t in targets:
    if t["scene_id"] < 10:  # scenes 0-9 are the bins (synth_dev/README.md)
        count[(t["scene_id"], t["im_id"])] += t["inst_count"]
json.dump([t for t in targets if count[(t["scene_id"], t["im_id"])] >= 10], open(sys.argv[2], "w"))
EOF
# run BIN CACHES WORKLOAD: prints the p50 in ms.
run() {
  local bin=$1 caches=$2 args=()
  case $3 in
    ycbv_none) args=(--dataset "${DATA_DIR}/ycbv_clutter" --caches "${caches}/ycbv_clutter" --adds-ids 1 --masks none) ;;
    bins_none) args=(--dataset "${DATA_DIR}/synth_dev" --caches "${caches}/synth_dev" --adds-ids 321 --masks none --targets "${work}/bins10.json") ;;
    lmo_gt) args=(--dataset "${DATA_DIR}/lmo" --caches "${caches}/lmo" --every 4) ;;
    synth_gt) args=(--dataset "${DATA_DIR}/synth_dev" --caches "${caches}/synth_dev" --adds-ids 321 --every 3) ;;
    ycbv_gt) args=(--dataset "${DATA_DIR}/ycbv_clutter" --caches "${caches}/ycbv_clutter" --adds-ids 1) ;;
    *) echo "side_by_side: unknown workload $3" >&2; exit 2 ;;
  esac
  "${bin}" "${args[@]}" --threads 2 --hypotheses 18 "${extra[@]}" > "${work}/out.txt" 2> "${work}/err.txt" ||
    { echo "side_by_side: ${bin} failed on $3:" >&2; tail -3 "${work}/err.txt" >&2; exit 1; }
  # Without masks the report's per-image latency; with masks the per-instance total.
  awk '/^latency per image/ {gsub(",", "", $6); print $6; exit} /^\| total \|/ {print $4; exit}' "${work}/out.txt"
}
declare -A p50
for r in $(seq 1 "${ROUNDS}"); do
  for b in "${builds[@]}"; do
    name=${b%%=*}; rest=${b#*=}; bin=${rest%%:*}; caches=${rest#*:}
    for w in ${WORKLOADS}; do
      ms=$(run "${bin}" "${caches}" "${w}")
      echo "[side_by_side] round ${r} ${name} ${w}: p50 ${ms} ms"
      p50[${name},${w}]+="${p50[${name},${w}]:+ / }${ms}"
    done
  done
done
printf '\n| p50 ms (round 1 / 2 / ...) |'
for b in "${builds[@]}"; do printf ' %s |' "${b%%=*}"; done
printf '\n|---|'
for b in "${builds[@]}"; do printf -- '---|'; done
printf '\n'
for w in ${WORKLOADS}; do
  printf '| %s |' "${w}"
  for b in "${builds[@]}"; do printf ' %s |' "${p50[${b%%=*},${w}]}"; done
  printf '\n'
done
