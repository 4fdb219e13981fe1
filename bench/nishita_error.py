#!/usr/bin/python3
"""Error of Blender 3.4's own Nishita sky and of `airmass sky` settings against one converged
reference, for the `blender-nishita` preset over the upper hemisphere (the accuracy half of
the speed target in docs/sky.md; bench/sky_vs_blender.sh measures the time half).

    /usr/bin/python3 bench/nishita_error.py --airmass build/bin/airmass [--width 512]
        [--elevations 5,15,40] [--grids 0,32,48,64]

Reference: `airmass sky --preset blender-nishita --no-multiple --chapman exact --samples 128
--grid 0 --wavelengths 380:780:2.5` (161 wavelengths, 380-780 nm: the preset's solar table). Blender: its Nishita Sky Texture
(altitude 1 m, no disc) rendered through an equirectangular camera, one ray per pixel centre.
Error of a pixel = max over R, G, B of |c − c_ref| / max(c_ref, Y_ref) (as `airmass report
sky`), statistics weighted by solid angle over the pixels above the horizon, pooled over the
sun elevations. Prints a Markdown table. Debian's python3 (numpy, OpenImageIO).
"""
import argparse
import math
import os
import subprocess
import sys
import tempfile

import numpy as np
import OpenImageIO as oiio

# Blender renders its own Nishita sky with this script (shared with tests/python/test_sky_exr.py).
BLENDER_PANO = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "scripts", "blender_nishita_pano.py")


def read(path):
    px = oiio.ImageBuf(path).get_pixels(oiio.FLOAT)
    if px is None:
        sys.exit("nishita_error: cannot read " + path)
    return np.asarray(px, dtype=np.float64)[..., :3]


def airmass_sky(exe, out, width, elevation, extra):
    cmd = [exe, "sky", "--preset", "blender-nishita", "-o", out, "--width", str(width), "--height", str(width // 2),
           "--hemisphere", "upper", "--no-multiple", "--no-sun-disc", "--altitude-km", "0.001",
           "--sun-elevation", str(elevation), "--sun-rotation", "90", "--quiet"] + extra
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode != 0:
        sys.exit("nishita_error: %s failed:\n%s" % (" ".join(cmd), p.stderr))
    return read(out)


def pixel_errors(img, ref):
    y_ref = 0.2126 * ref[..., 0] + 0.7152 * ref[..., 1] + 0.0722 * ref[..., 2]
    den = np.maximum(ref, y_ref[..., None])
    return (np.abs(img - ref) / np.maximum(den, 1e-30)).max(axis=-1)


def weighted_stats(errors, weights):
    e, w = np.concatenate(errors), np.concatenate(weights)
    order = np.argsort(e)
    cdf = np.cumsum(w[order]) / w.sum()
    p95 = e[order][np.searchsorted(cdf, 0.95)]
    return float((e * w).sum() / w.sum()), float(p95), float(e.max())


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--airmass", required=True)
    ap.add_argument("--blender", default="blender")
    ap.add_argument("--width", type=int, default=512)
    ap.add_argument("--elevations", default="5,15,40")
    ap.add_argument("--grids", default="0,32,48,64")
    a = ap.parse_args()
    w, h = a.width, a.width // 2
    elevations = [float(x) for x in a.elevations.split(",")]
    grids = [int(x) for x in a.grids.split(",")]
    rows = h // 2  # the upper hemisphere: row centres above the horizon
    lat = math.pi / 2 - (np.arange(rows) + 0.5) * math.pi / h
    weight_row = np.cos(lat)
    errs = {"Blender 3.4 Nishita (512x128 texture, 32 steps)": ([], [])}
    for g in grids:
        errs["airmass, grid %d%s" % (g, " (every pixel)" if g == 0 else "")] = ([], [])
    with tempfile.TemporaryDirectory() as tmp:
        for elev in elevations:
            print("nishita_error: sun %g°" % elev, file=sys.stderr)
            # Distinct file names: OpenImageIO caches images by name, so a rewritten file
            # read again under the same name could return the old pixels.
            ref = airmass_sky(a.airmass, os.path.join(tmp, "ref_%g.exr" % elev), w, elev,
                              ["--chapman", "exact", "--samples", "128", "--grid", "0",
                               "--wavelengths", "380:780:2.5"])[:rows]
            out = os.path.join(tmp, "blender_%g.exr" % elev)
            p = subprocess.run([a.blender, "-b", "--factory-startup", "--python-exit-code", "1", "--python", BLENDER_PANO,
                                "--", out, str(w), str(h), str(elev), "90"], capture_output=True, text=True)
            if p.returncode != 0 or not os.path.exists(out):
                sys.exit("nishita_error: Blender failed:\n" + p.stdout[-2000:] + p.stderr[-2000:])
            wts = np.repeat(weight_row[:, None], w, axis=1).ravel()
            e = pixel_errors(read(out)[:rows], ref).ravel()
            errs["Blender 3.4 Nishita (512x128 texture, 32 steps)"][0].append(e)
            errs["Blender 3.4 Nishita (512x128 texture, 32 steps)"][1].append(wts)
            for g in grids:
                img = airmass_sky(a.airmass, os.path.join(tmp, "g%d_%g.exr" % (g, elev)), w, elev,
                                  ["--grid", str(g)])[:rows]
                key = "airmass, grid %d%s" % (g, " (every pixel)" if g == 0 else "")
                errs[key][0].append(pixel_errors(img, ref).ravel())
                errs[key][1].append(wts)
    print("Sun elevations %s°, %d×%d upper hemisphere, against the converged reference "
          "(exact Chapman, 128 samples, 161 wavelengths); error weighted by solid angle." % (a.elevations, w, rows))
    print()
    print("| sky | mean error | 95th percentile | max |")
    print("|---|---|---|---|")
    for k, (e, wt) in errs.items():
        mean, p95, mx = weighted_stats(e, wt)
        print("| %s | %.3g %% | %.3g %% | %.3g %% |" % (k, 100 * mean, 100 * p95, 100 * mx))


if __name__ == "__main__":
    main()
