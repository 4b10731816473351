#!/usr/bin/env bash
# The paper's tables (Tab. 1-2 shape) on synthetic scenes: for each preset, train on the even
# frames and score the odd ones with the full recipe, each of the five ablations, the STGS
# baseline, and the cross-fade / nearest baselines. Writes bench/results/quality.md (Markdown
# table: PSNR / SSIM / LPIPS / train time) and bench/results/quality.png (bar chart of PSNR).
#
#   bash bench/quality.sh                 # ITERS=2000 PRESETS="default fast" CAMERAS=12 SIZE=256x192
#   ITERS=20000 bash bench/quality.sh     # the paper's full budget (hours on 2 cores)
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
iters=${ITERS:-2000}
presets=${PRESETS:-default fast}
cameras=${CAMERAS:-12}
size=${SIZE:-256x192}
cap=${CAP:-30000}
work=${WORK:-$root/bench/results/quality}
bin="$root/build/apps/retimegs"
[ -x "$bin" ] || "$root/scripts/setup.sh"
mkdir -p "$work"
variants=(full no-flow-init no-flow-loss no-triple no-stretch linear stgs crossfade nearest)
table="$root/bench/results/quality.md"
csv="$work/quality.csv"
echo "preset,variant,psnr,ssim,lpips,train_seconds" > "$csv"
for preset in $presets; do
  scene="$work/$preset/scene"
  [ -f "$scene/scene.json" ] || "$bin" synth --preset "$preset" --cameras "$cameras" --frames 17 \
    --size "$size" --out "$scene"
  for v in "${variants[@]}"; do
    run="$work/$preset/$v"
    metrics="$run/metrics.json"
    seconds=0
    if [ ! -f "$metrics" ]; then
      rm -rf "$run"; mkdir -p "$run"
      case "$v" in
        crossfade|nearest) "$bin" eval --baseline "$v" --scene "$scene" --frames odd --out "$metrics" ;;
        *)
          flags=()
          [ "$v" = stgs ] && flags=(--baseline stgs)
          [ "$v" != full ] && [ "$v" != stgs ] && flags=(--ablate "$v")
          start=$(date +%s)
          "$bin" train --scene "$scene" --out "$run/train" --iters "$iters" --cap "$cap" "${flags[@]}"
          echo $(( $(date +%s) - start )) > "$run/train_seconds"
          "$bin" eval --model "$run/train/model.rgs" --scene "$scene" --frames odd --out "$metrics" ;;
      esac
    fi
    [ -f "$run/train_seconds" ] && seconds=$(cat "$run/train_seconds")
    python_free_read() { grep -o "^  \"$1\": [^,]*" "$metrics" | head -1 | sed 's/.*: //'; }
    echo "$preset,$v,$(python_free_read psnr),$(python_free_read ssim),$(python_free_read lpips),$seconds" >> "$csv"
  done
done
{
  echo "# Quality on synthetic scenes (train even frames, score odd frames)"
  echo
  echo "$iters iterations per run ($(awk "BEGIN{printf \"%.0f\", 100*$iters/20000}") % of the paper's 20 000), cap $cap, $cameras cameras x 17 frames at $size; masked metrics."
  echo
  echo "| preset | variant | PSNR | SSIM | LPIPS | train time (s) |"
  echo "|---|---|---|---|---|---|"
  tail -n +2 "$csv" | awk -F, '{printf "| %s | %s | %.2f | %.4f | %.4f | %s |\n", $1, $2, $3, $4, $5, $6}'
} > "$table"
"$root/build/bench/quality_chart" "$csv" "$root/bench/results/quality.png"
cat "$table"
