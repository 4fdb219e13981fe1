#!/usr/bin/env bash
# The README's main command: installs what is missing, builds, and runs the main job
# on the default scene, writing everything into out/ (or $1):
#   out/chapman/   the Chapman speed-vs-accuracy trade (table + plot)
# and, as the later stages land, the sky texture, the atmosphere volume, the Blender
# render and the comparison report (see README "What the main command produces").
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
out="$(realpath -m "${1:-$root/out}")"
bash "$root/scripts/setup.sh"
bash "$root/scripts/build.sh"
airmass="${AIRMASS_BUILD_DIR:-$root/build}/bin/airmass"
mkdir -p "$out"

echo "== Chapman function: speed-vs-accuracy trade -> $out/chapman"
"$airmass" report chapman --out "$out/chapman" > /dev/null
/usr/bin/python3 "$root/scripts/plot_chapman.py" "$out/chapman"

echo "== done: $out"
