#!/usr/bin/env python3
"""The sky image's grid against every pixel evaluated, over conditions where it is hardest.

    scripts/sky_grid_check.py [--airmass BIN] [--baseline BIN] [--set single|defaults|random]
                              [--seed N --count K] [--out DIR]

Three sets of conditions (docs/sky.md "Faint light and exponential rows in the image's grid"):

  single    17 images, 512 x 256, single scattering only, no sun disc, each preset's own
            spectral basis: earth, blender-nishita, earth-hazy and mars from the preset's
            observer (0 km: on the ground), 10-50 km
            and orbit at sun -4 ... 15 deg. Each default image (grid auto) against the same
            settings with --grid 0 (every pixel, the same 16 view samples): the grid's own error.
            A pixel is judged against its own luminance or 1e-3 of the image's 99th-percentile
            luminance, whichever is more.
  defaults  10 images of `earth` at its defaults (multiple scattering on), 1024 x 512, sun
            rotation 0, from the ground to 1000 km at sun -12 ... 10 deg, against --grid 0
            --ms-grid 0 (every pixel, its multiple scattering integrated along its ray); the
            floor 1e-2 of the 99th percentile (the night side's 1e-6 pixels seen from orbit
            would otherwise dominate).

  random    --count images of random conditions (--seed): a preset, 0-1000 km, sun -12 ... 40
            deg at a random rotation, multiple scattering on or off, 384 x 192, no sun disc;
            each against --grid 0 (the same multiple-scattering view: the image grid's own
            error), floor 1e-3.

Per image: the solid-angle-weighted p95 and the maximum over pixels of max over R, G, B of
|a - b| / max(Y_b, floor). With --baseline, the same for a second build, side by side (the
reference is made by --airmass). The table cache goes to DIR/cache.
"""
import argparse
import os
import random
import subprocess
import sys

import numpy as np
import OpenImageIO as oiio

SINGLE = [
    ("earth", 0, -4), ("earth", 20, -4), ("earth", 50, -4), ("earth", 400, -4), ("earth", 400, 10),
    ("earth", 0, 15), ("earth", 10, 2), ("blender-nishita", 0, None), ("blender-nishita", 0, -4),
    ("blender-nishita", 20, -4), ("earth-hazy", 0, -4), ("earth-hazy", 20, -4), ("earth-hazy", 50, -4),
    ("earth-hazy", 400, 10), ("earth-hazy", 0, 2), ("mars", 50, -4), ("mars", 0, -4),
]
DEFAULTS = [(0, 10), (0, -4), (20, -4), (50, -4), (100, -4), (400, 10), (400, 0), (400, -4), (400, -12), (1000, 0)]


def read(path):
    inp = oiio.ImageInput.open(path)
    if inp is None:
        sys.exit("sky_grid_check: cannot read " + path)
    a = np.asarray(inp.read_image("float"), dtype=np.float64)[:, :, :3]
    inp.close()
    return a


def errors(a, r, floor_fraction):
    h, w, _ = r.shape
    t0, t1 = np.pi * np.arange(h) / h, np.pi * (np.arange(h) + 1) / h
    wt = np.repeat((np.cos(t0) - np.cos(t1))[:, None], w, axis=1)
    y = 0.2126 * r[..., 0] + 0.7152 * r[..., 1] + 0.0722 * r[..., 2]
    lit = y > 0
    floor = floor_fraction * np.percentile(y[lit], 99)
    e = (np.abs(a - r).max(axis=2) / np.maximum(y, floor))[lit]
    wt = wt[lit]
    order = np.argsort(e)
    cum = np.cumsum(wt[order]) / wt.sum()
    return 100 * e[order][min(np.searchsorted(cum, 0.95), e.size - 1)], 100 * e.max()


def render(binary, args, out, env):
    subprocess.run([binary, "sky", "-q", *args, "-o", out], check=True, env=env)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--airmass", default="build/bin/airmass")
    ap.add_argument("--baseline", help="a second build, measured beside --airmass")
    ap.add_argument("--set", choices=["single", "defaults", "random"], default="single")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--count", type=int, default=40)
    ap.add_argument("--out", default="out/sky-grid-check")
    o = ap.parse_args()
    os.makedirs(o.out, exist_ok=True)
    env = dict(os.environ, AIRMASS_CACHE_DIR=os.path.join(o.out, "cache"))
    builds = [("this build", o.airmass)] + ([("baseline", o.baseline)] if o.baseline else [])
    if o.set == "single":
        cases = [(f"{p}, {a} km, sun {'default' if s is None else s}",
                  ["--preset", p, "--no-multiple", "--no-sun-disc", "--width", "512", "--height", "256"] +
                  (["--altitude-km", str(a)] if a else []) + ([] if s is None else ["--sun-elevation", str(s)]),
                  ["--grid", "0"])
                 for p, a, s in SINGLE]
        floor = 1e-3
    elif o.set == "random":
        rng = random.Random(o.seed)
        cases = []
        for _ in range(o.count):
            p = rng.choice(["earth", "blender-nishita", "earth-hazy", "mars"])
            a = rng.choice([0, 0.3, 2, 5, 20, 50, 100, 400, 1000])
            s = round(rng.uniform(-12, 40), 1)
            rot = round(rng.uniform(0, 360), 1)
            ms = rng.random() < 0.5
            cases.append((f"{p}, {a} km, sun {s}, rotation {rot}, {'multiple' if ms else 'single'}",
                          ["--preset", p, "--altitude-km", str(a), "--sun-elevation", str(s), "--sun-rotation",
                           str(rot), "--width", "384", "--height", "192", "--no-sun-disc"] +
                          ([] if ms else ["--no-multiple"]), ["--grid", "0"]))
        floor = 1e-3
    else:
        cases = [(f"earth, {a} km, sun {s}",
                  ["--preset", "earth", "--sun-elevation", str(s), "--sun-rotation", "0", "--width", "1024",
                   "--height", "512"] + (["--altitude-km", str(a)] if a else []), ["--grid", "0", "--ms-grid", "0"]) for a, s in DEFAULTS]
        floor = 1e-2
    header = "| condition | " + " | ".join(f"{name}: p95 / max" for name, _ in builds) + " |"
    print(header)
    print("|---|" + "---:|" * len(builds))
    for k, (label, args, ref_args) in enumerate(cases):
        ref = os.path.join(o.out, f"{k:02d}.ref.exr")
        render(o.airmass, args + ref_args, ref, env)
        r = read(ref)
        cells = []
        for b, (_, binary) in enumerate(builds):
            img = os.path.join(o.out, f"{k:02d}.{b}.exr")
            render(binary, args, img, env)
            p95, worst = errors(read(img), r, floor)
            cells.append(f"{p95:.3f} / {worst:.2f} %")
        print(f"| {label} | " + " | ".join(cells) + " |", flush=True)


if __name__ == "__main__":
    main()
