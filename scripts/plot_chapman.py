#!/usr/bin/python3
"""Plot the Chapman methods' relative error vs zenith angle at x = 10, 100, 760, 1e4.

Reads chapman_curves.csv written by `airmass report chapman --out DIR` and writes
DIR/chapman_error.png. Invalid values (NaN, negative) are drawn as gaps; errors below
1e-17 are clipped to 1e-17 so they stay on the log axis.
"""
import argparse
import csv
import math
import os
import sys
from collections import defaultdict

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("report_dir", help="directory holding chapman_curves.csv")
    args = ap.parse_args()
    src = os.path.join(args.report_dir, "chapman_curves.csv")
    curves = defaultdict(lambda: ([], []))
    with open(src) as f:
        for row in csv.DictReader(f):
            err = float(row["rel_err"])
            if math.isnan(err):
                err = float("nan")
            else:
                err = max(err, 1e-17)
            xs, ys = curves[(row["method"], float(row["x"]))]
            xs.append(float(row["chi_deg"]))
            ys.append(err)
    methods = sorted({m for m, _ in curves}, key=lambda m: (m != "airmass", m))
    xvals = sorted({x for _, x in curves})
    fig, axes = plt.subplots(2, 2, figsize=(13, 8.5), sharey=True)
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for ax, x in zip(axes.flat, xvals):
        for i, m in enumerate(methods):
            xs, ys = curves[(m, x)]
            ax.semilogy(xs, ys, label=m, lw=2.2 if m == "airmass" else 1.0, color=colors[i % len(colors)])
        ax.axhline(1e-6, color="k", ls=":", lw=0.8)
        ax.axvline(90, color="grey", lw=0.5)
        ax.set_title(f"x = r/H = {x:g}")
        ax.set_xlim(0, 180)
        ax.set_ylim(1e-17, 1e2)
        ax.set_xlabel("zenith angle χ [deg]")
        ax.grid(True, which="major", alpha=0.3)
    for ax in axes[:, 0]:
        ax.set_ylabel("|Ch / Ch_exact − 1|")
    axes[0, 0].legend(fontsize=8, loc="lower left")
    fig.suptitle("Chapman function: relative error vs the exact quadrature (gaps: NaN or negative results)")
    fig.tight_layout()
    out = os.path.join(args.report_dir, "chapman_error.png")
    tmp = out + ".tmp.png"
    fig.savefig(tmp, dpi=90)
    os.replace(tmp, out)
    print(f"plot_chapman: wrote {out}", file=sys.stderr)


if __name__ == "__main__":
    main()
