#!/usr/bin/env bash
# The README's test command: installs what is missing, builds, and runs every test
# (C++ GoogleTest cases and the Python/Blender tests, all through CTest).
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
bash "$root/scripts/setup.sh"
bash "$root/scripts/build.sh"
build="${AIRMASS_BUILD_DIR:-$root/build}"
cd "$build"
ctest --output-on-failure -j "${AIRMASS_JOBS:-$(nproc)}" --timeout 2400 "$@"
