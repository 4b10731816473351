#!/usr/bin/env bash
# Sets up (packages + build) and runs the whole test suite; ends with ctest's summary line.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
"$root/scripts/setup.sh"
# The parsers under ASan + UBSan in build-fuzz/: their unit tests, every seed corpus, 10 s of
# fuzzing per target. Its own ctest summary; a failure stops the run here.
"$root/scripts/fuzz.sh" --check
cd "$root/build"
ctest --output-on-failure -j "$(nproc)"
