#!/usr/bin/env bash
# The aarch64 stage of scripts/test.sh: cross-compiles the core modules (the ones
# without OpenCV/Exiv2, AEROVO_CORE_ONLY) for aarch64 with Debian's g++-aarch64-linux-gnu
# (cmake/toolchain-aarch64-linux-gnu.cmake) in build-aarch64/, Release (-O2), and runs their unit
# tests under qemu-aarch64 through ctest, twice: AEROVO_SIMD=native (the NEON/SVE kernels chosen at
# run time) and AEROVO_SIMD=scalar (the portable path; the SURF and matcher tests only).
# SurfMatchGolden compares the keypoints and matches with the ones recorded on x86. Environment:
# Usage: scripts/test-aarch64.sh [build|test]   (default: both; scripts/test.sh times them apart)
#   AARCH64_BUILD_DIR   build directory (build-aarch64)
#   AEROVO_SKIP_AARCH64=1  skip the stage (scripts/test.sh)
#   AEROVO_UNITY_BUILD=OFF build source by source (default ON: a unity build, CMakeLists.txt)
# Excluded under qemu (ctest -E, the regex below), measured 2026-12-02 with qemu-user 7.2 (a
# run: 223 tests native in 553 s and 51 scalar in 154 s at load average 12-15, BENCHMARKS.md):
#   - the tests that start a second thread do not finish under this qemu-user (600 s and 300 s
#     timeouts; the same code with 1 thread passes). Not the threads' code: a dynamically
#     linked aarch64 program that starts one std::thread and joins it spins at 100 % CPU and
#     does not finish in 20 s under qemu-aarch64 7.2 here, while the same program linked
#     -static finishes in 0.08 s (2026-12-07). The loops' threads (core/parallel.h) are tested
#     on x86 (Release, ASan, TSan); under qemu, the core tests that start threads are left out:
#     ParallelFor.* but its serial and thread-count tests,
#     SurfAdaptive.IdenticalForIdenticalInputAndAnyThreadCount (3 threads),
#     MatcherTest.MultiThreadAndKernelsGiveIdenticalResults,
#     MatcherKdForestTest.DeterministicAcrossSeedsThreadsAndReuse (2, 3, all threads);
#   - SurfAdaptive.OutputUnchangedOnASynthetic1080pFrame and SurfAdaptive.
#     TheSelectionIsExactlyThePlainSelectionOverAllCandidates: full-HD SURF runs, several per test
#     (thread counts, grids), > 300 s each under qemu-user; on aarch64 the in-layer maximum kernels
#     (NEON against scalar) are checked by InLayerMaximumKernelTest and the keypoints against x86
#     by SurfMatchGolden;
#   - SurfAdaptive.CellFloorsChangeNoPointOfAStream (a stream with 1 and 2 threads: > 300 s
#     under qemu-user, 2026-12-05) and LoopClosures.TheSameSeedGivesTheSameResultWithOneOrTwoThreads
#     (253 s) for the threads; LoopClosures.TheGateRejectsARepeatedFieldThatVerifiesGeometrically
#     (> 300 s: the real matcher and RANSAC on 33 candidates, offline and online). The per-cell
#     floors' output is checked on aarch64 by the other SurfAdaptive tests and SurfMatchGolden, the
#     closures' detection by LoopClosures.AppearanceFindsTheRevisit... (14 s);
#   - MavlinkLink.*: the autopilot link's receive thread with UDP sockets and wall-clock
#     timeouts does not finish under qemu-user (600 s timeout). The framing, CRC, message and
#     parser tests (Mavlink*, MavlinkParser*, MavlinkUrl*) do run.
#   - MatcherKdForestTest.RecallOnRandomDescriptorsWithNoisyTwins (3000 x 4000 descriptors
#     matched exhaustively twice: 159 s under qemu-user, the stage's longest test, 2026-12-05): it
#     measures the forest's recall, which the kernels do not change (the Release and sanitizer
#     stages run it on x86); the NEON and scalar kernels' exact distances are checked against the
#     brute force by the other Matcher tests (MatcherKdForestTest.FullBudgetEqualsExhaustive,
#     MatcherTest.AgreesWithBruteForceOnHardData) and the matches against x86 by SurfMatchGolden.
#   No known failures: the two ClusteredRansac tests that failed on aarch64 only
#   (RefinementMatchesStandardAccuracy, FinalPassRunsWhenTheSpreadFitMovesTheCellsFit) had other
#   synthetic scenes there because C++ leaves the order of a call's argument evaluations unspecified
#   (x86-64 GCC right to left, aarch64 GCC left to right), so Eigen::Vector2d(ux(rng), uy(rng))
#   drew other points; the draws are now one per statement (testing::DrawYThenX) and both pass.
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD=${AARCH64_BUILD_DIR:-build-aarch64}
JOBS=$(nproc)
SIMD_TESTS='^(Surf|Sigmas/SurfBlob|Matcher)'
EXCLUDE='^(ParallelFor\.(EveryIndexOnceInChunksOfTheGivenSizeOnValidWorkers|WorkersShareTheWorkAndPerWorkerScratchSumsAlike|TheFirstExceptionIsRethrownAndTheRestIsNotStarted|NestedCallsRunSerially|SeveralCallersAtOnce|IdleWorkersTakeNoCpu|AForkedChildRunsItsLoopsOnItsOwnWorkers)|SurfAdaptive\.IdenticalForIdenticalInputAndAnyThreadCount|SurfAdaptive\.OutputUnchangedOnASynthetic1080pFrame|SurfAdaptive\.TheSelectionIsExactlyThePlainSelectionOverAllCandidates|MatcherTest\.MultiThreadAndKernelsGiveIdenticalResults|MatcherKdForestTest\.DeterministicAcrossSeedsThreadsAndReuse|SurfAdaptive\.CellFloorsChangeNoPointOfAStream|LoopClosures\.TheSameSeedGivesTheSameResultWithOneOrTwoThreads|LoopClosures\.TheGateRejectsARepeatedFieldThatVerifiesGeometrically|MatcherKdForestTest\.RecallOnRandomDescriptorsWithNoisyTwins|MavlinkLink\..*)$'
STEP=${1:-all}
case $STEP in all | build | test) ;; *) echo "usage: $0 [build|test]" >&2; exit 2 ;; esac
if [ "$STEP" != test ]; then
  ./scripts/install-deps-aarch64.sh
  t0=$(date +%s)
  cmake -S . -B "$BUILD" -G Ninja -DCMAKE_TOOLCHAIN_FILE=cmake/toolchain-aarch64-linux-gnu.cmake \
    -DCMAKE_BUILD_TYPE=Release -DCMAKE_CXX_FLAGS_RELEASE="-O2 -DNDEBUG" -DAEROVO_CORE_ONLY=ON \
    -DAEROVO_BUILD_TESTS=ON -DAEROVO_SANITIZE=OFF -DAEROVO_NATIVE=OFF \
    -DAEROVO_UNITY_BUILD="${AEROVO_UNITY_BUILD:-ON}" >/dev/null
  cmake --build "$BUILD" --parallel "$JOBS"
  echo "test-aarch64: build took $(($(date +%s) - t0)) s"
fi
[ "$STEP" != build ] || exit 0
t1=$(date +%s)
# Every core unit test with the run-time choice of kernels; then, with the portable (scalar)
# kernels, the tests of the code that has SIMD kernels (SURF and the matcher, with the golden
# comparison): the other modules run the same code in both modes.
echo "test-aarch64: ctest under qemu-aarch64, AEROVO_SIMD=native (all core unit tests)"
AEROVO_SIMD=native ctest --test-dir "$BUILD" --output-on-failure --no-tests=error \
  --parallel "$JOBS" --timeout 300 -E "$EXCLUDE"
t2=$(date +%s)
echo "test-aarch64: AEROVO_SIMD=native took $((t2 - t1)) s"
echo "test-aarch64: ctest under qemu-aarch64, AEROVO_SIMD=scalar (SURF, matcher, golden)"
AEROVO_SIMD=scalar ctest --test-dir "$BUILD" --output-on-failure --no-tests=error \
  --parallel "$JOBS" --timeout 300 -E "$EXCLUDE" -R "$SIMD_TESTS"
echo "test-aarch64: AEROVO_SIMD=scalar took $(($(date +%s) - t2)) s"
echo "test-aarch64: tests took $(($(date +%s) - t1)) s"
