#!/usr/bin/python3
"""Benchmark of `airmass vdb`: voxels written per second, and the issue's target — the
1-km Earth `view` region (ground camera, +X, 60°, 640×360, 200 km) built and written in
at most 2 s on 2 cores.

    /usr/bin/python3 bench/bench_vdb.py [--airmass build/bin/airmass] [--repeat 5] [--threads 2]

Each case runs the CLI `--repeat` times (`--json` report: build and write seconds as
measured inside the process) and prints the medians as a Markdown table, with the wall
time of the whole process (start-up, scene loading and exit included) beside them.
"""
import argparse
import json
import pathlib
import statistics
import subprocess
import sys
import tempfile
import time

TARGET_S = 2.0
CASES = [  # (label, extra arguments)
    ("view 1 km (target)", ["--region", "view", "--default-camera", "--voxel-size", "1"]),
    ("view 0.5 km", ["--region", "view", "--default-camera", "--voxel-size", "0.5"]),
    ("planet 20 km, tiled", ["--region", "planet", "--voxel-size", "20"]),
]


def run_case(binary, args, threads, repeat, tmp):
    rows = []
    for i in range(repeat):
        out = tmp / f"bench{i}.vdb"
        cmd = [str(binary), "vdb", "--preset", "earth", *args, "--threads", str(threads), "--json", "-q", "-o", str(out)]
        t0 = time.perf_counter()
        p = subprocess.run(cmd, capture_output=True, text=True)
        wall = time.perf_counter() - t0
        if p.returncode != 0:
            sys.exit(f"bench_vdb: {' '.join(cmd)} failed:\n{p.stderr}")
        s = json.loads(p.stdout)
        for f in s["files"]:
            pathlib.Path(f).unlink()
        rows.append((s["build_seconds"], s["write_seconds"], wall, s["active_voxels"], s["file_bytes"], s["dense_bytes"]))
    med = lambda k: statistics.median(r[k] for r in rows)  # noqa: E731
    return {"build": med(0), "write": med(1), "wall": med(2), "voxels": rows[0][3], "file": rows[0][4],
            "dense": rows[0][5]}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--airmass", type=pathlib.Path, default=pathlib.Path("build/bin/airmass"))
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--threads", type=int, default=2)
    args = ap.parse_args()
    if not args.airmass.is_file():
        sys.exit(f"bench_vdb: {args.airmass} not found (build first, or pass --airmass)")
    print(f"airmass vdb, preset earth, {args.threads} threads, median of {args.repeat} runs\n")
    print("| case | active voxels | build (s) | write (s) | build+write (s) | voxels/s | file (MiB) | dense (MiB) | wall (s) |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    target = None
    with tempfile.TemporaryDirectory(prefix="airmass-bench-vdb-") as d:
        for label, extra in CASES:
            r = run_case(args.airmass, extra, args.threads, args.repeat, pathlib.Path(d))
            bw = r["build"] + r["write"]
            print(f"| {label} | {r['voxels']} | {r['build']:.3f} | {r['write']:.3f} | {bw:.3f} | "
                  f"{r['voxels'] / bw:.3g} | {r['file'] / 2**20:.1f} | {r['dense'] / 2**20:.1f} | {r['wall']:.3f} |")
            if target is None:
                target = (bw, r["wall"])
    ok = target[0] <= TARGET_S
    print(f"\ntarget: 1-km Earth view region built and written in {target[0]:.3f} s "
          f"({'meets' if ok else 'MISSES'} the {TARGET_S:.0f}-s target; {target[1]:.3f} s wall for the whole process)")


if __name__ == "__main__":
    main()
