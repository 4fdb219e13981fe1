#!/usr/bin/env bash
# libFuzzer runs of the fuzz targets in tests/fuzz (docs/reliability.md): builds them with clang
# (CMake option AIRMASS_FUZZ: libFuzzer + ASan + UBSan, folder build-fuzz/), then for each target
# replays its corpus (tests/fuzz/corpus/<target>/: the seeds and every input that once crashed)
# and fuzzes it for SECONDS. New inputs go to build-fuzz/corpus/<target>/ (the repository's corpus
# is only read); a crash, hang (-timeout) or memory blow-up (-rss_limit_mb) leaves its input in
# build-fuzz/artifacts/ and fails the run.
#
#   scripts/run-fuzz.sh [SECONDS] [TARGET...]    SECONDS per target (default 60; 0: replay only)
#   targets: scene_toml scene_json capi csv (default: all)
# Environment: AIRMASS_FUZZ_BUILD_DIR (default build-fuzz), AIRMASS_JOBS (default nproc).
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
build="${AIRMASS_FUZZ_BUILD_DIR:-$root/build-fuzz}"
jobs="${AIRMASS_JOBS:-$(nproc)}"
seconds="${1:-60}"
[ $# -gt 0 ] && shift
targets=("$@")
[ ${#targets[@]} -gt 0 ] || targets=(scene_toml scene_json capi csv)
start=$(date +%s)

CC=clang CXX=clang++ cmake -S "$root" -B "$build" -G Ninja -DAIRMASS_FUZZ=ON -DAIRMASS_BUILD_BENCH=OFF \
  -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g1 -DNDEBUG" \
  -DCMAKE_C_FLAGS_RELWITHDEBINFO="-O1 -g1 -DNDEBUG" >"$build.configure.log" 2>&1 ||
  { tail -n 30 "$build.configure.log" >&2; exit 1; }
cmake --build "$build" -j "$jobs" --target $(printf 'fuzz_%s ' "${targets[@]}")
echo "fuzz: built in $(($(date +%s) - start)) s"

export ASAN_OPTIONS="${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=1}"
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}"
mkdir -p "$build/artifacts"
status=0
summary=""
for t in "${targets[@]}"; do
  bin="$build/fuzz/fuzz_$t"
  seeds="$root/tests/fuzz/corpus/$t"
  work="$build/corpus/$t"
  mkdir -p "$work"
  log="$build/fuzz_$t.log"
  flags=(-timeout=20 -rss_limit_mb=2048 -max_len=8192 -print_final_stats=1 -artifact_prefix="$build/artifacts/$t-")
  # Replay: every corpus file once (a regression of any fixed crash fails here).
  if ! "$bin" "${flags[@]}" -runs=0 "$seeds" >"$log.replay" 2>&1; then
    echo "fuzz: $t: corpus replay FAILED (log $log.replay)"; tail -n 40 "$log.replay"; status=1; continue
  fi
  if [ "$seconds" -gt 0 ]; then
    if ! "$bin" "${flags[@]}" -max_total_time="$seconds" "$work" "$seeds" >"$log" 2>&1; then
      echo "fuzz: $t: FAILED (log $log; input in $build/artifacts/)"; tail -n 60 "$log"; status=1
    fi
    execs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$' || echo "?")
    corpus=$(ls "$work" | wc -l)
    cov=$(grep -o 'cov: [0-9]*' "$log" | tail -n 1 | grep -o '[0-9]*' || echo "?")
    line="fuzz: $t: $execs executions in ${seconds} s, corpus $(ls "$seeds" | wc -l) seeds + $corpus found, coverage $cov edges"
  else
    line="fuzz: $t: corpus replayed ($(ls "$seeds" | wc -l) inputs)"
  fi
  echo "$line"
  summary+="$line"$'\n'
done
printf '%s' "$summary" >"$build/fuzz_summary.txt"
echo "fuzz: total $(($(date +%s) - start)) s"
exit $status
