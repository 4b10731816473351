#!/usr/bin/env bash
# "Your own capture" end to end, timed: footage and a calibration as a user brings them, here the
# CMU Panoptic basketball clip of ../shared/data (31 cameras x 17 frames, 640x360) as per-camera
# JPEG folders (ims/<camera>/) with a rig file written from its calibration, without its masks.
#   import videos (test cameras 0, 10, 15, 30) -> prepare --masks (DIS flow, COLMAP points,
#   approximate masks for the scores) -> train --preset fast on the even frames -> render an 8x
#   slow motion of test camera 0 -> eval on the odd frames of the training cameras (masked by the
#   approximate masks, and the whole image) and of the test cameras.
# Writes bench/results/own_capture.md: each step's wall time and the scores. CALIB=none runs the
# same without the rig file (COLMAP recovers the calibration from the 17 frames of every camera;
# issue 43's "Done when" compares the two) and writes bench/results/own_capture_nocalib.md.
#
#   bash bench/own_capture.sh      # PRESET=fast CALIB=rig DATA=../shared/data/panoptic-basketball
#   CALIB=none bash bench/own_capture.sh
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
preset=${PRESET:-fast}
data=${DATA:-$root/../shared/data/panoptic-basketball}
calib=${CALIB:-rig}
case $calib in
  rig) name=own_capture ;;
  none) name=own_capture_nocalib ;;
  *) echo "CALIB must be rig or none, got '$calib'" >&2; exit 2 ;;
esac
work=${WORK:-$root/bench/results/$name}
bin="$root/build/apps/retimegs"
[ -x "$bin" ] || "$root/scripts/setup.sh"
source "$root/bench/eval_json.sh"
rm -rf "$work"
mkdir -p "$work"

# The calibration as an OpenCV rig file: K and world-to-camera [R | t] per camera (Panoptic's
# train_meta.json / test_meta.json hold them per frame; the cameras are fixed).
python3 - "$data" "$work/rig.json" <<'EOF'
import json, sys
data, out = sys.argv[1], sys.argv[2]
cameras = []
for meta in ("train_meta.json", "test_meta.json"):
    m = json.load(open(f"{data}/{meta}"))
    for k, w2c, cam in zip(m["k"][0], m["w2c"][0], m["cam_id"][0]):
        cameras.append({"name": str(cam), "K": k, "R": [row[:3] for row in w2c[:3]],
                        "t": [row[3] for row in w2c[:3]], "width": m["w"], "height": m["h"]})
json.dump({"cameras": cameras}, open(out, "w"), indent=1)
EOF

declare -A seconds
step() {  # step NAME COMMAND...: runs and times one step
  local name=$1 start
  shift
  start=$(date +%s.%N)
  "$@"
  seconds[$name]=$(echo "$(date +%s.%N) - $start" | bc)
}
scene="$work/scene"
run="$work/run"
calib_args=(--calib "$work/rig.json")
calib_text="--calib rig.json"
# The shared frames are undistorted (Panoptic's calibration has no distortion): a user who knows
# that says so, and COLMAP fits no distortion term.
if [ "$calib" = none ]; then
  calib_args=(--camera-model SIMPLE_PINHOLE)
  calib_text="--camera-model SIMPLE_PINHOLE (no --calib: COLMAP)"
fi
step import "$bin" import videos --in "$data/ims" "${calib_args[@]}" \
  --out "$scene" --test-cameras 0,10,15,30
step prepare "$bin" prepare --scene "$scene" --masks
step train "$bin" train --scene "$scene" --out "$run" --preset "$preset"
step render "$bin" render --model "$run/model.rgs" --scene "$scene" --camera 0 --slowmo 8 \
  --out "$work/cam0_slowmo_8x.mp4"
# The scene's training cameras (without --calib, those COLMAP could not place are left out).
train_cams=$(python3 -c 'import json, sys
print(",".join(c["name"] for c in json.load(open(sys.argv[1]))["cameras"] if c["split"] == "train"))' \
  "$scene/scene.json")
step eval "$bin" eval --model "$run/model.rgs" --scene "$scene" --cameras "$train_cams" \
  --out "$work/heldout.json"
"$bin" eval --model "$run/model.rgs" --scene "$scene" --cameras 0,10,15,30 --out "$work/test.json"
for b in flow crossfade; do
  "$bin" eval --baseline "$b" --scene "$scene" --cameras "$train_cams" --out "$work/$b.json"
done

fmt() {  # seconds -> "M min SS s"
  local s
  s=$(printf '%.0f' "$1")
  printf '%d min %02d s' $((s / 60)) $((s % 60))
}
{
  echo "# Your own capture: footage + $calib_text to a slow-motion shot"
  echo
  echo "Recorded $(date -u +%Y-%m-%d) at commit $(git -C "$root" rev-parse --short HEAD) with"
  echo "\`PRESET=$preset CALIB=$calib bash bench/own_capture.sh\` on $(nproc) cores."
  echo
  echo "| step | command | time |"
  echo "|---|---|---|"
  echo "| import | \`import videos --in ims $calib_text --test-cameras 0,10,15,30\` | $(fmt "${seconds[import]}") |"
  echo "| prepare | \`prepare --masks\` (DIS flow, COLMAP points, approximate masks) | $(fmt "${seconds[prepare]}") |"
  echo "| train | \`train --preset $preset\` (even frames) | $(fmt "${seconds[train]}") |"
  echo "| render | \`render --camera 0 --slowmo 8\` (test camera, 129 frames, H.264) | $(fmt "${seconds[render]}") |"
  echo "| eval | \`eval\` (odd frames of the $(tr ',' '\n' <<<"$train_cams" | wc -l) training cameras) |" \
    "$(fmt "${seconds[eval]}") |"
  echo
  echo "Held-out (odd) frames: training cameras inside the approximate masks and on the whole image;"
  echo "test cameras (never trained on) on the whole image."
  echo
  echo "| method | masked PSNR | whole PSNR | test cams PSNR |"
  echo "|---|---|---|---|"
  # A baseline blends a camera's own training frames: none for a test camera ("–").
  for m in heldout:test:retimegs flow:none:flow crossfade:none:cross-fade; do
    IFS=: read -r train test method <<<"$m"
    echo "| $method | $(fmt_metric "$(metric "$work/$train.json" psnr)" 2) |" \
      "$(fmt_metric "$(metric "$work/$train.json" psnr whole)" 2) |" \
      "$(if [ -f "$work/$test.json" ]; then fmt_metric "$(metric "$work/$test.json" psnr whole)" 2; else echo "–"; fi) |"
  done
} > "$root/bench/results/$name.md"
cat "$root/bench/results/$name.md"
