#!/usr/bin/python3
"""The gallery image of one scene from its K seed renders, and its noise figure.

    /usr/bin/python3 scripts/showcase/finish.py --out out/showcase --scene NAME --title TEXT \\
        --ev EV --png docs/images/gallery/NAME.png [--doc docs/gallery.md]

Reads OUT/NAME_seed<k>.exr + .json (scripts/showcase/render_scene.py) and OUT/NAME_sky.npy
(the sky pixels) and writes:
  * OUT/NAME.exr      the mean of the seeds (linear, what the PNG shows);
  * OUT/NAME.json     settings, times and the noise statistics;
  * the PNG: the mean tone-mapped — scaled by 2^EV, soft saturation c' = 1 − exp(−c) per
    channel, sRGB (scripts/gallery.sh's mapping with a fixed exposure) — with a caption band
    under it giving the settings, the render time and the measured noise.
With --doc, the table between <!-- BEGIN showcase --> and <!-- END showcase --> in that file
is rewritten from every OUT/*.json summary.

Noise: the definition of `airmass compare` (compare/report.py, imported, not copied): per pixel
and channel the standard error s of the mean of the K seeds (std with ddof 1 / sqrt K) and the
relative noise mean s / max(N, 1e-3·mean N) over the sky pixels (report.rel_stats); there is
no native reference here, so N is the seeds' mean itself.
"""

import argparse
import glob
import json
import math
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "..", "compare"))
import report  # noqa: E402  compare/report.py: images, statistics

BOUND = 0.02  # the gallery's noise bound over the sky (issue 19)
CAPTION_PX = 74  # height of the caption band under the image
MAX_PNG_BYTES = 600 * 1024  # above this the PNG gets a 256-colour palette (shrink_png)


def tone_map(img, ev):
    """Scale by 2^EV, soft saturation 1 − exp(−c), sRGB: display values in [0, 1]."""
    c = np.maximum(np.nan_to_num(img, nan=0.0, posinf=0.0, neginf=0.0), 0.0) * (2.0 ** ev)
    return report.srgb(1.0 - np.exp(-c))


