#!/usr/bin/env bash
# The developers' CI check: `.ci/run` as CI runs it, in a fresh clone of this checkout's
# HEAD (beside it, so ../shared resolves the same way) with an empty compiler cache, and the
# stage times at the end. Run it before landing a change to the build or a large change of
# code: CI gives a submission 90 minutes, and a new machine has no cache.
#
#   bash scripts/ci_cold.sh           # cold: empty CCACHE_DIR
#   WARM=1 bash scripts/ci_cold.sh    # warm: the machine's own compiler cache
#
# Environment: CLONE_DIR (default ../g6d-ci-cold, removed first), KEEP=1 keeps the clone.
# The packages must be installed (scripts/setup.sh) or the run installs them first.
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT="$PWD"
CLONE_DIR="${CLONE_DIR:-$(dirname "${ROOT}")/g6d-ci-cold}"
case "${CLONE_DIR}" in
  "${ROOT}" | / | "") echo "[ci_cold] refusing CLONE_DIR=${CLONE_DIR}" >&2; exit 2 ;;
esac
rm -rf "${CLONE_DIR}"
git clone -q --no-hardlinks "${ROOT}" "${CLONE_DIR}"
echo "[ci_cold] clone of $(git rev-parse --short HEAD) in ${CLONE_DIR}"
if [[ "${WARM:-0}" != "1" ]]; then
  CCACHE_DIR="$(mktemp -d /tmp/g6d-ccache-cold.XXXXXX)"
  export CCACHE_DIR
  echo "[ci_cold] empty compiler cache: CCACHE_DIR=${CCACHE_DIR}"
fi
start=$(date +%s)
status=0
(cd "${CLONE_DIR}" && CI=true bash .ci/run </dev/null) > "${ROOT}/out-ci-cold.log" 2>&1 || status=$?
end=$(date +%s)
grep -E '^\[ci\]' "${ROOT}/out-ci-cold.log" || true
echo "[ci_cold] .ci/run exit ${status} in $((end - start)) s ($(((end - start) / 60)) min; CI's limit is 90 min)," \
  "log: out-ci-cold.log"
if [[ "${WARM:-0}" != "1" ]]; then rm -rf "${CCACHE_DIR}"; fi
if [[ "${KEEP:-0}" != "1" ]]; then rm -rf "${CLONE_DIR}"; fi
exit "${status}"
