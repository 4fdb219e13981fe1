#!/usr/bin/env bash
# Runs the Linux C ABI self-test on an emulated CPU without AVX (qemu-x86_64 -cpu Nehalem,
# docs/portable.md): the library must choose its baseline kernels there, pass its checks, and
# render the same sky as the native run to 1e-5 relative. --quick leaves out the sky sessions
# (a second set of multiple-scattering tables; emulation is ≈ 75x slower than native).
# Usage: run_old_cpu_selftest.sh QEMU SELFTEST OLD_CPU_PIXELS LINUX_PIXELS
set -euo pipefail
qemu="$1"; selftest="$2"; old_pixels="$3"; linux_pixels="$4"
rm -f "$old_pixels"
"$qemu" -cpu Nehalem "$selftest" --quick --expect-simd baseline --pixels "$old_pixels"
[ -f "$linux_pixels" ] || { echo "FAIL: no Linux pixels at $linux_pixels (the capi_selftest test writes them)"; exit 1; }
/usr/bin/python3 "$(dirname "$0")/compare_pixels.py" "$linux_pixels" "$old_pixels" "Nehalem (qemu)"