def caption_image(display, lines):
    """The image with a caption band under it, as an RGB array in [0, 1] (matplotlib text)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    h, w = display.shape[:2]
    H = h + CAPTION_PX
    dpi = 100
    fig = plt.figure(figsize=(w / dpi, H / dpi), dpi=dpi)
    fig.patch.set_facecolor("black")
    ax = fig.add_axes([0.0, CAPTION_PX / H, 1.0, h / H])
    ax.imshow(display, interpolation="nearest", aspect="auto")
    ax.set_axis_off()
    for i, line in enumerate(lines):
        fig.text(6.0 / w, 1.0 - (h + 4 + 17 * i) / H, line, color="white", fontsize=10.0 if i == 0 else 8.6,
                 family="DejaVu Sans", va="top", ha="left", fontweight="bold" if i == 0 else "normal")
    fig.canvas.draw()
    rgba = np.asarray(fig.canvas.buffer_rgba(), dtype=np.float64)[..., :3] / 255.0
    plt.close(fig)
    return rgba


def fmt_time(s):
    return "%.0f s" % s if s < 120 else "%.1f min" % (s / 60.0) if s < 7200 else "%.1f h" % (s / 3600.0)


def summarise(out, scene, title, ev):
    infos = []
    k = 0
    while os.path.isfile(os.path.join(out, "%s_seed%d.json" % (scene, k))):
        with open(os.path.join(out, "%s_seed%d.json" % (scene, k)), encoding="utf-8") as f:
            infos.append(json.load(f))
        k += 1
    if len(infos) < 2:
        raise SystemExit("finish: %s needs at least 2 seed renders in %s (found %d)" % (scene, out, len(infos)))
    stack = np.stack([report.read_exr(os.path.join(out, "%s_seed%d.exr" % (scene, i))) for i in range(k)])
    mean = stack.mean(axis=0)
    se = stack.std(axis=0, ddof=1) / math.sqrt(k)
    mask = np.load(os.path.join(out, "%s_sky.npy" % scene))
    if mask.shape != mean.shape[:2] or not mask.any():
        raise SystemExit("finish: %s: the sky mask is empty or not the image's size" % scene)
    sky, _ = report.rel_stats(mean[mask], mean[mask], se[mask])
    whole, _ = report.rel_stats(mean, mean, se)
    i0 = infos[0]
    summary = {
        "scene": scene, "title": title, "width": i0["width"], "height": i0["height"],
        "seeds": k, "samples_per_seed": i0["samples"], "samples_per_pixel": k * i0["samples"],
        "render_seconds": [i["render_seconds"] for i in infos],
        "build_seconds": [i["build_seconds"] for i in infos],
        "noise_rel_sky": sky["noise_rel"], "noise_rel_sky_per_channel":
            {c: sky["per_channel"][c]["noise_rel"] for c in "RGB"},
        "noise_rel_image": whole["noise_rel"], "sky_pixels": int(mask.sum()),
        "below_bound": bool(sky["noise_rel"] < BOUND), "bound": BOUND, "exposure_ev": ev,
        # Monte Carlo noise falls as 1/sqrt(samples): what the bound would take, at the same
        # seeds, resolution and machine load (an extrapolation, not a measurement).
        "spp_for_bound": int(math.ceil(k * i0["samples"] * max(1.0, (sky["noise_rel"] / (0.9 * BOUND)) ** 2))),
        "seconds_for_bound": sum(i["render_seconds"] for i in infos) * max(1.0, (sky["noise_rel"] / (0.9 * BOUND)) ** 2),
        "settings": {key: i0[key] for key in ("blender", "device", "denoiser", "max_bounces", "diffuse_bounces",
                                              "volume_bounces", "volume_max_steps", "filter", "sun_elevation_deg",
                                              "sun_rotation_deg", "camera", "airmass", "lamp", "operators")},
        "noise_definition": "compare/report.py rel_stats: mean over sky pixels and channels of the standard error "
                            "of the seeds' mean / max(mean, 1e-3 · its average)",
    }
    return summary, mean


def caption_lines(sm):
    a = sm["settings"]["airmass"]
    st = sm["settings"]
    total = sum(sm["render_seconds"])
    what = {"terrain_sky": "sky texture + Sun lamp, no volume"}.get(
        sm["scene"], "%s volume%s%s" % ("VDB" if sm["scene"].endswith("vdb") else "analytic",
                                        {"SUN_EMISSION": ", Analytic Sun" + (" + multiple scattering" if a.get(
                                            "volume_multiple") else ""), "SCATTER": ", Volume Scatter"}.get(
                                            a.get("volume_lighting"), ""),
                                        ", step %.3g km" % a["step_km"]))
    line1 = "%s  —  sun %.1f°, %s" % (sm["title"], st["sun_elevation_deg"], what)
    line2 = ("%d × %d, %d seeds × %d samples = %d spp, Cycles CPU (Blender %s), no denoiser, bounces: diffuse %d, "
             "volume %d" % (sm["width"], sm["height"], sm["seeds"], sm["samples_per_seed"], sm["samples_per_pixel"],
                            st["blender"], st["diffuse_bounces"], st["volume_bounces"]))
    line3 = ("render %s (%s), 2 shared cores; noise (rel. s.e. of the seeds' mean): "
             "sky %.2f %% %s 2 %%, whole image %.2f %%" % (
                 fmt_time(total), " + ".join(fmt_time(s) for s in sm["render_seconds"]), 100 * sm["noise_rel_sky"],
                 "<" if sm["below_bound"] else "≥ (ABOVE the bound)", 100 * sm["noise_rel_image"]))
    line4 = "PNG: linear × 2^(%+.1f EV), 1 − exp(−c), sRGB; linear EXR in out/showcase/%s.exr" % (
        sm["exposure_ev"], sm["scene"])
    return [line1, line2, line3, line4]


def shrink_png(path, limit=MAX_PNG_BYTES):
    """A noisy image does not compress: above the limit the PNG is stored with a 256-colour
    palette (Pillow's median cut, no dithering), atomically. Returns whether it was."""
    if os.path.getsize(path) <= limit:
        return False
    from PIL import Image
    tmp = path + ".tmp.png"
    try:
        with Image.open(path) as im:
            im.convert("RGB").quantize(colors=256, method=Image.Quantize.MEDIANCUT,
                                       dither=Image.Dither.NONE).save(tmp, optimize=True)
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.remove(tmp)
    return True


def write_exr_mean(path, img):
    oiio = report.B.oiio
    h, w = img.shape[:2]
    buf = oiio.ImageBuf(oiio.ImageSpec(w, h, 3, oiio.FLOAT))
    buf.set_pixels(oiio.ROI(0, w, 0, h), img.astype(np.float32))
    tmp = path + ".tmp.exr"
    if not buf.write(tmp, "float", "exr"):
        raise RuntimeError("cannot write %s: %s" % (tmp, buf.geterror()))
    os.replace(tmp, path)


def doc_table(out, png_dir_rel):
    rows = ["| image | resolution | samples (seeds × per seed) | render time (this machine) | sky noise (rel. s.e.) | "
            "whole-image noise | exposure | for sky noise 1.8 % (extrapolated) |", "|---|---|---|---|---|---|---|---|"]
    for p in sorted(glob.glob(os.path.join(out, "*.json"))):
        if "_seed" in os.path.basename(p):
            continue
        with open(p, encoding="utf-8") as f:
            sm = json.load(f)
        rows.append("| [%s](%s/%s.png) | %d × %d | %d × %d = %d spp | %s (%s) | %.2f %%%s | %.2f %% | %+.1f EV | %s |" % (
            sm["title"], png_dir_rel, sm["scene"], sm["width"], sm["height"], sm["seeds"], sm["samples_per_seed"],
            sm["samples_per_pixel"], fmt_time(sum(sm["render_seconds"])),
            " + ".join(fmt_time(s) for s in sm["render_seconds"]), 100 * sm["noise_rel_sky"],
            "" if sm["below_bound"] else " (above the 2 % bound)", 100 * sm["noise_rel_image"], sm["exposure_ev"],
            "already below" if sm["below_bound"] else "≈ %d spp, ≈ %s" % (sm["spp_for_bound"],
                                                                        fmt_time(sm["seconds_for_bound"]))))
    return "\n".join(rows)


def update_doc(doc, table):
    with open(doc, encoding="utf-8") as f:
        text = f.read()
    a, b = "<!-- BEGIN showcase -->", "<!-- END showcase -->"
    if a not in text or b not in text:
        raise SystemExit("finish: %s has no %s … %s markers" % (doc, a, b))
    new = text[:text.index(a) + len(a)] + "\n" + table + "\n" + text[text.index(b):]
    tmp = doc + ".tmp"
    with open(tmp, "w", encoding="utf-8") as f:
        f.write(new)
    os.replace(tmp, doc)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", required=True)
    ap.add_argument("--scene", required=True)
    ap.add_argument("--title", required=True)
    ap.add_argument("--ev", type=float, required=True)
    ap.add_argument("--png", required=True)
    ap.add_argument("--doc")
    a = ap.parse_args()
    report.B = report.Backends()
    if report.B.oiio is None:
        raise SystemExit("finish: needs Debian's python3 with OpenImageIO (python3-openimageio)")
    sm, mean = summarise(a.out, a.scene, a.title, a.ev)
    write_exr_mean(os.path.join(a.out, a.scene + ".exr"), mean)
    os.makedirs(os.path.dirname(os.path.abspath(a.png)), exist_ok=True)
    report.write_png(a.png, caption_image(tone_map(mean, a.ev), caption_lines(sm)))
    sm["png_palette"] = shrink_png(a.png)
    sm["png"] = a.png
    sm["png_bytes"] = os.path.getsize(a.png)
    tmp = os.path.join(a.out, a.scene + ".json.tmp")
    with open(tmp, "w", encoding="utf-8") as f:
        json.dump(sm, f, indent=1)
    os.replace(tmp, os.path.join(a.out, a.scene + ".json"))
    y = report.luminance(mean)
    y = y[np.isfinite(y) & (y > 0)]
    auto_ev = math.log2(0.18 / math.exp(np.log(y).mean())) if y.size else 0.0
    print("showcase: %-15s %d × %d, %d × %d spp, render %s, sky noise %.2f %% (%s the 2 %% bound), PNG %d KB, "
          "exposure %+.1f EV (geometric-mean-to-0.18 would be %+.1f EV)" % (
              a.scene, sm["width"], sm["height"], sm["seeds"], sm["samples_per_seed"],
              fmt_time(sum(sm["render_seconds"])), 100 * sm["noise_rel_sky"],
              "below" if sm["below_bound"] else "ABOVE", sm["png_bytes"] // 1024, a.ev, auto_ev))
    if a.doc:
        rel = os.path.relpath(os.path.dirname(os.path.abspath(a.png)), os.path.dirname(os.path.abspath(a.doc)))
        update_doc(a.doc, doc_table(a.out, rel))


if __name__ == "__main__":
    main()
