#!/usr/bin/env bash
# The main job on the built-in default: set up, synthesise the default dynamic scene, prepare it
# (keeps the scene's exact flows and points; a real capture gets DIS flow and points here), train
# on its even frames, render an 8x slow-motion video, and evaluate the held-out odd frames (masked and
# whole image, and the static background's stability in 8x slow motion) against the cross-fade and
# optical-flow baselines. Outputs go to demo/ (or the folder given as the first argument).
# ITERS (default 3000, about 2 minutes of training on 2 cores) sets the training budget.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
out=${1:-$root/demo}
iters=${ITERS:-3000}
"$root/scripts/setup.sh"
bin="$root/build/apps/retimegs"
mkdir -p "$out"
"$bin" synth --preset default --out "$out/scene" --force
"$bin" prepare --scene "$out/scene" --train-frames even
"$bin" sheet --scene "$out/scene" --out "$out/contact_sheet.png" --force
"$bin" train --scene "$out/scene" --out "$out/run" --train-frames even --iters "$iters" --cap 60000 \
  --force
"$bin" render --model "$out/run/model.rgs" --scene "$out/scene" --camera cam00 --slowmo 8 \
  --out "$out/slowmo_8x.mp4" --force
"$bin" eval --model "$out/run/model.rgs" --scene "$out/scene" --frames odd --stability \
  --out "$out/metrics.json" --force
for baseline in crossfade flow; do
  "$bin" eval --baseline "$baseline" --scene "$out/scene" --frames odd --stability \
    --out "$out/$baseline.json" --force
done
echo
echo "scene:             $out/scene (contact sheet $out/contact_sheet.png)"
echo "model:             $out/run/model.rgs (log $out/run/log.jsonl)"
echo "8x slow motion:    $out/slowmo_8x.mp4"
echo "held-out metrics:  $out/metrics.json (baselines: $out/crossfade.json, $out/flow.json)"
