#!/usr/bin/env bash
# The main job on the embedded default. Today (foundation stage) it sets up, builds the
# template cache of one object and prints the cache summary and a contact sheet; the full
# service + replay demo replaces this once the service and sample issues land.
#   bash scripts/demo.sh                 # LM-O's ape if ../shared is present, else a generated box
#   MESH=path.ply UNITS=mm bash scripts/demo.sh
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
BUILD_DIR="${BUILD_DIR:-build}"
OUT="${OUT:-out/demo}"
mkdir -p "${OUT}"
MESH="${MESH:-../shared/data/lmo/models/obj_000001.ply}"
UNITS="${UNITS:-mm}"
if [[ ! -f "${MESH}" ]]; then
  echo "[demo] ${MESH} is absent: using a procedurally coloured box instead"
  MESH="${OUT}/demo_box.ply"
  UNITS=mm
  python3 scripts/make_demo_mesh.py "${MESH}" 1
fi
ID="${ID:-$(basename "${MESH%.*}")}"
"${BUILD_DIR}/tools/g6d-build-templates" --mesh "${MESH}" --units "${UNITS}" --object-id "${ID}" \
  --out "${OUT}/${ID}.g6dcache" --threads 2
"${BUILD_DIR}/tools/g6d-inspect" "${OUT}/${ID}.g6dcache" --sheet "${OUT}/${ID}_sheet.png"
echo "[demo] cache: ${OUT}/${ID}.g6dcache   contact sheet: ${OUT}/${ID}_sheet.png"
