#!/usr/bin/env bash
# The Analytic Sun lighting's error against cost (docs/addon.md, "Analytic Sun"), against references
# this command computes itself:
#
#   bench/analytic_sun_trade.sh [BUILD_DIR] [--no-doc]
#
# 1. The sun's columns table (the add-on's 256 × 64 and others): the transmittance exp(−Σ σt m)
#    the material gets by bilinear lookup against the same with the masses by quadrature, at
#    random points of the atmosphere and sun directions where the sun is up; the library call's
#    time. No Blender render.
# 2. Cycles renders (Debian's Blender 3.4, CPU, 96 × 54, 16 spp, Box filter, single scattering) of
#    the add-on's analytic volume, per Step (km), day (sun 8°) and sunset (sun −1°, looking away),
#    against `airmass render` of the same physics and camera (Analytic Sun: the scene's phases,
#    `--rgb-model renderer`; Volume Scatter: the same with `--renderer-matched`, its own
#    reference); per-pixel relative error over the sky pixels, render wall time (2 threads).
#
# Writes the tables to stdout and, unless --no-doc, into docs/addon.md between the
# <!-- BEGIN analytic_sun_trade --> / <!-- END analytic_sun_trade --> markers. ~3 minutes on 2 cores.
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
BUILD=${1:-build}
DOC=1
[ "${2:-}" = "--no-doc" ] && DOC=0
ZIP="$BUILD/addon/airmass_blender.zip"
[ -f "$ZIP" ] || { echo "analytic_sun_trade: no add-on zip at $ZIP: build first" >&2; exit 2; }
command -v blender >/dev/null || { echo "analytic_sun_trade: blender not found (scripts/setup.sh)" >&2; exit 2; }
WORK=$(mktemp -d "${TMPDIR:-/tmp}/airmass-sun-trade.XXXXXX")
trap 'rm -rf "$WORK"' EXIT
# The add-on unpacked into a scratch user scripts folder, enabled with --addons (the user's own
# Blender settings are not touched).
mkdir -p "$WORK/scripts/addons"
/usr/bin/python3 -c "import sys, zipfile; zipfile.ZipFile(sys.argv[1]).extractall(sys.argv[2])" "$ZIP" "$WORK/scripts/addons"
chmod +x "$WORK/scripts/addons/airmass_blender/bin/airmass"
export BLENDER_USER_CONFIG=$WORK/config BLENDER_USER_SCRIPTS=$WORK/scripts BLENDER_USER_DATAFILES=$WORK/datafiles
blender -b --factory-startup --addons airmass_blender -t 2 --python-exit-code 1 \
  --python "$ROOT/bench/analytic_sun_trade.py" -- --work "$WORK" --out "$WORK/trade.md" > "$WORK/blender.log" 2>&1 \
  || { tail -30 "$WORK/blender.log" >&2; echo "analytic_sun_trade: Blender failed" >&2; exit 1; }
grep '^analytic_sun_trade:' "$WORK/blender.log" >&2 || true
cat "$WORK/trade.md"
if [ "$DOC" -eq 1 ]; then
  /usr/bin/python3 - "$ROOT/docs/addon.md" "$WORK/trade.md" <<'PY'
import os, sys
doc, table = sys.argv[1], open(sys.argv[2], encoding="utf-8").read().strip()
text = open(doc, encoding="utf-8").read()
a, b = "<!-- BEGIN analytic_sun_trade -->", "<!-- END analytic_sun_trade -->"
if a not in text or b not in text:
    sys.exit("analytic_sun_trade: %s has no %s … %s markers" % (doc, a, b))
new = text[:text.index(a) + len(a)] + "\n" + table + "\n" + text[text.index(b):]
open(doc + ".tmp", "w", encoding="utf-8").write(new)
os.replace(doc + ".tmp", doc)
print("analytic_sun_trade: docs/addon.md updated", file=sys.stderr)
PY
fi
