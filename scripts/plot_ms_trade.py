#!/usr/bin/python3
"""Plot the multiple-scattering trade written by `airmass report ms --out DIR`.

    /usr/bin/python3 scripts/plot_ms_trade.py DIR/ms_trade.csv [-o DIR/ms_trade.png]

Two panels: the error of the total radiance against the Monte Carlo reference (max over the
cases and wavelengths, and the RMS as a faint marker) versus the precompute CPU time (all
threads; robust on a shared machine) for the `earth` preset's 48 wavelengths, and versus the
table memory. One marker style per group of
the report (orders K, table sizes, mappings, ray samples, isotropic LUT).
"""
import argparse
import csv
import os
import sys
import tempfile

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

MARKERS = {"orders K": "o", "table": "s", "mapping": "D", "ray samples": "^", "isotropic LUT": "*"}
COLORS = {"orders K": "C0", "table": "C1", "mapping": "C2", "ray samples": "C3", "isotropic LUT": "C4"}


def read(path):
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    if not rows:
        sys.exit(f"plot_ms_trade: {path}: no rows")
    for r in rows:
        for k in ("precompute_s_earth48", "cpu_s_earth48", "table_mb_earth48", "max_err_pct", "rms_err_pct",
                  "mean_mc_sigma_pct"):
            r[k] = float(r[k])
    return rows


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("csv")
    ap.add_argument("-o", "--out", help="PNG path (default: next to the CSV)")
    a = ap.parse_args()
    rows = read(a.csv)
    out = a.out or os.path.join(os.path.dirname(os.path.abspath(a.csv)), "ms_trade.png")
    costly = [r for r in rows if r["mode"] != "none" and r["cpu_s_earth48"] > 0]
    if not costly:
        sys.exit("plot_ms_trade: no precompute timings (was the report run with --quick?)")
    single = [r for r in rows if r["mode"] == "none"]
    fig, axes = plt.subplots(1, 2, figsize=(13, 5.5), sharey=True)
    for ax, key, label in ((axes[0], "cpu_s_earth48",
                            "precompute CPU time (all threads), earth preset, 48 wavelengths [s]"),
                           (axes[1], "table_mb_earth48", "table memory, 48 wavelengths [MB]")):
        for group in MARKERS:
            g = [r for r in costly if r["group"] == group]
            if not g:
                continue
            ax.scatter([r[key] for r in g], [r["max_err_pct"] for r in g], marker=MARKERS[group], s=60,
                       color=COLORS[group], label=f"{group}: max error", zorder=3)
            ax.scatter([r[key] for r in g], [r["rms_err_pct"] for r in g], marker=MARKERS[group], s=25,
                       facecolors="none", edgecolors=COLORS[group], alpha=0.6, zorder=2)
            for r in g:
                ax.annotate(r["config"], (r[key], r["max_err_pct"]), fontsize=6, xytext=(4, 2),
                            textcoords="offset points")
        ylabels = ax.get_yaxis_transform()  # x in axes fraction, y in data
        for r in single:
            ax.axhline(r["max_err_pct"], color="grey", ls=":", lw=1)
            ax.text(0.01, r["max_err_pct"], "single scattering only (max)", fontsize=7, color="grey", va="bottom",
                    transform=ylabels)
        sigma = costly[0]["mean_mc_sigma_pct"]
        ax.axhline(1.0, color="k", lw=0.8, ls="--")
        ax.axhline(3 * sigma, color="C7", lw=0.8, ls="-.")
        ax.text(0.01, 1.0, "1 % requirement", fontsize=7, va="bottom", transform=ylabels)
        ax.text(0.01, 3 * sigma, "3σ of the Monte Carlo (mean)", fontsize=7, va="bottom", color="C7",
                transform=ylabels)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel(label)
        ax.grid(True, which="both", alpha=0.3)
    axes[0].set_ylabel("error of the total radiance vs Monte Carlo [%] (filled: max, open: RMS)")
    axes[1].legend(fontsize=7, loc="upper right")
    fig.suptitle("Multiple scattering: error vs cost (airmass report ms)")
    fig.tight_layout()
    fd, tmp = tempfile.mkstemp(suffix=".png", dir=os.path.dirname(out) or ".")
    os.close(fd)
    fig.savefig(tmp, dpi=130)
    os.replace(tmp, out)
    print(out)


if __name__ == "__main__":
    main()
