#!/usr/bin/env bash
# Run on a build machine (Debian 12): downloads into .gpu/ the Debian packages that the lean GPU
# build (-DRETIMEGS_GPU_ONLY=ON) needs, for scripts/gpu_check.sh on a bare GPU machine, which has
# no package manager and no network. Prints their total size: the files brought to that machine
# may take 64 MiB in all (DESIGN.md §3).
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)

packages=(
  libeigen3-dev                 # header-only
  libfmt-dev libfmt9            # fmt's headers and CMake files; the shared library core links
  libgtest-dev libgmock-dev     # static libraries; GTest's CMake files refer to gmock's too
  nlohmann-json3-dev            # header-only
  libnanoflann-dev              # header-only (train's nearest neighbours)
)

bundle="$root/.gpu"
rm -rf "$bundle"
mkdir -p "$bundle"
# As root, apt's download sandbox user cannot write into the checkout; the files are only read.
(cd "$bundle" && apt-get download -q -o APT::Sandbox::User=root "${packages[@]}")

bytes=$(du -cb "$bundle"/*.deb | tail -n 1 | cut -f 1)
echo "gpu_bundle: ${#packages[@]} packages in .gpu/, $((bytes / 1024)) KiB"
if ((bytes > 64 * 1024 * 1024)); then
  echo "gpu_bundle: more than the 64 MiB a bare GPU machine may be brought" >&2
  exit 1
fi
