#!/usr/bin/env bash
# Cameras on their own clocks (issue 65): a synthetic rig (`synth --preset pulsing`, whose motion
# looks alike from every camera, as `--sync auto` needs) in which half the cameras run OFFSET
# frames late, trained five ways with one recipe and scored on the held-out (odd) frames:
#   sync      : every camera genlocked (the reference);
#   given     : the late cameras' frames at t = k + OFFSET, scene.json records it (synth
#               --time-offsets), training and eval use each camera's own time;
#   ignored   : the same images, the offsets left out of scene.json (synth --unrecorded-offsets):
#               every frame k taken as time k, as a user who never measured them has it;
#   estimated : the offsets `import videos --sync auto` finds in the ignored scene's images (with
#               the true rig file), scene.json "clocks": "estimated", refined in training (the
#               default for estimated clocks);
#   unrefined : the same estimated offsets taken as exact (refine_clocks false).
# The estimated scenes are the ignored scene with the importer's offsets written in (the import's
# own scene lacks the synthetic masks, flows and points; its images are the same PNGs). Camera
# refinement stays off throughout (the calibration is exact). Scores: held-out PSNR (masked) over
# the genlocked cameras (the same images and times in every scene, so the same truth) and over
# every camera, each at the time its scene says (the truth for sync and given, time k for ignored,
# the estimate plus the learned correction for estimated), and the late cameras' offsets as
# estimated and refined.
# Writes bench/results/clocks.md.
#
#   bash bench/clocks.sh     # PRESET=fast CAMERAS=8 SIZE=160x120 FRAMES=25 OFFSET=0.4 DEVICE= BIN=; ITERS=, CAP= (the preset's)
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
preset=${PRESET:-fast}
cameras=${CAMERAS:-8}
size=${SIZE:-160x120}
frames=${FRAMES:-25}
offset=${OFFSET:-0.4}
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
  if ((c % 2)); then late+=("$(printf 'cam%02d:%s' "$c" "$offset")"); else on_clock+=("$(printf 'cam%02d' "$c")"); fi
done
offsets=$(IFS=,; echo "${late[*]}")
genlocked=$(IFS=,; echo "${on_clock[*]}")
synth=("$bin" synth --preset pulsing --cameras "$cameras" --frames "$frames" --size "$size")
[ -f "$work/sync/scene.json" ] || "${synth[@]}" --out "$work/sync"
[ -f "$work/given/scene.json" ] || "${synth[@]}" --time-offsets "$offsets" --out "$work/given"
[ -f "$work/ignored/scene.json" ] ||
  "${synth[@]}" --time-offsets "$offsets" --unrecorded-offsets --out "$work/ignored"

# The true rig file (a zero perturbation writes it), then the import that estimates the offsets.
[ -f "$work/rig/calibration_true.json" ] ||
  "${synth[@]}" --perturb-calibration 0,0,0 --out "$work/rig"
if [ ! -f "$work/imported/scene.json" ]; then
  rm -rf "$work/imported"
  "$bin" import videos --in "$work/ignored/images" --calib "$work/rig/calibration_true.json" \
    --sync auto --out "$work/imported" 2>&1 | tee "$work/import.log"
fi
# Each camera's estimated clock offset: its scene.json time_offset (0 where absent), one per line
# in camera order (the importer writes cameras sorted by name, as synth does).
estimated_offsets() {
  awk '/"name":/ { if (n) print t; n = 1; t = 0 }
       /"time_offset":/ { gsub(/[ ,]/, ""); split($0, a, ":"); t = a[2] }
       END { if (n) print t }' "$work/imported/scene.json"
}
# The ignored scene with those offsets and "clocks": "estimated" written into its scene.json.
make_estimated() {
  local out=$1
  [ -f "$out/scene.json" ] && return
  rm -rf "$out"
  cp -r "$work/ignored" "$out"
  local values
  values=$(estimated_offsets | paste -sd' ')
  awk -v values="$values" '
    BEGIN { n = split(values, v, " ") }
    /"name":/ { c++ }
    /"split":/ { sub(/"split"/, "\"time_offset\": " v[c] ", \"split\"") }
    /"calibration":/ { sub(/"calibration"/, "\"clocks\": \"estimated\", \"calibration\"") }
    { print }' "$work/ignored/scene.json" > "$out/scene.json"
}
make_estimated "$work/estimated"
make_estimated "$work/unrefined"
echo '{"refine_cameras": false}' > "$work/cameras_exact.json"
echo '{"refine_cameras": false, "refine_clocks": false}' > "$work/clocks_exact.json"

rows=()
for v in sync given ignored estimated unrefined; do
  scene="$work/$v"
  run="$work/runs/$v"
  config="$work/cameras_exact.json"
  [ "$v" = unrefined ] && config="$work/clocks_exact.json"
  if [ ! -f "$run/model.rgs" ]; then
    rm -rf "$run"
    "$bin" train --scene "$scene" --out "$run" --preset "$preset" --config "$config" "${iters[@]}" \
      "${device[@]}" 2>&1 | tee "$work/$v.train.log"
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
# The late cameras' offsets: true, estimated by the import, and as training refined them.
clock_rows=()
mapfile -t estimates < <(estimated_offsets)
for ((c = 1; c < cameras; c += 2)); do
  name=$(printf 'cam%02d' "$c")
  refined=$(grep -o "camera $name: clock offset [-+0-9.]*" "$work/estimated.train.log" | awk '{print $5}')
  clock_rows+=("| $name | $offset | ${estimates[$c]} | ${refined:-–} |")
done
{
  echo "# Cameras on their own clocks (synthetic rig)"
  echo
  echo "\`synth --preset pulsing\`, $cameras cameras x $frames frames at $size; the odd-numbered"
  echo "cameras $offset frames late ($offsets) in every scene but *sync*. \`train --preset"
  echo "$preset${ITERS:+ --iters $ITERS}${CAP:+ --cap $CAP}\` on the even frames (camera refinement off), \`eval --frames odd\`"
  echo "over every camera at its scene's times; PSNR (dB) inside the masks / on the whole image."
  echo
  echo "| scene | held-out PSNR, genlocked cameras ($genlocked) | held-out PSNR, all cameras |"
  echo "|---|---|---|"
  printf '%s\n' "${rows[@]}"
  echo
  echo "| camera | true offset | \`--sync auto\` | refined in training |"
  echo "|---|---|---|---|"
  printf '%s\n' "${clock_rows[@]}"
} > "$results"
cat "$results"
