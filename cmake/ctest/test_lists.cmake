# Lists of tests by ctest name, read by test_properties.cmake (ctest) and check_listed_tests.cmake
# (the test ctest.listed_tests_exist). Names are exact (no patterns).

# Label "accuracy": end-to-end accuracy runs over whole flights. The Release stage of
# scripts/test.sh runs them; the sanitizer stage leaves them out (ctest -LE accuracy): they
# repeat the per-frame path of the pipeline that the shorter end-to-end tests (bad input, CLI,
# outputs, signals, telemetry, short simulated flights) run under the sanitizers too, and their
# accuracy figures are those of the optimised build.
#   - Video4k: the 4K flight (the detection reduction; also Preprocess.* and FrameInput.*);
#   - LongRun: 10 000 frames (its flat-memory check means nothing under ASan's allocator);
#   - Runner.Tampa...Seed, Runner.Polish...: tampa again with other seeds (the same flight as
#     Runner.TampaPhantom3MeetsTheOnePercentTarget);
#   - ReferenceOutputs: skipped in instrumented builds anyway (their figures are the Release
#     build's), which would still simulate its flight first.
set(AEROVO_ACCURACY_TESTS
  Video4k.DefaultRunDetectsAtHalfResolutionWithinFivePercentOfFullResolution
  LongRun.TenThousandFramesWithFlatMemory
  Runner.TampaRelocalisationDoesNotDependOnTheSeed
  Runner.PolishMakesTheTrackIndependentOfTheSeed
  ReferenceOutputs
)

# COST: relative run time (seconds in the Release build, idle machine), so that ctest -j starts
# the long tests first instead of ending on one long test with a core idle. ctest uses its own
# measured times instead once a build dir has run its tests (Testing/Temporary/CTestCostData.txt).
set(AEROVO_TEST_COSTS
)
