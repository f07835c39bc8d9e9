# Lists of tests by ctest name, read by test_properties.cmake (ctest) and check_listed_tests.cmake
# (the test ctest.listed_tests_exist). Names are exact (no patterns). A listed Suite.Test of a
# suite registered as one ctest test (AEROVO_WHOLE_SUITE_TESTS, cmake/AerovoTesting.cmake: MapFix,
# GpsDenied, ...) keeps a ctest test of its own; a test "which stays" below may run inside its
# suite's ctest test (MapFix.AStart300MOffIsFound in MapFix).

# Label "accuracy": end-to-end accuracy runs over whole flights. The Release stage of
# scripts/test.sh runs them; the sanitizer stage leaves them out (ctest -LE accuracy): each
# repeats, on more frames or with other figures, a path that a test still run under the
# sanitizers takes too (named below), and their accuracy figures are those of the optimised build.
#   - Video4k: the 4K flight (the detection reduction; also Preprocess.* and FrameInput.*);
#   - LongRun: 10 000 frames, the per-frame path of every flight test (its flat-memory check
#     means nothing under ASan's allocator);
#   - Runner.Tampa...Seed, Runner.Polish...: tampa again with other seeds (the same flight as
#     Runner.TampaPhantom3MeetsTheOnePercentTarget, which stays);
#   - ReferenceOutputs: skipped in instrumented builds anyway (their figures are the Release
#     build's; tests/e2e/reference_outputs_test.cc), after simulating the suite's flight;
#   - AdaptivePoints.IlluminationDownToATenth...: the adaptive detection of the defaults on darker
#     frames (AdaptivePoints.ThermalLikeFlight..., which stays, and the features unit tests);
#   - Attitude.NadirFlightIsUnchanged...: the attitude correction on a nadir flight, the code of
#     Attitude.TiltedFlight..., which stays.
#   - Runner.BrightonPhantom3...: a third real photo flight against the stored real-flight table
#     (the photo-folder path of Runner.TampaPhantom3..., which stays; 16:9 photo metadata: the
#     image-metadata unit tests and fuzzer).
#   - MapFix.AppliedFixesBound...: the map fixes fused into a drifting track, against the truth
#     (the map-fix thread, matcher and outputs: MapFix.SimulatedFlightFixes..., which stays, and
#     the map_match and map_fixer unit tests).
#   - SixStripSurvey.*: the back-end's figures on 2.4 and 2.9 km surveys (the same offline and
#     online paths as OfflineOptimisation's 1 km lawnmower, which stays).
#   - MapFix.AFalseMapRegion...: a wide search rejected by the gate over a run (the search path:
#     MapFix.AStart300MOffIsFound, which stays, and MapMatchCallas.Search*, the gate's unit tests).
#   - MapSeveral.RecentPartialMapFirstOlder...: fixes from two maps over a whole flight, against the
#     truth, and the report's markers (the windows filled from the next map:
#     MapSeveral.PartialCoverWarns..., which stays, and ReferenceMaps.AWindowThePreferredMap...;
#     the report's map: HtmlReport).
#   - MapDemo.ThreeKilometres...: 3.3 km over the Callas orthophoto without GPS, fused fixes, a
#     gap, a false tile and a start 300 m off in one flight, against the truth (the paths of
#     MapFix.AStart300MOffIsFound and MapFix.SimulatedFlightFixes..., which stay).
set(AEROVO_ACCURACY_TESTS
  Video4k.DefaultRunDetectsAtHalfResolutionWithinFivePercentOfFullResolution
  LongRun.TenThousandFramesWithFlatMemory
  Runner.TampaRelocalisationDoesNotDependOnTheSeed
  Runner.PolishMakesTheTrackIndependentOfTheSeed
  ReferenceOutputs
  AdaptivePoints.IlluminationDownToATenthKeepsTheTrackWithTheDefaults
  Attitude.NadirFlightIsUnchangedByTheCorrection
  Runner.BrightonPhantom3SixteenByNineHoldsTheStoredFigures
  MapFix.AppliedFixesBoundTheErrorOfADriftingTrack
  SixStripSurvey.BuiltInTerrain
  SixStripSurvey.CallasOrthophoto
  MapFix.AFalseMapRegionIsRejectedByTheGate
  MapSeveral.RecentPartialMapFirstOlderFullMapAfterIt
  MapDemo.ThreeKilometresWithoutGpsOverAnotherSurveysMap
)

