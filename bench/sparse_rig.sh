#!/usr/bin/env bash
# Few cameras: the CMU Panoptic clip of ../shared/data cut to small rigs. For each N in COUNTS, N of
# its 27 training cameras spread round the dome (farthest-point sampling of their centres, from
# the first training camera; the same rule for any rig) and the same 4 test cameras (0, 10, 15,
# 30), imported as a scene of their own; then prepare (its default points unless POINTS), train
# --preset PRESET on the even frames, and score the odd frames:
#   - the training cameras' held-out frames, inside the masks, against the flow and cross-fade
#     baselines of the same cameras;
#   - the test cameras (novel views; no masks: whole image), against the full rig's figure.
# Also the points prepare built (its one-line summary) and what they cover.
# Writes bench/results/sparse_rig.md (RESULTS) and keeps each rig's scene and run under WORK.
#
#   bash bench/sparse_rig.sh                # COUNTS="2 3 4 6 8" PRESET=fast POINTS= (default)
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
preset=${PRESET:-fast}
points=${POINTS:-}
read -r -a counts <<< "${COUNTS:-2 3 4 6 8}"
data=${DATA:-$root/../shared/data/panoptic-basketball}
work=${WORK:-$root/bench/results/sparse_rig}
results=${RESULTS:-$root/bench/results/sparse_rig.md}
bin=${BIN:-$root/build/apps/retimegs}
[ -x "$bin" ] || "$root/scripts/setup.sh"
source "$root/bench/eval_json.sh"
mkdir -p "$work"
full="$work/full"
[ -f "$full/scene.json" ] || "$bin" import panoptic --in "$data" --out "$full"

# rig N OUT: a scene of N training cameras spread round the rig and every test camera of $full,
# its images and masks linked; prints the training cameras' names.
rig() {
  python3 - "$full" "$1" "$2" << 'EOF'
import json, os, sys
full, n, out = sys.argv[1], int(sys.argv[2]), sys.argv[3]
scene = json.load(open(os.path.join(full, "scene.json")))
def centre(c):
    m = c["world_to_camera"]
    r = [row[:3] for row in m[:3]]
    t = [row[3] for row in m[:3]]
    return [-sum(r[k][i] * t[k] for k in range(3)) for i in range(3)]
train = [c for c in scene["cameras"] if c.get("split", "train") == "train"]
test = [c for c in scene["cameras"] if c.get("split", "train") == "test"]
chosen = [train[0]]
while len(chosen) < n:
    far = max((c for c in train if c not in chosen),
              key=lambda c: min(sum((a - b) ** 2 for a, b in zip(centre(c), centre(d)))
                                for d in chosen))
    chosen.append(far)
keep = [c for c in scene["cameras"] if c in chosen or c in test]
scene["cameras"] = keep
os.makedirs(out, exist_ok=True)
for kind in ("images", "masks"):
    for c in keep:
        src = os.path.join(full, kind, c["name"])
        if os.path.isdir(src):
            os.makedirs(os.path.join(out, kind), exist_ok=True)
            dst = os.path.join(out, kind, c["name"])
            if not os.path.exists(dst):
                os.symlink(os.path.abspath(src), dst)
with open(os.path.join(out, "scene.json"), "w") as f:
    json.dump(scene, f, indent=2)
print(",".join(c["name"] for c in chosen))
EOF
}

rows=()
for n in "${counts[@]}"; do
  dir="$work/n$n"
  scene="$dir/scene"
  cams=$(rig "$n" "$scene")
  echo "== $n training cameras: $cams"
  status=ok
  if ! "$bin" prepare --scene "$scene" ${points:+--points "$points"} 2>&1 | tee "$dir/prepare.log"; then
    status="prepare failed: $(tail -1 "$dir/prepare.log" | sed 's/^retimegs: //' | cut -c1-100)"
  fi
  source_line=$(grep -o 'points ([^)]*)' "$dir/prepare.log" | tail -1 | sed 's/points (//; s/)//' || true)
  cover=$(grep -o 'cover [0-9]* %' "$dir/prepare.log" | tail -1 | grep -o '[0-9]*' || true)
  model=–; flow=–; cross=–; test=–
  if [ "$status" = ok ]; then
    [ -f "$dir/run/model.rgs" ] ||
      "$bin" train --scene "$scene" --out "$dir/run" --preset "$preset" --force 2>&1 |
      tee "$dir/train.log" | grep -v '^train ' || true
    "$bin" eval --model "$dir/run/model.rgs" --scene "$scene" --out "$dir/model.json" --force
    "$bin" eval --baseline flow --scene "$scene" --out "$dir/flow.json" --force
    "$bin" eval --baseline crossfade --scene "$scene" --out "$dir/crossfade.json" --force
    model=$(fmt_metric "$(metric "$dir/model.json" psnr train_views)" 2)
    test=$(fmt_metric "$(metric "$dir/model.json" psnr test_views)" 2)
    flow=$(fmt_metric "$(metric "$dir/flow.json" psnr train_views)" 2)
    cross=$(fmt_metric "$(metric "$dir/crossfade.json" psnr train_views)" 2)
  fi
  rows+=("| $n | $cams | ${source_line:-–} | ${cover:-–} | $model | $flow | $cross | $test | $status |")
done

{
  echo "# Few cameras: Panoptic subsets"
  echo
  echo "Recorded $(date -u +%Y-%m-%d) at commit $(git -C "$root" rev-parse --short HEAD 2>/dev/null || echo '?')" \
    "with \`COUNTS=\"${counts[*]}\" PRESET=$preset${POINTS:+ POINTS=$POINTS} bash bench/sparse_rig.sh\`."
  echo
  echo "N training cameras of the 27 spread round the dome, the same 4 test cameras (0, 10, 15, 30)."
  echo "Held-out PSNR (dB): the training cameras' odd frames inside the masks (model, flow and"
  echo "cross-fade baselines), the test cameras' odd frames on the whole image (no masks). Points:"
  echo "prepare's sources and the share of the training cameras' mask pixels they cover."
  echo
  echo "| N | training cameras | points | covered % | model | flow | cross-fade | test cameras | status |"
  echo "|---|---|---|---|---|---|---|---|---|"
  printf '%s\n' "${rows[@]}"
} > "$results"
cat "$results"
