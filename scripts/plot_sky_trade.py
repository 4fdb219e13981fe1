#!/usr/bin/python3
"""Pareto plot of the sky texture's speed-vs-accuracy trade (`airmass report sky`).

    /usr/bin/python3 scripts/plot_sky_trade.py OUT_DIR [--png OUT_DIR/sky_trade.png]

Reads OUT_DIR/sky_trade.csv and draws, for every configuration (Chapman method × view
samples × spectral basis × sky grid), the 95th-percentile relative error above the horizon
against the time per megapixel, both on log axes; the Pareto front (no configuration both
faster and more accurate) is drawn as a line and listed on stdout. Debian's python3
(matplotlib); the PNG is written atomically.
"""
import argparse
import csv
import math
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

# The bases `airmass report sky` labels: RGB, Blender's 21 wavelengths, then the 10-, 5-nm
# samplings (spectral-48 / -95 over 360-830 nm; fewer where a preset's tables cover less, e.g.
# spectral-41 / -81 for blender-nishita) and, when it is none of these, the preset's own basis.
BASIS_COLOURS = ["tab:red", "tab:orange", "tab:blue", "tab:green", "tab:purple", "tab:brown"]


def basis_colours(rows):
    """Colour per basis label, in the order the report lists them."""
    labels = []
    for r in rows:
        if r["basis"] not in labels:
            labels.append(r["basis"])
    order = sorted(labels, key=lambda b: (b != "rgb-schuler", b != "spectral-21",
                                          int(b.split("-")[1]) if b.split("-")[-1].isdigit() else 10**6))
    return {b: BASIS_COLOURS[i % len(BASIS_COLOURS)] for i, b in enumerate(order)}
MARKERS = ["o", "s", "^", "v", "D", "P", "X", "*", "<", ">"]
ERROR_FLOOR = 1e-5  # plotted in place of 0 on the log axis


def read_rows(path):
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    if not rows:
        sys.exit(f"plot_sky_trade: {path} has no rows")
    for r in rows:
        r["samples"] = int(r["samples"])
        r["grid"] = int(r.get("grid", 0) or 0)
        for k in ("ms_per_mpix", "p95_above", "p95_below", "p95_check_all"):
            r[k] = float(r[k])
    return rows


def pareto(points):
    """Indices of the points not dominated in (time, error), sorted by time."""
    order = sorted(range(len(points)), key=lambda i: (points[i][0], points[i][1]))
    front, best = [], math.inf
    for i in order:
        if points[i][1] < best:
            front.append(i)
            best = points[i][1]
    return front


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out_dir", help="directory written by `airmass report sky --out`")
    ap.add_argument("--png", help="output PNG (default OUT_DIR/sky_trade.png)")
    args = ap.parse_args()
    rows = read_rows(os.path.join(args.out_dir, "sky_trade.csv"))
    png = args.png or os.path.join(args.out_dir, "sky_trade.png")

    methods = sorted({r["chapman"] for r in rows})
    colours = basis_colours(rows)
    marker = {m: MARKERS[i % len(MARKERS)] for i, m in enumerate(methods)}
    fig, ax = plt.subplots(figsize=(9, 6), dpi=120)
    for r in rows:
        err = max(r["p95_above"], ERROR_FLOOR) if math.isfinite(r["p95_above"]) else 1.0
        ax.scatter(r["ms_per_mpix"], err, marker=marker[r["chapman"]],
                   color=colours[r["basis"]],
                   edgecolors="black" if r["grid"] > 0 else "none", linewidths=0.8, s=28, alpha=0.85)
    pts = [(r["ms_per_mpix"], max(r["p95_above"], ERROR_FLOOR)) for r in rows]
    front = pareto(pts)
    ax.plot([pts[i][0] for i in front], [pts[i][1] for i in front], color="black", lw=1, alpha=0.6,
            label="Pareto front")
    ax.axhline(0.01, color="gray", ls="--", lw=0.8, label="1 %")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("time per megapixel (ms, full sphere, all threads)")
    ax.set_ylabel("95th-percentile relative error above the horizon")
    ax.set_title("airmass sky: speed vs accuracy (against the converged reference)")
    handles = [plt.Line2D([], [], ls="", marker="o", color=c, label=b) for b, c in colours.items()]
    handles += [plt.Line2D([], [], ls="", marker=marker[m], color="gray", label=m) for m in methods]
    handles += [plt.Line2D([], [], ls="", marker="o", color="white", markeredgecolor="black", label="sky grid")]
    handles += ax.get_legend_handles_labels()[0]
    ax.legend(handles=handles, fontsize=7, loc="upper right", ncol=2)
    ax.grid(True, which="both", alpha=0.2)
    fig.tight_layout()
    tmp = png + ".tmp.png"
    fig.savefig(tmp)
    os.replace(tmp, png)

    print("Pareto front (ms/Mpx, p95 above, configuration):")
    for i in front:
        r = rows[i]
        print(f"  {r['ms_per_mpix']:10.1f}  {r['p95_above']:.2e}  {r['chapman']} {r['samples']} samples "
              f"{r['basis']} grid {r['grid']}")
    print(f"wrote {png}")


if __name__ == "__main__":
    main()
