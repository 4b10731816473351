#!/usr/bin/env bash
# Sets up (packages + build) and runs the whole test suite; ends with ctest's summary line.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
# Tests only: Chromium for the browser viewer test (web/test/viewer.test.mjs), and Node with npm
# where the machine has none; then playwright-core from web/package-lock.json.
test_packages=(chromium)
command -v npm > /dev/null || test_packages+=(nodejs npm)
# Without a GPU (CI) the CUDA sources, where nvcc is found, are compiled for one architecture,
# Hopper: one is enough to catch a broken kernel. The `gpu` tests then skip with the reason. With a
# GPU, CMake's default builds for it.
cuda_args=()
nvidia-smi -L > /dev/null 2>&1 || cuda_args=(-DCMAKE_CUDA_ARCHITECTURES=90)
RETIMEGS_EXTRA_PACKAGES="${test_packages[*]}" "$root/scripts/setup.sh" "${cuda_args[@]}"
if [ ! -d "$root/web/node_modules" ]; then
  (cd "$root/web" && npm ci --no-audit --no-fund)
fi
# The parsers under ASan + UBSan in build-fuzz/: their unit tests, every seed corpus, 10 s of
# fuzzing per target. Its own ctest summary; a failure stops the run here.
"$root/scripts/fuzz.sh" --check
cd "$root/build"
ctest --output-on-failure -j "$(nproc)"
