#!/usr/bin/env bash
# The sanitizer stage of the tests (docs/reliability.md), part of scripts/run-tests.sh and so of
# .ci/run: one AddressSanitizer + UndefinedBehaviorSanitizer build (scripts/configure-asan.sh:
# clang, -fno-sanitize-recover=all, -O1, its own folder build-asan/) of the C++ GoogleTest suite,
# the `airmass` CLI the suite runs, the C ABI and its self-test (tests/capi) and the libFuzzer
# targets (tests/fuzz, run next by scripts/run-fuzz.sh in the same folder); then the CTest tests
# labelled `sanitize`. Only those targets are built: no cross builds, no add-on, no Blender.
# Any sanitizer report aborts its process (-fno-sanitize-recover=all), so the test fails.
#
#   scripts/run-sanitizers.sh            configure, build, run the `sanitize` label
#   scripts/run-sanitizers.sh -R Sky     extra ctest arguments
# Environment: AIRMASS_SANITIZE_BUILD_DIR (default build-asan), AIRMASS_JOBS (default nproc).
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
build="${AIRMASS_SANITIZE_BUILD_DIR:-$root/build-asan}"
jobs="${AIRMASS_JOBS:-$(nproc)}"
start=$(date +%s)

bash "$root/scripts/configure-asan.sh" "$build"
cmake --build "$build" -j "$jobs" --target airmass_tests airmass_cli capi_selftest airmass_fuzz_all
built=$(date +%s)
echo "sanitizers: built in $((built - start)) s"

# Leaks count too; a report stops the process with a stack (symbolised through -g1).
export ASAN_OPTIONS="${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=1:strict_string_checks=1:detect_stack_use_after_return=1:check_initialization_order=1}"
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}"
# Its own table cache (docs/sky.md): tables the instrumented code computes, not the main build's.
export AIRMASS_CACHE_DIR="$build/table-cache"
# Two numerical cases are left out by default (AIRMASS_SANITIZE_EXCLUDE='' keeps them): each
# repeats, at a finer size, code that its lighter neighbours in the suite run under the
# sanitizers too — the hazy aureole at a finer multiple-scattering table (102 s under ASan,
# 2026-12-02; the same precompute as every MultipleScattering* case) and the planet-region
# VDB layer at 50 km voxels (56 s; the box and tiled regions run the same sampler and writer).
exclude="${AIRMASS_SANITIZE_EXCLUDE-^(MultipleScatteringPresets\.FinerTableHalvesTheHazyAureoleError|VdbRegions/VdbVolumeLayer\.DenseBlocksEqualTheWriterGridsVoxelForVoxel/planet)}"
ctest --test-dir "$build" --output-on-failure -j "$jobs" -L sanitize --timeout 900 ${exclude:+-E "$exclude"} "$@"
echo "sanitizers: tests in $(($(date +%s) - built)) s (total $(($(date +%s) - start)) s)"
