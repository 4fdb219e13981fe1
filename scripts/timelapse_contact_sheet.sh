#!/usr/bin/env bash
# A sunrise-to-sunset time-lapse of the sky at a named place, as one contact-sheet PNG, made with
# the CLI's sky sequences (docs/sun.md: `airmass sky --time-range ... --fps`).
#
#   scripts/timelapse_contact_sheet.sh [BUILD_DIR] [PLACE LATITUDE LONGITUDE START END STEP_S WIDTH]
#
# Defaults: build, paris 48.8566 2.3522 2026-06-21T03:30:00Z 2026-06-21T20:30:00Z 3600 256 — the
# June solstice in Paris (sunrise about 03:47 UTC, sunset about 19:58 UTC), one frame an hour:
# 18 frames. Sky: preset `earth` (spectral, multiple scattering on, 48 wavelengths), observer on
# the ground, sun disc on, the scene's +Y north; each frame WIDTH × WIDTH/2 pixels.
# Writes docs/images/timelapse_<PLACE>.png (atomically); the EXRs and the frame CSV go to a
# temporary folder that is removed afterwards.
#
# Tiles: each frame's upper sky, from the zenith down to 10° below the horizon (the rows of
# Blender's equirectangular image, all 360° of azimuth: W, N, E, S, W from left to right, the
# image centre is +X = east), labelled with the frame's UTC time and the sun's elevation and
# azimuth from the CSV. Tone mapping: ONE exposure for the whole sheet (so the day's light
# changes show): the log-average luminance Y = 0.2126 R + 0.7152 G + 0.0722 B over every pixel
# above the horizon of every frame is mapped to 0.18; then c' = 1 − exp(−c) per channel and the
# sRGB transfer function. Needs Debian's /usr/bin/python3 (numpy, OpenImageIO, matplotlib).
set -euo pipefail

BUILD=${1:-build}
PLACE=${2:-paris}
LAT=${3:-48.8566}
LON=${4:-2.3522}
START=${5:-2026-06-21T03:30:00Z}
END=${6:-2026-06-21T20:30:00Z}
STEP=${7:-3600}
WIDTH=${8:-256}
AIRMASS="$BUILD/bin/airmass"
[ -x "$AIRMASS" ] || { echo "timelapse: no airmass binary at $AIRMASS (give the build dir)" >&2; exit 2; }
REPO=$(cd "$(dirname "$0")/.." && pwd)
OUT="$REPO/docs/images/timelapse_${PLACE}.png"
WORK=$(mktemp -d -t airmass-timelapse-XXXXXX)
trap 'rm -rf "$WORK"' EXIT

echo "timelapse: $PLACE ($LAT, $LON), $START to $END every $STEP s, ${WIDTH}px"
"$AIRMASS" sky --preset earth --width "$WIDTH" --latitude "$LAT" --longitude "$LON" \
  --time-range "$START,$END" --fps "1/$STEP" -o "$WORK/sky_####.exr" --quiet

/usr/bin/python3 - "$WORK" "$OUT" "$PLACE" "$LAT" "$LON" "$WIDTH" <<'EOF'
import csv
import os
import sys

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import OpenImageIO as oiio  # noqa: E402

work, out, place, lat, lon, width = sys.argv[1], sys.argv[2], sys.argv[3], float(sys.argv[4]), float(sys.argv[5]), int(sys.argv[6])
with open(os.path.join(work, "sky.csv"), newline="") as f:
    rows = list(csv.DictReader(f))
frames = []
for r in rows:
    inp = oiio.ImageInput.open(os.path.join(work, r["file"]))
    if inp is None:
        sys.exit("timelapse: " + oiio.geterror())
    rgb = inp.read_image(oiio.FLOAT)[..., :3].astype(np.float64)
    inp.close()
    frames.append(rgb)
height = frames[0].shape[0]
elevation = 90.0 - (np.arange(height) + 0.5) * 180.0 / height  # row centres, top = zenith
above = elevation > 0.0
keep = elevation >= -10.0


def luminance(rgb):
    return 0.2126 * rgb[..., 0] + 0.7152 * rgb[..., 1] + 0.0722 * rgb[..., 2]


ys = np.concatenate([luminance(rgb[above]).ravel() for rgb in frames])
exposure = 0.18 / np.exp(np.mean(np.log(ys[ys > 0])))
cols = 3
nrows = (len(frames) + cols - 1) // cols
fig, axes = plt.subplots(nrows, cols, figsize=(cols * 3.0, nrows * 1.05), dpi=100)
for i, ax in enumerate(np.ravel(axes)):
    ax.set_axis_off()
    if i >= len(frames):
        continue
    x = 1.0 - np.exp(-np.maximum(frames[i][keep] * exposure, 0.0))
    srgb = np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)
    ax.imshow(np.clip(srgb, 0.0, 1.0), interpolation="bilinear", aspect="auto")
    r = rows[i]
    ax.set_title("%s UTC  sun %+.1f°, az %.0f°" % (r["utc"][11:16], float(r["elevation_deg"]), float(r["azimuth_deg"])),
                 fontsize=7, pad=2)
fig.suptitle("%s (%.4f°, %.4f°), %s: preset earth, %d×%d px per frame, one exposure ×%.3g; "
             "left to right W N E S W" % (place.capitalize(), lat, lon, rows[0]["utc"][:10], width, height, exposure),
             fontsize=7)
fig.subplots_adjust(left=0.01, right=0.99, bottom=0.01, top=1 - 0.35 / nrows, wspace=0.03, hspace=0.3)
tmp = os.path.join(os.path.dirname(out), ".%s.tmp.png" % os.path.basename(out))
fig.savefig(tmp, dpi=100)
os.replace(tmp, out)
print("timelapse: wrote %s (%d frames, exposure x%.3g, %d KB)" % (out, len(frames), exposure, os.path.getsize(out) // 1024))
EOF
