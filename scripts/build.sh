#!/usr/bin/env bash
# Configure and build Airmass into build/ (the CLI ends up at build/bin/airmass).
# Warnings are errors when CI is set or AIRMASS_WERROR=ON.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
build="${AIRMASS_BUILD_DIR:-$root/build}"
werror="${AIRMASS_WERROR:-$([ -n "${CI:-}" ] && echo ON || echo OFF)}"
jobs="${AIRMASS_JOBS:-$(nproc)}"
mkdir -p "$build"
cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release -DAIRMASS_WERROR="$werror" >"$build/configure.log" 2>&1 || {
  cat "$build/configure.log" >&2; exit 1; }
cmake --build "$build" -j "$jobs"
