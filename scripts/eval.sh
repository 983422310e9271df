#!/usr/bin/env bash
# End-to-end evaluation of g6d-service on a BOP dataset, through LCM as a robot would use it:
# build the missing template caches, start g6d-service on a private loopback multicast
# port, convert every scene of the targets (g6d-bop2lcm), replay each log one frame at a
# time (g6d-replay --mode wait), then score the merged results with g6d-eval and print one
# table: ADD(-S)@0.1d, AR_VSD, AR_MSSD, AR_MSPD, AR and latency percentiles.
#
#   bash scripts/eval.sh DATASET_DIR [K] [OUT_DIR]
#     K        hypotheses N_H of the service (default 18, as g6d-bench-dataset)
#     OUT_DIR  default out/eval/<dataset folder name>
#
# Leaves in OUT_DIR: results.csv (all scenes, BOP format), summary.json (replay counts,
# latencies and g6d-eval's numbers), eval.json (g6d-eval's full report), logs/ (the LCM
# logs), scenes/ (per-scene CSV and replay summary), service.log, caches/ (unless CACHE_DIR).
# Exit code 0 only when every step ran and every frame was answered.
#
# Environment:
#   BUILD_DIR=build        build folder (configured and built by scripts/setup.sh)
#   G6D_SKIP_APT=1         passed to setup.sh: build only, no apt-get
#   G6D_SKIP_BUILD=1       do not run setup.sh at all (use the binaries in BUILD_DIR as they are)
#   CACHE_DIR=DIR          template caches <obj_XXXXXX>.g6dcache (default OUT_DIR/caches;
#                          one folder per dataset: object ids of different datasets collide)
#   WORKERS=2              service worker threads
#   COLOR=png              colour encoding of the logs (png, zstd, raw: lossless; jpeg: lossy)
#   TIMEOUT_MS=120000      per-frame answer timeout of g6d-replay
#   TRACKING=off           g6d-service --tracking: BOP scores every image on its own, so the
#                          images are detected one by one (on: tracks across a scene's images)
#   EVAL_ARGS="..."        extra g6d-eval arguments, e.g. "--adds-ids 21"
#   INSTANCES=label        g6d-bop2lcm --instances: label (GT visible masks), box (their
#                          bounding boxes only, as g6d-bench-dataset --degrade-masks box) or
#                          none (detection requests: object id and count only, as
#                          g6d-bench-dataset --masks none)
#   IDENTITY=given         g6d-bop2lcm --identity: given, or unknown (no object ids: the
#                          service chooses among every loaded object)
set -euo pipefail
cd "$(dirname "$0")/.."

