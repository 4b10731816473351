#!/usr/bin/env bash
# The paper's tables (Tab. 1-2 shape) on synthetic scenes: for each preset, train on the even
# frames and score the odd ones with the full recipe, each of the five ablations, the STGS
# baseline, and the flow / cross-fade / nearest baselines. Writes bench/results/quality.md
# (Markdown table: masked PSNR / SSIM / LPIPS, the same on the whole image, temporal stability
# of the 8x slow motion, train time) and bench/results/quality.png (bar chart of masked PSNR).
#
# RECIPE=paper trains the full recipe and the ablations with `--preset paper` (the paper's reading
# of every departure, docs/method.md) at the same budget, into results/quality_paper.md;
# RECIPE=departures the full recipe with one of the paper's readings at a time (its config key, or
# no-static-init), into results/quality_departures.md. All recipes train on the same scenes.
#
#   bash bench/quality.sh                 # ITERS=2000 PRESETS="default fast" CAMERAS=12 SIZE=256x192 RECIPE=project
#   ITERS=20000 bash bench/quality.sh     # the paper's full budget (hours on 2 cores)
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
iters=${ITERS:-2000}
presets=${PRESETS:-default fast}
cameras=${CAMERAS:-12}
size=${SIZE:-256x192}
cap=${CAP:-30000}
recipe=${RECIPE:-project}
variants=(full no-flow-init no-flow-loss no-triple no-stretch linear)
case "$recipe" in
  project) name=quality recipe_flags=() variants+=(stgs flow crossfade nearest) ;;
  paper) name=quality_paper recipe_flags=(--preset paper) ;;
  departures)
    name=quality_departures recipe_flags=()
    variants=(full flow_hold relocate_per_duration init_average_lifts init_mean_velocity
      tie_end_velocities no-static-init) ;;
  *) echo "quality.sh: RECIPE must be project, paper or departures, not '$recipe'" >&2 && exit 2 ;;
esac
work=${WORK:-$root/bench/results/$name}
bin="$root/build/apps/retimegs"
[ -x "$bin" ] || "$root/scripts/setup.sh"
mkdir -p "$work"
table="$root/bench/results/$name.md"
csv="$work/quality.csv"
source "$root/bench/eval_json.sh"
echo "preset,variant,psnr,ssim,lpips,whole_psnr,whole_ssim,whole_lpips,stability,train_seconds" \
  > "$csv"
for preset in $presets; do
  scene="$root/bench/results/quality/$preset/scene"
  [ -f "$scene/scene.json" ] || "$bin" synth --preset "$preset" --cameras "$cameras" --frames 17 \
    --size "$size" --out "$scene"
  for v in "${variants[@]}"; do
    run="$work/$preset/$v"
    metrics="$run/metrics.json"
    seconds=0
    if [ ! -f "$metrics" ]; then
      rm -rf "$run"; mkdir -p "$run"
      case "$v" in
        flow|crossfade|nearest)
          "$bin" eval --baseline "$v" --scene "$scene" --frames odd --stability --out "$metrics" ;;
        *)
          flags=("${recipe_flags[@]}")
          if [ "$v" = stgs ]; then
            flags=(--baseline stgs)
          elif [[ $v == *_* ]]; then  # a config key of the paper's readings
            echo "{\"$v\": true}" > "$run/paper_reading.json"
            flags+=(--config "$run/paper_reading.json")
          elif [ "$v" != full ]; then
            flags+=(--ablate "$v")
          fi
          start=$(date +%s)
          "$bin" train --scene "$scene" --out "$run/train" --iters "$iters" --cap "$cap" "${flags[@]}"
          echo $(( $(date +%s) - start )) > "$run/train_seconds"
          "$bin" eval --model "$run/train/model.rgs" --scene "$scene" --frames odd --stability \
            --out "$metrics" ;;
      esac
    fi
    [ -f "$run/train_seconds" ] && seconds=$(cat "$run/train_seconds")
    figures=()
    for key in psnr ssim lpips; do figures+=("$(metric "$metrics" "$key")"); done
    for key in psnr ssim lpips; do figures+=("$(metric "$metrics" "$key" whole)"); done
    figures+=("$(metric "$metrics" max stability)")
    (IFS=,; echo "$preset,$v,${figures[*]},$seconds") >> "$csv"
  done
done
{
  echo "# Quality on synthetic scenes (train even frames, score odd frames)"
  echo
  echo "Recipe: $recipe$([ "$recipe" = paper ] && echo " (--preset paper)"); $iters iterations per run ($(awk "BEGIN{printf \"%.0f\", 100*$iters/20000}") % of the paper's 20 000), cap $cap, $cameras cameras x 17 frames at $size."
  echo "PSNR / SSIM / LPIPS inside the masks, then on the whole image; stability: largest mean"
  echo "absolute change between consecutive frames of the 8x slow motion over static pixels, in"
  echo "8-bit levels (largest over cameras; ground truth 0)."
  echo
  echo "| preset | variant | PSNR | SSIM | LPIPS | whole PSNR | whole SSIM | whole LPIPS | stability | train time (s) |"
  echo "|---|---|---|---|---|---|---|---|---|---|"
  tail -n +2 "$csv" | while IFS=, read -r p v psnr ssim lpips wpsnr wssim wlpips stab seconds; do
    echo "| $p | $v | $(fmt_metric "$psnr" 2) | $(fmt_metric "$ssim" 4) | $(fmt_metric "$lpips" 4) |" \
      "$(fmt_metric "$wpsnr" 2) | $(fmt_metric "$wssim" 4) | $(fmt_metric "$wlpips" 4) |" \
      "$(fmt_metric "$stab" 2) | $seconds |"
  done
} > "$table"
[ "$recipe" != project ] || "$root/build/bench/quality_chart" "$csv" "$root/bench/results/quality.png"
cat "$table"
