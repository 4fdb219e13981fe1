#!/usr/bin/env bash
# The portable C ABI library (baseline x86-64 + runtime dispatch; what the add-on ships)
# against the same library compiled with -march=x86-64-v3, timed in one run
# (bench/portable_vs_native.py; README "Portable library"). Builds the -march copy into
# <build>-march (the C ABI target only).
#   bench/portable_vs_native.sh [--width W] [--repeats N] [--threads T] [--no-multiple]
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
build="${AIRMASS_BUILD_DIR:-$root/build}"
march="${build}-march"
cmake -S "$root" -B "$march" -G Ninja -DCMAKE_BUILD_TYPE=Release -DAIRMASS_ARCH=x86-64-v3 \
  -DAIRMASS_BUILD_TESTS=OFF -DAIRMASS_BUILD_BENCH=OFF >/dev/null
cmake --build "$march" -j "${AIRMASS_JOBS:-$(nproc)}" --target airmass_c >/dev/null
cmake --build "$build" -j "${AIRMASS_JOBS:-$(nproc)}" --target airmass_c >/dev/null
exec /usr/bin/python3 "$root/bench/portable_vs_native.py" "$build/lib/libairmass_c.so" "$march/lib/libairmass_c.so" "$@"
