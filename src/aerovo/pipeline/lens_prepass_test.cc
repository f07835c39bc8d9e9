#include "aerovo/pipeline/lens_prepass.h"

#include <filesystem>
#include <vector>

#include <gtest/gtest.h>

#include "aerovo/core/error.h"

namespace aerovo::run_steps {
namespace {

TEST(LensPrepass, PairStartsAreSpreadOverTheFlight) {
  // (i + 0.5) / 5 of the way, each followed by the next frame.
  EXPECT_EQ(LensPrepassPairStarts(25, 5), (std::vector<int>{2, 7, 12, 17, 22}));
  // A short flight: the last pair ends on the last frame, no pair twice.
  EXPECT_EQ(LensPrepassPairStarts(6, 5), (std::vector<int>{0, 1, 3, 4}));
  EXPECT_EQ(LensPrepassPairStarts(2, 5), (std::vector<int>{0}));
  EXPECT_TRUE(LensPrepassPairStarts(1, 5).empty());
  EXPECT_TRUE(LensPrepassPairStarts(0, 5).empty());
}

TEST(LensPrepass, RunsOnlyWithoutALensAndOnAnInputReadTwice) {
  RunConfig c;
  c.input = std::filesystem::temp_directory_path().string();  // an existing folder
  EXPECT_EQ(LensPrepassSkipReason(c, false), "");
  EXPECT_EQ(LensPrepassSkipReason(c, true), "a live source cannot be read twice");
  RunConfig off = c;
  off.lens_estimation = LensEstimationMode::kOff;
  EXPECT_EQ(LensPrepassSkipReason(off, false), "lens_estimation off");
  RunConfig cal = c;
  cal.calibration = "cameras.json";
  EXPECT_EQ(LensPrepassSkipReason(cal, false), "a calibration file is given");
  RunConfig k = c;
  k.p2 = 1e-4;
  EXPECT_EQ(LensPrepassSkipReason(k, false), "lens distortion coefficients are given");
  RunConfig missing = c;
  missing.input = "/nonexistent/aerovo/flight.mp4";
  EXPECT_EQ(LensPrepassSkipReason(missing, false),
            "the input is not a file or folder that can be read again");
  // The paper's pipeline has no self-calibration.
  EXPECT_EQ(PaperRunConfig().lens_estimation, LensEstimationMode::kOff);
  EXPECT_EQ(RunConfig().lens_estimation, LensEstimationMode::kAuto);
}

TEST(LensPrepass, SkippedSummaryHasNoEstimate) {
  LensPrepass p;
  p.why = "lens_estimation off";
  const nlohmann::json j = ToJson(p);
  EXPECT_EQ(j["status"], "skipped");
  EXPECT_EQ(j["applied"], false);
  EXPECT_EQ(j["why"], "lens_estimation off");
  EXPECT_FALSE(j.contains("k"));
}

TEST(LensPrepass, BadFrameSizeIsAnError) {
  RunConfig c;
  c.input = std::filesystem::temp_directory_path().string();
  EXPECT_THROW(RunLensPrepass(c, 0, 480, 300.0), InvalidArgument);
  EXPECT_THROW(RunLensPrepass(c, 640, 480, 0.0), InvalidArgument);
}

}  // namespace
}  // namespace aerovo::run_steps
