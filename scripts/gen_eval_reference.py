#!/usr/bin/python3
"""Error-vs-cost table for `airmass eval` (single scattering), against the repo's own
brute-force reference (`airmass eval --reference`: nested adaptive quadrature, exact
Chapman function nowhere, sun optical depths by quadrature).

    /usr/bin/python3 scripts/gen_eval_reference.py --airmass build/bin/airmass \
        [--preset earth] [--write-reference tests/data/eval_reference_earth.csv] [--plot out.png]

1. Builds a grid of view geometries (observer 0 m … 1000 km, view zenith 0 … 180°,
   sun from high to 6° below the horizon, three azimuths).
2. Evaluates it once with --reference (the slow part, ~1 min on 2 cores).
3. Evaluates it with each --samples N and --chapman METHOD, single-threaded and
   repeated, and prints, per setting, the relative error of the in-scatter
   (radiance_rayleigh + radiance_mie) against the reference — median, 95th percentile
   and maximum over rows and wavelengths — and the CPU time per view ray (user + system time of the process, one thread).
Rows whose reference in-scatter is below 1e-9 (the sun far below the horizon) are left
out of the error statistics (their relative error is meaningless; the absolute one is
below 1e-9 of the daylight sky).
"""
import argparse
import csv
import io
import resource
import subprocess
import sys

COLUMNS = "altitude_m,view_zenith_deg,sun_zenith_deg,azimuth_deg"


def grid():
    rows = []
    for h in (0.0, 1000.0, 10e3, 60e3, 1e6):
        for vz in (0.0, 30.0, 60.0, 80.0, 88.0, 90.0, 92.0, 100.0, 120.0, 160.0, 180.0):
            for sz in (30.0, 75.0, 88.0, 90.0, 93.0, 96.0):
                for az in (0.0, 90.0, 180.0):
                    rows.append((h, vz, sz, az))
    return rows


def rows_text(rows, repeat=1):
    out = io.StringIO()
    out.write(COLUMNS + "\n")
    for _ in range(repeat):
        for r in rows:
            out.write(",".join(repr(x) for x in r) + "\n")
    return out.getvalue()


def child_cpu_seconds():
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def run(airmass, args, text):
    """Rows out, and the CPU time the command used (not wall time: the machine may be shared)."""
    t0 = child_cpu_seconds()
    p = subprocess.run([airmass, "eval", "--no-multiple"] + args, input=text, capture_output=True, text=True)
    dt = child_cpu_seconds() - t0
    if p.returncode != 0:
        sys.exit("airmass eval failed: " + p.stderr)
    return list(csv.DictReader(io.StringIO(p.stdout))), dt


def inscatter(rec):
    return float(rec["radiance_rayleigh"]) + float(rec["radiance_mie"])


def percentile(v, q):
    v = sorted(v)
    return v[min(len(v) - 1, int(q * (len(v) - 1) + 0.5))]


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--airmass", required=True)
    ap.add_argument("--preset", default="earth")
    ap.add_argument("--wavelengths", default="680,550,440")
    ap.add_argument("--samples", default="4,6,8,12,16,24,32,64,128")
    ap.add_argument("--methods", default="airmass,golubev2019,schuler2012")
    ap.add_argument("--repeat", type=int, default=20, help="rows are repeated this often for timing")
    ap.add_argument("--write-reference", help="also write the reference rows to this CSV")
    ap.add_argument("--read-reference", help="take the reference rows from this CSV (as written by --write-reference)")
    ap.add_argument("--plot", help="write an error-vs-cost plot (PNG)")
    a = ap.parse_args()

    rows = grid()
    common = ["--preset", a.preset, "--wavelengths", a.wavelengths, "--solar-irradiance", "1"]
    if a.read_reference:
        with open(a.read_reference) as f:
            ref = list(csv.DictReader(f))
    else:
        ref, _ = run(a.airmass, common + ["--reference"], rows_text(rows))
    if a.write_reference:
        with open(a.write_reference, "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=list(ref[0].keys()), lineterminator="\n")
            w.writeheader()
            w.writerows(ref)
    print(f"# {len(rows)} geometries x {len(a.wavelengths.split(','))} wavelengths, preset {a.preset}; "
          f"error = |S - S_ref| / S_ref of the in-scatter S")
    print("| chapman | samples | median error | 95th pct | max error | ns per view ray |")
    print("|---|---:|---:|---:|---:|---:|")
    results = []
    for method in a.methods.split(","):
        for n in [int(x) for x in a.samples.split(",")]:
            args = common + ["--samples", str(n), "--chapman", method, "--threads", "1"]
            got, _ = run(a.airmass, args, rows_text(rows))
            errs = []
            for g, r in zip(got, ref):
                s_ref = inscatter(r)
                if s_ref < 1e-9:
                    continue
                errs.append(abs(inscatter(g) - s_ref) / s_ref)
            # cost: (many rows − one pass) / extra rows, so start-up cancels
            _, t_many = run(a.airmass, args, rows_text(rows, a.repeat))
            _, t_one = run(a.airmass, args, rows_text(rows, 1))
            ns = max(t_many - t_one, 0.0) / ((a.repeat - 1) * len(rows)) * 1e9
            results.append((method, n, percentile(errs, 0.5), percentile(errs, 0.95), max(errs), ns))
            print(f"| {method} | {n} | {results[-1][2]:.2e} | {results[-1][3]:.2e} | {results[-1][4]:.2e} | {ns:.0f} |")
            sys.stdout.flush()
    if a.plot:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        fig, ax = plt.subplots(figsize=(6, 4))
        for method in a.methods.split(","):
            r = [x for x in results if x[0] == method]
            ax.loglog([x[5] for x in r], [x[4] for x in r], "o-", label=f"{method}: max")
            ax.loglog([x[5] for x in r], [x[3] for x in r], "s--", label=f"{method}: 95th pct")
        ax.set_xlabel("ns per view ray (1 thread)")
        ax.set_ylabel("relative error of the in-scatter")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
        fig.tight_layout()
        fig.savefig(a.plot, dpi=120)


if __name__ == "__main__":
    main()
