#!/usr/bin/env bash
# The paper's Table 2 on the CMU Panoptic clip: the full recipe and its five ablations, each
# switching one part off (train --ablate: no-flow-init, no-flow-loss, no-triple, no-stretch,
# linear), trained and scored as bench/panoptic.sh trains and scores them (held-out odd frames,
# masked and whole image; the fit; the test cameras; stability; train time), once with the
# project's recipe and once with the paper's reading of every departure (--preset paper), at one
# budget. Writes results/ablations_project.md and results/ablations_paper.md.
#
#   bash bench/ablations.sh     # BUDGET=fast (the CPU: 12 runs, 8 min each with AVX-512, 22-40 without) | default
#
# On a bare GPU machine, scripts/gpu_panoptic.sh --preset default|paper --methods "LIST" trains
# and scores the same rows at the default budget, a few to a call.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
budget=${BUDGET:-fast}
work=${WORK:-$root/bench/results/ablations}
methods="full no-flow-init no-flow-loss no-triple no-stretch linear"
case "$budget" in
  # --preset paper is the default budget; fast's budget is its --iters and --cap (docs/cli.md).
  fast) paper_budget=(ITERS=5000 CAP=100000) ;;
  default) paper_budget=() ;;
  *) echo "ablations.sh: BUDGET must be fast or default, not '$budget'" >&2 && exit 2 ;;
esac
mkdir -p "$work/project" "$work/paper"
# One prepared scene for both recipes (imported and prepared by the first run).
ln -sfn "$work/project/scene" "$work/paper/scene"
env PRESET="$budget" WORK="$work/project" METHODS="$methods" \
  RESULTS="$root/bench/results/ablations_project.md" bash "$root/bench/panoptic.sh"
env PRESET=paper "${paper_budget[@]}" WORK="$work/paper" METHODS="$methods" \
  RESULTS="$root/bench/results/ablations_paper.md" bash "$root/bench/panoptic.sh"
