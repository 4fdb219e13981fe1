#!/usr/bin/python3
"""Plot the voxel-size trade of `airmass report vdb --out DIR` (docs/vdb.md).

    /usr/bin/python3 scripts/plot_vdb_trade.py DIR [-o DIR/vdb_trade.png]

Left: the largest relative optical-depth error (over R, G, B) along each fixed ray
against the voxel size. Right: what the voxel size costs for the Earth view region
(dense boxes Blender 3.4 allocates, file size, build + write time).
"""
import argparse
import csv
import os
import pathlib
import sys
import tempfile

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def read_csv(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("dir", type=pathlib.Path, help="directory written by `airmass report vdb --out`")
    ap.add_argument("-o", "--output", type=pathlib.Path, help="PNG path (default DIR/vdb_trade.png)")
    args = ap.parse_args(argv)
    rays_csv, costs_csv = args.dir / "vdb_trade_rays.csv", args.dir / "vdb_trade_costs.csv"
    for p in (rays_csv, costs_csv):
        if not p.is_file():
            sys.exit(f"plot_vdb_trade: {p} not found; run `airmass report vdb --out {args.dir}` first")
    rays = read_csv(rays_csv)
    costs = read_csv(costs_csv)
    out = args.output or args.dir / "vdb_trade.png"

    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4.2))
    names = list(dict.fromkeys(r["ray"] for r in rays))
    # the voxel values measured (docs/vdb.md, Voxel values): auto solid, point dashed, average dotted;
    # a CSV from before the column: its rows as "auto"
    modes = list(dict.fromkeys(r.get("voxel_values", "auto") for r in rays))
    styles = {"auto": "o-", "point": "s--", "average": "^:"}
    for i, name in enumerate(names):
        for mode in modes:
            pts = sorted((float(r["voxel_size_km"]), float(r["tau_rel_error_max"])) for r in rays
                         if r["ray"] == name and r.get("voxel_values", "auto") == mode)
            ax1.loglog([p[0] for p in pts], [max(p[1], 1e-12) for p in pts], styles.get(mode, "x-"), color=f"C{i}",
                       label=name if mode == modes[0] else None, ms=3 if mode != "auto" else 5)
    if len(modes) > 1:
        for mode in modes:
            ax1.plot([], [], styles.get(mode, "x-"), color="grey", label=f"values: {mode}")
    sizes = sorted({float(r["voxel_size_km"]) for r in rays})
    if len(sizes) > 1:  # O(v²) guide through the finest zenith point
        ax1.loglog(sizes, [1e-3 * (s / sizes[0]) ** 2 for s in sizes], "k:", lw=1, label="∝ voxel²")
    ax1.set_xlabel("voxel size (km)")
    ax1.set_ylabel("max relative error of optical depth (R, G, B)")
    ax1.set_title("grid (trilinear) vs analytic optical depth")
    ax1.grid(True, which="both", alpha=0.3)
    ax1.legend(fontsize=8)

    for region, style in (("view-200km", "-"), ("slab", "--")):
        rows = sorted((r for r in costs if r["region"] == region and r["refused"] == "0"
                       and r.get("voxel_values", "auto") == "auto"),
                      key=lambda r: float(r["voxel_size_km"]))
        if not rows:
            continue
        v = [float(r["voxel_size_km"]) for r in rows]
        mib = 1024.0 * 1024.0
        ax2.loglog(v, [float(r["dense_bytes"]) / mib for r in rows], "o" + style, color="C0",
                   label=f"{region}: dense boxes (MiB)")
        ax2.loglog(v, [max(float(r["file_bytes"]) / mib, 1e-6) for r in rows], "s" + style, color="C1",
                   label=f"{region}: file (MiB)")
        ax2.loglog(v, [float(r["build_s"]) + float(r["write_s"]) for r in rows], "^" + style, color="C2",
                   label=f"{region}: build + write (s)")
    ax2.set_xlabel("voxel size (km)")
    ax2.set_title("cost")
    ax2.grid(True, which="both", alpha=0.3)
    ax2.legend(fontsize=7)
    fig.tight_layout()

    # Atomic: write beside the destination, then rename.
    fd, tmp = tempfile.mkstemp(suffix=".png", dir=out.parent, prefix=f".{out.stem}.")
    os.close(fd)
    try:
        fig.savefig(tmp, dpi=120)
        os.replace(tmp, out)
    except BaseException:
        os.unlink(tmp)
        raise
    print(f"plot_vdb_trade: wrote {out}")


if __name__ == "__main__":
    main()
