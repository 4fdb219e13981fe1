#!/usr/bin/python3
"""Single scattering along single view rays against the brute-force reference, per preset.

    /usr/bin/python3 scripts/view_sampling_check.py [--airmass build/bin/airmass] [--samples 16,64,256]

For each preset and each ray (an observer on the ground; view zenith, sun zenith and azimuth
from the sun in degrees) prints the single-scattering radiance at 450, 550 and 650 nm from
`airmass eval --no-multiple --samples N` (the view march of every sky image; 16 is the
default) as its relative error against `airmass eval --no-multiple --reference` (brute-force
nested quadrature, relative tolerance 1e-7: the repo's own reference), the largest over the
three wavelengths. A markdown table on stdout (docs/sky.md "Hazy atmospheres at low sun").

The rays are the sunset and twilight geometries where the light a ray gathers comes from
where the sun's or the view's optical depth thins out, and one daylight ray as a control.
"""
import argparse
import subprocess
import sys

PRESETS = ["earth", "blender-nishita", "earth-hazy", "mars"]
# (view zenith, sun zenith, azimuth): observer on the ground
RAYS = [
    (60, 60, 90),   # daylight control
    (80, 85, 90),   # sun 5°, near the horizon, sideways
    (85, 88, 0),    # sun 2°, horizon toward the sun
    (85, 88, 180),  # sun 2°, horizon away from the sun
    (60, 92, 0),    # sun −2°
    (60, 94, 0),    # sun −4°
    (85, 94, 0),    # sun −4°, horizon toward the sun
]
WAVELENGTHS = "450,550,650"


def evaluate(airmass, preset, extra):
    rows = "".join("0,%g,%g,%g\n" % ray for ray in RAYS)
    out = subprocess.run([airmass, "eval", "--preset", preset, "--no-multiple", "--wavelengths", WAVELENGTHS] + extra,
                         input=rows, capture_output=True, text=True, check=True).stdout
    lines = [l for l in out.splitlines() if l and l[0].isdigit()]
    values = [float(l.split(",")[8]) for l in lines]  # radiance (single scattering, ground)
    n = len(WAVELENGTHS.split(","))
    if len(values) != n * len(RAYS):
        sys.exit("view_sampling_check: unexpected output of airmass eval:\n" + out)
    return [values[k * n:(k + 1) * n] for k in range(len(RAYS))]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--airmass", default="build/bin/airmass")
    ap.add_argument("--samples", default="16,64,256", help="view samples per constituent, comma-separated")
    args = ap.parse_args()
    samples = [int(s) for s in args.samples.split(",")]
    print("| preset | view zenith | sun zenith | azimuth | " + " | ".join("%d samples" % s for s in samples) + " |")
    print("|---|---:|---:|---:|" + "---:|" * len(samples))
    for preset in PRESETS:
        ref = evaluate(args.airmass, preset, ["--reference"])
        runs = [evaluate(args.airmass, preset, ["--samples", str(s)]) for s in samples]
        for k, ray in enumerate(RAYS):
            cells = []
            for run in runs:
                errs = [abs(v - r) / r for v, r in zip(run[k], ref[k]) if r > 0.0]
                cells.append("%.2g %%" % (100.0 * max(errs)) if errs else "dark")
            print("| %s | %g° | %g° | %g° | %s |" % ((preset,) + ray + (" | ".join(cells),)))


if __name__ == "__main__":
    main()
