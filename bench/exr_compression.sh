#!/usr/bin/env bash
# What the EXR's compression costs a sky: whole-process wall time and file size of
# `airmass sky --preset earth` (2048 × 1024, defaults otherwise, warm table cache) for each
# --exr-compression, as ratios against `none` (the default) measured in the same run. Every
# choice is lossless (tests/test_sky.cpp SkyFiles.EveryExrCompressionIsLossless), so the
# images are identical and only time and size differ.
#
#   bench/exr_compression.sh [BUILD_DIR] [REPEATS] [THREADS] [WIDTH]
set -euo pipefail

BUILD=${1:-build}
REPEATS=${2:-3}
THREADS=${3:-2}
WIDTH=${4:-2048}
AIRMASS="$BUILD/bin/airmass"
[ -x "$AIRMASS" ] || { echo "exr_compression: no airmass binary at $AIRMASS (give the build dir)" >&2; exit 2; }
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT
export AIRMASS_CACHE_DIR="$TMP/cache"
ARGS=(sky --preset earth --width "$WIDTH" --threads "$THREADS" -q)
"$AIRMASS" "${ARGS[@]}" -o "$TMP/warmup.exr"  # fills the table cache: every timed run is warm

echo "exr_compression: earth ${WIDTH}x$((WIDTH / 2)), $REPEATS repeats, $THREADS threads, $(nproc) CPUs," \
     "load average $(cut -d' ' -f1-3 /proc/loadavg)"
echo "| --exr-compression | wall s (best of $REPEATS) | time / none | MB | size / none |"
echo "|---|---|---|---|---|"
base_t="" base_s=""
for c in none zip piz; do
  best=""
  for _ in $(seq "$REPEATS"); do
    t0=$(date +%s.%N)
    "$AIRMASS" "${ARGS[@]}" --exr-compression "$c" -o "$TMP/$c.exr"
    t1=$(date +%s.%N)
    best=$(python3 -c "print(min($t1 - $t0, float('${best:-inf}')))")
  done
  size=$(stat -c %s "$TMP/$c.exr")
  [ -n "$base_t" ] || { base_t=$best; base_s=$size; }
  python3 -c "print('| %s | %.3f | %.2fx | %.1f | %.2fx |' % ('$c', $best, $best / $base_t, $size / 1e6, $size / $base_s))"
done
