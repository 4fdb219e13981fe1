#!/usr/bin/env bash
# The sanitizer stage of the tests (docs/reliability.md): an AddressSanitizer + UndefinedBehavior-
# Sanitizer build (CMake option AIRMASS_SANITIZE, GCC, -O1, its own folder build-asan/) of the
# C++ GoogleTest suite, the `airmass` CLI the suite runs, the C ABI and its self-test (tests/capi),
# and the fuzz targets' corpus replay (tests/fuzz); then the CTest tests labelled `sanitize`.
# Any sanitizer report aborts its process (-fno-sanitize-recover=all), so the test fails.
# -DNDEBUG as in the Release build users run (assertions of header-only dependencies, e.g. toml++,
# are compiled out there; ASan/UBSan then check what really happens).
#
#   scripts/run-sanitizers.sh            configure, build, run the `sanitize` label
#   scripts/run-sanitizers.sh -R Sky     extra ctest arguments
# Environment: AIRMASS_SANITIZE_BUILD_DIR (default build-asan), AIRMASS_JOBS (default nproc).
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
build="${AIRMASS_SANITIZE_BUILD_DIR:-$root/build-asan}"
jobs="${AIRMASS_JOBS:-$(nproc)}"
start=$(date +%s)

cmake -S "$root" -B "$build" -G Ninja -DAIRMASS_SANITIZE=ON -DAIRMASS_BUILD_BENCH=OFF \
  -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g1 -DNDEBUG" \
  -DCMAKE_C_FLAGS_RELWITHDEBINFO="-O1 -g1 -DNDEBUG" >"$build.configure.log" 2>&1 ||
  { tail -n 30 "$build.configure.log" >&2; exit 1; }
cmake --build "$build" -j "$jobs" --target airmass_tests airmass_cli capi_selftest airmass_fuzz_replay_all
built=$(date +%s)
echo "sanitizers: built in $((built - start)) s"

# Leaks count too; a report stops the process with a stack (symbolised through -g1).
export ASAN_OPTIONS="${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=1:strict_string_checks=1:detect_stack_use_after_return=1:check_initialization_order=1}"
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}"
ctest --test-dir "$build" --output-on-failure -j "$jobs" -L sanitize --timeout 900 "$@"
echo "sanitizers: tests in $(($(date +%s) - built)) s (total $(($(date +%s) - start)) s)"
