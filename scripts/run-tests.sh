#!/usr/bin/env bash
# The README's test command: installs what is missing, builds, and runs every test
# (C++ GoogleTest cases and the Python/Blender tests, all through CTest).
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
bash "$root/scripts/setup.sh"
bash "$root/scripts/build.sh"
build="${AIRMASS_BUILD_DIR:-$root/build}"
cd "$build"
# The CLI's table cache (docs/sky.md) goes into the build folder, not the user's ~/.cache.
export AIRMASS_CACHE_DIR="${AIRMASS_CACHE_DIR:-$build/table-cache}"
status=0
t0=$(date +%s)
ctest --output-on-failure -j "${AIRMASS_JOBS:-$(nproc)}" --timeout 2400 "$@" || status=$?
t1=$(date +%s)
echo "run-tests: main ctest $((t1 - t0)) s"
# The fuzz corpora are replayed by the main ctest above too (fuzz_replay_*, the ordinary build).
# Reliability stage (docs/reliability.md), in its own build folder beside the main one
# (build-asan: clang, ASan + UBSan, libFuzzer): the C++ suite and the C ABI self-test under the
# sanitizers (CTest label `sanitize`), then every fuzz target's corpus replayed and AIRMASS_FUZZ_RUNS
# fuzzed inputs from a fixed seed. On by default (so in .ci/run); AIRMASS_RELIABILITY=0 skips it.
# With extra ctest arguments (a selection) it is skipped too, unless AIRMASS_RELIABILITY=1.
reliability="${AIRMASS_RELIABILITY:-$([ $# -eq 0 ] && echo 1 || echo 0)}"
if [ "$reliability" != 0 ]; then
  # AIRMASS_SANITIZE_ARGS: extra ctest arguments for the sanitizer tests (e.g. "-E MultipleScattering").
  # Every test labelled `sanitize` runs, the OpenVDB ones too: Debian's TBB headers, where UBSan
  # stopped them, are left uninstrumented (cmake/sanitize-ignorelist.txt, docs/reliability.md).
  # shellcheck disable=SC2086
  AIRMASS_SANITIZE_BUILD_DIR="${build}-asan" bash "$root/scripts/run-sanitizers.sh" ${AIRMASS_SANITIZE_ARGS:-} || status=1
  t2=$(date +%s)
  AIRMASS_FUZZ_BUILD_DIR="${build}-asan" bash "$root/scripts/run-fuzz.sh" --runs "${AIRMASS_FUZZ_RUNS:-2000}" || status=1
  echo "run-tests: sanitizer stage $((t2 - t1)) s, fuzz stage $(($(date +%s) - t2)) s"
fi
exit $status
