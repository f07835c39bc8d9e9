#!/usr/bin/env bash
# Installs the dependencies, builds aerovo and runs every test: this is the README's test command
# and what CI (.ci/run) runs, on a clean clone with 2 cores. Stages:
#   1. Release build (tests, benchmarks, examples) in build/, every test (ctest);
#   1b. aarch64: the core modules cross-compiled for aarch64 (build-aarch64/), their unit tests
#      under qemu-aarch64, NEON and scalar paths (scripts/test-aarch64.sh);
#   2. AddressSanitizer + UndefinedBehaviorSanitizer build (-O1 -g1, no benchmarks) in
#      build-asan/, every test again but four long accuracy runs (see sanitizers()); any
#      ASan/UBSan/LeakSanitizer report fails the test;
#   3. the libFuzzer targets (scripts/fuzz.sh, clang++, build-fuzz/), FUZZ_TIME s each (30).
# Each stage prints its duration. Environment:
#   AEROVO_TEST_QUICK=1   developers: stage 1 only (Release build + tests)
#   AEROVO_SKIP_AARCH64=1 skip the aarch64 cross build and its qemu tests
#   BUILD_DIR, ASAN_BUILD_DIR, FUZZ_BUILD_DIR   build directories (build, build-asan, build-fuzz)
#   FUZZ_TIME             seconds per fuzz target (default 30)
#   AEROVO_CONFIGURE_ONLY=1  only configure stage 1's build dir (tests/readme_order_test.sh)
# Every cache option a stage relies on is set on its cmake line: a build dir configured before
# by ./scripts/demo.sh (tests off) gets the tests back; ctest fails when it finds no test.
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD_DIR=${BUILD_DIR:-build}
RELEASE_OPTIONS=(-G Ninja -DCMAKE_BUILD_TYPE=Release -DAEROVO_BUILD_TESTS=ON
  -DAEROVO_BUILD_BENCHMARKS=ON -DAEROVO_BUILD_EXAMPLES=ON -DAEROVO_SANITIZE=OFF
  -DAEROVO_BUILD_FUZZERS=OFF -DAEROVO_NATIVE=OFF)
if [ "${AEROVO_CONFIGURE_ONLY:-0}" = 1 ]; then
  exec cmake -S . -B "$BUILD_DIR" "${RELEASE_OPTIONS[@]}"
fi
./scripts/install-deps.sh
ASAN_BUILD_DIR=${ASAN_BUILD_DIR:-build-asan}
JOBS=$(nproc)
declare -A STAGE_S
t_all=$(date +%s)

stage() {  # stage NAME COMMAND...: runs and times one stage
  local name=$1 t0
  shift
  echo "=== test.sh: $name"
  t0=$(date +%s)
  "$@"
  STAGE_S[$name]=$(($(date +%s) - t0))
  echo "=== test.sh: $name took ${STAGE_S[$name]} s"
}

release() {
  cmake -S . -B "$BUILD_DIR" "${RELEASE_OPTIONS[@]}"
  cmake --build "$BUILD_DIR" --parallel "$JOBS"
  ctest --test-dir "$BUILD_DIR" --output-on-failure --no-tests=error --parallel "$JOBS" \
    --timeout 1500
}

sanitizers() {
  # -O1 -g1 (line tables): sanitizer builds compile ~2x slower than Release; -O1 keeps the tests
  # fast enough and the reports still name file:line.
  cmake -S . -B "$ASAN_BUILD_DIR" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DAEROVO_SANITIZE=ON \
    -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g1 -DNDEBUG" -DAEROVO_BUILD_TESTS=ON \
    -DAEROVO_BUILD_BENCHMARKS=OFF -DAEROVO_BUILD_EXAMPLES=OFF -DAEROVO_BUILD_FUZZERS=OFF \
    -DAEROVO_NATIVE=OFF
  cmake --build "$ASAN_BUILD_DIR" --parallel "$JOBS"
  # detect_leaks: LeakSanitizer at exit; third-party leaks are suppressed in scripts/lsan.supp
  # (each entry explained). UBSan: -fno-sanitize-recover=all already aborts on the first report.
  # Not repeated under the sanitizers (they run in the Release stage): the long accuracy runs that
  # only repeat code paths shorter tests cover here too — the 4K flight (Video4k: the detection
  # reduction, also Preprocess.* and FrameInput.*), the 10 000-frame run (LongRun: the per-frame
  # path of every flight test; its flat-memory check means nothing under ASan's allocator) and the
  # seed-independence runs of tampa (the same flight as Runner.TampaPhantom3MeetsTheOnePercentTarget,
  # run again with other seeds).
  local skip='^(Video4k\..*|LongRun\..*|Runner\.TampaRelocalisationDoesNotDependOnTheSeed|Runner\.PolishMakesTheTrackIndependentOfTheSeed)$'
  ASAN_OPTIONS=detect_leaks=1:abort_on_error=0:strict_string_checks=1 \
    UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1 \
    LSAN_OPTIONS=suppressions=$PWD/scripts/lsan.supp:print_suppressions=0 \
    ctest --test-dir "$ASAN_BUILD_DIR" --output-on-failure --no-tests=error --parallel "$JOBS" \
    --timeout 3000 -E "$skip"
}

stage release release
if [ "${AEROVO_TEST_QUICK:-0}" != 1 ]; then
  [ "${AEROVO_SKIP_AARCH64:-0}" = 1 ] || stage aarch64 ./scripts/test-aarch64.sh
  stage sanitizers sanitizers
  stage fuzz ./scripts/fuzz.sh
fi
echo "=== test.sh: all stages passed in $(($(date +%s) - t_all)) s" \
  "($(for k in "${!STAGE_S[@]}"; do printf '%s %s s; ' "$k" "${STAGE_S[$k]}"; done))"
