#!/usr/bin/env bash
# One BOP scene through the real g6d-service as each input type (issue 15): g6d frames,
# Drake lcmt_image_array, bot_core images_t with raw RGB and with MJPEG colour. Each log is
# served by a service started from the log's own options file (LOG.yaml) and replayed with
# g6d-replay --input-type; the BOP CSVs are compared with the native one row by row.
#   bash scripts/input_types.sh [DATASET] [SCENE]      (default ../shared/data/ycbv_clutter 1)
#   BUILD_DIR=build OUT_DIR=out/input_types K=18 WORKERS=2 bash scripts/input_types.sh
set -euo pipefail
cd "$(dirname "$0")/.."
DATASET="${1:-../shared/data/ycbv_clutter}"
SCENE="${2:-1}"
B="${BUILD_DIR:-build}"
OUT="${OUT_DIR:-out/input_types}"
K="${K:-18}"
WORKERS="${WORKERS:-2}"
URL="udpm://239.255.76.67:$((20000 + $$ % 20000))?ttl=0&recv_buf_size=8388608"
mkdir -p "${OUT}/caches"

# Template caches of the target objects (mesh and units from models_info.json).
python3 - "${DATASET}" <<'PY' > "${OUT}/objects.tsv"
import json, sys
info = json.load(open(f"{sys.argv[1]}/models/models_info.json"))
targets = json.load(open(f"{sys.argv[1]}/test_targets_bop19.json"))
for obj_id in sorted({int(t["obj_id"]) for t in targets}):
    entry = info[str(obj_id)]
    print(f"obj_{obj_id:06d}\t{entry.get('mesh', f'obj_{obj_id:06d}.ply')}\t{entry.get('units', 'mm')}")
PY
while IFS=$'\t' read -r id mesh units; do
  [[ -f "${OUT}/caches/${id}.g6dcache" ]] && continue
  "${B}/tools/g6d-build-templates" --mesh "${DATASET}/models/${mesh}" --units "${units}" \
    --object-id "${id}" --out "${OUT}/caches/${id}.g6dcache" \
    --models-info "${DATASET}/models/models_info.json" --threads "${WORKERS}" | tail -1
done < "${OUT}/objects.tsv"

for spec in g6d:png drake:png bot_core:raw bot_core:jpeg; do
  as=${spec%%:*}; color=${spec##*:}
  log="${OUT}/${as}_${color}.lcmlog"
  "${B}/replay/g6d-bop2lcm" --dataset "${DATASET}" --scene "${SCENE}" --channel INPUT_TYPES \
    --as "${as}" --color "${color}" --out "${log}" | tail -1
  # --tracking off: the BOP images are scored one by one, and the comparison is row by row
  # (a track's constant-velocity start depends on the replay's send times).
  "${B}/service/g6d-service" --templates "${OUT}/caches" --config "${log}.yaml" \
    --hypotheses "${K}" --workers "${WORKERS}" --tracking off --output INPUT_TYPES_POSES \
    --status INPUT_TYPES_STATUS --lcm-url "${URL}" > "${log}.service.log" 2>&1 &
  pid=$!
  "${B}/replay/g6d-replay" --log "${log}" --channel INPUT_TYPES --input-type "${as}" \
    --results-channel INPUT_TYPES_POSES --status-channel INPUT_TYPES_STATUS \
    --wait-for-service-ms 60000 --lcm-url "${URL}" --timeout-ms 60000 \
    --results-csv "${OUT}/${as}_${color}.csv" 2>&1 | tail -1
  kill -TERM "${pid}"
  wait "${pid}" || true
done

# ADD(-S) and AR of each CSV (g6d-eval); BOP's YCB-V evaluation scores the master chef can
# and the foam brick with ADD-S although models_info.json lists no symmetry for them.
adds_ids="$(python3 -c 'import json, sys; print(",".join(k for k, e in json.load(open(sys.argv[1])).items() if e.get("name") in ("002_master_chef_can", "061_foam_brick")))' "${DATASET}/models/models_info.json")"
for name in g6d_png drake_png bot_core_raw bot_core_jpeg; do
  "${B}/tools/g6d-eval" --dataset "${DATASET}" --results "${OUT}/${name}.csv" ${adds_ids:+--adds-ids "${adds_ids}"} \
    | awk -F'|' -v name="${name}" '$2 ~ /^ *all *$/ { gsub(/ /, "", $5); gsub(/ /, "", $9); print name "\t" $5 "\t" $9 }'
done > "${OUT}/metrics.tsv"

python3 - "${OUT}" <<'PY'
import csv, math, sys
def load(path):
    rows = {}
    for r in csv.DictReader(open(path)):
        rows[(int(r["scene_id"]), int(r["im_id"]), int(r["obj_id"]))] = (
            [float(x) for x in r["R"].split()], [float(x) for x in r["t"].split()], r["R"], r["t"])
    return rows
native = load(f"{sys.argv[1]}/g6d_png.csv")
metrics = {row[0]: row[1:] for row in csv.reader(open(f"{sys.argv[1]}/metrics.tsv"), delimiter="\t")}
print("| input | rows | bit-identical to g6d | max / median translation diff (mm) | max rotation diff (deg) | ADD(-S) | AR |")
print("|---|---|---|---|---|---|---|")
add, ar = metrics.get("g6d_png", ["-", "-"])
print(f"| g6d_png | {len(native)} | (reference) | | | {add} | {ar} |")
for name in ["drake_png", "bot_core_raw", "bot_core_jpeg"]:
    other = load(f"{sys.argv[1]}/{name}.csv")
    same, dt, dr = 0, [], []
    for key, (r0, t0, rs0, ts0) in native.items():
        if key not in other:
            continue
        r1, t1, rs1, ts1 = other[key]
        same += rs0 == rs1 and ts0 == ts1
        dt.append(math.dist(t0, t1))
        trace = sum(r0[i] * r1[i] for i in range(9))
        dr.append(math.degrees(math.acos(max(-1.0, min(1.0, (trace - 1) / 2)))))
    dt.sort()
    add, ar = metrics.get(name, ["-", "-"])
    print(f"| {name} | {len(other)}/{len(native)} | {same} | {max(dt):.2f} / {dt[len(dt) // 2]:.2f} | {max(dr):.1f} | {add} | {ar} |")
PY
