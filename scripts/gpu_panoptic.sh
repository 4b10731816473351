#!/usr/bin/env bash
# Run on a bare GPU machine (DESIGN.md §3), after scripts/gpu_bundle.sh --panoptic on a build
# machine brought .gpu/ along: the CMU Panoptic clip of bench/panoptic.sh trained with
# `--preset default` on the GPU and scored as that script scores it (held-out odd frames on the
# training cameras, masked and whole image; the fit; the 4 test cameras; stability), beside the
# CPU run's figures of bench/results/panoptic.md. One call: unpacks the packages, builds the lean
# app (-DRETIMEGS_GPU_ONLY=ON -DRETIMEGS_GPU_APP=ON, target retimegs), imports the clip from its
# JPEGs (the imported PNGs, 116 MB, would not fit in the 64 MiB brought), puts in the points
# prepared on the build machine (COLMAP and the visual hull are not here), computes the DIS flows
# with `retimegs prepare` (~800 MB as .flo: they are not brought either), trains, scores, and
# prints the table last with the wall time of each step. Logs and results (build.log, steps.log,
# panoptic.md, summary.txt) go to $OUT when it is set, else to build-gpu/panoptic/; the scene and
# its flows (762 MB) stay in build-gpu/panoptic/scene/, the models in build-gpu/panoptic/<preset>/,
# so that a second call on the same machine goes on where the first stopped (bench/panoptic.sh
# keeps what is done): the ablations of bench/ablations.sh fit a few methods to a call.
#
#   bash scripts/gpu_panoptic.sh [--no-gpu-ok] [--iters N] [--preset NAME] [--methods "LIST"]
#                                [CMAKE_ARGS...]
#
# --methods: bench/panoptic.sh's METHODS (default "full"), e.g. "full no-flow-loss linear".
# --no-gpu-ok carries on without a GPU (train and eval then run with --device auto, i.e. on the
# CPU), to check the script on a build machine with a small --iters. CMAKE_ARGS go to the
# configure step, e.g. -DCMAKE_CUDA_ARCHITECTURES=90.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
no_gpu_ok=0
iters=""
preset=default
methods=full
while (($#)); do
  case $1 in
    --no-gpu-ok) no_gpu_ok=1 ;;
    --iters) iters=${2:?--iters N} && shift ;;
    --preset) preset=${2:?--preset NAME} && shift ;;
    --methods) methods=${2:?--methods LIST} && shift ;;
    *) break ;;
  esac
  shift
done
source "$root/scripts/gpu_common.sh"
out="${OUT:-$build/panoptic}"
bundle="$root/.gpu/panoptic"
[[ -f $bundle/data/train_meta.json ]] ||
  die "no .gpu/panoptic/: run scripts/gpu_bundle.sh --panoptic on a build machine and bring .gpu/"
mkdir -p "$out"
steps_log="$out/steps.log"
: > "$steps_log"
rows=()
# step NAME COMMAND...: runs it, its output in steps.log, its wall time in the table.
step() {
  local name=$1 started=$SECONDS
  shift
  echo "== $name: $*" >> "$steps_log"
  if ! "$@" >> "$steps_log" 2>&1; then
    tail -n 30 "$steps_log"
    die "$name failed (log: $steps_log)"
  fi
  rows+=("$(printf '%-8s %5d s' "$name" $((SECONDS - started)))")
}

gpu_check_machine
gpu_unpack_bundle
gpu_build "$out/build.log" retimegs -DRETIMEGS_GPU_APP=ON "$@"
rows+=("$(printf '%-8s %5d s' build "$build_seconds")")
bin="$build/apps/retimegs"
scene="$build/panoptic/scene"
work="$build/panoptic/$preset"
mkdir -p "$work"
ln -sfn "$scene" "$work/scene"

# The scene the points were prepared for, imported again from the same files by the same code.
if [[ ! -f $scene/scene.json ]]; then
  step import "$bin" import panoptic --in "$bundle/data" --out "$scene"
  cmp -s "$scene/scene.json" "$bundle/scene.json" ||
    die "$scene/scene.json differs from the one the points were prepared for ($bundle/scene.json)"
  mkdir -p "$scene/points"
  cp "$bundle"/points/*.ply "$scene/points/"
fi
device=cuda
((gpu)) || device=auto
step panoptic env BIN="$bin" WORK="$work" PRESET="$preset" DEVICE="$device" ITERS="$iters" \
  METHODS="$methods" RESULTS="$out/panoptic.md" bash "$root/bench/panoptic.sh"
# bench/panoptic.sh's own times of its steps (this call's or, for what an earlier call on this
# machine did, that one's): prepare (the flows here) and each training; the rest is scoring.
rows+=("$(printf '  flows %14s %5d s' "" "$(cat "$work/prepare_seconds")")")
for m in $methods; do
  if [[ -f $work/$m/train_seconds ]]; then
    rows+=("$(printf '  train %-14s %5d s' "$m" "$(cat "$work/$m/train_seconds")")")
  fi
done

cpu_full=$(grep '^| full ' "$root/bench/results/panoptic.md" || echo "| full | (none recorded) |")
{
  echo "gpu_panoptic summary"
  echo "  card        $card"
  echo "  preset      $preset${iters:+, --iters $iters}, device $device"
  echo "  wall time"
  for row in "${rows[@]}"; do echo "    $row"; done
  echo
  sed -n '/^| method/,$p' "$out/panoptic.md"
  echo
  # shellcheck disable=SC2016  # the backquotes are the file's
  echo "CPU run ($(sed -n 's/^Recorded \(.*\) with `\(.*\)`.*/\1, \2/p' "$root/bench/results/panoptic.md")):"
  echo "$cpu_full"
} | tee "$out/summary.txt"
