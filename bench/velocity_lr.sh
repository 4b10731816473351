#!/usr/bin/env bash
# Velocity learning-rate sweep (docs/method.md, "Optimiser"): trains the full recipe on
# the quality benchmark's scenes (bench/quality.sh makes them) with `lr_velocity` scaled by each
# factor, scores the odd frames, and writes bench/results/velocity_lr.md.
#
#   bash bench/velocity_lr.sh              # FACTORS="0.25 0.5 1 2 4" PRESETS="default fast" ITERS=2000
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
iters=${ITERS:-2000}
presets=${PRESETS:-default fast}
factors=${FACTORS:-0.25 0.5 1 2 4}
cameras=${CAMERAS:-12}
size=${SIZE:-256x192}
cap=${CAP:-30000}
base_lr=1.6e-4  # TrainConfig::lr_velocity and lr_means (default kept: see README)
work=${WORK:-$root/bench/results/quality}
bin="$root/build/apps/retimegs"
[ -x "$bin" ] || "$root/scripts/setup.sh"
table="$root/bench/results/velocity_lr.md"
rows=()
for preset in $presets; do
  scene="$work/$preset/scene"
  [ -f "$scene/scene.json" ] || "$bin" synth --preset "$preset" --cameras "$cameras" --frames 17 \
    --size "$size" --out "$scene"
  for f in $factors; do
    lr=$(awk "BEGIN{printf \"%.6g\", $base_lr*$f}")
    run="$work/$preset/lr_velocity_x$f"
    metrics="$run/metrics.json"
    if [ ! -f "$metrics" ]; then
      rm -rf "$run"; mkdir -p "$run"
      echo "{\"lr_velocity\": $lr}" > "$run/config.json"
      start=$(date +%s)
      "$bin" train --scene "$scene" --out "$run/train" --iters "$iters" --cap "$cap" \
        --config "$run/config.json"
      echo $(( $(date +%s) - start )) > "$run/train_seconds"
      "$bin" eval --model "$run/train/model.rgs" --scene "$scene" --frames odd --out "$metrics"
    fi
    read_metric() { grep -o "^  \"$1\": [^,]*" "$metrics" | head -1 | sed 's/.*: //'; }
    rows+=("$(printf '| %s | %s × (%s) | %.2f | %.4f | %.4f | %s |' "$preset" "$f" "$lr" \
      "$(read_metric psnr)" "$(read_metric ssim)" "$(read_metric lpips)" "$(cat "$run/train_seconds")")")
  done
done
{
  echo "# Velocity learning-rate sweep (full recipe, train even frames, score odd frames)"
  echo
  echo "$iters iterations per run, cap $cap, $cameras cameras x 17 frames at $size; masked metrics."
  echo
  echo "| preset | lr_velocity | PSNR | SSIM | LPIPS | train time (s) |"
  echo "|---|---|---|---|---|---|"
  printf '%s\n' "${rows[@]}"
} > "$table"
cat "$table"
