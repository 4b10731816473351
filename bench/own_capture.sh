#!/usr/bin/env bash
# "Your own capture" end to end, timed: footage and a calibration as a user brings them, here the
# CMU Panoptic basketball clip of ../shared/data (31 cameras x 17 frames, 640x360) as per-camera
# JPEG folders (ims/<camera>/) with a rig file written from its calibration, without its masks.
#   import videos (test cameras 0, 10, 15, 30) -> prepare --masks (DIS flow, COLMAP points,
#   approximate masks for the scores) -> train --preset fast on the even frames -> render an 8x
#   slow motion of test camera 0 -> eval on the odd frames of the training cameras (masked by the
#   approximate masks, and the whole image) and of the test cameras.
# Writes bench/results/own_capture.md: each step's wall time and the scores.
#
#   bash bench/own_capture.sh            # PRESET=fast DATA=../shared/data/panoptic-basketball
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
preset=${PRESET:-fast}
data=${DATA:-$root/../shared/data/panoptic-basketball}
work=${WORK:-$root/bench/results/own_capture}
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
step import "$bin" import videos --in "$data/ims" --calib "$work/rig.json" --out "$scene" \
  --test-cameras 0,10,15,30
step prepare "$bin" prepare --scene "$scene" --masks
step train "$bin" train --scene "$scene" --out "$run" --preset "$preset"
step render "$bin" render --model "$run/model.rgs" --scene "$scene" --camera 0 --slowmo 8 \
  --out "$work/cam0_slowmo_8x.mp4"
train_cams=$(seq -s, 1 29 | tr , '\n' | grep -vxE '10|15' | paste -sd,)
step eval "$bin" eval --model "$run/model.rgs" --scene "$scene" --cameras "$train_cams" \
  --out "$work/heldout.json"
"$bin" eval --model "$run/model.rgs" --scene "$scene" --cameras 0,10,15,30 --out "$work/test.json"
for b in flow crossfade; do
  "$bin" eval --baseline "$b" --scene "$scene" --cameras "$train_cams" --out "$work/$b.json"
  "$bin" eval --baseline "$b" --scene "$scene" --cameras 0,10,15,30 --out "$work/$b-test.json"
done

fmt() {  # seconds -> "M min SS s"
  local s
  s=$(printf '%.0f' "$1")
  printf '%d min %02d s' $((s / 60)) $((s % 60))
}
{
  echo "# Your own capture: footage + rig file to a slow-motion shot"
  echo
  echo "Recorded $(date -u +%Y-%m-%d) at commit $(git -C "$root" rev-parse --short HEAD) with"
  echo "\`PRESET=$preset bash bench/own_capture.sh\` on $(nproc) cores."
  echo
  echo "| step | command | time |"
  echo "|---|---|---|"
  echo "| import | \`import videos --in ims --calib rig.json --test-cameras 0,10,15,30\` | $(fmt "${seconds[import]}") |"
  echo "| prepare | \`prepare --masks\` (DIS flow, COLMAP points, approximate masks) | $(fmt "${seconds[prepare]}") |"
  echo "| train | \`train --preset $preset\` (even frames) | $(fmt "${seconds[train]}") |"
  echo "| render | \`render --camera 0 --slowmo 8\` (test camera, 129 frames, H.264) | $(fmt "${seconds[render]}") |"
  echo "| eval | \`eval\` (odd frames of the 27 training cameras) | $(fmt "${seconds[eval]}") |"
  echo
  echo "Held-out (odd) frames: training cameras inside the approximate masks and on the whole image;"
  echo "test cameras (never trained on) on the whole image."
  echo
  echo "| method | masked PSNR | whole PSNR | test cams PSNR |"
  echo "|---|---|---|---|"
  for m in heldout:test:retimegs flow:flow-test:flow crossfade:crossfade-test:cross-fade; do
    IFS=: read -r train test name <<<"$m"
    echo "| $name | $(fmt_metric "$(metric "$work/$train.json" psnr)" 2) |" \
      "$(fmt_metric "$(metric "$work/$train.json" psnr whole)" 2) |" \
      "$(fmt_metric "$(metric "$work/$test.json" psnr whole)" 2) |"
  done
} > "$root/bench/results/own_capture.md"
cat "$root/bench/results/own_capture.md"
