#!/usr/bin/env bash
# Runs the Windows build's C ABI self-test under wine64 (docs/portable.md) and compares the
# sky it renders with the Linux run's, value by value, to 1e-5 relative.
# Usage: run_windows_selftest.sh WINDOWS_LIB_DIR WINEPREFIX WINDOWS_PIXELS LINUX_PIXELS
set -euo pipefail
dir="$1"; prefix="$2"; win_pixels="$3"; linux_pixels="$4"
wine=/usr/lib/wine/wine64
[ -x "$wine" ] || { echo "FAIL: $wine not found (scripts/setup.sh installs wine64)"; exit 1; }
[ -f "$dir/capi_selftest.exe" ] && [ -f "$dir/airmass_c.dll" ] || {
  echo "FAIL: no Windows build in $dir (scripts/build-windows.sh makes it)"; exit 1; }
mkdir -p "$prefix"
export WINEPREFIX="$prefix" WINEDEBUG=-all WINEDLLOVERRIDES="mscoree,mshtml="
# A fresh prefix is made on first use (≈ 15 s); wineboot first so its messages stay out of the test.
[ -f "$prefix/system.reg" ] || "$wine" wineboot -i >/dev/null 2>&1 || true
rm -f "$win_pixels"
cd "$dir"
"$wine" ./capi_selftest.exe --pixels "Z:${win_pixels}" | tr -d '\r'
status=${PIPESTATUS[0]}
[ "$status" -eq 0 ] || { echo "FAIL: capi_selftest.exe exited with $status"; exit 1; }
[ -f "$linux_pixels" ] || { echo "FAIL: no Linux pixels at $linux_pixels (the capi_selftest test writes them)"; exit 1; }
/usr/bin/python3 "$(dirname "$0")/compare_pixels.py" "$linux_pixels" "$win_pixels" Windows
