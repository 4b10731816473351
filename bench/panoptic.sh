#!/usr/bin/env bash
# A real capture end to end: the CMU Panoptic "basketball" clip of ../shared/data (31 cameras x
# 17 frames, 640x360). Import -> prepare (DIS flow, COLMAP points) -> train on the even frames of
# the 27 training cameras (full recipe and the STGS baseline) -> score the odd frames on the
# training cameras (masked) and on the 4 held-out test cameras (novel views, no masks: whole
# image), next to cross-fade and nearest. Writes bench/results/panoptic.md and
# bench/results/panoptic_sheet_{train,test}.png (ground truth | ours | cross-fade at held-out
# frame 7).
#
#   bash bench/panoptic.sh                 # ITERS=3000 CAP=30000 POINTS=colmap
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
iters=${ITERS:-3000}
cap=${CAP:-30000}
points=${POINTS:-colmap}
data=${DATA:-$root/../shared/data/panoptic-basketball}
work=${WORK:-$root/bench/results/panoptic}
bin="$root/build/apps/retimegs"
[ -x "$bin" ] || "$root/scripts/setup.sh"
mkdir -p "$work"
scene="$work/scene"
test_cams=0,10,15,30
train_cams=$(seq -s, 1 29 | tr , '\n' | grep -vxE '10|15' | paste -sd,)
[ -f "$scene/scene.json" ] || "$bin" import panoptic --in "$data" --out "$scene"
start=$(date +%s)
"$bin" prepare --scene "$scene" --points "$points"
echo $(( $(date +%s) - start )) > "$work/prepare_seconds"

for v in full stgs; do
  run="$work/$v"
  if [ ! -f "$run/model.rgs" ]; then
    flags=()
    [ "$v" = stgs ] && flags=(--baseline stgs)
    start=$(date +%s)
    "$bin" train --scene "$scene" --out "$run" --iters "$iters" --cap "$cap" "${flags[@]}"
    echo $(( $(date +%s) - start )) > "$run/train_seconds"
  fi
done
for v in full stgs crossfade nearest; do
  case "$v" in
    full|stgs) source=(--model "$work/$v/model.rgs") ;;
    *) source=(--baseline "$v") ;;
  esac
  for split in train test; do
    cams=$train_cams
    [ "$split" = test ] && cams=$test_cams
    renders=()  # --save-renders replaces its folder: one per method and split
    [ "$v" = full ] || [ "$v" = crossfade ] && renders=(--save-renders "$work/renders/$v-$split")
    [ -f "$work/${v}_$split.json" ] || "$bin" eval "${source[@]}" --scene "$scene" --frames odd \
      --cameras "$cams" "${renders[@]}" --out "$work/${v}_$split.json"
  done
done
for split in train test; do
  cams=5,18
  [ "$split" = test ] && cams=0,30
  "$bin" sheet --scene "$scene" --cameras "$cams" --frames 7 --tile-width 320 \
    --renders "$work/renders/full-$split,$work/renders/crossfade-$split" \
    --out "$root/bench/results/panoptic_sheet_$split.png"
done

metric() { grep -o "^  \"$2\": [^,]*" "$1" | head -1 | sed 's/.*: //'; }
{
  echo "# CMU Panoptic basketball: train even frames, score odd frames"
  echo
  echo "$iters iterations, cap $cap, points: $points; 27 training cameras x 9 frames at 640x360."
  echo "Training cameras: masked metrics (PSNR in the masks, SSIM on their boxes, LPIPS on"
  echo "black-masked images). Test cameras (0, 10, 15, 30; never trained on; no masks): whole image."
  echo
  echo "| method | train cams PSNR | SSIM | LPIPS | test cams PSNR | SSIM | LPIPS | train time (s) |"
  echo "|---|---|---|---|---|---|---|---|"
  for v in full stgs crossfade nearest; do
    seconds=0
    [ -f "$work/$v/train_seconds" ] && seconds=$(cat "$work/$v/train_seconds")
    printf '| %s | %.2f | %.4f | %.4f | %.2f | %.4f | %.4f | %s |\n' "$v" \
      "$(metric "$work/${v}_train.json" psnr)" "$(metric "$work/${v}_train.json" ssim)" \
      "$(metric "$work/${v}_train.json" lpips)" "$(metric "$work/${v}_test.json" psnr)" \
      "$(metric "$work/${v}_test.json" ssim)" "$(metric "$work/${v}_test.json" lpips)" "$seconds"
  done
} > "$root/bench/results/panoptic.md"
cat "$root/bench/results/panoptic.md"
