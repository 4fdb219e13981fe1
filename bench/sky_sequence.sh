#!/usr/bin/env bash
# A sky sequence against the same frames as separate runs, both measured in this run.
#
#   bench/sky_sequence.sh [BUILD_DIR] [FRAMES] [WIDTH] [THREADS]
#
# Sequence: one `airmass sky --time-range ... --fps 1/600` run of FRAMES frames (default 24:
# a Paris midsummer sunrise, one frame every 10 minutes from 03:00 UT), which computes the
# multiple-scattering tables once. Baseline: FRAMES `airmass sky` runs, one per frame, with
# the sun angles the sequence's CSV lists (--sun-elevation/--sun-rotation), each computing
# its own tables. Same scene (preset earth: 48 wavelengths, multiple scattering on), same
# image (WIDTH × WIDTH/2, default 256 × 128), --threads THREADS (default 2). Wall time of
# the whole runs (process start, tables, render, EXR write). Prints both times and the
# ratio sequence / separate runs (below 1: the sequence is cheaper).
set -euo pipefail

BUILD=${1:-build}
FRAMES=${2:-24}
WIDTH=${3:-256}
THREADS=${4:-2}
AIRMASS="$BUILD/bin/airmass"
[ -x "$AIRMASS" ] || { echo "sky_sequence: no airmass binary at $AIRMASS (give the build dir)" >&2; exit 2; }
HEIGHT=$((WIDTH / 2))
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT

START="2026-06-21T03:00:00Z"
END=$(/usr/bin/python3 -c "import datetime as d; print((d.datetime(2026,6,21,3)+d.timedelta(minutes=10*($FRAMES-1))).strftime('%Y-%m-%dT%H:%M:%SZ'))")
COMMON=(--preset earth --width "$WIDTH" --height "$HEIGHT" --threads "$THREADS" --quiet)

now() { date +%s.%N; }

mkdir -p "$TMP/seq" "$TMP/single"
t0=$(now)
"$AIRMASS" sky "${COMMON[@]}" --latitude 48.85 --longitude 2.35 --time-range "$START,$END" --fps 1/600 \
  -o "$TMP/seq/sky_####.exr"
t1=$(now)
n=$(($(wc -l < "$TMP/seq/sky.csv") - 1))
[ "$n" -eq "$FRAMES" ] || { echo "sky_sequence: the sequence made $n frames, not $FRAMES" >&2; exit 1; }

t2=$(now)
tail -n +2 "$TMP/seq/sky.csv" | while IFS=, read -r frame utc lat lon elev az belev brot rest; do
  "$AIRMASS" sky "${COMMON[@]}" --sun-elevation "$belev" --sun-rotation "$brot" -o "$TMP/single/sky_$frame.exr"
done
t3=$(now)

/usr/bin/python3 - "$t0" "$t1" "$t2" "$t3" "$FRAMES" "$WIDTH" "$HEIGHT" "$THREADS" <<'PY'
import sys
t0, t1, t2, t3 = map(float, sys.argv[1:5])
frames, w, h, threads = sys.argv[5:9]
seq, single = t1 - t0, t3 - t2
print(f"sky sequence, {frames} frames of {w}x{h} (preset earth, multiple scattering, --threads {threads}):")
print(f"  one sequence run (tables once)      {seq:8.2f} s  ({seq / int(frames):.3f} s/frame)")
print(f"  {frames} single-frame runs              {single:8.2f} s  ({single / int(frames):.3f} s/frame)")
print(f"  ratio sequence / single runs        {seq / single:8.3f}")
PY
