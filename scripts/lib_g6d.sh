# shellcheck shell=bash
# Shell helpers for scripts/demo.sh (source it; it defines functions and nothing else runs).
# Every function prints its progress to stderr with a "[g6d]" prefix and fails (non-zero)
# with a message saying what went wrong.

# g6d_lcm_url: a private loopback LCM URL for this run: a random multicast port, ttl=0
# (packets never leave the host), and a 4 MB receive buffer so that a whole frame (~0.5-1
# MB of PNG + zstd) can wait in the socket (the kernel caps it at net.core.rmem_max).
g6d_lcm_url() {
  echo "udpm://239.255.76.67:$((20000 + RANDOM % 20000))?ttl=0&recv_buf_size=4194304"
}

# g6d_target_objects DATASET: "obj_XXXXXX<TAB>mesh<TAB>units" per object of the BOP'19
# targets (every object of models_info.json when there is no targets file); mesh relative
# to models/ and units from models_info.json's `mesh` / `units` (BOP default:
# obj_XXXXXX.ply in mm).
g6d_target_objects() {
  python3 - "$1" <<'PY'
import json, os, sys
root = sys.argv[1]
info = json.load(open(os.path.join(root, "models", "models_info.json")))
targets_path = os.path.join(root, "test_targets_bop19.json")
if os.path.exists(targets_path):
    ids = sorted({int(t["obj_id"]) for t in json.load(open(targets_path))})
else:
    ids = sorted(int(k) for k in info)
for obj_id in ids:
    entry = info.get(str(obj_id))
    if entry is None:
        sys.exit(f"object {obj_id} of the targets is not in {root}/models/models_info.json")
    print(f"obj_{obj_id:06d}\t{entry.get('mesh', f'obj_{obj_id:06d}.ply')}\t{entry.get('units', 'mm')}")
PY
}

# g6d_target_scenes DATASET: the scene ids of the BOP'19 targets (every scene folder of
# test/ when there is no targets file), space separated.
g6d_target_scenes() {
  python3 - "$1" <<'PY'
import json, os, sys
root = sys.argv[1]
targets_path = os.path.join(root, "test_targets_bop19.json")
if os.path.exists(targets_path):
    scenes = sorted({int(t["scene_id"]) for t in json.load(open(targets_path))})
else:
    scenes = sorted(int(d) for d in os.listdir(os.path.join(root, "test")) if d.isdigit())
print(" ".join(str(s) for s in scenes))
PY
}

# g6d_build_missing_caches BIN_BUILD_TEMPLATES DATASET CACHE_DIR THREADS: builds
# CACHE_DIR/<obj>.g6dcache for every target object that has none yet (symmetries from
# models_info.json).
g6d_build_missing_caches() {
  local bin="$1" dataset="$2" cache_dir="$3" threads="$4" objects id mesh units cache
  mkdir -p "${cache_dir}"
  objects="$(g6d_target_objects "${dataset}")" || return 1
  while IFS=$'\t' read -r id mesh units; do
    cache="${cache_dir}/${id}.g6dcache"
    [[ -f "${cache}" ]] && continue
    echo "[g6d] building ${cache} from ${dataset}/models/${mesh} (${units})" >&2
    "${bin}" --mesh "${dataset}/models/${mesh}" --units "${units}" --object-id "${id}" --out "${cache}" \
      --models-info "${dataset}/models/models_info.json" --threads "${threads}" > /dev/null || return 1
  done <<< "${objects}"
}

# g6d_start_service BIN_SERVICE CACHE_DIR URL LOG [more service arguments...]: starts
# g6d-service in the background; its pid goes into G6D_SERVICE_PID. Pair it with
# `trap g6d_stop_service EXIT`.
G6D_SERVICE_PID=""
g6d_start_service() {
  local bin="$1" cache_dir="$2" url="$3" log="$4"
  shift 4
  "${bin}" --templates "${cache_dir}" --lcm-url "${url}" "$@" > "${log}" 2>&1 &
  G6D_SERVICE_PID=$!
  echo "[g6d] g6d-service pid ${G6D_SERVICE_PID} on ${url} (log ${log})" >&2
}

# g6d_stop_service: SIGTERM to the service started by g6d_start_service and wait for it;
# returns its exit status (0 after a clean shutdown). Safe to call twice.
g6d_stop_service() {
  local status=0
  if [[ -n "${G6D_SERVICE_PID}" ]] && kill -0 "${G6D_SERVICE_PID}" 2> /dev/null; then
    kill -TERM "${G6D_SERVICE_PID}"
    wait "${G6D_SERVICE_PID}" || status=$?
  fi
  G6D_SERVICE_PID=""
  return "${status}"
}

# g6d_service_alive: true while the service started by g6d_start_service runs.
g6d_service_alive() {
  [[ -n "${G6D_SERVICE_PID}" ]] && kill -0 "${G6D_SERVICE_PID}" 2> /dev/null
}

# g6d_bop_datasets DATA_DIR: the names of the folders of DATA_DIR that are BOP datasets with
# BOP'19 targets (test_targets_bop19.json and models/models_info.json), space-separated.
g6d_bop_datasets() {
  local d names=""
  for d in "$1"/*/; do
    [[ -f "${d}/test_targets_bop19.json" && -f "${d}/models/models_info.json" ]] && names+="$(basename "${d}") "
  done
  echo "${names}"
}