# Label "repeated_flight": end-to-end runs that repeat, under other settings, a whole-flight path
# that a test still run under the sanitizers takes (named for each below). The Release stage of
# scripts/test.sh runs them; the sanitizer stage leaves them out (ctest -LE), where each costs
# 0.5-4 minutes of an instrumented flight and finds no code the kept test does not run. What the
# sanitizers are for stays there: every unit test, the bad-input, CLI, outputs, signal, telemetry
# and report tests, and at least one flight through each input kind, lens and option family.
#   - docs.commands_run_as_written: the commands of README.md and docs/ (their CLI paths: RunCli.*,
#     CliOutputs, GeoProducts, HtmlReport, BadInput.*);
#   - Demo.QuickDemo...: the demo's simulate, run, report (GeoProducts, HtmlReport do the same);
#   - Runner.SimulatedCallasFlight..., Runner.TurinP4m...: accuracy against truth or GPS on a
#     simulated and a real flight (Runner.VideoWithDjiSrtFromTheSimulator, Runner.TampaPhantom3...;
#     photo metadata: the image-metadata unit tests and fuzzer);
#   - Runner.SigintLeavesValidOutputs: SIGINT on tampa (CliSignal: SIGINT, SIGTERM, SIGHUP);
#   - TelemetryTrust.EnuOrigin..., ImplausibleRun..., ImplausibleAltitude..., ShiftedTelemetry...:
#     the GPS checks on more flights (TelemetryTrust.ImplausibleSpike..., the gps_check and clock
#     unit tests);
#   - WideLens.FastFixedWing..., WideLens.MildPinhole..., WideLens.FisheyeFlight...: wide-lens
#     flights undistorted by a known lens (LensSelfCalibration.Fisheye..., which undistorts a
#     fisheye flight's frames by the same lens model once its estimate is applied; the lens
#     file: the camera_files unit tests; the lens model: the camera unit tests);
#   - LensSelfCalibration.Pinhole..., GoProLike..., FirstPoses...: (LensSelfCalibration.Fisheye...,
#     which applies the estimate at its switch frame too);
#   - RunCli.RunFromItsSavedConfigJson...: the same run twice (RunConfigSchema.SavedConfigJson...);
#   - CliConventions.RunPrintsTheAnswerFirst..., OneNameForTheSameOption..., HelpCmdIsCmdHelp...:
#     the text of help and answers (CliConventions.UsageErrorsExitTwo...: the argument parsing);
#   - Attitude.SrtWithOnlyAnAltitudeAboveSeaLevel...: (Height.*, Attitude.TiltedFlight...);
#   - BadInput.DamagedTelemetryWithLenientTelemetry...: a 12-frame flight per damage
#     (BadInput.DamagedSrt.../DamagedGpx...: the same damages parsed; the lenient readers' unit
#     tests in telemetry_readers_test.cc; the fuzzers).
#   - OfflineOptimisationThreads: the lawnmower's optimised, windowed and loop-closure runs again
#     with 1 thread, compared with 2 (OfflineOptimisation runs each path once; the sanitizers do
#     not see data races, and the same-result-at-any-thread-count property is the optimised
#     build's).
#   - SensorPattern.ThermalFlightWithVignettingAndFixedPattern...: the flat field's photo median on
#     the thermal flight, with and without it (AdaptivePoints.ThermalLikeFlight..., whose
#     thermal preset has the pattern too and takes the same path; SensorPattern.ThermalVideo...,
#     the running estimate; the flat_field unit tests).
#   - mavlink.node_mavlink_live: the contract flight as a live stream played at real-time pace
#     (mavlink.node_mavlink_contract: the same messages through the same arithmetic from a file;
#     the live source's queue and clock: FrameSource and FrameLoop unit tests). An instrumented
#     build is slower than the stream: the newest-frame queue then drops the flight's black
#     frame, which the test needs bridged.
set(AEROVO_REPEATED_FLIGHT_TESTS
  SensorPattern.ThermalFlightWithVignettingAndFixedPatternIsTrackedWithTheDefaults
  docs.commands_run_as_written
  Demo.QuickDemoWritesEverythingAndTracksTheTruth
  Runner.SimulatedCallasFlightAgainstExactTruth
  Runner.TurinP4mWithXmpAltitudeAndYaw
  Runner.SigintLeavesValidOutputs
  TelemetryTrust.EnuOriginIsTheFirstAcceptedFix
  TelemetryTrust.ImplausibleRunOrSmallJumpDoesNotSteerTheGeoReference
  TelemetryTrust.ImplausibleAltitudeOrLateStepDoesNotSteerTheTrack
  TelemetryTrust.ShiftedTelemetryOffsetIsEstimatedAndApplied
  WideLens.FastFixedWingFlightKeepsEveryFrame
  WideLens.MildPinholeLensPointsPathMatchesTheFramesPath
  WideLens.FisheyeFlightIsAccurateWithItsCalibrationFileOnly
  LensSelfCalibration.PinholeIsNotAppliedAndTheTrackIsUnchanged
  LensSelfCalibration.GoProLikeBarrelIsEstimatedAndApplied
  LensSelfCalibration.FirstPosesComeBeforeTheEstimateAppliedAtAFixedFrame
  RunCli.RunFromItsSavedConfigJsonReproducesTheRun
  CliConventions.RunPrintsTheAnswerFirstWithin80ColumnsAndTheConfigOnlyWhenVerbose
  CliConventions.OneNameForTheSameOptionInEveryCommand
  CliConventions.HelpCmdIsCmdHelpAndEveryHelpListsTheExitCodes
  Attitude.SrtWithOnlyAnAltitudeAboveSeaLevelNeedsTheGroundElevation
  BadInput.DamagedTelemetryWithLenientTelemetryIsSkippedAndReported
  OfflineOptimisationThreads
  mavlink.node_mavlink_live
)

