#!/usr/bin/env bash
# Configures the reliability build folder (docs/reliability.md), shared by scripts/run-sanitizers.sh
# and scripts/run-fuzz.sh: clang, AddressSanitizer + UndefinedBehaviorSanitizer on every target
# (AIRMASS_SANITIZE, -fno-sanitize-recover=all) and libFuzzer's coverage (AIRMASS_FUZZ), -O1 -g1,
# -DNDEBUG as in the Release build users run. No benchmarks; nothing else is built until asked.
#   scripts/configure-asan.sh BUILD_DIR
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
build="$1"
mkdir -p "$build"
CC=clang CXX=clang++ cmake -S "$root" -B "$build" -G Ninja -DAIRMASS_SANITIZE=ON -DAIRMASS_FUZZ=ON \
  -DAIRMASS_BUILD_BENCH=OFF -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g1 -DNDEBUG" -DCMAKE_C_FLAGS_RELWITHDEBINFO="-O1 -g1 -DNDEBUG" \
  >"$build/configure.log" 2>&1 || { tail -n 30 "$build/configure.log" >&2; exit 1; }
