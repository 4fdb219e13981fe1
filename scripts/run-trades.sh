#!/usr/bin/env bash
# The maintainers' command: the measured speed-vs-accuracy trade of every approximation and
# knob, each against the reference the repository computes itself, and then the README's and
# docs' tables and images regenerated from them (scripts/update_readme.py rewrites README.md,
# docs/*.md between BEGIN/END markers and docs/images/ — run it in a checkout you mean to
# commit from). Output into out/ (or $1):
#
#   out/chapman/  Chapman methods: error vs time        out/sky/  sky texture knobs (earth)
#   out/vdb/      voxel size and tiling                 out/ms/   multiple-scattering tables
#   out/gallery/  the README's sky gallery              out/sky-PRESET/  the same for the
#                                                        other presets (docs/sky.md)
#
# Takes about 60 minutes on 2 cores (48 of them the sky trades, 12 per preset).
# AIRMASS_QUICK=1: smaller trade reports, for a smoke run (their figures are then not the
# README's).
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
out="$(realpath -m "${1:-$root/out}")"
bash "$root/scripts/setup.sh"
bash "$root/scripts/build.sh"
build="${AIRMASS_BUILD_DIR:-$root/build}"
airmass="$build/bin/airmass"
py=/usr/bin/python3
quick=()
[ "${AIRMASS_QUICK:-0}" = 1 ] && quick=(--quick)
mkdir -p "$out"
SECONDS=0
stage() { echo; echo "== [$((SECONDS / 60)) min $((SECONDS % 60)) s] $*"; }

stage "sky gallery -> $out/gallery"
bash "$root/scripts/gallery.sh" "$out/gallery" "$build" 1024

stage "Chapman function trade -> $out/chapman"
"$airmass" report chapman --out "$out/chapman" > /dev/null
"$py" "$root/scripts/plot_chapman.py" "$out/chapman"

stage "sky texture trade -> $out/sky"
"$airmass" report sky --out "$out/sky" "${quick[@]}"
"$py" "$root/scripts/plot_sky_trade.py" "$out/sky" --png "$out/sky/sky_pareto.png"
for preset in blender-nishita earth-hazy mars; do
  stage "sky texture trade, $preset -> $out/sky-$preset"
  "$airmass" report sky --preset "$preset" --no-multiple-view --out "$out/sky-$preset" "${quick[@]}"
done

stage "voxel-size trade -> $out/vdb"
"$airmass" report vdb --out "$out/vdb"
"$py" "$root/scripts/plot_vdb_trade.py" "$out/vdb"

stage "multiple scattering trade -> $out/ms"
"$airmass" report ms --out "$out/ms" "${quick[@]}"
"$py" "$root/scripts/plot_ms_trade.py" "$out/ms/ms_trade.csv" -o "$out/ms/ms_trade.png"

stage "README tables and images (rewrites README.md, docs/)"
"$py" "$root/scripts/update_readme.py" "$out"
echo "== done in $((SECONDS / 60)) min: $out"
