#!/usr/bin/env bash
# Builds the libFuzzer targets of fuzz/ with clang++ (ASan + UBSan + libFuzzer) in their own build
# directory and runs each for a bounded time, starting from its seed corpus fuzz/corpus/<target>/.
# Fails when any target finds a crash, a sanitizer report, a leak, a hang (> 5 s on one input) or
# an out-of-memory (> 2 GB RSS); the input is saved under <build>/fuzz-artifacts/<target>/.
#
# Usage: scripts/fuzz.sh [target...]        (default: every target)
#   FUZZ_TIME=20          seconds per target (libFuzzer -max_total_time)
#   FUZZ_BUILD_DIR=build-fuzz
#   FUZZ_CONFIGURE=0      use FUZZ_BUILD_DIR as it is configured (default: configure it here)
#   FUZZ_BUILD_ONLY=1     build the targets, do not run them (scripts/test.sh times them apart)
#   FUZZ_JOBS             targets fuzzed at a time (default: the number of cores)
#   FUZZ_STATS=file.md    append a Markdown table row per target (for BENCHMARKS.md)
# Reproduce a finding: <build>/fuzz/fuzz_<target> <artifact file>. A failure also prints the
# sanitizer's or libFuzzer's report with its stack, the run's seed and each input found (up to
# 16 KiB, base64), so that a log alone reproduces it (a CI clone is gone after the run):
#   base64 -d > crash <<'EOF' ... EOF; <build>/fuzz/fuzz_<target> crash
# The corpus grown by a run stays in <build>/fuzz-corpus/<target>/ (not in the repository).
set -euo pipefail
cd "$(dirname "$0")/.."
ALL_TARGETS=(srt gpx csv dataflash tlog ulog config_json config_yaml image_metadata mavlink
  calibration reference_track run_folder map video)
if [ $# -gt 0 ]; then TARGETS=("$@"); else TARGETS=("${ALL_TARGETS[@]}"); fi
FUZZ_TIME=${FUZZ_TIME:-20}
B=${FUZZ_BUILD_DIR:-build-fuzz}

if [ "${FUZZ_CONFIGURE:-1}" != 0 ]; then
  link=()  # mold when installed (scripts/install-deps.sh; scripts/test.sh says why)
  command -v ld.mold >/dev/null && link=("-DCMAKE_EXE_LINKER_FLAGS=-fuse-ld=mold -Wl,--no-fork")
  cmake -S . -B "$B" -G Ninja -DCMAKE_CXX_COMPILER=clang++ -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g1 -DNDEBUG" -DAEROVO_BUILD_FUZZERS=ON \
    -DAEROVO_BUILD_TESTS=OFF -DAEROVO_BUILD_BENCHMARKS=OFF "${link[@]}" >/dev/null
fi
cmake --build "$B" --parallel "$(nproc)" --target $(printf 'fuzz_%s ' "${TARGETS[@]}")
[ "${FUZZ_BUILD_ONLY:-0}" != 1 ] || exit 0

# Leaks: detected (per input and at exit); third-party leak suppressions in scripts/lsan.supp.
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=0:symbolize=1}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-halt_on_error=1:print_stacktrace=1}
export LSAN_OPTIONS=${LSAN_OPTIONS:-suppressions=$PWD/scripts/lsan.supp:print_suppressions=0}

# Targets run FUZZ_JOBS at a time (default: the number of cores); each libFuzzer process is one
# thread, so on 2 cores two targets take the wall time of one. Rows are printed in target order.
FUZZ_JOBS=${FUZZ_JOBS:-$(nproc)}
run_target() {  # run_target T: fuzzes T, writes its table row to $B/fuzz-logs/T.row, exits rc
  local t=$1 corpus="$B/fuzz-corpus/$1" artifacts="$B/fuzz-artifacts/$1/" log="$B/fuzz-logs/$1.log"
  local start rc=0 secs last execs eps cov ft corp
  mkdir -p "$corpus" "$artifacts" "$(dirname "$log")"
  start=$(date +%s)
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
  printf '%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\n' "$t" "$execs" "$eps" "$secs" "$corp" "$cov" "$ft" \
    "$rc" >"$B/fuzz-logs/$t.row"
  return "$rc"
}

# report_failure T LOG ARTIFACTS: the report from its first line (with the stack that follows),
# the seed, and every input saved, base64-encoded (inputs over 16 KiB: only their size).
report_failure() {
  local t=$1 log=$2 artifacts=$3 f size
  grep -m1 -E '^INFO: Seed: ' "$log" || true
  awk '/ERROR: |runtime error|==[0-9]+==.*(ERROR|WARNING)|deadly signal|Timeout|out-of-memory/ \
       { on = 1 } on && n < 60 { print; n++ }' "$log"
  for f in "$artifacts"*; do
    [ -f "$f" ] || continue
    size=$(stat -c %s "$f")
    if [ "$size" -le 16384 ]; then
      echo "input $(basename "$f") ($size bytes; base64 -d > crash, then $B/fuzz/fuzz_$t crash):"
      base64 -w 76 "$f"
    else
      echo "input $(basename "$f"): $size bytes, not printed"
    fi
  done
}

mkdir -p "$B/fuzz-logs"
running=0
for t in "${TARGETS[@]}"; do
  rm -f "$B/fuzz-logs/$t.row"
  if [ "$running" -ge "$FUZZ_JOBS" ]; then
    wait -n || true
    running=$((running - 1))
  fi
  run_target "$t" &
  running=$((running + 1))
done
wait || true

failed=()
printf '%-16s %10s %9s %6s %9s %7s %7s\n' target execs exec/s time_s corpus cov ft
for t in "${TARGETS[@]}"; do
  IFS=$'\t' read -r _ execs eps secs corp cov ft rc <"$B/fuzz-logs/$t.row" ||
    { execs='?' eps='?' secs='?' corp='?' cov='?' ft='?' rc=1; }
  artifacts="$B/fuzz-artifacts/$t/"
  log="$B/fuzz-logs/$t.log"
  printf '%-16s %10s %9s %6s %9s %7s %7s\n' "$t" "$execs" "$eps" "$secs" "$corp" "$cov" "$ft"
  if [ -n "${FUZZ_STATS:-}" ]; then
    printf '| fuzz_%s | %s | %s | %s | %s | %s / %s |\n' "$t" "$execs" "$eps" "$secs" "$corp" \
      "$cov" "$ft" >>"$FUZZ_STATS"
  fi
  if [ "$rc" -ne 0 ]; then
    failed+=("$t")
    echo "fuzz: fuzz_$t FAILED (exit $rc); log $log; artifacts:" >&2
    ls -1 "$artifacts" >&2 || true
    report_failure "$t" "$log" "$artifacts" >&2
  fi
done
if [ ${#failed[@]} -ne 0 ]; then
  echo "fuzz: failures in: ${failed[*]}" >&2
  exit 1
fi
echo "fuzz: ${#TARGETS[@]} targets, ${FUZZ_TIME} s each: no crash, leak, hang or sanitizer report"
