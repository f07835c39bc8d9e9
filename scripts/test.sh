#!/usr/bin/env bash
# Installs the dependencies, builds aerovo and runs every test: this is the README's test command
# and what CI (.ci/run) runs, on a clean clone with 2 cores. Stages:
#   1. Release build (tests, benchmarks, examples) in build/, every test (ctest) but the unit
#      tests of the modules other than pipeline, which stage 2 runs (all of them with
#      AEROVO_TEST_QUICK=1);
#   1b. aarch64: the core modules cross-compiled for aarch64 (build-aarch64/), their unit tests
#      under qemu-aarch64, NEON and scalar paths (scripts/test-aarch64.sh);
#   2. AddressSanitizer + UndefinedBehaviorSanitizer build (clang++, -O1 -g1, no benchmarks) in
#      build-asan/, every test again but the labels "accuracy" and "repeated_flight" (long
#      flights that the Release stage runs, each path kept under the sanitizers by a shorter
#      test; cmake/ctest/test_lists.cmake says which and why), each module's unit tests in one
#      process; any ASan/UBSan/LeakSanitizer report fails the test;
#   3. the libFuzzer targets (scripts/fuzz.sh), built in stage 2's build dir, FUZZ_TIME s each
#      (30), as many at a time as there are cores.
# Each stage prints its wall and CPU (user+sys) time, build and tests separately; the end prints
# a table of them and the 15 slowest tests. Environment:
#   AEROVO_TEST_QUICK=1   developers: stage 1 only (Release build + tests)
#   AEROVO_SKIP_AARCH64=1 skip the aarch64 cross build and its qemu tests
#   BUILD_DIR, ASAN_BUILD_DIR   build directories (build, build-asan)
#   FUZZ_BUILD_DIR        the fuzzers' own build dir (build-fuzz), only without clang++
#   FUZZ_TIME             seconds per fuzz target (default 20)
#   AEROVO_CONFIGURE_ONLY=1  only configure stage 1's build dir (tests/readme_order_test.sh)
#   AEROVO_UNITY_BUILD=OFF   build every stage source by source (default ON: unity builds)
# Every cache option a stage relies on is set on its cmake line: a build dir configured before
# by ./scripts/demo.sh (tests off) gets the tests back; ctest fails when it finds no test.
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD_DIR=${BUILD_DIR:-build}
# mold (scripts/install-deps.sh) links the executables and shared libraries: a build links ~30
# test executables, each in about a sixth of GNU ld's CPU time (BENCHMARKS.md, CI time). Python's
# extension module (MODULE, possibly with LTO) keeps the default linker. --no-fork: mold links
# in the process the compiler driver waits for, so its CPU time counts in the stage's.
LINK_OPTIONS=()
if command -v ld.mold >/dev/null; then
  LINK_OPTIONS=("-DCMAKE_EXE_LINKER_FLAGS=-fuse-ld=mold -Wl,--no-fork"
    "-DCMAKE_SHARED_LINKER_FLAGS=-fuse-ld=mold -Wl,--no-fork")
fi
# The Release stage builds only the pipeline's unit tests when the sanitizer stage follows, which
# builds and runs every module's (CMakeLists.txt, AEROVO_UNIT_TESTS); with AEROVO_TEST_QUICK=1
# (and AEROVO_CONFIGURE_ONLY=1) it builds them all.
UNIT_TESTS=pipeline
# Unity builds (CMakeLists.txt, AEROVO_UNITY_BUILD) for every stage's build (the aarch64 one
# reads the variable too): about half the compile CPU of a clean build (BENCHMARKS.md, CI time).
# AEROVO_UNITY_BUILD=OFF builds source by source, as a plain cmake configure does (a developer's
# incremental rebuilds recompile one source, not its batch).
UNITY=${AEROVO_UNITY_BUILD:-ON}
if [ "${AEROVO_TEST_QUICK:-0}" = 1 ] || [ "${AEROVO_CONFIGURE_ONLY:-0}" = 1 ]; then UNIT_TESTS=ALL; fi
RELEASE_OPTIONS=(-G Ninja -DCMAKE_BUILD_TYPE=Release -DAEROVO_BUILD_TESTS=ON
  -DAEROVO_UNIT_TESTS="$UNIT_TESTS"
  -DAEROVO_BUILD_BENCHMARKS=ON -DAEROVO_BUILD_EXAMPLES=ON -DAEROVO_SANITIZE=OFF
  -DAEROVO_BUILD_FUZZERS=OFF -DAEROVO_NATIVE=OFF -DAEROVO_UNITY_BUILD="$UNITY" "${LINK_OPTIONS[@]}")