# COST: relative run time, so that ctest --parallel starts the long tests first instead of
# ending on one long test with a core idle (the end-to-end tests are registered last). Figure per
# test: the larger of its wall seconds in the Release stage and a third of its wall seconds in the
# sanitizer stage (the instrumented build runs 2-4x slower), from two clean-clone runs of
# scripts/test.sh, 2026-12-06 (BENCHMARKS.md, CI time). ctest uses its own measured times instead
# once a build dir has run its tests (Testing/Temporary/CTestCostData.txt). Names must be
# registered in every build (no unit test, which the sanitizer stage runs inside its module's
# executable). Pairs: name cost.
set(AEROVO_TEST_COSTS
  docs.commands_run_as_written 72
  CliOutputs 48
  MapFix 44
  LongRun.TenThousandFramesWithFlatMemory 39
  Video4k.DefaultRunDetectsAtHalfResolutionWithinFivePercentOfFullResolution 30
  OfflineOptimisation 25
  mavlink.node_mavlink_live 23
  MapDemo.ThreeKilometresWithoutGpsOverAnotherSurveysMap 21
  ReferenceOutputs 20
  Demo.QuickDemoWritesEverythingAndTracksTheTruth 20
  WideLens.FastFixedWingFlightKeepsEveryFrame 19
  Runner.TampaRelocalisationDoesNotDependOnTheSeed 19
  HtmlReport 19
  WideLens.FisheyeFlightIsAccurateWithItsCalibrationFileOnly 18
  OfflineOptimisationThreads 18
  CliSignal 17
  MapBuild 16
  MapFix.AppliedFixesBoundTheErrorOfADriftingTrack 14
  SixStripSurvey.BuiltInTerrain 13
  MapRun.TheMapIsCheckedAgainstTheFlightAndItsCoverReported 13
  LensSelfCalibration.ALiveSourcesLensIsEstimatedFromItsOwnFrames 13
  WideLens.MildPinholeLensPointsPathMatchesTheFramesPath 12
  SixStripSurvey.CallasOrthophoto 12
  Runner.SimulatedCallasFlightAgainstExactTruth 12
  GpsDenied 12
  MapSeveral.RecentPartialMapFirstOlderFullMapAfterIt 11
  AdaptivePoints.IlluminationDownToATenthKeepsTheTrackWithTheDefaults 11
  mavlink.node_mavlink_udp 10
  mavlink.node_mavlink_map_gps_input 10
  mavlink.node_mavlink_contract 10
  Runner.TampaPhantom3MeetsTheOnePercentTarget 10
  MapSeveral.PartialCoverWarnsAndACorruptSecondMapIsNamed 10
  LensSelfCalibration.FisheyeIsEstimatedAndApplied 10
  FrameInput.HugePhotosAreReducedToThePixelBudget 10
  MapFix.AFalseMapRegionIsRejectedByTheGate 9
  LensSelfCalibration.FirstPosesComeBeforeTheEstimateAppliedAtAFixedFrame 9
  Attitude.TiltedFlightIsThreeTimesMoreAccurateWithTheCorrection 9
  AdaptivePoints.ThermalLikeFlightIsTrackedWithTheDefaults 8
  SensorPattern.ThermalVideoIsCorrectedByTheRunningEstimate 7
  SensorPattern.ThermalFlightWithVignettingAndFixedPatternIsTrackedWithTheDefaults 7
  GeoProducts 7
  BadInput.DamagedTelemetryWithLenientTelemetryIsSkippedAndReported 7
  cli.correspondence_on_a_tampa_pair 6
  TelemetryTrust.ImplausibleSpikeOrFirstFixDoesNotSteerTheGeoReference 6
  LensSelfCalibration.GoProLikeBarrelIsEstimatedAndApplied 6
  Attitude.NadirFlightIsUnchangedByTheCorrection 5
  Runner.VideoWithDjiSrtFromTheSimulator 4
)
