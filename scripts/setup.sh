#!/usr/bin/env bash
# Installs every Debian package g6d needs (idempotent), then configures and builds.
#   bash scripts/setup.sh            # packages + Release build in ./build
#   G6D_SKIP_APT=1 bash scripts/setup.sh   # build only
#   G6D_SKIP_BUILD=1 bash scripts/setup.sh # packages only
#   BUILD_DIR=build-x CMAKE_ARGS="-DG6D_SANITIZE=thread" bash scripts/setup.sh
#   BUILD_TARGETS="service_test executor_test" bash scripts/setup.sh   # only these targets
set -euo pipefail
cd "$(dirname "$0")/.."

PACKAGES=(
  build-essential cmake pkg-config ccache git ninja-build lld
  liblcm-dev liblcm-bin libglib2.0-dev liblcm-java default-jdk-headless
  libeigen3-dev libopencv-dev libopen3d-dev libassimp-dev libosmesa6-dev
  libceres-dev libzstd-dev zlib1g-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  libspdlog-dev libcli11-dev nlohmann-json3-dev libyaml-cpp-dev
  python3 python3-dev pybind11-dev python3-numpy python3-pytest
  clang libclang-rt-14-dev
)

if [[ "${G6D_SKIP_APT:-0}" != "1" ]]; then
  apt_start=$(date +%s)
  missing=()
  for p in "${PACKAGES[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
  done
  SUDO=""
  if [[ $(id -u) -ne 0 ]]; then SUDO="sudo"; fi
  echo "[setup] apt-get update"
  $SUDO apt-get update -qq
  if ((${#missing[@]})); then
    echo "[setup] installing: ${missing[*]}"
    DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
  else
    echo "[setup] all ${#PACKAGES[@]} packages already installed"
  fi
  echo "[setup] packages: $(($(date +%s) - apt_start)) s"
fi

if [[ "${G6D_SKIP_BUILD:-0}" == "1" ]]; then exit 0; fi

BUILD_DIR="${BUILD_DIR:-build}"
JOBS="${JOBS:-2}"
# ccache hits across clones and build folders: paths below the checkout count as relative.
export CCACHE_BASEDIR="${CCACHE_BASEDIR:-$PWD}" CCACHE_NOHASHDIR="${CCACHE_NOHASHDIR:-true}"
# Ninja for a new build folder (it keeps both cores busy across targets and logs each
# step's time in .ninja_log); a folder configured before keeps its generator.
GENERATOR_ARGS=()
if [[ ! -f "${BUILD_DIR}/CMakeCache.txt" ]] && command -v ninja >/dev/null; then
  GENERATOR_ARGS=(-G Ninja)
fi
configure_start=$(date +%s)
echo "[setup] configuring ${BUILD_DIR}"
cmake -S . -B "${BUILD_DIR}" "${GENERATOR_ARGS[@]}" -DCMAKE_BUILD_TYPE="${BUILD_TYPE:-Release}" ${CMAKE_ARGS:-} >/dev/null
# BUILD_TARGETS="a b" builds only those targets (the sanitizer suites use it).
TARGET_ARGS=()
for t in ${BUILD_TARGETS:-}; do TARGET_ARGS+=(--target "$t"); done
echo "[setup] building with -j${JOBS}${BUILD_TARGETS:+ (targets: ${BUILD_TARGETS})}"
build_start=$(date +%s)
cmake --build "${BUILD_DIR}" -j"${JOBS}" "${TARGET_ARGS[@]}"
build_end=$(date +%s)
echo "[setup] done: binaries in ${BUILD_DIR}/ (configure $((build_start - configure_start)) s," \
  "build $((build_end - build_start)) s)"
