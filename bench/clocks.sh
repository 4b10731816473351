#!/usr/bin/env bash
# Cameras on their own clocks (issue 65): a synthetic rig in which half the cameras run half a
# frame late, trained three ways with one recipe and scored on the held-out (odd) frames:
#   sync     : every camera genlocked (the reference);
#   honoured : the odd-numbered cameras' frames at t = k + 0.5, scene.json records it
#              (synth --time-offsets), training and eval use each camera's own time;
#   ignored  : the same images, the offsets left out of scene.json (synth --unrecorded-offsets):
#              every frame k taken as time k, as a user who never measured them has it.
# Scores: held-out PSNR (masked) over the genlocked cameras (cam00, cam02, ...: the same images
# and times in all three scenes, so the same truth), and over every camera of its own scene (each
# at its own time where recorded; the ignored scene's late cameras scored against time k).
# Writes bench/results/clocks.md.
#
#   bash bench/clocks.sh     # PRESET=fast CAMERAS=8 SIZE=256x192 FRAMES=17 DEVICE= BIN=; ITERS=, CAP= (the preset's)
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
preset=${PRESET:-fast}
cameras=${CAMERAS:-8}
size=${SIZE:-256x192}
frames=${FRAMES:-17}
work=${WORK:-$root/bench/results/clocks}
results=${RESULTS:-$root/bench/results/clocks.md}
bin=${BIN:-$root/build/apps/retimegs}
device=(${DEVICE:+--device "$DEVICE"})
iters=(${ITERS:+--iters "$ITERS"} ${CAP:+--cap "$CAP"})
[ -x "$bin" ] || "$root/scripts/setup.sh"
source "$root/bench/eval_json.sh"
mkdir -p "$work"

late=() on_clock=()
for ((c = 0; c < cameras; c++)); do
  if ((c % 2)); then late+=("$(printf 'cam%02d:0.5' "$c")"); else on_clock+=("$(printf 'cam%02d' "$c")"); fi
done
offsets=$(IFS=,; echo "${late[*]}")
genlocked=$(IFS=,; echo "${on_clock[*]}")
synth=("$bin" synth --preset default --cameras "$cameras" --frames "$frames" --size "$size")
[ -f "$work/sync/scene.json" ] || "${synth[@]}" --out "$work/sync"
[ -f "$work/honoured/scene.json" ] || "${synth[@]}" --time-offsets "$offsets" --out "$work/honoured"
[ -f "$work/ignored/scene.json" ] ||
  "${synth[@]}" --time-offsets "$offsets" --unrecorded-offsets --out "$work/ignored"

rows=()
for v in sync honoured ignored; do
  scene="$work/$v"
  run="$work/runs/$v"
  if [ ! -f "$run/model.rgs" ]; then
    rm -rf "$run"
    "$bin" train --scene "$scene" --out "$run" --preset "$preset" "${iters[@]}" "${device[@]}"
  fi
  [ -f "$work/$v.genlocked.json" ] ||
    "$bin" eval --model "$run/model.rgs" --scene "$scene" --frames odd --cameras "$genlocked" \
      "${device[@]}" --out "$work/$v.genlocked.json"
  [ -f "$work/$v.all.json" ] ||
    "$bin" eval --model "$run/model.rgs" --scene "$scene" --frames odd "${device[@]}" \
      --out "$work/$v.all.json"
  row="| $v |"
  for set in genlocked all; do
    row+=" $(fmt_metric "$(metric "$work/$v.$set.json" psnr)" 2) / $(fmt_metric "$(metric "$work/$v.$set.json" psnr whole)" 2) |"
  done
  rows+=("$row")
done
{
  echo "# Cameras on their own clocks (synthetic rig)"
  echo
  echo "\`synth --preset default\`, $cameras cameras x $frames frames at $size; the odd-numbered"
  echo "cameras half a frame late ($offsets) in *honoured* and *ignored*. \`train --preset"
  echo "$preset${ITERS:+ --iters $ITERS}${CAP:+ --cap $CAP}\` on the even frames, \`eval --frames odd\`; PSNR (dB) inside the masks / on the whole image."
  echo
  echo "| scene | held-out PSNR, genlocked cameras ($genlocked) | held-out PSNR, all cameras (own scene) |"
  echo "|---|---|---|"
  printf '%s\n' "${rows[@]}"
} > "$results"
cat "$results"
