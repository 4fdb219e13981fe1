#!/usr/bin/env bash
# Installs everything Airmass needs from Debian's packages. Idempotent: when every
# package is already present it prints one line and exits without touching apt.
set -euo pipefail

PACKAGES=(
  # build
  build-essential cmake ninja-build pkg-config
  # C++ libraries
  libglm-dev libopenimageio-dev openimageio-tools libopenvdb-dev libtbb-dev libblosc-dev
  libboost-math-dev libboost-iostreams-dev libcerf-dev libimath-dev libopenexr-dev
  libgtest-dev libgmock-dev libbenchmark-dev libcli11-dev nlohmann-json3-dev libtomlplusplus-dev
  # reference data, plots and tests (Debian's python3, which Blender also sees)
  python3 python3-numpy python3-scipy python3-mpmath python3-matplotlib python3-pytest
  python3-openvdb python3-openimageio
  # renderers
  blender povray
  # headless X server: the Blender add-on's UI test (tests/blender/run_ui_tests.py) and panel screenshot
  xvfb
)

missing=()
for p in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "setup: all ${#PACKAGES[@]} packages present"
  exit 0
fi

SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
echo "setup: installing ${#missing[@]} package(s): ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/tmp/airmass-apt.log 2>&1 || {
  echo "setup: apt-get install failed; last lines of /tmp/airmass-apt.log:" >&2
  tail -n 30 /tmp/airmass-apt.log >&2
  exit 1
}
echo "setup: done"
