# shellcheck shell=bash disable=SC2034,SC2154  # variables shared with the script sourcing it
# Sourced by scripts/gpu_check.sh and scripts/gpu_panoptic.sh, which run on a bare GPU machine
# (DESIGN.md §3): the checks of what the machine must have, the unpacking of the packages that
# scripts/gpu_bundle.sh put in .gpu/, and the lean build (-DRETIMEGS_GPU_ONLY=ON) on every core.
# Expects `root` (the checkout) and `no_gpu_ok` (1: carry on without a GPU); sets `build`,
# `prefix`, `gpu` (1 when there is one), `card`, `nvcc` and `build_seconds`. The packages go to
# $RETIMEGS_GPU_PREFIX, default /tmp/retimegs-gpu-deps (replaced on every run).
build="$root/build-gpu"
prefix=${RETIMEGS_GPU_PREFIX:-/tmp/retimegs-gpu-deps}

die() {
  echo "$(basename "$0" .sh): $*" >&2
  exit 1
}

# What the machine must have; each missing piece ends the run here with one line.
gpu_check_machine() {
  gpu=0
  card="none"
  local listed
  if listed=$(nvidia-smi --query-gpu=name,memory.total,driver_version --format=csv,noheader \
    2> /dev/null) && [[ -n $listed ]]; then
    gpu=1
    card=$(head -n 1 <<< "$listed")
  elif ((!no_gpu_ok)); then
    die "no NVIDIA GPU: nvidia-smi is missing or lists none"
  fi
  nvcc=$(command -v nvcc || true)
  if [[ -z $nvcc && -x /usr/local/cuda/bin/nvcc ]]; then nvcc=/usr/local/cuda/bin/nvcc; fi
  [[ -n $nvcc ]] || die "no nvcc: the CUDA toolkit is missing or its bin/ is not on PATH"
  local tool
  for tool in cmake ninja; do
    command -v "$tool" > /dev/null || die "no $tool on PATH"
  done
  command -v "${CXX:-c++}" > /dev/null || command -v g++ > /dev/null ||
    die "no C++ compiler (c++ or g++, or \$CXX) on PATH"
}

# The packages' files, under a prefix of our own: never into / (no package manager here).
gpu_unpack_bundle() {
  local debs=("$root"/.gpu/*.deb) deb unpack
  [[ -e ${debs[0]} ]] ||
    die "no .gpu/*.deb: run scripts/gpu_bundle.sh on a build machine and bring .gpu/ along"
  rm -rf "$prefix"
  mkdir -p "$prefix"
  for deb in "${debs[@]}"; do
    if command -v dpkg-deb > /dev/null; then
      dpkg-deb -x "$deb" "$prefix"
    else  # a .deb is an ar archive whose data.tar.* holds the files
      unpack=$(mktemp -d)
      (cd "$unpack" && ar x "$deb" && tar -xf data.tar.* -C "$prefix")
      rm -rf "$unpack"
    fi
  done
  # Shared libraries of the prefix, for the linker (those the libraries we link need in turn)
  # and at run time. Debian puts BLAS and LAPACK in folders of their own, which its alternatives
  # system links into lib/<multiarch>/: not done here.
  local lib="$prefix/usr/lib/x86_64-linux-gnu"
  export LD_LIBRARY_PATH="$lib:$lib/blas:$lib/lapack${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
  # Headers of the prefix's multiarch folder (libjpeg's jconfig.h: its version) before the
  # machine's own, which the compiler searches by default and may belong to another version.
  export CPATH="$prefix/usr/include/x86_64-linux-gnu${CPATH:+:$CPATH}"
}

# gpu_build LOG TARGETS [CMAKE_ARGS...]: configures the lean build and builds TARGETS (a
# space-separated list; "all" for everything); on failure prints the log's end and stops.
gpu_build() {
  local log=$1 targets=$2 started=$SECONDS
  shift 2
  # Debian puts CMake packages of architecture-specific libraries under lib/<multiarch>/cmake/,
  # which CMake searches only where it knows the multiarch name: both places are given.
  if ! cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release -DRETIMEGS_GPU_ONLY=ON \
    -DCMAKE_CUDA_COMPILER="$nvcc" \
    "-DCMAKE_PREFIX_PATH=$prefix/usr;$prefix/usr/lib/x86_64-linux-gnu/cmake" "$@" \
    > "$log" 2>&1; then
    tail -n 30 "$log"
    die "configuring failed (log: $log)"
  fi
  # shellcheck disable=SC2086  # the targets are words
  if ! cmake --build "$build" -j "$(nproc)" --target $targets >> "$log" 2>&1; then
    tail -n 30 "$log"
    die "the build failed (log: $log)"
  fi
  build_seconds=$((SECONDS - started))
}
