// MapFixer (map_fixer.h) on a GeoTIFF of random texture written here (a transverse Mercator CRS
// centred on the map's north-west corner, 0.5 m/px) and frames cut from the same texture, so that
// each frame's true position is known: a file source attempts every frame it is given, in order,
// and its fixes land on the truth; a live source skips the frames due while the matcher is busy;
// a prediction off the map is "no_map"; map_fixes.csv and summary.json's block are filled in.
#include "aerovo/pipeline/map_fixer.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <random>
#include <string>
#include <string_view>
#include <vector>

#include <gdal_priv.h>
#include <ogr_spatialref.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "aerovo/core/testing.h"
#include "aerovo/geo/local_enu.h"
#include "aerovo/map/reference_map.h"
#include "aerovo/pipeline/map_fixer_test_util.h"

namespace aerovo::run_steps::map_fixer_test {
namespace {

namespace fs = std::filesystem;

using map_testing::kLat0;
using map_testing::kLon0;
using map_testing::kMpp;
using map_testing::TexturedMap;

const TexturedMap& FixerMap() {
  static const TexturedMap m(5, "aerovo_map_fixer");
  return m;
}

// The count of `status` in the summary's by_status, -1 when it is not listed.
int StatusCount(const RunSummary::MapFixes& m, std::string_view status) {
  for (const auto& [name, count] : m.by_status) {
    if (name == status) return count;
  }
  return -1;
}

TEST(MapFixer, FileSourceAttemptsEveryFrameAndFixesLandOnTheTruth) {
  const map::ReferenceMaps maps({FixerMap().path});
  MapMatchOptions o;
  o.every_n_frames = 2;
  o.search_radius_m = 30.0;
  MapFixer fixer(maps, o, /*live=*/false);
  EXPECT_TRUE(fixer.Due(0));
  EXPECT_FALSE(fixer.Due(1));
  fixer.Submit(FixerMap().Job(0, 300, 300, 12.0));
  fixer.Submit(FixerMap().Job(2, 420, 380, -8.0));
  fixer.Submit(FixerMap().Job(4, 500, 450, 5.0));
  fixer.Submit(FixerMap().Job(6, 300, 300, 0.0));
  fixer.Submit(FixerMap().Job(8, 300, 300, 5000.0));  // off the map
  fixer.CountNoPrediction();
  RunSummary summary;
  const fs::path dir = FixerMap().path.parent_path();
  fixer.Finish(dir, &summary);
  fixer.Finish(dir, &summary);  // idempotent
  ASSERT_TRUE(summary.map_fixes.has_value());
  const RunSummary::MapFixes& m = *summary.map_fixes;
  EXPECT_EQ(m.every_n_frames, 2);
  EXPECT_EQ(m.attempted, 5);
  EXPECT_EQ(m.fixes, 4);
  EXPECT_EQ(m.no_prediction, 1);
  EXPECT_EQ(m.skipped_busy, 0);
  ASSERT_EQ(m.with_gps, 4);
  EXPECT_LT(m.max_m, 0.3);
  EXPECT_NEAR(m.track_max_m, 12.0, 0.01);
  EXPECT_EQ(StatusCount(m, "no_map"), 1);
  const std::string csv = ::aerovo::testing::ReadText(dir / "map_fixes.csv");
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 6);
  EXPECT_EQ(csv.rfind("8,8.000,no_map,", std::string::npos) != std::string::npos, true) << csv;
}

// Lost and found (no search at the start): a prediction 150 m off fails twice in the 30 m window
// (search_after_failures 2), the third attempt searches 200 m and finds the frame (the first
// fix, 4 s after the first attempt); then, the track trusted, the same error again is found by the
// next search but rejected by its gate (30 m + 10 % of the 150 m the predictions moved since).
TEST(MapFixer, WideSearchAfterFailuresFindsAFarPredictionThenGatesOne) {
  const map::ReferenceMaps maps({FixerMap().path});
  MapMatchOptions o;
  o.search_radius_m = 30.0;
  o.search_at_start = false;
  o.search_after_failures = 2;
  o.search_wide_radius_m = 200.0;
  MapFixer fixer(maps, o, /*live=*/false);
  for (int i = 0; i < 3; ++i) fixer.Submit(FixerMap().Job(2 * i, 300, 300, 150.0));
  fixer.Submit(FixerMap().Job(6, 300, 320, 0.0));  // local fix: the track trusted
  for (int i = 0; i < 3; ++i) fixer.Submit(FixerMap().Job(8 + 2 * i, 300, 340, 150.0));
  RunSummary summary;
  const fs::path dir = FixerMap().path.parent_path();
  fixer.Finish(dir, &summary);
  ASSERT_TRUE(summary.map_fixes.has_value());
  const RunSummary::MapFixes& m = *summary.map_fixes;
  EXPECT_EQ(m.attempted, 7);
  EXPECT_EQ(m.searches, 2);
  EXPECT_EQ(m.found, 1);
  EXPECT_EQ(m.fixes, 2);
  ASSERT_TRUE(m.time_to_first_fix_s.has_value());
  EXPECT_DOUBLE_EQ(*m.time_to_first_fix_s, 4.0);
  EXPECT_LT(m.max_m, 0.3);
  // The rows' status and search columns (19 columns).
  const std::string csv = ::aerovo::testing::ReadText(dir / "map_fixes.csv");
  std::vector<std::string> rows;
  for (std::size_t at = csv.find('\n'); at + 1 < csv.size();) {
    const std::size_t end = csv.find('\n', at + 1);
    const std::string line = csv.substr(at + 1, end - at - 1);
    std::vector<std::string> cells(1);
    for (const char c : line) {
      if (c == ',') {
        cells.emplace_back();
      } else {
        cells.back() += c;
      }
    }
    rows.push_back(cells.size() == 21 ? cells[2] + " " + cells[16] : line);
    at = end;
  }
  const std::vector<std::string> expected = {
      "few_inliers local", "few_inliers local", "fix wide", "fix local",
      "few_inliers local", "few_inliers local", "gate wide"};
  EXPECT_EQ(rows, expected) << csv;
}

// `job` without a prediction (MapFixJob::anchored false: the track not geo-referenced yet), at
// `local_north_m` north in the local frame.
MapFixJob Unanchored(MapFixJob job, double local_north_m) {
  job.anchored = false;
  job.heading_rad.reset();
  job.predicted = GeoPoint{};
  job.local_m = Eigen::Vector2d(0.0, local_north_m);
  return job;
}

// No prediction (MapFixJob::anchored false): the first job is searched over the whole map (400 x
// 400 m in tiles of 200 m: 4) without a heading and found, a candidate; the next one, 20 m south
// in the local frame, is predicted through it and matched locally: it confirms the candidate,
// and TakeSeed hands it over once. A frame of another texture is searched, found nowhere, and
// the next search_after_failures (2) unanchored jobs are counted as without a prediction.
TEST(MapFixer, WithoutAPredictionTheWholeMapIsSearchedAndTheNextFixConfirmsIt) {
  const map::ReferenceMaps maps({FixerMap().path});
  MapMatchOptions o;
  o.search_radius_m = 30.0;
  o.search_wide_radius_m = 100.0;
  o.search_after_failures = 2;
  MapFixer fixer(maps, o, /*live=*/false);
  fixer.Submit(Unanchored(FixerMap().Job(0, 300, 300, 0.0), 0.0));
  EXPECT_FALSE(fixer.TakeSeed(true).has_value());  // a candidate only
  fixer.Submit(Unanchored(FixerMap().Job(2, 300, 340, 0.0), -20.0));
  const std::optional<MapFixRecord> seed = fixer.TakeSeed(true);
  ASSERT_TRUE(seed.has_value());
  EXPECT_EQ(seed->frame, 2);
  EXPECT_EQ(seed->seed, MapSeedRole::kConfirmed);
  ASSERT_TRUE(seed->gps_error_m.has_value());
  EXPECT_LT(*seed->gps_error_m, 0.3);
  EXPECT_NEAR(seed->fix.heading_rad, 0.0, 0.01);
  EXPECT_FALSE(fixer.TakeSeed(true).has_value());  // once
  // Another texture: nowhere on the map.
  MapFixJob other = Unanchored(FixerMap().Job(4, 300, 300, 0.0), 0.0);
  cv::Mat noise(180, 240, CV_8U);
  cv::theRNG().state = 11;
  cv::randu(noise, 0, 256);
  cv::GaussianBlur(noise, noise, cv::Size(), 2.0);
  cv::normalize(noise, noise, 0, 255, cv::NORM_MINMAX);
  for (int y = 0; y < 180; ++y) {
    for (int x = 0; x < 240; ++x) other.pixels.at(x, y) = noise.at<std::uint8_t>(y, x);
  }
  MapFixer lost(maps, o, /*live=*/false);
  for (int i = 0; i < 4; ++i) {
    other.frame = 2 * i;
    other.time_s = 2.0 * i;
    lost.Submit(other);
  }
  RunSummary summary, lost_summary;
  const fs::path dir = FixerMap().path.parent_path();
  fixer.Finish(dir, &summary);
  ASSERT_TRUE(summary.map_fixes.has_value());
  const RunSummary::MapFixes& m = *summary.map_fixes;
  EXPECT_EQ(m.attempted, 2);
  EXPECT_EQ(m.whole_map_searches, 1);
  EXPECT_EQ(m.whole_map_tiles, 4);
  EXPECT_EQ(m.candidates, 1);
  ASSERT_TRUE(m.georef_seed.has_value());
  EXPECT_EQ(m.georef_seed->frame, 2);
  EXPECT_EQ(m.georef_seed->candidate_frame, 0);
  EXPECT_EQ(m.georef_note, "");
  lost.Finish(dir, &lost_summary);
  const RunSummary::MapFixes& l = *lost_summary.map_fixes;
  EXPECT_EQ(l.attempted, 2);  // jobs 0 and 3 searched, 1 and 2 without a prediction
  EXPECT_EQ(l.whole_map_searches, 2);
  EXPECT_EQ(l.no_prediction, 2);
  EXPECT_EQ(l.fixes, 0);
  EXPECT_FALSE(l.georef_seed.has_value());
  EXPECT_NE(l.georef_note.find(
                "no whole-map search found the frame (2 searches over 4 of the map's 4 tiles"),
            std::string::npos)
      << l.georef_note;
}

// No seed within map_fix.seed_wait_s (MapFixer::GiveUpSeed): a confirmation that comes after
// it is not handed over, and the note says when the run went local and what came too late.
TEST(MapFixer, AfterGivingUpTheSeedAConfirmationIsNotTaken) {
  const map::ReferenceMaps maps({FixerMap().path});
  MapMatchOptions o;
  o.search_radius_m = 30.0;
  o.search_wide_radius_m = 100.0;
  o.seed_wait_s = 0.5;
  MapFixer fixer(maps, o, /*live=*/false);
  fixer.Submit(Unanchored(FixerMap().Job(0, 300, 300, 0.0), 0.0));
  EXPECT_FALSE(fixer.TakeSeed(true).has_value());  // a candidate only
  fixer.Submit(Unanchored(FixerMap().Job(2, 300, 340, 0.0), -20.0));  // it confirms it...
  fixer.GiveUpSeed(1, 0.5);
  EXPECT_TRUE(fixer.gave_up_seed());
  EXPECT_FALSE(fixer.TakeSeed(true).has_value());  // ...too late
  RunSummary summary;
  fixer.Finish(FixerMap().path.parent_path(), &summary);
  const RunSummary::MapFixes& m = *summary.map_fixes;
  EXPECT_FALSE(m.georef_seed.has_value());
  EXPECT_EQ(m.candidates, 1);
  EXPECT_EQ(m.georef_note,
            "no seed within map_fix.seed_wait_s (0.5 s): the frames were written in the local "
            "frame from frame 1 (0.500 s) on and the run stayed local; 1 candidate found by 1 "
            "whole-map search, 1 confirmed after the wait (not taken)");
}

// A start position given (map_fix.start_*): only the square around it is searched. Within 60 m
// of the frame: one tile, the frame found; 250 m away (the frame far outside the window of the
// square of 60 m around it): not found, and the note says where it searched.
TEST(MapFixer, AStartPositionGivenBoundsTheSearchWithoutAPrediction) {
  const map::ReferenceMaps maps({FixerMap().path});
  const LocalEnu enu(kLat0, kLon0, 0.0);
  const auto search_from = [&](double east_m, RunSummary* summary) {
    MapMatchOptions o;
    o.search_wide_radius_m = 100.0;
    o.start_radius_m = 60.0;
    const GeoPoint start = enu.Reverse(300 * kMpp + east_m, -300 * kMpp, 0.0);
    o.start_lat_deg = start.lat_deg;
    o.start_lon_deg = start.lon_deg;
    MapFixer fixer(maps, o, /*live=*/false);
    MapFixJob job = FixerMap().Job(0, 300, 300, 0.0);
    job.anchored = false;
    job.heading_rad.reset();
    fixer.Submit(std::move(job));
    fixer.Finish(FixerMap().path.parent_path(), summary);
  };
  RunSummary near, far;
  search_from(20.0, &near);
  EXPECT_EQ(near.map_fixes->whole_map_tiles, 1);
  EXPECT_EQ(near.map_fixes->candidates, 1);
  search_from(250.0, &far);
  EXPECT_EQ(far.map_fixes->candidates, 0);
  EXPECT_NE(far.map_fixes->georef_note.find("within 60 m of the start position"), std::string::npos)
      << far.map_fixes->georef_note;
}

TEST(MapFixer, LiveSourceSkipsFramesDueWhileBusy) {
  const map::ReferenceMaps maps({FixerMap().path});
  MapFixer fixer(maps, MapMatchOptions{}, /*live=*/true);
  // Submitted back to back: the first is pending or being matched (tens of ms) while the others
  // arrive, microseconds later.
  for (int i = 0; i < 4; ++i) fixer.Submit(FixerMap().Job(i, 400, 400, 3.0));
  RunSummary summary;
  fixer.Finish(FixerMap().path.parent_path(), &summary);
  ASSERT_TRUE(summary.map_fixes.has_value());
  EXPECT_EQ(summary.map_fixes->attempted, 1);
  EXPECT_EQ(summary.map_fixes->skipped_busy, 3);
  EXPECT_EQ(summary.map_fixes->fixes, 1);
}

// A map too coarse for the frames: a frame 43.2 m wide on the ground (240 px at 0.18 m/px) spans
// 86 of the map's 0.5 m pixels, under min_frame_width_px (96). The attempt is not made
// (map_too_coarse, not a texture failure) and the summary's warning names the map and the
// resolution a map would need (43.2 m / 96 px = 0.45 m/px); a frame 120 m wide is fixed beside it.
// With min_frame_width_px 64 the same frame is matched and fails (its pixels are at 0.5 m/px, not
// the 0.18 its height says): the warning then says the map may be too coarse, the frame being
// under twice the minimum (128 px) across.
TEST(MapFixer, AMapTooCoarseForTheFramesIsSaidAndNotMatched) {
  const map::ReferenceMaps maps({FixerMap().path});
  MapMatchOptions o;
  o.search_at_start = false;
  o.search_radius_m = 30.0;
  const fs::path dir = FixerMap().path.parent_path();
  MapFixJob narrow = FixerMap().Job(1, 420, 380, 5.0);
  narrow.height_m = 18.0;
  {
    MapFixer fixer(maps, o, /*live=*/false);
    fixer.Submit(FixerMap().Job(0, 300, 300, 5.0));
    fixer.Submit(narrow);
    RunSummary summary;
    fixer.Finish(dir, &summary);
    ASSERT_TRUE(summary.map_fixes.has_value());
    EXPECT_EQ(summary.map_fixes->attempted, 2);
    EXPECT_EQ(summary.map_fixes->fixes, 1);
    EXPECT_EQ(StatusCount(*summary.map_fixes, "map_too_coarse"), 1);
    ASSERT_EQ(summary.warnings.size(), 1u);
    const std::string& w = summary.warnings[0];
    for (const char* part :
         {"map.tif': 1 of 2 map fix attempts not made, the map too coarse for the frames",
          "a frame 43 m wide on the ground is 86 pixels across at 0.50 m per pixel",
          "map_fix.min_frame_width_px (96)", "a map of at most 0.45 m per pixel is needed"}) {
      EXPECT_NE(w.find(part), std::string::npos) << part << "\n" << w;
    }
    const std::string csv = ::aerovo::testing::ReadText(dir / "map_fixes.csv");
    EXPECT_NE(csv.find("\n1,1.000,map_too_coarse,"), std::string::npos) << csv;
  }
  o.min_frame_width_px = 64;
  MapFixer fixer(maps, o, /*live=*/false);
  fixer.Submit(narrow);
  RunSummary summary;
  fixer.Finish(dir, &summary);
  ASSERT_TRUE(summary.map_fixes.has_value());
  EXPECT_EQ(summary.map_fixes->attempted, 1);
  EXPECT_EQ(summary.map_fixes->fixes, 0);
  EXPECT_EQ(StatusCount(*summary.map_fixes, "map_too_coarse"), 0);
  ASSERT_EQ(summary.warnings.size(), 1u);
  for (const char* part : {"map.tif': 1 of 1 map fix attempts failed with the frame under 128 "
                           "pixels across at the map's resolution",
                           "the map may be too coarse for the frames",
                           "at most 0.34 m per pixel gives the matching 128 pixels"}) {
    EXPECT_NE(summary.warnings[0].find(part), std::string::npos) << part << "\n"
                                                                 << summary.warnings[0];
  }
}

}  // namespace
}  // namespace aerovo::run_steps::map_fixer_test