if [ "${AEROVO_CONFIGURE_ONLY:-0}" = 1 ]; then
  exec cmake -S . -B "$BUILD_DIR" "${RELEASE_OPTIONS[@]}"
fi
ASAN_BUILD_DIR=${ASAN_BUILD_DIR:-build-asan}
JOBS=$(nproc)
t_all=$(date +%s)
STAGES=()   # "name wall_s cpu_s", in order
TESTLOGS=() # "stage:ctest log", for the slowest tests

# CPU_S: user+sys CPU seconds of every child process finished so far (bash `times`, second line;
# run in this shell, not a subshell, so that it sees this shell's children).
TIMES_FILE=$(mktemp)
CURRENT=""
# On a failure: which stage, and the times so far.
trap 'rc=$?; rm -f "$TIMES_FILE"; if [ $rc -ne 0 ] && [ -n "$CURRENT" ]; then
  echo "=== test.sh: FAILED in stage $CURRENT (exit $rc)"; summary; fi' EXIT
cpu_now() {
  times >"$TIMES_FILE"
  CPU_S=$(awk 'NR == 2 { for (i = 1; i <= 2; i++) { split($i, t, /[ms]/); s += t[1] * 60 + t[2] } }
    END { printf "%.0f", s }' "$TIMES_FILE")
}

stage() {  # stage NAME COMMAND...: runs one step, prints and records its wall and CPU time
  local name=$1 t0 c0
  shift
  echo "=== test.sh: $name"
  CURRENT=$name
  cpu_now
  c0=$CPU_S
  t0=$(date +%s)
  "$@"
  cpu_now
  STAGES+=("$name $(($(date +%s) - t0)) $((CPU_S - c0))")
  echo "=== test.sh: $name took $(($(date +%s) - t0)) s wall, $((CPU_S - c0)) s CPU"
}

run_ctest() {  # run_ctest STAGE BUILD_DIR [ctest args...]: ctest, its log kept for the summary
  local name=$1 dir=$2
  shift 2
  TESTLOGS+=("$name:$dir/ctest.log")
  ctest --test-dir "$dir" --output-on-failure --no-tests=error --parallel "$JOBS" "$@" |
    tee "$dir/ctest.log"
}

release_build() {
  cmake -S . -B "$BUILD_DIR" "${RELEASE_OPTIONS[@]}"
  cmake --build "$BUILD_DIR" --parallel "$JOBS"
}
release_tests() { run_ctest release "$BUILD_DIR" --timeout 1500; }

# clang++ (scripts/install-deps.sh) builds the sanitizer stage and the fuzzers together: one
# instrumented build of the library instead of two (BENCHMARKS.md, CI time). Without clang++,
# g++ builds the sanitizer stage and scripts/fuzz.sh (which needs clang++) fails in its own stage.
HAVE_CLANG=0
command -v clang++ >/dev/null && HAVE_CLANG=1
sanitizers_build() {
  # -O1 -g1 (line tables): sanitizer builds compile ~2x slower than Release; -O1 keeps the tests
  # fast enough and the reports still name file:line (the modules that compute per pixel or point
  # are at -O2: CMakeLists.txt, AEROVO_SANITIZE_O2_MODULES). clang++ compiles the instrumented code in
  # less CPU than g++, whose UBSan instrumentation about doubles a TU's compile time
  # (BENCHMARKS.md, CI time). AEROVO_TEST_WHOLE_EXECUTABLES: each module's unit tests run as one
  # process (under ASan a process takes ~0.5 s to start, more than most unit tests).
  local cxx=(-DAEROVO_BUILD_FUZZERS=OFF)
  [ "$HAVE_CLANG" = 1 ] && cxx=(-DCMAKE_CXX_COMPILER=clang++ -DAEROVO_BUILD_FUZZERS=ON)
  cmake -S . -B "$ASAN_BUILD_DIR" -G Ninja "${cxx[@]}" -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DAEROVO_SANITIZE=ON \
    -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g1 -DNDEBUG" -DAEROVO_BUILD_TESTS=ON \
    -DAEROVO_TEST_WHOLE_EXECUTABLES=ON -DAEROVO_UNIT_TESTS=ALL \
    -DAEROVO_BUILD_BENCHMARKS=OFF -DAEROVO_BUILD_EXAMPLES=OFF \
    -DAEROVO_NATIVE=OFF -DAEROVO_UNITY_BUILD="$UNITY" "${LINK_OPTIONS[@]}"
  cmake --build "$ASAN_BUILD_DIR" --parallel "$JOBS"
}
sanitizers_tests() {
  # detect_leaks: LeakSanitizer at exit; third-party leaks are suppressed in scripts/lsan.supp
  # (each entry explained). UBSan: -fno-sanitize-recover=all already aborts on the first report.
  # -LE: not the long accuracy runs and repeated flights the Release stage runs
  # (cmake/ctest/test_lists.cmake).
  ASAN_OPTIONS=detect_leaks=1:abort_on_error=0:strict_string_checks=1 \
    UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1 \
    LSAN_OPTIONS=suppressions=$PWD/scripts/lsan.supp:print_suppressions=0 \
    run_ctest sanitizers "$ASAN_BUILD_DIR" --timeout 3000 -LE 'accuracy|repeated_flight'
}

summary() {
  local row name wall cpu log
  echo "=== test.sh: stage times (wall and user+sys CPU, seconds; $JOBS cores)"
  printf '%-20s %8s %8s\n' stage wall_s cpu_s
  for row in "${STAGES[@]}"; do
    read -r name wall cpu <<<"$row"
    printf '%-20s %8s %8s\n' "$name" "$wall" "$cpu"
  done
  printf '%-20s %8s\n' total "$(($(date +%s) - t_all))"
  echo "=== test.sh: the 15 slowest tests (wall s, under ctest --parallel $JOBS)"
  # ctest's lines: "  12/300 Test  #45: Name ......   Passed   12.34 sec".
  for row in "${TESTLOGS[@]}"; do
    name=${row%%:*}
    log=${row#*:}
    sed -nE "s/^ *[0-9]+\/[0-9]+ Test +#[0-9]+: ([^ ]+) .* ([0-9.]+) sec$/\2 $name \1/p" "$log"
  # awk, not head, takes the first 15: it reads all of sort's output, so sort never dies of
  # SIGPIPE (with pipefail and set -e that ended the script with 141 after every stage passed).
  done | sort -rn | awk 'NR <= 15 { printf "%8.1f  %-11s %s\n", $1, $2, $3 }'
}

stage install-deps ./scripts/install-deps.sh
stage release-build release_build
stage release-tests release_tests
if [ "${AEROVO_TEST_QUICK:-0}" != 1 ]; then
  if [ "${AEROVO_SKIP_AARCH64:-0}" != 1 ]; then
    stage aarch64-build ./scripts/test-aarch64.sh build
    stage aarch64-tests ./scripts/test-aarch64.sh test
  fi
  stage sanitizers-build sanitizers_build
  stage sanitizers-tests sanitizers_tests
  if [ "$HAVE_CLANG" = 1 ]; then
    stage fuzz-run env FUZZ_BUILD_DIR="$ASAN_BUILD_DIR" FUZZ_CONFIGURE=0 ./scripts/fuzz.sh
  else
    stage fuzz-build env FUZZ_BUILD_ONLY=1 ./scripts/fuzz.sh
    stage fuzz-run env FUZZ_CONFIGURE=0 ./scripts/fuzz.sh
  fi
fi
CURRENT=""
summary
echo "=== test.sh: all stages passed in $(($(date +%s) - t_all)) s"
