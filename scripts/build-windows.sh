#!/usr/bin/env bash
# Cross-builds the core and the C ABI for Windows x64 with Debian's mingw-w64 into
# <build>-windows/lib: airmass_c.dll (what the add-on loads on Windows) and capi_selftest.exe
# (the C ABI's tests, run under wine64 by CTest's capi_windows). docs/portable.md.
# Needs the native build's generated Chapman table (scripts/build.sh builds it first).
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
build="${AIRMASS_BUILD_DIR:-$root/build}"
win="${build}-windows"
jobs="${AIRMASS_JOBS:-$(nproc)}"
table="$build/plugin/chapman_airmass_table.cpp"
[ -f "$table" ] || { echo "build-windows: $table missing; build the native tree first (scripts/build.sh)" >&2; exit 1; }
command -v x86_64-w64-mingw32-g++-posix >/dev/null || {
  echo "build-windows: x86_64-w64-mingw32-g++-posix missing (scripts/setup.sh installs g++-mingw-w64-x86-64-posix)" >&2; exit 1; }
# The core's header-only dependencies, seen by the cross compiler through links (not through
# /usr/include, which would put glibc's headers in front of mingw's).
deps="$win/header-deps"
mkdir -p "$deps"
for d in boost glm nlohmann toml++ hwy; do ln -sfn "/usr/include/$d" "$deps/$d"; done
cmake -S "$root" -B "$win" -G Ninja -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_TOOLCHAIN_FILE="$root/cmake/mingw-w64.cmake" -DAIRMASS_CORE_ONLY=ON \
  -DAIRMASS_HEADER_DEPS_DIR="$deps" -DAIRMASS_CHAPMAN_TABLE_CPP="$table" \
  -DAIRMASS_WERROR="${AIRMASS_WERROR:-$([ -n "${CI:-}" ] && echo ON || echo OFF)}" >"$win/configure.log" 2>&1 || {
  cat "$win/configure.log" >&2; exit 1; }
cmake --build "$win" -j "$jobs" --target airmass_c capi_selftest