if [[ $# -lt 1 || $# -gt 3 ]]; then
  sed -n '2,32p' "$0" | sed 's/^# \{0,1\}//'
  exit 2
fi
DATASET="${1%/}"
K="${2:-18}"
if [[ ! -d "${DATASET}" ]]; then
  echo "[eval] dataset folder '${DATASET}' does not exist" >&2
  exit 2
fi
if [[ ! "${K}" =~ ^[1-9][0-9]*$ ]]; then
  echo "[eval] K must be a positive integer, got '${K}'" >&2
  exit 2
fi
NAME="$(basename "$(cd "${DATASET}" && pwd)")"
OUT="${3:-out/eval/${NAME}}"
BUILD_DIR="${BUILD_DIR:-build}"
CACHE_DIR="${CACHE_DIR:-${OUT}/caches}"
WORKERS="${WORKERS:-2}"
COLOR="${COLOR:-png}"
TIMEOUT_MS="${TIMEOUT_MS:-120000}"
MODELS_INFO="${DATASET}/models/models_info.json"
TARGETS="${DATASET}/test_targets_bop19.json"
for f in "${MODELS_INFO}" "${TARGETS}"; do
  if [[ ! -f "${f}" ]]; then
    echo "[eval] ${f} is missing: the evaluation needs the models and the BOP'19 targets" >&2
    exit 2
  fi
done

if [[ "${G6D_SKIP_BUILD:-0}" != "1" ]]; then
  BUILD_DIR="${BUILD_DIR}" bash scripts/setup.sh
fi
BIN_TEMPLATES="${BUILD_DIR}/tools/g6d-build-templates"
BIN_SERVICE="${BUILD_DIR}/service/g6d-service"
BIN_BOP2LCM="${BUILD_DIR}/replay/g6d-bop2lcm"
BIN_REPLAY="${BUILD_DIR}/replay/g6d-replay"
BIN_EVAL="${BUILD_DIR}/tools/g6d-eval"
for bin in "${BIN_TEMPLATES}" "${BIN_SERVICE}" "${BIN_BOP2LCM}" "${BIN_REPLAY}" "${BIN_EVAL}"; do
  if [[ ! -x "${bin}" ]]; then
    echo "[eval] ${bin} is not built (run scripts/setup.sh, or set BUILD_DIR)" >&2
    exit 2
  fi
done

mkdir -p "${OUT}/logs" "${OUT}/scenes" "${CACHE_DIR}"
rm -f "${OUT}"/scenes/* "${OUT}/results.csv" "${OUT}/summary.json" "${OUT}/eval.json"

# 1. Template caches of the target objects: mesh and units from models_info.json
#    (`mesh` relative to models/ and `units`, else obj_XXXXXX.ply in mm).
OBJECTS="$(python3 - "${TARGETS}" "${MODELS_INFO}" <<'EOF'
import json, sys
targets = json.load(open(sys.argv[1]))
info = json.load(open(sys.argv[2]))
for obj_id in sorted({int(t["obj_id"]) for t in targets}):
    entry = info.get(str(obj_id))
    if entry is None:
        sys.exit(f"object {obj_id} of the targets is not in {sys.argv[2]}")
    mesh = entry.get("mesh", f"obj_{obj_id:06d}.ply")
    units = entry.get("units", "mm")
    print(f"obj_{obj_id:06d}\t{mesh}\t{units}")
EOF
)"
SCENES="$(python3 -c 'import json, sys; print(" ".join(str(s) for s in sorted({int(t["scene_id"]) for t in json.load(open(sys.argv[1]))})))' "${TARGETS}")"
echo "[eval] ${NAME}: scenes ${SCENES}; objects $(echo "${OBJECTS}" | cut -f1 | tr '\n' ' ')K = ${K}"
while IFS=$'\t' read -r id mesh units; do
  cache="${CACHE_DIR}/${id}.g6dcache"
  if [[ -f "${cache}" ]]; then
    continue
  fi
  echo "[eval] building ${cache} from models/${mesh} (${units})"
  "${BIN_TEMPLATES}" --mesh "${DATASET}/models/${mesh}" --units "${units}" --object-id "${id}" \
    --out "${cache}" --models-info "${MODELS_INFO}" --threads "${WORKERS}" 2>&1 | tail -1
done <<< "${OBJECTS}"

# 2. The service, on a loopback multicast port of this run only (ttl=0 keeps every packet
#    on this host). recv_buf_size lets a whole frame (~0.5 MB of PNG + zstd) wait in the
#    socket buffer; the kernel caps it at net.core.rmem_max.
PORT=$((20000 + RANDOM % 20000))
URL="udpm://239.255.76.67:${PORT}?ttl=0&recv_buf_size=4194304"
SERVICE_PID=""
stop_service() {
  if [[ -n "${SERVICE_PID}" ]] && kill -0 "${SERVICE_PID}" 2>/dev/null; then
    kill -TERM "${SERVICE_PID}"
    wait "${SERVICE_PID}" || echo "[eval] g6d-service exited with status $? (see ${OUT}/service.log)" >&2
  fi
  SERVICE_PID=""
}
trap stop_service EXIT
trap "exit 130" INT TERM
"${BIN_SERVICE}" --templates "${CACHE_DIR}" --lcm-url "${URL}" --workers "${WORKERS}" --hypotheses "${K}" \
  --tracking "${TRACKING:-off}" > "${OUT}/service.log" 2>&1 &
SERVICE_PID=$!
echo "[eval] g6d-service pid ${SERVICE_PID} on ${URL} (log ${OUT}/service.log)"

# 3. Convert and replay every scene, one frame at a time.
failed=0
first=1
for scene in ${SCENES}; do
  log="${OUT}/logs/$(printf '%06d' "${scene}").lcmlog"
  "${BIN_BOP2LCM}" --dataset "${DATASET}" --scene "${scene}" --color "${COLOR}" \
    --instances "${INSTANCES:-label}" --identity "${IDENTITY:-given}" --out "${log}"
  wait_arg=()
  if [[ ${first} == 1 ]]; then
    wait_arg=(--wait-for-service-ms 120000)  # the service loads its caches first
    first=0
  fi
  if ! "${BIN_REPLAY}" --log "${log}" --lcm-url "${URL}" --mode wait --timeout-ms "${TIMEOUT_MS}" "${wait_arg[@]}" \
      --results-csv "${OUT}/scenes/${scene}.csv" --summary-json "${OUT}/scenes/${scene}.json"; then
    echo "[eval] replay of scene ${scene} did not complete" >&2
    failed=1
  fi
  if ! kill -0 "${SERVICE_PID}" 2>/dev/null; then
    echo "[eval] g6d-service died; its log:" >&2
    tail -20 "${OUT}/service.log" >&2
    exit 1
  fi
done
stop_service

# 4. Merge the scenes (one header) and evaluate.
{
  echo "scene_id,im_id,obj_id,score,R,t,time"
  for scene in ${SCENES}; do
    if [[ -f "${OUT}/scenes/${scene}.csv" ]]; then tail -n +2 "${OUT}/scenes/${scene}.csv"; fi
  done
} > "${OUT}/results.csv"
# shellcheck disable=SC2086  # EVAL_ARGS is a list of words
if ! "${BIN_EVAL}" --dataset "${DATASET}" --results "${OUT}/results.csv" --json "${OUT}/eval.json" \
    ${EVAL_ARGS:-} > "${OUT}/eval.txt"; then
  echo "[eval] g6d-eval failed:" >&2
  cat "${OUT}/eval.txt" >&2
  exit 1
fi

# 5. One summary JSON and one table.
python3 - "${OUT}" "${NAME}" "${K}" "${SCENES}" <<'EOF'
import json, sys
out, name, k, scenes = sys.argv[1], sys.argv[2], int(sys.argv[3]), sys.argv[4].split()

def percentile(values, q):  # nearest rank, as g6d-replay and g6d-bench-dataset
    if not values:
        return 0.0
    values = sorted(values)
    return values[int(q * (len(values) - 1) + 0.5)]

counts = dict(sent=0, answered=0, lost=0, timed_out=0, late=0, rejected_frames=0)
estimates_by_status, latencies, service_times, solve_by_object, solve_all = {}, [], [], {}, []
for scene in scenes:
    try:
        replay = json.load(open(f"{out}/scenes/{scene}.json"))
    except FileNotFoundError:
        continue
    for key in counts:
        counts[key] += replay[key]
    for status, n in replay["estimates"]["by_status"].items():
        estimates_by_status[status] = estimates_by_status.get(status, 0) + n
    for frame in replay["frames"]:
        if not frame["answered"]:
            continue
        latencies.append(frame["latency_s"])
        service_times.append(frame["service_total_s"])
        for estimate in frame.get("estimates", []):
            solve_by_object.setdefault(estimate["object_id"], []).append(estimate["solve_time_s"])
            solve_all.append(estimate["solve_time_s"])
evaluation = json.load(open(f"{out}/eval.json"))
overall = evaluation["overall"]
ok = estimates_by_status.get("ok", 0)
summary = {
    "dataset": name, "hypotheses": k, "scenes": [int(s) for s in scenes], **counts,
    "estimates": {"total": sum(estimates_by_status.values()), "ok": ok,
                  "failed": sum(estimates_by_status.values()) - ok, "by_status": estimates_by_status},
    "latency_s": {"p50": percentile(latencies, 0.5), "p95": percentile(latencies, 0.95),
                  "max": max(latencies, default=0.0)},
    "service_total_s": {"p50": percentile(service_times, 0.5), "p95": percentile(service_times, 0.95)},
    "solve_time_s": {"p50": percentile(solve_all, 0.5), "p95": percentile(solve_all, 0.95)},
    "metrics": {key: overall[key] for key in ("targets", "add_recall", "ar_vsd", "ar_mssd", "ar_mspd", "ar")},
    "objects": [{"name": o["name"], "add_kind": o["add_kind"], "targets": o["targets"],
                 **{key: o[key] for key in ("add_recall", "ar_vsd", "ar_mssd", "ar_mspd", "ar")},
                 "solve_p50_s": percentile(solve_by_object.get(o["name"], []), 0.5),
                 "solve_p95_s": percentile(solve_by_object.get(o["name"], []), 0.95)}
                for o in evaluation["objects"]],
}
json.dump(summary, open(f"{out}/summary.json", "w"), indent=2)

print(f"\n{name}: g6d-service through LCM, K = {k}; {counts['sent']} images sent, {counts['answered']} answered, "
      f"{counts['lost']} lost; {ok} of {summary['estimates']['total']} estimates ok\n")
print("| object | targets | ADD(-S) | AR_VSD | AR_MSSD | AR_MSPD | AR | p50 (s) | p95 (s) |")
print("|---|---|---|---|---|---|---|---|---|")
for o in summary["objects"]:
    label = o["name"] + (" (ADD-S)" if o["add_kind"] == "ADD-S" else "")
    print(f"| {label} | {o['targets']} | {100 * o['add_recall']:.1f} | {o['ar_vsd']:.3f} | {o['ar_mssd']:.3f} | "
          f"{o['ar_mspd']:.3f} | {o['ar']:.3f} | {o['solve_p50_s']:.2f} | {o['solve_p95_s']:.2f} |")
m = summary["metrics"]
print(f"| **all** | {m['targets']} | {100 * m['add_recall']:.1f} | {m['ar_vsd']:.3f} | {m['ar_mssd']:.3f} | "
      f"{m['ar_mspd']:.3f} | {m['ar']:.3f} | {summary['latency_s']['p50']:.2f} | {summary['latency_s']['p95']:.2f} |")
print("\nADD(-S) = recall (%) within 0.1 d; AR as BOP'19. Latency: per object the solver time per instance, "
      "in the 'all' row the end-to-end time per image (send -> answer through LCM).")
EOF
echo "[eval] wrote ${OUT}/results.csv, ${OUT}/summary.json, ${OUT}/eval.json"
if [[ ${failed} != 0 ]]; then
  echo "[eval] some frames got no answer: see ${OUT}/scenes/*.json" >&2
  exit 1
fi
