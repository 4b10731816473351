#!/usr/bin/env bash
# A real capture end to end: the CMU Panoptic "basketball" clip of ../shared/data (31 cameras x
# 17 frames, 640x360). Import -> prepare (DIS flow; points by prepare's default, visual hull +
# COLMAP on this masked capture) -> train on the even frames of the 27 training cameras (full
# recipe and the STGS baseline, one `--preset`) -> score, next to the flow, cross-fade and nearest
# baselines:
#   - the odd frames on the training cameras, inside the masks and on the whole image;
#   - the models' fit on their training frames (the even frames, training cameras, masked);
#   - the odd frames on the 4 held-out test cameras (novel views, no masks: whole image), at the
#     scene's near plane (9 % of its extent, 0.30 m here: a rig camera does not look out through
#     its own body, which the other cameras saw and the model learned) or NEAR when set;
#   - temporal stability of the 8x slow motion on training cameras 5 and 18 (static pixels:
#     outside the dilated masks), in 8-bit levels;
# with each model's primitive count, peak RSS (from the `train` log) and training time.
# Writes bench/results/panoptic.md and bench/results/panoptic_sheet_{train,test}.png (ground
# truth | ours | flow | cross-fade at held-out frame 7).
#
#   bash bench/panoptic.sh                 # PRESET=fast NEAR= (the scene's) POINTS= (prepare's default)
# scripts/gpu_panoptic.sh and bench/ablations.sh run it with BIN (the retimegs to run), DEVICE
# (train's and eval's --device), ITERS and CAP (train's --iters, --cap), METHODS (which of full,
# stgs, the ablations no-flow-init, no-flow-loss, no-triple, no-stretch, linear, no-static-init
# (train --ablate), a config key of the paper's readings (flow_hold, ...: set to true), and the
# baselines flow, crossfade, nearest to score; the sheets need full, flow and crossfade),
# FLOW (prepare's --flow, for a scene whose flows are not written yet) and RESULTS (the table's
# file).
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
preset=${PRESET:-fast}
near=${NEAR:-}
near_text=${NEAR:-"the scene's (9 % of its extent, 0.30 m)"}
points=${POINTS:-}
data=${DATA:-$root/../shared/data/panoptic-basketball}
work=${WORK:-$root/bench/results/panoptic}
results=${RESULTS:-$root/bench/results/panoptic.md}
read -r -a methods <<< "${METHODS:-full stgs flow crossfade nearest}"
# scored "$v": whether METHODS names it; trained "$v": whether it is a model this script trains.
scored() { [[ " ${methods[*]} " == *" $1 "* ]]; }
# A method with an underscore is a training config key set to true (one of the paper's readings,
# docs/method.md's departures: flow_hold, relocate_per_duration, ...).
trained() {
  [[ $1 =~ ^(full|stgs|no-flow-init|no-flow-loss|no-triple|no-stretch|linear|no-static-init)$ ||
    $1 =~ ^[a-z0-9]+(_[a-z0-9]+)+$ ]]
}
for v in "${methods[@]}"; do
  trained "$v" || [[ $v =~ ^(flow|crossfade|nearest)$ ]] ||
    { echo "panoptic.sh: unknown method '$v' in METHODS" >&2; exit 2; }
done
device=(${DEVICE:+--device "$DEVICE"})
bin=${BIN:-$root/build/apps/retimegs}
[ -x "$bin" ] || "$root/scripts/setup.sh"
source "$root/bench/eval_json.sh"
mkdir -p "$work"
scene="$work/scene"
test_cams=0,10,15,30
train_cams=$(seq -s, 1 29 | tr , '\n' | grep -vxE '10|15' | paste -sd,)
stability_cams=5,18
[ -f "$scene/scene.json" ] || "$bin" import panoptic --in "$data" --out "$scene"
num_frames=$(grep -o '"num_frames": *[0-9]*' "$scene/scene.json" | grep -o '[0-9]*$')
train_frames=$(seq -s, 0 2 $((num_frames - 1)))
start=$(date +%s)
"$bin" prepare --scene "$scene" ${points:+--points "$points"} ${FLOW:+--flow "$FLOW"}
# A rerun resumes a prepared scene in a second: keep the first run's time.
[ -f "$work/prepare_seconds" ] || echo $(( $(date +%s) - start )) > "$work/prepare_seconds"

