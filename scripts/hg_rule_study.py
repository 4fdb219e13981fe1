#!/usr/bin/python3
"""Which Henyey–Greenstein g should stand for a Cornette–Shanks phase (docs/compare.md, "One
phase → Henyey–Greenstein rule")? Renders, natively and spectrally, each preset's sky with its
aerosol phase exact (Cornette–Shanks g), as HG(g) and as HG(g of equal mean cosine), every
other constituent unchanged (Rayleigh stays Rayleigh), and prints the relative error of both
candidates against the exact image, as `airmass compare`'s report measures it:
e = (candidate − exact) / max(exact, 10⁻³ · mean exact) per pixel and channel.

    scripts/hg_rule_study.py --cli build/plugin/cli/airmass [--width 256] [--out DIR]

Views: the whole sky (equirectangular panorama, 2 m above the ground) at two sun elevations,
and the preset's own camera and sun (what `airmass compare` renders by default). Needs
OpenImageIO's Python module and numpy.
"""

import argparse
import os
import subprocess
import sys
import tempfile

import numpy as np
import OpenImageIO as oiio

PRESETS = {"earth": ("mie", 0.8), "earth-hazy": ("mie", 0.8), "atmosphere-plus": ("mie", 0.85),
           "blender-nishita": ("mie", 0.76)}


def mean_cosine_g(g):
    return 3.0 * g * (4.0 + g * g) / (5.0 * (2.0 + g * g))


def read(path):
    return np.asarray(oiio.ImageBuf(path).get_pixels(oiio.FLOAT))[..., :3].astype(np.float64)


def render(cli, preset, out, phase, view, width, samples):
    toml = out + ".toml"
    name, _ = PRESETS[preset]
    with open(toml, "w") as f:
        f.write('preset = "%s"\nname = "study"\n\n[[constituent]]\nname = "%s"\nphase = %s\n' % (preset, name, phase))
    cmd = [cli, "render", toml, "-o", out + ".exr", "--width", str(width), "--samples", str(samples), "-q"]
    if view["panoramic"]:
        cmd += ["--panoramic", "--camera-position-km", "0,0,0.002", "--camera-direction", "1,0,0", "--camera-up", "0,0,1"]
    if view.get("sun") is not None:
        cmd += ["--sun-elevation", str(view["sun"])]
    subprocess.run(cmd, check=True)
    return read(out + ".exr")


def errors(candidate, exact):
    e = (candidate - exact) / np.maximum(exact, 1e-3 * exact.mean())
    return float(np.abs(e).mean()), float(np.percentile(np.abs(e), 95)), float(e.mean())


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--cli", required=True)
    ap.add_argument("--width", type=int, default=256)
    ap.add_argument("--samples", type=int, default=64)
    ap.add_argument("--out")
    args = ap.parse_args()
    out = args.out or tempfile.mkdtemp(prefix="hg-rule-")
    os.makedirs(out, exist_ok=True)
    views = [{"label": "sky, sun 5°", "panoramic": True, "sun": 5.0},
             {"label": "sky, sun 30°", "panoramic": True, "sun": 30.0},
             {"label": "preset camera", "panoramic": False, "sun": None}]
    print("| preset | view | HG(g): mean / p95 / signed | HG(g of equal mean cosine): mean / p95 / signed |")
    print("|---|---|---|---|")
    totals = {"g": [], "mc": []}
    for preset, (_, g) in PRESETS.items():
        for k, view in enumerate(views):
            base = os.path.join(out, "%s_%d" % (preset, k))
            exact = render(args.cli, preset, base + "_cs", '{ type = "cornette-shanks", g = %r }' % g, view,
                           args.width, args.samples)
            cells = []
            for key, gg in (("g", g), ("mc", mean_cosine_g(g))):
                img = render(args.cli, preset, base + "_hg_" + key, '{ type = "henyey-greenstein", g = %r }' % gg,
                             view, args.width, args.samples)
                m, p, s = errors(img, exact)
                totals[key].append((m, p, abs(s)))
                cells.append("g = %.4f: %.2f %% / %.2f %% / %+.2f %%" % (gg, 100 * m, 100 * p, 100 * s))
            print("| %s | %s | %s | %s |" % (preset, view["label"], cells[0], cells[1]))
            sys.stdout.flush()
    for key, label in (("g", "HG(g)"), ("mc", "HG(g of equal mean cosine)")):
        a = np.array(totals[key])
        print("%s: mean over views: mean |e| %.2f %%, p95 %.2f %%, |signed| %.2f %%" % (
            label, 100 * a[:, 0].mean(), 100 * a[:, 1].mean(), 100 * a[:, 2].mean()))


if __name__ == "__main__":
    main()
