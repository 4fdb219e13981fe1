#!/usr/bin/env bash
# Sky gallery: renders a few skies with `airmass sky` to EXR and to tone-mapped PNG.
#
#   scripts/gallery.sh OUT_DIR [BUILD_DIR] [WIDTH]
#
# Skies (preset `earth`, sun rotation 90° so the sun is at the image centre, +X):
#   sunrise    sun  2°, ground          noon     sun 60°, ground
#   twilight   sun −4°, ground          10km     sun 20°, observer at 10 km
#   orbit      sun 30°, observer at 400 km (the planet, its limb, black space)
# Writes OUT_DIR/<name>.exr (32-bit float, linear Rec.709, Blender equirectangular),
# OUT_DIR/<name>.png (8-bit sRGB) and OUT_DIR/gallery.md (a Markdown table for the README).
#
# PNG tone mapping (simple, per image, documented in docs/sky.md):
#   1. exposure: scale so that the geometric mean of the luminance Y = 0.2126 R + 0.7152 G
#      + 0.0722 B over the pixels with Y > 0 becomes 0.18 (middle grey);
#   2. exponential soft saturation per channel, c' = 1 − exp(−c) (Schüler, GPU Pro 3 §2.6.3);
#   3. the sRGB transfer function, then 8 bits.
# Needs Debian's /usr/bin/python3 (numpy, OpenImageIO).
set -euo pipefail

OUT=${1:?usage: scripts/gallery.sh OUT_DIR [BUILD_DIR] [WIDTH]}
BUILD=${2:-build}
WIDTH=${3:-1024}
AIRMASS="$BUILD/bin/airmass"
[ -x "$AIRMASS" ] || { echo "gallery: no airmass binary at $AIRMASS (give the build dir)" >&2; exit 2; }
mkdir -p "$OUT"

# name | label | airmass sky options
SKIES=(
  "sunrise|Sunrise, sun 2°|--sun-elevation 2"
  "noon|Noon, sun 60°|--sun-elevation 60"
  "twilight|Twilight, sun −4°|--sun-elevation -4"
  "10km|From 10 km, sun 20°|--sun-elevation 20 --altitude-km 10"
  "orbit|The planet from 400 km, sun 30°|--sun-elevation 30 --altitude-km 400"
)

for entry in "${SKIES[@]}"; do
  IFS='|' read -r name label opts <<<"$entry"
  echo "gallery: $name ($label)"
  # shellcheck disable=SC2086  # opts is a list of options
  "$AIRMASS" sky --preset earth --sun-rotation 90 --width "$WIDTH" $opts -o "$OUT/$name.exr" --quiet
done

/usr/bin/python3 - "$OUT" "${SKIES[@]}" <<'EOF'
import os
import sys

import numpy as np
import OpenImageIO as oiio

out_dir, skies = sys.argv[1], sys.argv[2:]


def tone_map(rgb):
    """Linear Rec.709 radiance → 8-bit sRGB: geometric-mean exposure to 0.18, 1 − exp(−x), sRGB."""
    y = 0.2126 * rgb[..., 0] + 0.7152 * rgb[..., 1] + 0.0722 * rgb[..., 2]
    lit = y[y > 0]
    exposure = 0.18 / np.exp(np.mean(np.log(lit))) if lit.size else 1.0
    x = 1.0 - np.exp(-np.maximum(rgb * exposure, 0.0))
    srgb = np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)
    return np.clip(np.round(srgb * 255), 0, 255).astype(np.uint8), exposure


rows = ["| sky | image |", "|---|---|"]
for entry in skies:
    name, label, _ = entry.split("|", 2)
    inp = oiio.ImageInput.open(os.path.join(out_dir, name + ".exr"))
    if inp is None:
        sys.exit("gallery: " + oiio.geterror())
    rgb = inp.read_image(oiio.FLOAT)[..., :3]
    inp.close()
    png, exposure = tone_map(rgb)
    spec = oiio.ImageSpec(png.shape[1], png.shape[0], 3, oiio.UINT8)
    spec.attribute("airmass:exposure", float(exposure))
    path = os.path.join(out_dir, name + ".png")
    tmp = os.path.join(out_dir, "." + name + ".tmp.png")
    o = oiio.ImageOutput.create(tmp)
    if o is None or not o.open(tmp, spec) or not o.write_image(png) or not o.close():
        sys.exit("gallery: cannot write " + path + ": " + oiio.geterror())
    os.replace(tmp, path)
    rows.append(f"| {label} (exposure ×{exposure:.3g}) | ![{name}]({name}.png) |")
    print(f"gallery: wrote {path} (exposure x{exposure:.3g})")
md = os.path.join(out_dir, "gallery.md")
with open(md + ".tmp", "w") as f:
    f.write("\n".join(rows) + "\n")
os.replace(md + ".tmp", md)
print("gallery: wrote " + md)
EOF
