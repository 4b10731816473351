#!/usr/bin/env bash
# Installs every Debian package retimegs needs (non-interactive, idempotent) and builds it in
# build/ (Release, -O3, native SIMD). Safe to re-run. Extra arguments go to CMake's configure
# step, e.g. scripts/setup.sh -DRETIMEGS_NATIVE=OFF
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)

packages=(
  g++ cmake ninja-build pkg-config
  libeigen3-dev            # small dense math
  libopencv-dev            # images, flow I/O and estimation, video (FFmpeg backend)
  ffmpeg                   # render's H.264 (.mp4, .mov, .mkv): frames piped to libx264 at a --crf
  libopencv-contrib-dev    # DeepFlow / TV-L1 flow (optflow)
  nlohmann-json3-dev libcli11-dev libfmt-dev libspdlog-dev
  libnanoflann-dev         # nearest neighbours (initialisation, stretching)
  colmap                   # prepare --points colmap (feature_extractor, point_triangulator)
  libgtest-dev libgmock-dev libbenchmark-dev
  slurm-wlm munge          # scripts/test_slurm.sh: a throw-away Slurm cluster for `retimegs slurm`
  libcpp-httplib-dev       # retimegs view: the viewer's HTTP server
  libpng-dev libjpeg-dev    # io/image_io.cpp decodes PNG / JPEG itself, with silent handlers
  clang libclang-rt-14-dev libomp-dev  # scripts/fuzz.sh: libFuzzer, ASan + UBSan (fuzz/)
  python3                  # bench/windows.sh and bench/own_capture.sh read JSON results
)
# Packages a caller needs beside the build's (scripts/test.sh: the browser test's Chromium).
read -ra extra_packages <<< "${RETIMEGS_EXTRA_PACKAGES:-}"
packages+=("${extra_packages[@]}")

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  sudo=""
  if [ "$(id -u)" -ne 0 ]; then sudo="sudo"; fi
  echo "setup: installing ${missing[*]}"
  $sudo apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi

cmake -S "$root" -B "$root/build" -G Ninja -DCMAKE_BUILD_TYPE=Release "$@" > /dev/null
cmake --build "$root/build" -j "$(nproc)"
