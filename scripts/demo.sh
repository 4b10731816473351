#!/usr/bin/env bash
# The main job on the built-in default: set up, synthesise the default dynamic scene, and write
# a contact sheet of it. Outputs go to demo/ (or the folder given as the first argument).
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
out=${1:-$root/demo}
"$root/scripts/setup.sh"
bin="$root/build/apps/retimegs"
mkdir -p "$out"
"$bin" synth --preset default --out "$out/scene" --force
"$bin" sheet --scene "$out/scene" --out "$out/contact_sheet.png"
echo "scene:         $out/scene"
echo "contact sheet: $out/contact_sheet.png"
