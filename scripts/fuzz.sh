#!/usr/bin/env bash
# Builds the libFuzzer targets of fuzz/ with clang++ (ASan + UBSan + libFuzzer) in their own build
# directory and runs each for a bounded time, starting from its seed corpus fuzz/corpus/<target>/.
# Fails when any target finds a crash, a sanitizer report, a leak, a hang (> 5 s on one input) or
# an out-of-memory (> 2 GB RSS); the input is saved under <build>/fuzz-artifacts/<target>/.
#
# Usage: scripts/fuzz.sh [target...]        (default: every target)
#   FUZZ_TIME=30          seconds per target (libFuzzer -max_total_time)
#   FUZZ_BUILD_DIR=build-fuzz
#   FUZZ_STATS=file.md    append a Markdown table row per target (for BENCHMARKS.md)
# Reproduce a finding: <build>/fuzz/fuzz_<target> <artifact file>
# The corpus grown by a run stays in <build>/fuzz-corpus/<target>/ (not in the repository).
set -euo pipefail
cd "$(dirname "$0")/.."
ALL_TARGETS=(srt gpx csv config_json config_yaml image_metadata mavlink)
if [ $# -gt 0 ]; then TARGETS=("$@"); else TARGETS=("${ALL_TARGETS[@]}"); fi
FUZZ_TIME=${FUZZ_TIME:-30}
B=${FUZZ_BUILD_DIR:-build-fuzz}

cmake -S . -B "$B" -G Ninja -DCMAKE_CXX_COMPILER=clang++ -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g1 -DNDEBUG" -DAEROVO_BUILD_FUZZERS=ON -DAEROVO_BUILD_TESTS=OFF -DAEROVO_BUILD_BENCHMARKS=OFF >/dev/null
cmake --build "$B" --parallel "$(nproc)" --target $(printf 'fuzz_%s ' "${TARGETS[@]}")

# Leaks: detected (per input and at exit); third-party leak suppressions in scripts/lsan.supp.
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=0:symbolize=1}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-halt_on_error=1:print_stacktrace=1}
export LSAN_OPTIONS=${LSAN_OPTIONS:-suppressions=$PWD/scripts/lsan.supp:print_suppressions=0}

failed=()
printf '%-16s %10s %9s %6s %9s %7s %7s\n' target execs exec/s time_s corpus cov ft
for t in "${TARGETS[@]}"; do
  corpus="$B/fuzz-corpus/$t"
  artifacts="$B/fuzz-artifacts/$t/"
  log="$B/fuzz-logs/$t.log"
  mkdir -p "$corpus" "$artifacts" "$(dirname "$log")"
  start=$(date +%s)
  rc=0
  "$B/fuzz/fuzz_$t" -max_total_time="$FUZZ_TIME" -timeout=5 -rss_limit_mb=2048 \
    -detect_leaks=1 -print_final_stats=1 -artifact_prefix="$artifacts" \
    "$corpus" "fuzz/corpus/$t" >"$log" 2>&1 || rc=$?
  secs=$(($(date +%s) - start))
  # libFuzzer's last status line: "#123 DONE cov: 456 ft: 789 corp: 12/3456b ... exec/s: 99".
  last=$(grep -E '^#[0-9]+' "$log" | tail -1 || true)
  execs=$(grep -oE 'stat::number_of_executed_units: *[0-9]+' "$log" | grep -oE '[0-9]+$' || echo '?')
  eps=$(grep -oE 'stat::average_exec_per_sec: *[0-9]+' "$log" | grep -oE '[0-9]+$' || echo '?')
  cov=$(grep -oE 'cov: [0-9]+' <<<"$last" | grep -oE '[0-9]+' || echo '?')
  ft=$(grep -oE 'ft: [0-9]+' <<<"$last" | grep -oE '[0-9]+' || echo '?')
  corp=$(grep -oE 'corp: [0-9]+/[0-9]+[a-zA-Z]*' <<<"$last" | sed 's/corp: //' || echo '?')
  printf '%-16s %10s %9s %6s %9s %7s %7s\n' "$t" "$execs" "$eps" "$secs" "$corp" "$cov" "$ft"
  if [ -n "${FUZZ_STATS:-}" ]; then
    printf '| fuzz_%s | %s | %s | %s | %s | %s / %s |\n' "$t" "$execs" "$eps" "$secs" "$corp" \
      "$cov" "$ft" >>"$FUZZ_STATS"
  fi
  if [ "$rc" -ne 0 ]; then
    failed+=("$t")
    echo "fuzz: fuzz_$t FAILED (exit $rc); log $log; artifacts:" >&2
    ls -1 "$artifacts" >&2 || true
    grep -E 'ERROR|SUMMARY|runtime error|==[0-9]+==' "$log" | head -20 >&2 || true
  fi
done
if [ ${#failed[@]} -ne 0 ]; then
  echo "fuzz: failures in: ${failed[*]}" >&2
  exit 1
fi
echo "fuzz: ${#TARGETS[@]} targets, ${FUZZ_TIME} s each: no crash, leak, hang or sanitizer report"
