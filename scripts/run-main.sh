#!/usr/bin/env bash
# The README's main command: installs what is missing, builds, and runs the user's job on the
# default scene (examples/compare/ground-noon.toml: the `earth` preset, a camera 2 m above the
# ground looking at the horizon, the sun at 60°), writing everything into out/ (or $1):
#
#   out/main/sky.exr           the sky texture (equirectangular, Blender's World convention)
#   out/main/atmosphere.vdb    the atmosphere volume of the region the camera sees (km)
#   out/main/analytic.json     the same densities in closed form (the add-on's node tree)
#   out/compare/               the camera rendered natively and in Blender (sky texture,
#                              analytic volume, VDB volume, analytic volume with multiple
#                              scattering): report.md, PNGs, summary.json
#   out/gallery/               skies from sunrise to orbit (EXR + PNG)
#
# It modifies no tracked file. The measured speed-vs-accuracy trades and the README's tables
# are the maintainers' script, scripts/run-trades.sh.
# Environment: AIRMASS_BUILD_DIR (default build/), COMPARE_WIDTH (default 64 px), COMPARE_SAMPLES (default 32 per seed).
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
out="$(realpath -m "${1:-$root/out}")"
bash "$root/scripts/setup.sh"
bash "$root/scripts/build.sh"
build="${AIRMASS_BUILD_DIR:-$root/build}"
airmass="$build/bin/airmass"
py=/usr/bin/python3
scene="$root/examples/compare/ground-noon.toml"
mkdir -p "$out/main"
SECONDS=0
stage() { echo; echo "== [$((SECONDS / 60)) min $((SECONDS % 60)) s] $*"; }

stage "sky texture of the default scene -> $out/main/sky.exr"
"$airmass" sky "$scene" -o "$out/main/sky.exr"

stage "atmosphere volume of the region the camera sees -> $out/main/atmosphere.vdb"
"$airmass" vdb "$scene" -o "$out/main/atmosphere.vdb" --region view --analytic "$out/main/analytic.json"

stage "render vs native in Blender -> $out/compare"
"$airmass" compare "$scene" -o "$out/compare" --width "${COMPARE_WIDTH:-64}" --samples "${COMPARE_SAMPLES:-32}" \
  --paths sky_texture,analytic_volume,analytic_volume_ms,vdb_volume

stage "sky gallery -> $out/gallery"
bash "$root/scripts/gallery.sh" "$out/gallery" "$build" 1024

echo "== done in $((SECONDS / 60)) min $((SECONDS % 60)) s: $out (open $out/compare/report.md)"
