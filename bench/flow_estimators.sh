#!/usr/bin/env bash
# Every estimator of `retimegs prepare --flow` on data/flow's five ground-truth pairs: mean
# end-point error, outlier share (KITTI's Fl) and seconds per pair on one thread
# (bench/flow_bench.cpp). Writes bench/results/flow_estimators.md; bench/README.md summarises it.
# Usage: bash bench/flow_estimators.sh [BUILD_DIR]   (default build/)
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-$root/build}
ninja -C "$build" flow_bench >/dev/null
out=$root/bench/results/flow_estimators.md
tmp=$(mktemp)
trap 'rm -f "$tmp"' EXIT
{
  echo "# Optical-flow estimators on data/flow's ground truth"
  echo
  echo "Recorded $(date -u +%Y-%m-%d) at commit \`$(git -C "$root" rev-parse --short HEAD)\` with"
  echo "\`bash bench/flow_estimators.sh\` (OpenCV $(pkg-config --modversion opencv4 2>/dev/null || echo '?'),"
  echo "one OpenCV thread, \`nice -n 10\`). EPE in pixels over the valid pixels (Sintel: occluded"
  echo "pixels included), Fl = share of pixels with an error above 3 px and above 5 % of the true"
  echo "motion. Times are rough: taken on a shared 2-core machine with other jobs running."
  echo
  nice -n 10 "$build/bench/flow_bench"
} >"$tmp"
mv "$tmp" "$out"
trap - EXIT
cat "$out"