# cell FILE KEY SECTION DIGITS: one formatted figure, "–" when the file does not exist.
cell() {
  if [ -f "$1" ]; then fmt_metric "$(metric "$1" "$2" "$3")" "$4"; else echo "–"; fi
}
# write_table: the results table of every method scored so far, replaced whole.
write_table() {
  local v seconds primitives rss gpu t s
  {
    echo "# CMU Panoptic basketball: train even frames, score odd frames"
    echo
    echo "Recorded $(date -u +%Y-%m-%d) at commit $(git -C "$root" rev-parse --short HEAD 2>/dev/null || echo '?')" \
      "with \`PRESET=$preset${FLOW:+ FLOW=$FLOW}${DEVICE:+ DEVICE=$DEVICE}${ITERS:+ ITERS=$ITERS}${CAP:+ CAP=$CAP} bash bench/panoptic.sh\`; prepare took $(cat "$work/prepare_seconds") s."
    echo
    echo "Preset $preset, points: ${points:-the default of prepare}; 27 training cameras x $(( (num_frames + 1) / 2 )) frames at 640x360."
    echo "Training cameras, held-out (odd) frames: masked metrics (PSNR in the masks, SSIM on their"
    echo "boxes, LPIPS on black-masked images), then the whole image. Fit: masked PSNR on the training"
    echo "frames themselves. Test cameras (0, 10, 15, 30; never trained on; no masks): whole image,"
    echo "models rendered with a near plane of $near_text (a rig camera's own body, learned from the"
    echo "other views, is not drawn in its render)."
    echo "Stability: largest mean absolute change between consecutive frames of the 8x slow motion over"
    echo "static pixels (outside the dilated masks) of cameras $stability_cams, in 8-bit levels."
    echo "Peak RSS and primitives from the train log (on a GPU also the most its buffers held)."
    echo
    echo "| method | train cams PSNR | SSIM | LPIPS | whole PSNR | whole SSIM | whole LPIPS | fit PSNR | test cams PSNR | SSIM | LPIPS | stability | primitives | peak RSS (MB) (GPU) | train time (s) |"
    echo "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"
    for v in "${methods[@]}"; do
      seconds=– primitives=– rss=– gpu=
      [ -f "$work/$v/train_seconds" ] && seconds=$(cat "$work/$v/train_seconds")
      if [ -f "$work/$v/train.log" ]; then
        primitives=$(grep -o '([0-9]* primitives); peak memory' "$work/$v/train.log" | tail -1 |
          grep -o '[0-9]*' | head -1)
        rss=$(grep -o 'peak memory [0-9]* MB' "$work/$v/train.log" | tail -1 | grep -o '[0-9]*')
        gpu=$(grep -o ', GPU [0-9]* MB' "$work/$v/train.log" | tail -1 | grep -o '[0-9]*' || true)
      fi
      t="$work/${v}_train.json" s="$work/${v}_test.json"
      echo "| $v | $(cell "$t" psnr "" 2) | $(cell "$t" ssim "" 4) | $(cell "$t" lpips "" 4) |" \
        "$(cell "$t" psnr whole 2) | $(cell "$t" ssim whole 4) | $(cell "$t" lpips whole 4) |" \
        "$(cell "$work/${v}_fit.json" psnr "" 2) | $(cell "$s" psnr "" 2) | $(cell "$s" ssim "" 4) |" \
        "$(cell "$s" lpips "" 4) | $(cell "$work/${v}_stability.json" max stability 2) |" \
        "${primitives:-–} | ${rss:-–}${gpu:+ ($gpu)} | $seconds |"
    done
  } > "$results.tmp"
  mv "$results.tmp" "$results"
}

# Each method trained, then scored, then the table written again: a run stopped part way (a GPU
# call's time limit) leaves the rows of the methods it finished.
for v in "${methods[@]}"; do
  run="$work/$v"
  if trained "$v" && [ ! -f "$run/model.rgs" ]; then
    flags=("${device[@]}" ${ITERS:+--iters "$ITERS"} ${CAP:+--cap "$CAP"})
    mkdir -p "$run"
    case "$v" in
      full) ;;
      stgs) flags+=(--baseline stgs) ;;
      *_*)
        # Beside the run's folder: train --out refuses a folder that holds other files.
        echo "{\"$v\": true}" > "$work/$v.config.json"
        flags+=(--config "$work/$v.config.json") ;;
      *) flags+=(--ablate "$v") ;;
    esac
    start=$(date +%s)
    "$bin" train --scene "$scene" --out "$run" --preset "$preset" "${flags[@]}" 2>&1 |
      tee "$run/train.log"
    echo $(( $(date +%s) - start )) > "$run/train_seconds"
  fi
  case "$v" in
    flow|crossfade|nearest) source=(--baseline "$v") ;;
    *) source=(--model "$work/$v/model.rgs" ${near:+--near "$near"} "${device[@]}") ;;
  esac
  for split in train test fit stability; do
    flags=(--frames odd)
    case "$split" in
      train) flags+=(--cameras "$train_cams") ;;
      test) flags+=(--cameras "$test_cams") ;;
      fit) flags=(--frames "$train_frames" --cameras "$train_cams") ;;
      stability) flags+=(--cameras "$stability_cams" --stability) ;;
    esac
    # A baseline returns the training frames themselves: no fit to measure; and it blends a
    # camera's own training frames, which a test camera has none of.
    [[ $split =~ ^(fit|test)$ ]] && ! trained "$v" && continue
    # --save-renders replaces its folder: one per method and split.
    case "$v-$split" in
      full-train|full-test|flow-train|crossfade-train)
        flags+=(--save-renders "$work/renders/$v-$split") ;;
    esac
    [ -f "$work/${v}_$split.json" ] || "$bin" eval "${source[@]}" --scene "$scene" "${flags[@]}" \
      --out "$work/${v}_$split.json" --force
  done
  write_table
done
for split in train test; do
  if ! { scored full && scored flow && scored crossfade; }; then break; fi
  cams=5,18
  renders="$work/renders/full-$split,$work/renders/flow-$split,$work/renders/crossfade-$split"
  # No baseline for a test camera: ground truth | ours.
  [ "$split" = test ] && cams=0,30 renders="$work/renders/full-$split"
  "$bin" sheet --scene "$scene" --cameras "$cams" --frames 7 --tile-width 320 --renders "$renders" \
    --out "$root/bench/results/panoptic_sheet_$split.png" --force
done

cat "$results"
