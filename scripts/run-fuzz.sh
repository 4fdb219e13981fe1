#!/usr/bin/env bash
# libFuzzer runs of the fuzz targets in tests/fuzz (docs/reliability.md), in the reliability build
# folder (scripts/configure-asan.sh: clang, libFuzzer + ASan + UBSan; the same folder as
# scripts/run-sanitizers.sh). For each target: replay its corpus (tests/fuzz/corpus/<target>/: the
# seeds and every input that once crashed), then fuzz it. A crash, a hang (-timeout), a memory
# blow-up (-rss_limit_mb) or a leak leaves its input in BUILD/artifacts/ and fails the run.
#
#   scripts/run-fuzz.sh [SECONDS] [TARGET...]     fuzz SECONDS per target (default 60; 0: replay only);
#                                                 new inputs kept in BUILD/corpus/<target>/ across runs
#   scripts/run-fuzz.sh --runs N [TARGET...]      what CI runs (scripts/run-tests.sh): exactly N inputs
#                                                 per target from a fixed seed (-seed=1) and an empty
#                                                 work corpus, so every run tries the same inputs
#                                                 (-max_total_time caps a slow machine: AIRMASS_FUZZ_CAP_S)
#   targets: scene_toml scene_json capi csv (default: all)
# Environment: AIRMASS_FUZZ_BUILD_DIR (default build-asan), AIRMASS_JOBS (default nproc).
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
build="${AIRMASS_FUZZ_BUILD_DIR:-$root/build-asan}"
jobs="${AIRMASS_JOBS:-$(nproc)}"
runs=""
seconds=60
if [ "${1:-}" = "--runs" ]; then
  runs="$2"; shift 2
elif [ $# -gt 0 ]; then
  seconds="$1"; shift
fi
targets=("$@")
[ ${#targets[@]} -gt 0 ] || targets=(scene_toml scene_json capi csv)
start=$(date +%s)

bash "$root/scripts/configure-asan.sh" "$build"
cmake --build "$build" -j "$jobs" --target $(printf 'fuzz_%s ' "${targets[@]}")
echo "fuzz: built in $(($(date +%s) - start)) s"

export ASAN_OPTIONS="${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=1}"
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}"
mkdir -p "$build/artifacts"
status=0
summary=""
for t in "${targets[@]}"; do
  t0=$(date +%s)
  bin="$build/fuzz/fuzz_$t"
  seeds="$root/tests/fuzz/corpus/$t"
  work="$build/corpus/$t"
  [ -z "$runs" ] || rm -rf "$work"  # CI: the same start every time
  mkdir -p "$work"
  log="$build/fuzz_$t.log"
  flags=(-timeout=20 -rss_limit_mb=2048 -max_len=8192 -print_final_stats=1 -artifact_prefix="$build/artifacts/$t-")
  # Replay: every corpus file once (a regression of any fixed crash fails here).
  if ! "$bin" "${flags[@]}" -runs=0 "$seeds" >"$log.replay" 2>&1; then
    echo "fuzz: $t: corpus replay FAILED (log $log.replay)"; tail -n 40 "$log.replay"; status=1; continue
  fi
  if [ -n "$runs" ]; then
    run_flags=(-seed=1 -runs="$runs" -max_total_time="${AIRMASS_FUZZ_CAP_S:-600}")
    what="$runs inputs, seed 1"
  elif [ "$seconds" -gt 0 ]; then
    run_flags=(-max_total_time="$seconds")
    what="${seconds} s"
  else
    run_flags=()
  fi
  if [ ${#run_flags[@]} -gt 0 ]; then
    if ! "$bin" "${flags[@]}" "${run_flags[@]}" "$work" "$seeds" >"$log" 2>&1; then
      echo "fuzz: $t: FAILED (log $log; input in $build/artifacts/)"; tail -n 60 "$log"; status=1
    fi
    execs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | tail -n 1 | grep -o '[0-9]*$' || echo "?")
    cov=$(grep -o 'cov: [0-9]*' "$log" | tail -n 1 | grep -o '[0-9]*' || echo "?")
    line="fuzz: $t: $execs executions ($what) in $(($(date +%s) - t0)) s incl. replay, corpus $(ls "$seeds" | wc -l) seeds + $(ls "$work" | wc -l) found, coverage $cov edges"
  else
    line="fuzz: $t: corpus replayed ($(ls "$seeds" | wc -l) inputs) in $(($(date +%s) - t0)) s"
  fi
  echo "$line"
  summary+="$line"$'\n'
done
printf '%s' "$summary" >"$build/fuzz_summary.txt"
echo "fuzz: total $(($(date +%s) - start)) s"
exit $status
