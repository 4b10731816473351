#!/usr/bin/env bash
# Time windows against one run (README "Long clips and Slurm"): a synthetic clip trained as WINDOWS
# time windows of ITERS iterations each (`retimegs slurm`'s run_local.sh: prepare, train --window,
# merge), and as one run over the whole clip with their total, WINDOWS x ITERS iterations. Both
# score the odd (held-out) frames; each window model alone scores its own odd frames too, so that
# what the merge costs shows apart from what the windows cost. Both also measure temporal
# stability (eval --stability): the largest change of the static world between consecutive frames
# of an 8x slow motion at the merged model's seams, and at the other training frames. Writes
# bench/results/windows.md. OVERLAP=N: slurm --overlap N (training intervals each window trains
# beyond each seam; slurm's default otherwise).
#
#   bash bench/windows.sh        # ITERS="750 3000" WINDOWS=4 OVERLAP= FRAMES=33 CAMERAS=6 SIZE=128x96 CAP=60000
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
iters_list=${ITERS:-750 3000}
windows=${WINDOWS:-4}
overlap=${OVERLAP:-}
frames=${FRAMES:-33}
cameras=${CAMERAS:-6}
size=${SIZE:-128x96}
cap=${CAP:-60000}
threads=${THREADS:-0}
work=${WORK:-$root/bench/results/windows}
bin="$root/build/apps/retimegs"
[ -x "$bin" ] || "$root/scripts/setup.sh"
table="$root/bench/results/windows.md"
scene="$work/scene"
[ -f "$scene/scene.json" ] || "$bin" synth --preset default --cameras "$cameras" \
  --frames "$frames" --size "$size" --out "$scene"

metric() {  # metric FILE KEY [whole]: the masked (or whole-image) mean of metrics.json
  python3 -c "import json,sys; d=json.load(open(sys.argv[1])); k=sys.argv[2]; \
v=d['whole'][k] if len(sys.argv) > 3 else d[k]; print('%.2f' % v if k == 'psnr' else '%.4f' % v)" "$@"
}
# stability FILE KEY: a figure of eval --stability (8-bit levels), – where there is none.
stability() {
  python3 -c "import json,sys; v=json.load(open(sys.argv[1]))['stability'][sys.argv[2]]; \
print('–' if v is None else '%.2f' % v)" "$@"
}
# odd_frames A B: the held-out frames between training frames A and B, comma-separated.
odd_frames() { seq -s, $(($1 + 1)) 2 $(($2 - 1)); }

rows=()
for iters in $iters_list; do
  total=$((windows * iters))
  one="$work/one_$total"
  if [ ! -f "$one/metrics.json" ]; then
    start=$(date +%s)
    "$bin" train --scene "$scene" --out "$one/run" --iters "$total" --cap "$cap" \
      --threads "$threads" --force
    echo $(($(date +%s) - start)) > "$one/train_seconds"
    "$bin" eval --model "$one/run/model.rgs" --scene "$scene" --out "$one/metrics.json" \
      --stability --threads "$threads"
  fi
  split="$work/windows_${windows}x$iters${overlap:+_overlap$overlap}"
  # Trained windows are kept: remove metrics.json to merge and score them again (after a change to
  # merge or to how a merged model is drawn), the whole folder to train them again.
  if [ ! -f "$split/train_seconds" ]; then
    "$bin" slurm --scene "$scene" --out "$split/run" --windows "$windows" --iters "$iters" \
      --cap "$cap" ${overlap:+--overlap "$overlap"} --force
    start=$(date +%s)
    SLURM_CPUS_PER_TASK=$threads "$split/run/slurm/run_local.sh"
    echo $(($(date +%s) - start)) > "$split/train_seconds"
  fi
  if [ ! -f "$split/metrics.json" ]; then
    "$bin" merge --out "$split/run/model.rgs" --force "$split"/run/windows/*/model.rgs
    "$bin" eval --model "$split/run/model.rgs" --scene "$scene" --out "$split/metrics.json" \
      --stability --threads "$threads" --force
    # Each window alone on its own held-out frames, and the merged model on the same frames.
    for dir in "$split"/run/windows/*/; do
      k=$(basename "$dir")
      range=$(sed -n "s/^windows=(\(.*\))$/\1/p" "$split/run/slurm/window.sh" | tr ' ' '\n' |
        sed -n "$((k + 1))p")
      list=$(odd_frames "${range%:*}" "${range#*:}")
      "$bin" eval --model "$dir/model.rgs" --scene "$scene" --frames "$list" \
        --out "$split/window_$k.json" --threads "$threads" --force
      "$bin" eval --model "$split/run/model.rgs" --scene "$scene" --frames "$list" \
        --out "$split/merged_$k.json" --threads "$threads" --force
    done
  fi
  alone=() merged=()
  for f in "$split"/window_*.json; do
    k=${f##*_}
    k=${k%.json}
    alone+=("$(metric "$f" psnr)")
    merged+=("$(metric "$split/merged_$k.json" psnr)")
  done
  rows+=("$(printf '| %s | one run, %s iterations | %s / %s | %s / %s | %s / %s | %s | |' "$total" \
    "$total" "$(metric "$one/metrics.json" psnr)" "$(metric "$one/metrics.json" psnr whole)" \
    "$(metric "$one/metrics.json" ssim)" "$(metric "$one/metrics.json" ssim whole)" \
    "$(stability "$one/metrics.json" max_at_seams)" \
    "$(stability "$one/metrics.json" max_at_training_frames)" "$(cat "$one/train_seconds")")")
  rows+=("$(printf '| %s | %s windows x %s%s, merged | %s / %s | %s / %s | %s / %s | %s | %s → %s |' \
    "$total" "$windows" "$iters" "${overlap:+, overlap $overlap}" "$(metric "$split/metrics.json" psnr)" \
    "$(metric "$split/metrics.json" psnr whole)" "$(metric "$split/metrics.json" ssim)" \
    "$(metric "$split/metrics.json" ssim whole)" "$(stability "$split/metrics.json" max_at_seams)" \
    "$(stability "$split/metrics.json" max_at_training_frames)" "$(cat "$split/train_seconds")" \
    "$(
      IFS=' '
      echo "${alone[*]}"
    )" "$(
      IFS=' '
      echo "${merged[*]}"
    )")")
done
{
  echo "# Time windows against one run (train the even frames, score the odd frames)"
  echo
  echo "Synthetic \`default\` clip, $frames frames, $cameras cameras at $size, cap $cap per run;"
  echo "PSNR and SSIM inside the masks / on the whole image. The last column: each window model"
  echo "alone on its own held-out frames → the merged model on the same frames (masked PSNR)."
  echo "Static change: the largest mean change of the static pixels between consecutive frames of"
  echo "the 8x slow motion (8-bit levels, the largest over cameras), at the seams / at the other"
  echo "training frames (a run in one piece has no seam)."
  echo
  echo "| total iterations | run | PSNR | SSIM | static change | train time (s) | per window: alone → merged |"
  echo "|---|---|---|---|---|---|---|"
  printf '%s\n' "${rows[@]}"
} > "$table"
cat "$table"
