#!/usr/bin/python3
"""Single scattering along single view rays against the brute-force reference, per preset.

    /usr/bin/python3 scripts/view_sampling_check.py [--airmass build/bin/airmass] [--samples 16,64,256]
    /usr/bin/python3 scripts/view_sampling_check.py --sweep [--limbs] [--airmass A[,B...]] [--samples 16,64]

For each preset and each ray (an observer on the ground; view zenith, sun zenith and azimuth
from the sun in degrees) prints the single-scattering radiance at 450, 550 and 650 nm from
`airmass eval --no-multiple --samples N` (the view march of every sky image; 16 is the
default) as its relative error against `airmass eval --no-multiple --reference` (brute-force
nested quadrature, relative tolerance 1e-7: the repo's own reference), the largest over the
three wavelengths. A markdown table on stdout (docs/sky.md "Hazy atmospheres at low sun").

The rays are the sunset and twilight geometries where the light a ray gathers comes from
where the sun's or the view's optical depth thins out, and one daylight ray as a control.

--sweep: 299 rays per preset instead — observers at 2, 20, 50 and 400 km, sun zenith 85°, 92°,
94° and 97°, views 0.5° below the horizontal and through tangent altitudes of 1, 5 and 15 km
(rays through a periapsis, below the observer), azimuth 0°, 45°, 90° and 180° from the sun, and
75 rays from the ground — and per build (--airmass, comma-separated, to compare builds on the same
reference) and sample count the largest, 99th-, 90th-percentile and median error, a ray's error
being the largest over 450, 550 and 650 nm of |L − L_ref| / max(L_ref, 1e-4 of the brightest
ray's L_ref) (so a ray in the Earth's shadow, 1e-17 beside 1e-2, is not judged by its own
rounding). docs/sky.md "Rays through a periapsis".

--sweep --limbs: daylight limbs seen from orbit instead — observers at 50 and 400 km, sun zenith
30°, 60°, 75° and 85°, views through tangent altitudes of 1, 5, 10, 20 and 40 km, azimuth 0°, 90°,
135° and 180° from the sun (160 rays per preset): on the side away from the sun the ray passes
from sunlight into the planet's shadow before its periapsis (docs/sky.md "Limbs from orbit and
the shadow's edge").
"""
import argparse
import math
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


def through_tangent(preset, alt_km, tangent_km):
    """View zenith (degrees) of the ray from alt_km whose periapsis is at tangent_km."""
    radius_km = 3389.5 if preset == "mars" else 6360.0
    return 90.0 + math.degrees(math.acos((radius_km + tangent_km) / (radius_km + alt_km)))


def sweep_rays(preset):
    """(altitude_m, view zenith, sun zenith, azimuth) of the sweep."""
    rays = []
    for alt in (2.0, 20.0, 50.0, 400.0):
        for sun in (85.0, 92.0, 94.0, 97.0):
            for tangent in (None, 1.0, 5.0, 15.0):
                if tangent is not None and tangent >= alt:
                    continue
                view = 90.5 if tangent is None else through_tangent(preset, alt, tangent)
                rays += [(alt * 1e3, view, sun, az) for az in (0.0, 45.0, 90.0, 180.0)]
    rays += [(0.0, view, sun, az) for view in (60.0, 80.0, 85.0, 89.0, 89.9)
             for sun in (60.0, 85.0, 88.0, 92.0, 94.0) for az in (0.0, 90.0, 180.0)]
    return rays


def limb_rays(preset):
    """(altitude_m, view zenith, sun zenith, azimuth) of the daylight limbs seen from orbit."""
    rays = []
    for alt in (50.0, 400.0):
        for sun in (30.0, 60.0, 75.0, 85.0):
            for tangent in (1.0, 5.0, 10.0, 20.0, 40.0):
                view = through_tangent(preset, alt, tangent)
                rays += [(alt * 1e3, view, sun, az) for az in (0.0, 90.0, 135.0, 180.0)]
    return rays


def evaluate(airmass, preset, extra, rays=None):
    rows = "".join("%.9g,%.9g,%.9g,%.9g\n" % ray for ray in rays) if rays else \
        "".join("0,%g,%g,%g\n" % ray for ray in RAYS)
    out = subprocess.run([airmass, "eval", "--preset", preset, "--no-multiple", "--wavelengths", WAVELENGTHS] + extra,
                         input=rows, capture_output=True, text=True, check=True).stdout
    lines = [l for l in out.splitlines() if l and l[0].isdigit()]
    values = [float(l.split(",")[8]) for l in lines]  # radiance (single scattering, ground)
    n = len(WAVELENGTHS.split(","))
    count = len(rays) if rays else len(RAYS)
    if len(values) != n * count:
        sys.exit("view_sampling_check: unexpected output of airmass eval:\n" + out)
    return [values[k * n:(k + 1) * n] for k in range(count)]


def sweep(builds, samples, make_rays):
    print("| preset | build | samples | max | p99 | p90 | median | worst ray (altitude m, view, sun zenith, azimuth) |")
    print("|---|---|---:|---:|---:|---:|---:|---|")
    for preset in PRESETS:
        rays = make_rays(preset)
        ref = evaluate(builds[0], preset, ["--reference"], rays)
        floor = 1e-4 * max(max(r) for r in ref)
        for build in builds:
            for n in samples:
                run = evaluate(build, preset, ["--samples", str(n)], rays)
                errs = sorted((max(abs(v - r) / max(r, floor) for v, r in zip(run[k], ref[k])), rays[k])
                              for k in range(len(rays)))
                e = [x[0] for x in errs]
                print("| %s | %s | %d | %.3g %% | %.3g %% | %.3g %% | %.3g %% | %s |" % (
                    preset, build, n, 100 * e[-1], 100 * e[len(e) * 99 // 100], 100 * e[len(e) * 9 // 10],
                    100 * e[len(e) // 2], ", ".join("%.4g" % v for v in errs[-1][1])))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--airmass", default="build/bin/airmass")
    ap.add_argument("--samples", default="16,64,256", help="view samples per constituent, comma-separated")
    ap.add_argument("--sweep", action="store_true", help="299 rays per preset, summarised (see above)")
    ap.add_argument("--limbs", action="store_true", help="with --sweep: daylight limbs from orbit (see above)")
    args = ap.parse_args()
    samples = [int(s) for s in args.samples.split(",")]
    if args.sweep:
        sweep(args.airmass.split(","), samples, limb_rays if args.limbs else sweep_rays)
        return
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
