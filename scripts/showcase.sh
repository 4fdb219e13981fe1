#!/usr/bin/env bash
# The Blender gallery (issue 19, docs/gallery.md): what a user gets in Blender with the add-on,
# rendered in headless Blender through the add-on's own operators (Generate Sky, Sun Sync,
# Create Atmosphere Volume), Cycles CPU, no denoiser. Not part of the main job (tens of minutes).
#
#   scripts/showcase.sh [--build DIR] [--out DIR] [--png DIR] [--only a,b] [--width W] [--height H]
#                       [--samples-scale F] [--seeds K] [--no-doc] [--finish-only]
#
#   --build DIR        build folder holding addon/airmass_blender.zip (default build)
#   --out DIR          linear EXRs, per-seed renders, JSON summaries (default out/showcase; keep it out of git)
#   --png DIR          the captioned PNGs (default docs/images/gallery)
#   --only a,b         scenes to render (default: all four, names below)
#   --width/--height   resolution (default 960 × 540)
#   --samples-scale F  multiply every scene's samples by F (e.g. 0.05 to check the script quickly)
#   --seeds K          independent renders per scene (default 2; the noise is their standard error)
#   --no-doc           leave docs/gallery.md's table alone
#   --finish-only      no rendering: remake the PNGs, noise and table from the renders in --out
#
# Per scene: K Blender runs (seed 0 … K−1; seed 0 also writes the sky mask), then
# scripts/showcase/finish.py (Debian's python3 + OpenImageIO + matplotlib) makes the mean image,
# its noise over the sky — `airmass compare`'s definition, compare/report.py — the PNG with the
# settings, render time and noise printed under it, and the table in docs/gallery.md.
# Exits 3 when an image's sky noise is not below the 2 % bound (all images are still written).
set -euo pipefail

ROOT=$(cd "$(dirname "$0")/.." && pwd)
BUILD=build OUT=out/showcase PNG=docs/images/gallery ONLY="" WIDTH=960 HEIGHT=540 SCALE=1 SEEDS=2 DOC=1 FINISH_ONLY=0
while [ $# -gt 0 ]; do
  case "$1" in
    --build) BUILD=$2; shift 2 ;;
    --out) OUT=$2; shift 2 ;;
    --png) PNG=$2; shift 2 ;;
    --only) ONLY=$2; shift 2 ;;
    --width) WIDTH=$2; shift 2 ;;
    --height) HEIGHT=$2; shift 2 ;;
    --samples-scale) SCALE=$2; shift 2 ;;
    --seeds) SEEDS=$2; shift 2 ;;
    --no-doc) DOC=0; shift ;;
    --finish-only) FINISH_ONLY=1; shift ;;
    -h|--help) sed -n '2,23p' "$0"; exit 0 ;;
    *) echo "showcase: unknown option '$1' (see --help)" >&2; exit 2 ;;
  esac
done
ZIP="$BUILD/addon/airmass_blender.zip"
[ -f "$ZIP" ] || { echo "showcase: no add-on zip at $ZIP: build first (cmake --build $BUILD --target airmass_addon_zip)" >&2; exit 2; }
command -v blender >/dev/null || { echo "showcase: blender not found (Debian: apt-get install blender)" >&2; exit 2; }
/usr/bin/python3 -c 'import numpy, OpenImageIO, matplotlib' 2>/dev/null \
  || { echo "showcase: Debian's python3 needs numpy, OpenImageIO and matplotlib (scripts/setup.sh)" >&2; exit 2; }
if ! [[ "$SEEDS" =~ ^[0-9]+$ ]] || [ "$SEEDS" -lt 2 ]; then
  echo "showcase: --seeds must be an integer >= 2, got '$SEEDS'" >&2; exit 2
fi
if ! [[ "$WIDTH" =~ ^[0-9]+$ && "$HEIGHT" =~ ^[0-9]+$ ]] || [ "$WIDTH" -lt 16 ] || [ "$HEIGHT" -lt 9 ]; then
  echo "showcase: --width/--height must be integers >= 16 / 9, got '$WIDTH' / '$HEIGHT'" >&2; exit 2
fi
if ! [[ "$SCALE" =~ ^[0-9]*\.?[0-9]+([eE][-+]?[0-9]+)?$ ]] || ! /usr/bin/python3 -c "import sys; sys.exit(float(sys.argv[1]) <= 0)" "$SCALE"; then
  echo "showcase: --samples-scale must be a number > 0, got '$SCALE'" >&2; exit 2
fi
mkdir -p "$OUT" "$PNG"
ZIP=$(cd "$(dirname "$ZIP")" && pwd)/$(basename "$ZIP")

# Blender's user folders in a scratch place: the user's own settings are not touched.
USERDIR=$(mktemp -d "${TMPDIR:-/tmp}/airmass-showcase-user.XXXXXX")
trap 'rm -rf "$USERDIR"' EXIT
export BLENDER_USER_CONFIG=$USERDIR/config BLENDER_USER_SCRIPTS=$USERDIR/scripts BLENDER_USER_DATAFILES=$USERDIR/datafiles

# name | title | samples per seed (at scale 1) | exposure (EV)
SCENES=(
  "terrain_sky|The same mountains, Airmass sky texture only|8|-2.4"
  "terrain_volume|Mountains at golden hour, Airmass volume|16|-2.5"
  "sunset_shadow|Sunset: the Earth's shadow and the Belt of Venus|8|-0.5"
  "limb_vdb|The limb from 400 km, VDB volume|48|-4.6"
)

status=0
for entry in "${SCENES[@]}"; do
  IFS='|' read -r name title samples ev <<<"$entry"
  if [ -n "$ONLY" ] && [[ ",$ONLY," != *",$name,"* ]]; then continue; fi
  n=$(/usr/bin/python3 -c "import sys; print(max(1, round(float(sys.argv[1]) * float(sys.argv[2]))))" "$samples" "$SCALE")
  [ "$FINISH_ONLY" -eq 1 ] || rm -f "$OUT/${name}"_seed*.exr "$OUT/${name}"_seed*.json
  for ((k = 0; k < SEEDS && FINISH_ONLY == 0; k++)); do
    mask=(); [ "$k" -eq 0 ] && mask=(--mask)
    echo "showcase: $name seed $k ($WIDTH × $HEIGHT, $n samples)"
    blender -b --factory-startup --python-exit-code 1 --python "$ROOT/scripts/showcase/render_scene.py" -- \
      --zip "$ZIP" --scene "$name" --seed "$k" --out "$OUT" --width "$WIDTH" --height "$HEIGHT" \
      --samples "$n" "${mask[@]}" > "$OUT/${name}_seed$k.log" 2>&1 \
      || { echo "showcase: $name seed $k failed; the last lines of $OUT/${name}_seed$k.log:" >&2
           tail -n 20 "$OUT/${name}_seed$k.log" >&2; exit 1; }
    grep '^showcase:' "$OUT/${name}_seed$k.log" || true
  done
  doc=(); [ "$DOC" -eq 1 ] && doc=(--doc "$ROOT/docs/gallery.md")
  /usr/bin/python3 "$ROOT/scripts/showcase/finish.py" --out "$OUT" --scene "$name" --title "$title" --ev "$ev" \
    --png "$PNG/$name.png" "${doc[@]}"
  /usr/bin/python3 -c "import json,sys; sys.exit(0 if json.load(open(sys.argv[1]))['below_bound'] else 3)" \
    "$OUT/$name.json" || status=3
done
exit $status
