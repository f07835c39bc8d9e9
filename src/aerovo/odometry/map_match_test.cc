#include "aerovo/odometry/map_match.h"

#include <cmath>

#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "aerovo/core/angles.h"
#include "aerovo/core/error.h"
#include "aerovo/core/testing.h"

#if AEROVO_TESTS_HAVE_OPENCV
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#endif

namespace aerovo::map_match_test {
namespace {

TEST(MapMatch, OptionsAndInputsAreChecked) {
  MapMatchOptions o;
  o.search_radius_m = -1.0;
  EXPECT_THROW(MapMatcher{o}, InvalidArgument);
  // A start position without its radius, or a radius without a position (it would be searched
  // around 0 N 0 E), is refused; both, or neither, are taken.
  MapMatchOptions start;
  start.start_lat_deg = 28.04;
  EXPECT_THROW(Validate(start), InvalidArgument);
  start.start_lon_deg = -82.7;
  EXPECT_THROW(Validate(start), InvalidArgument);
  start.start_radius_m = 500.0;
  EXPECT_NO_THROW(Validate(start));
  start.start_lat_deg = start.start_lon_deg = 0.0;
  EXPECT_THROW(Validate(start), InvalidArgument);
  EXPECT_NO_THROW(Validate(MapMatchOptions{}));
  MapMatcher matcher{MapMatchOptions{}};
  GrayImage frame(64, 48, 100), map(100, 100, 100), valid(100, 100, 255), small(10, 10, 255);
  MapMatchFrame f{frame.view(), 50.0, 100.0, std::nullopt};
  EXPECT_THROW(matcher.Match(f, MapMatchWindow{map.view(), small.view(), 0.4}, {0, 0}),
               InvalidArgument);
  EXPECT_THROW(matcher.Match(f, MapMatchWindow{map.view(), valid.view(), 0.0}, {0, 0}),
               InvalidArgument);
  f.height_m = std::nan("");
  EXPECT_THROW(matcher.Match(f, MapMatchWindow{map.view(), valid.view(), 0.4}, {0, 0}),
               InvalidArgument);
}

TEST(MapMatch, WindowSizeAndResolution) {
  // 640 x 480 at 0.2 m/px: half-diagonal 80 m; + 60 m of search = 140 m each side.
  EXPECT_EQ(MapWindowSizePx(640, 480, 0.2, 60.0, 0.4), 701);
  MapMatchOptions o;
  EXPECT_DOUBLE_EQ(MapMatchResolution(o, 640, 0.2, 0.4), 0.4);   // the map is coarser
  EXPECT_DOUBLE_EQ(MapMatchResolution(o, 640, 0.2, 0.1), 0.32);  // 128 m over 400 px
  o.match_m_per_px = 0.5;
  EXPECT_DOUBLE_EQ(MapMatchResolution(o, 640, 0.2, 0.1), 0.5);
}

// The frame's width at the window's resolution decides whether a map is too coarse: a 640 px
// frame at 0.2 m/px is 128 m wide, so 94.8 px at 1.35 m/px (map_too_coarse under the default 96,
// no fit, before any point is detected) and 98.5 px at 1.3 m/px (matched: here against a texture
// that is not its ground, so no fix). The attempt reports its resolution and the frame's ground
// width, in Match, Search and MatchFeatures alike; min_frame_width_px moves the bound.
TEST(MapMatch, AFrameUnderMinFrameWidthAtTheMapsResolutionIsMapTooCoarse) {
  std::mt19937 rng(5);
  std::uniform_int_distribution<int> grey(0, 255);
  GrayImage frame(640, 480), map(300, 300), valid(300, 300, 255);
  for (int y = 0; y < 480; ++y) {
    for (int x = 0; x < 640; ++x)
      frame.at(x, y) = static_cast<std::uint8_t>((x / 64 + y / 64) % 2 * 200);
  }
  for (int y = 0; y < 300; ++y) {
    for (int x = 0; x < 300; ++x) map.at(x, y) = static_cast<std::uint8_t>(grey(rng));
  }
  const MapMatchFrame f{frame.view(), 500.0, 100.0, 0.0};
  MapMatcher matcher{MapMatchOptions{}};
  const MapFix coarse = matcher.Match(f, MapMatchWindow{map.view(), valid.view(), 1.35}, {0, 0});
  EXPECT_EQ(coarse.status, MapFixStatus::kMapTooCoarse);
  EXPECT_FALSE(coarse.fitted);
  EXPECT_EQ(coarse.frame_points, 0);
  EXPECT_DOUBLE_EQ(coarse.m_per_px, 1.35);
  EXPECT_DOUBLE_EQ(coarse.frame_width_m, 128.0);
  EXPECT_STREQ(ToString(coarse.status), "map_too_coarse");
  EXPECT_EQ(matcher.Search(f, MapMatchWindow{map.view(), valid.view(), 1.35}, {0, 0}, 50.0).status,
            MapFixStatus::kMapTooCoarse);
  MapWindowFeatures features;
  features.size_px = 300;
  features.m_per_px = 1.35;
  features.valid_px = 300 * 300;
  features.contrast = 200.0;
  EXPECT_EQ(matcher.MatchFeatures(f, features, {0, 0}).status, MapFixStatus::kMapTooCoarse);
  const MapFix fine = matcher.Match(f, MapMatchWindow{map.view(), valid.view(), 1.3}, {0, 0});
  EXPECT_NE(fine.status, MapFixStatus::kMapTooCoarse);
  EXPECT_GT(fine.frame_points, 0);
  features.m_per_px = 1.3;
  EXPECT_NE(matcher.MatchFeatures(f, features, {0, 0}).status, MapFixStatus::kMapTooCoarse);
  MapMatchOptions narrow;
  narrow.min_frame_width_px = 64;  // 128 m over 64 px: 2 m/px is still matched
  MapMatcher lenient{narrow};
  EXPECT_NE(lenient.Match(f, MapMatchWindow{map.view(), valid.view(), 1.9}, {0, 0}).status,
            MapFixStatus::kMapTooCoarse);
  EXPECT_EQ(lenient.Match(f, MapMatchWindow{map.view(), valid.view(), 2.1}, {0, 0}).status,
            MapFixStatus::kMapTooCoarse);
}

TEST(MapMatch, TexturelessWindowIsNoTexture) {
  std::mt19937 rng(3);
  std::uniform_int_distribution<int> noise(-2, 2);
  GrayImage frame(320, 240), map(400, 400), valid(400, 400, 255);
  for (int y = 0; y < 240; ++y) {
    for (int x = 0; x < 320; ++x)
      frame.at(x, y) = static_cast<std::uint8_t>((x * 7 + y * 13) % 256);
  }
  for (int y = 0; y < 400; ++y) {
    for (int x = 0; x < 400; ++x) map.at(x, y) = static_cast<std::uint8_t>(120 + noise(rng));
  }
  MapMatcher matcher{MapMatchOptions{}};
  const MapFix fix = matcher.Match(MapMatchFrame{frame.view(), 250.0, 100.0, 0.0},
                                   MapMatchWindow{map.view(), valid.view(), 0.4}, {0, 0});
  EXPECT_EQ(fix.status, MapFixStatus::kNoMapTexture);
  EXPECT_FALSE(fix.fitted);
  GrayImage none(400, 400, 0);
  EXPECT_EQ(matcher
                .Match(MapMatchFrame{frame.view(), 250.0, 100.0, 0.0},
                       MapMatchWindow{map.view(), none.view(), 0.4}, {0, 0})
                .status,
            MapFixStatus::kNoMap);
}

#if AEROVO_TESTS_HAVE_OPENCV
// The ground: the Callas orthophoto (8192 x 6400 px of 0.1082 m), read at half size, in an
// East-North frame with its origin at the reduced image's top-left pixel centre.
constexpr double kOrthoMpp = 2 * 0.1082;

struct Scene {
  cv::Mat ground;  // reduced orthophoto, grey
  cv::Mat map;     // the "other season" map over the same ground, kMapMpp
  static constexpr double kMapMpp = 0.4;
  // The map's pixel (X, Y) is at east = X kMapMpp, north = -Y kMapMpp.
};

// The map: the ground low-passed and resampled to 0.4 m/px, its tones changed as another
// season and haze would (a gamma, lower contrast, a brighter veil, a gradient of
// illumination), then JPEG-compressed at quality 40. `shift_region`: the part of the map
// x in [x0, x1) m east is drawn from the ground `shift_m` farther east (a tile placed wrong).
cv::Mat RenderMap(const cv::Mat& ground, double x0 = 0, double x1 = 0, double shift_m = 0) {
  const double f = Scene::kMapMpp / kOrthoMpp;
  cv::Mat blurred;
  cv::GaussianBlur(ground, blurred, cv::Size(), 0.45 * f);
  const cv::Size size(static_cast<int>(ground.cols / f), static_cast<int>(ground.rows / f));
  cv::Mat map(size, CV_8U);
  for (int y = 0; y < size.height; ++y) {
    for (int x = 0; x < size.width; ++x) {
      const double east = x * Scene::kMapMpp;
      const double src_east = (east >= x0 && east < x1) ? east + shift_m : east;
      const int u =
          std::clamp(static_cast<int>(std::lround(src_east / kOrthoMpp)), 0, ground.cols - 1);
      const int v = std::clamp(static_cast<int>(std::lround(y * f)), 0, ground.rows - 1);
      const double g = blurred.at<std::uint8_t>(v, u) / 255.0;
      const double season = std::pow(g, 0.7) * 0.65 + 0.22 + 0.06 * x / size.width;
      map.at<std::uint8_t>(y, x) = cv::saturate_cast<std::uint8_t>(255.0 * season);
    }
  }
  std::vector<std::uint8_t> jpeg;
  cv::imencode(".jpg", map, jpeg, {cv::IMWRITE_JPEG_QUALITY, 40});
  return cv::imdecode(jpeg, cv::IMREAD_GRAYSCALE);
}

// A 640 x 480 nadir frame, focal 500 px, from `height_m` over ground ENU `centre` (m), its
// image-up at `heading` (rad, counter-clockwise from north), with sensor noise.
cv::Mat RenderFrame(const cv::Mat& ground, const Eigen::Vector2d& centre, double heading,
                    double height_m, int seed) {
  const double gsd = height_m / 500.0, c = std::cos(heading), s = std::sin(heading);
  const double cx = 319.5, cy = 239.5;
  // ENU of pixel p = centre + gsd R(h) (p.x - cx, -(p.y - cy)); ground pixel u = E / mpp,
  // v = -N / mpp.
  cv::Mat a = (cv::Mat_<double>(2, 3) << c * gsd / kOrthoMpp, s * gsd / kOrthoMpp, 0,
               -s * gsd / kOrthoMpp, c * gsd / kOrthoMpp, 0);
  a.at<double>(0, 2) = centre.x() / kOrthoMpp - a.at<double>(0, 0) * cx - a.at<double>(0, 1) * cy;
  a.at<double>(1, 2) = -centre.y() / kOrthoMpp - a.at<double>(1, 0) * cx - a.at<double>(1, 1) * cy;
  cv::Mat frame;
  cv::warpAffine(ground, frame, a, cv::Size(640, 480), cv::INTER_LINEAR | cv::WARP_INVERSE_MAP);
  cv::Mat noise(frame.size(), CV_16S);
  cv::theRNG().state = static_cast<std::uint64_t>(seed);
  cv::randn(noise, 0, 3);
  frame.convertTo(frame, CV_16S);
  frame += noise;
  frame.convertTo(frame, CV_8U);
  return frame;
}

GrayImageView ViewOf(const cv::Mat& m) {
  return GrayImageView{m.data, m.cols, m.rows, static_cast<std::ptrdiff_t>(m.step[0])};
}

struct Window {
  cv::Mat pixels, valid;
  Eigen::Vector2d centre_enu;  // of the window's centre pixel, ground ENU, m
};

// The square window of `size` px of the map (`mpp` m/px) around the map pixel nearest `around`
// (ground ENU).
Window CutWindow(const cv::Mat& map, const Eigen::Vector2d& around, int size,
                 double mpp = Scene::kMapMpp) {
  const int cx = static_cast<int>(std::lround(around.x() / mpp));
  const int cy = static_cast<int>(std::lround(-around.y() / mpp));
  const int half = (size - 1) / 2;
  Window w;
  w.pixels = cv::Mat(size, size, CV_8U, cv::Scalar(0));
  w.valid = cv::Mat(size, size, CV_8U, cv::Scalar(0));
  for (int y = 0; y < size; ++y) {
    for (int x = 0; x < size; ++x) {
      const int mx = cx - half + x, my = cy - half + y;
      if (mx < 0 || my < 0 || mx >= map.cols || my >= map.rows) continue;
      w.pixels.at<std::uint8_t>(y, x) = map.at<std::uint8_t>(my, mx);
      w.valid.at<std::uint8_t>(y, x) = 255;
    }
  }
  w.centre_enu = Eigen::Vector2d(cx * mpp, -cy * mpp);
  return w;
}

class MapMatchCallas : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    const std::filesystem::path path =
        ::aerovo::testing::SharedDir() / "data/ortho/callas-quarry.jpg";
    if (::aerovo::testing::SharedDir().empty() || !std::filesystem::exists(path)) return;
    ground_ = new cv::Mat(cv::imread(path.string(), cv::IMREAD_REDUCED_GRAYSCALE_2));
    map_ = new cv::Mat(RenderMap(*ground_));
  }
  static void TearDownTestSuite() {
    delete ground_;
    delete map_;
    ground_ = map_ = nullptr;
  }
  void SetUp() override {
    if (ground_ == nullptr || ground_->empty()) {
      GTEST_SKIP() << "shared data not found: data/ortho/callas-quarry.jpg (set AEROVO_SHARED "
                      "or place ../shared beside the source tree)";
    }
  }
  // The fix of a frame at `truth` (heading `heading`) with the prior `prior_offset` off.
  static MapFix Fix(MapMatcher& matcher, const cv::Mat& map, const Eigen::Vector2d& truth,
                    double heading, std::optional<double> heading_estimate,
                    const Eigen::Vector2d& prior_offset, Eigen::Vector2d* error) {
    const cv::Mat frame = RenderFrame(*ground_, truth, heading, 100.0, 7);
    const Eigen::Vector2d prior = truth + prior_offset;
    const int size =
        MapWindowSizePx(640, 480, 0.2, matcher.options().search_radius_m, Scene::kMapMpp);
    const Window w = CutWindow(map, prior, size);
    const MapFix fix = matcher.Match(
        MapMatchFrame{ViewOf(frame), 500.0, 100.0, heading_estimate},
        MapMatchWindow{ViewOf(w.pixels), ViewOf(w.valid), Scene::kMapMpp}, prior - w.centre_enu);
    *error = fix.enu_m + w.centre_enu - truth;
    return fix;
  }
  // A search (MapMatcher::Search over a window of search_wide_radius_m around the prior, on
  // `map` reduced to the coarse resolution) refined by Match around its hit (MapRefineOptions);
  // `*error` the refined fix's error (the coarse hit's when the search found nothing).
  static MapFix SearchAndRefine(const MapMatchOptions& o, const cv::Mat& map,
                                const Eigen::Vector2d& truth, double heading,
                                std::optional<double> heading_estimate,
                                const Eigen::Vector2d& prior_offset, double gate_m,
                                Eigen::Vector2d* error, MapFix* coarse) {
    const cv::Mat frame = RenderFrame(*ground_, truth, heading, 100.0, 7);
    const Eigen::Vector2d prior = truth + prior_offset;
    const double coarse_mpp = MapSearchResolution(o, 640, 0.2, Scene::kMapMpp);
    cv::Mat reduced;
    cv::resize(map, reduced, cv::Size(), Scene::kMapMpp / coarse_mpp, Scene::kMapMpp / coarse_mpp,
               cv::INTER_AREA);
    const Window wide =
        CutWindow(reduced, prior,
                  MapWindowSizePx(640, 480, 0.2, o.search_wide_radius_m, coarse_mpp), coarse_mpp);
    MapMatcher matcher{o};
    *coarse = matcher.Search(MapMatchFrame{ViewOf(frame), 500.0, 100.0, heading_estimate},
                             MapMatchWindow{ViewOf(wide.pixels), ViewOf(wide.valid), coarse_mpp},
                             prior - wide.centre_enu, gate_m);
    const Eigen::Vector2d hit = coarse->enu_m + wide.centre_enu;
    *error = hit - truth;
    if (coarse->status != MapFixStatus::kFix) return *coarse;
    MapMatcher fine{MapRefineOptions(o, coarse_mpp)};
    const Window w = CutWindow(
        map, hit, MapWindowSizePx(640, 480, 0.2, fine.options().search_radius_m, Scene::kMapMpp));
    const MapFix fix = fine.Match(MapMatchFrame{ViewOf(frame), 500.0, 100.0, coarse->heading_rad},
                                  MapMatchWindow{ViewOf(w.pixels), ViewOf(w.valid), Scene::kMapMpp},
                                  hit - w.centre_enu);
    *error = fix.enu_m + w.centre_enu - truth;
    return fix;
  }
  static cv::Mat* ground_;
  static cv::Mat* map_;
};
cv::Mat* MapMatchCallas::ground_ = nullptr;
cv::Mat* MapMatchCallas::map_ = nullptr;

// Frames at 100 m (0.2 m/px) over six places of the quarry, four headings, the heading
// estimate 3 deg off and the prior 39 m off: every fix within 0.5 m and 1 deg of the truth
// (measured: at most 0.05 m and 0.03 deg), with a covariance that is not absurd (1-sigma under
// 1 m).
TEST_F(MapMatchCallas, FixesWithinToleranceAgainstAnotherSeasonMap) {
  MapMatcher matcher{MapMatchOptions{}};
  const std::vector<Eigen::Vector2d> places = {{250, -250}, {450, -300}, {600, -420},
                                               {350, -520}, {520, -180}, {180, -420}};
  const double headings[] = {0.0, 37.0, 130.0, -100.0};
  int fixes = 0;
  for (std::size_t i = 0; i < places.size(); ++i) {
    const double heading = headings[i % 4] * kDegToRad;
    Eigen::Vector2d error;
    const MapFix fix = Fix(matcher, *map_, places[i], heading, heading + 3.0 * kDegToRad,
                           Eigen::Vector2d(25.0, -30.0), &error);
    SCOPED_TRACE(::testing::Message() << "place " << i << " status " << ToString(fix.status)
                                      << " inliers " << fix.inliers << " error " << error.norm());
    ASSERT_EQ(fix.status, MapFixStatus::kFix);
    ++fixes;
    EXPECT_LT(error.norm(), 0.5);
    EXPECT_LT(std::abs(std::remainder(fix.heading_rad - heading, 2 * kPi)), 1.0 * kDegToRad);
    EXPECT_NEAR(fix.scale, 1.0, 0.03);
    EXPECT_GE(fix.inliers, 20);
    EXPECT_LT(fix.residual_m, 1.0);
    EXPECT_GT(fix.position_cov_m2.trace(), 0.0);
    EXPECT_LT(std::sqrt(fix.position_cov_m2.trace()), 1.0);
    EXPECT_NEAR(fix.prior_distance_m, std::hypot(25.0, 30.0), 1.5);
  }
  EXPECT_EQ(fixes, 6);
}

// Without a heading (rotation-invariant SURF, no guidance): still a fix at 130 deg.
TEST_F(MapMatchCallas, FixWithoutHeading) {
  MapMatcher matcher{MapMatchOptions{}};
  Eigen::Vector2d error;
  const MapFix fix = Fix(matcher, *map_, {450, -300}, 130.0 * kDegToRad, std::nullopt,
                         Eigen::Vector2d(-20.0, 15.0), &error);
  ASSERT_EQ(fix.status, MapFixStatus::kFix) << ToString(fix.status) << " " << fix.inliers;
  EXPECT_LT(error.norm(), 1.5);
  EXPECT_LT(std::abs(std::remainder(fix.heading_rad - 130.0 * kDegToRad, 2 * kPi)),
            1.0 * kDegToRad);
}

// A map whose band x in [300, 900) m east was placed 200 m wrong: a search wide enough to find
// the frame there (220 m) finds it 200 m from the prior, and the 50 m gate rejects it; the same
// frame over the correct map is a fix. The frame seen where the map has none of its ground is
// not a fix either.
TEST_F(MapMatchCallas, FalseMapRegionRejectedByTheGate) {
  const cv::Mat shifted = RenderMap(*ground_, 300.0, 900.0, -200.0);
  MapMatchOptions o;
  o.search_radius_m = 220.0;
  o.gate_m = 50.0;
  MapMatcher matcher{o};
  Eigen::Vector2d error;
  // The ground at 420 m east is drawn at 620 m in the shifted map.
  const Eigen::Vector2d truth(420, -330);
  const MapFix wrong =
      Fix(matcher, shifted, truth, 20.0 * kDegToRad, 20.0 * kDegToRad, {5, 5}, &error);
  EXPECT_EQ(wrong.status, MapFixStatus::kGate) << ToString(wrong.status);
  ASSERT_TRUE(wrong.fitted);
  EXPECT_NEAR(error.x(), 200.0, 1.5);
  EXPECT_NEAR(error.y(), 0.0, 1.5);
  const MapFix right =
      Fix(matcher, *map_, truth, 20.0 * kDegToRad, 20.0 * kDegToRad, {5, 5}, &error);
  EXPECT_EQ(right.status, MapFixStatus::kFix) << ToString(right.status);
  EXPECT_LT(error.norm(), 1.5);
  // A narrow search over the wrong tile: the frame's ground is not in the window at all.
  MapMatcher narrow{MapMatchOptions{}};
  const MapFix none =
      Fix(narrow, shifted, truth, 20.0 * kDegToRad, 20.0 * kDegToRad, {5, 5}, &error);
  EXPECT_NE(none.status, MapFixStatus::kFix) << error.transpose();
}

// A prior 300 m off: the wide search (400 m, coarse at 0.5 m/px: the 128 m wide frame at 256
// px) finds the frame, with and without a heading, and the refinement puts it within 1 m
// (measured: 0.04, 0.01, 0.01 m; the coarse step 160-220 ms, the refinement 20-40 ms).
TEST_F(MapMatchCallas, SearchFindsAFrameWhosePriorIs300MOff) {
  MapMatchOptions o;
  ASSERT_DOUBLE_EQ(MapSearchResolution(o, 640, 0.2, Scene::kMapMpp), 0.5);
  struct Case {
    Eigen::Vector2d truth, offset;
    double heading_deg;
    bool heading_known;
  };
  const Case cases[] = {{{450, -300}, {240, -180}, 37.0, true},
                        {{600, -420}, {-250, 170}, 130.0, false},
                        {{250, -250}, {300, 0}, -100.0, false}};
  for (const Case& c : cases) {
    Eigen::Vector2d error;
    MapFix coarse;
    const double heading = c.heading_deg * kDegToRad;
    const MapFix fix = SearchAndRefine(
        o, *map_, c.truth, heading,
        c.heading_known ? std::optional<double>(heading + 3.0 * kDegToRad) : std::nullopt, c.offset,
        o.search_wide_radius_m, &error, &coarse);
    SCOPED_TRACE(::testing::Message()
                 << "truth " << c.truth.transpose() << " coarse " << ToString(coarse.status)
                 << " inliers " << coarse.inliers << " second " << coarse.second_inliers
                 << " points " << coarse.frame_points << "/" << coarse.map_points << " matches "
                 << coarse.matches << " " << coarse.ms << " ms, fine " << ToString(fix.status)
                 << " " << fix.ms << " ms");
    ASSERT_EQ(coarse.status, MapFixStatus::kFix);
    EXPECT_GE(coarse.inliers, o.min_margin * coarse.second_inliers);
    EXPECT_NEAR(coarse.prior_distance_m, c.offset.norm(), 4.0);
    ASSERT_EQ(fix.status, MapFixStatus::kFix);
    EXPECT_LT(error.norm(), 1.0);
    EXPECT_LT(std::abs(std::remainder(fix.heading_rad - heading, 2 * kPi)), 1.0 * kDegToRad);
  }
}

// The map band x in [300, 900) m east placed 200 m wrong: a wide search from a good prior finds
// the frame's ground 200 m off, and a gate of 80 m (the track trusted) rejects it; the same
// search with the gate as wide as the radius would have taken it.
TEST_F(MapMatchCallas, SearchIntoAFalseMapRegionIsRejectedByTheGate) {
  const cv::Mat shifted = RenderMap(*ground_, 300.0, 900.0, -200.0);
  MapMatchOptions o;
  Eigen::Vector2d error;
  MapFix coarse;
  const Eigen::Vector2d truth(450, -300);
  SearchAndRefine(o, shifted, truth, 20.0 * kDegToRad, 20.0 * kDegToRad, {5, 5}, 80.0, &error,
                  &coarse);
  EXPECT_EQ(coarse.status, MapFixStatus::kGate) << ToString(coarse.status);
  ASSERT_TRUE(coarse.fitted);
  EXPECT_NEAR(error.x(), 200.0, 3.0);
  EXPECT_NEAR(error.y(), 0.0, 3.0);
  SearchAndRefine(o, shifted, truth, 20.0 * kDegToRad, 20.0 * kDegToRad, {5, 5}, 400.0, &error,
                  &coarse);
  EXPECT_EQ(coarse.status, MapFixStatus::kFix) << ToString(coarse.status);
}

// A repeated field: the map's ground around the frame copied 220 m east over the map (with
// other tones, as a second field of the same crop rows would look): two places match the
// frame and the search gives no fix, where the map without the copy gives one (measured: the
// matcher's ratio test drops the frame's points that have two near-equal candidates, 8 and 4
// inliers are left, few_inliers; a partial likeness that passes it is the margin's case,
// ambiguous).
TEST_F(MapMatchCallas, RepeatedTextureIsNoFix) {
  const Eigen::Vector2d truth(300, -400);
  cv::Mat repeated = map_->clone();
  const cv::Rect source(static_cast<int>((truth.x() - 80) / Scene::kMapMpp),
                        static_cast<int>((-truth.y() - 80) / Scene::kMapMpp),
                        static_cast<int>(160 / Scene::kMapMpp),
                        static_cast<int>(160 / Scene::kMapMpp));
  cv::Rect target = source;
  target.x += static_cast<int>(220 / Scene::kMapMpp);
  cv::Mat copy;
  (*map_)(source).convertTo(copy, -1, 0.9, 12.0);
  copy.copyTo(repeated(target));
  MapMatchOptions o;
  for (const bool heading_known : {true, false}) {
    Eigen::Vector2d error;
    MapFix coarse;
    const std::optional<double> heading = heading_known ? std::optional<double>(0.3) : std::nullopt;
    SearchAndRefine(o, repeated, truth, 0.3, heading, {100, 150}, 400.0, &error, &coarse);
    EXPECT_TRUE(coarse.status == MapFixStatus::kTooFewInliers ||
                coarse.status == MapFixStatus::kAmbiguous)
        << "inliers " << coarse.inliers << " second " << coarse.second_inliers << " error "
        << error.transpose();
    SearchAndRefine(o, *map_, truth, 0.3, heading, {100, 150}, 400.0, &error, &coarse);
    EXPECT_EQ(coarse.status, MapFixStatus::kFix) << ToString(coarse.status);
  }
}

// Two places that each hold half of the frame's ground (the map's tiles disagree: the east half
// of the ground around the frame is drawn 250 m farther east, other ground in its place): at
// five places of the quarry the best fit has under twice the inliers of the best other place's,
// or under min_inliers more, and the search is ambiguous (measured: 14 against 7, 37 against 21
// at two of them, where a margin of 1.5 alone took the east half's place, 250 m off).
TEST_F(MapMatchCallas, TwoPlacesWithHalfTheFrameEachAreAmbiguous) {
  const auto px = [](double m) { return static_cast<int>(std::lround(m / Scene::kMapMpp)); };
  const std::vector<Eigen::Vector2d> places = {
      {300, -400}, {450, -300}, {250, -250}, {350, -520}, {520, -180}};
  for (const Eigen::Vector2d& truth : places) {
    cv::Mat split = map_->clone();
    const cv::Rect east_half(px(truth.x()), px(-truth.y() - 60), px(80), px(120));
    cv::Rect moved = east_half, other = east_half;
    moved.x += px(250);
    other.x -= px(250);
    (*map_)(east_half).copyTo(split(moved));
    (*map_)(other).copyTo(split(east_half));
    MapMatchOptions o;
    Eigen::Vector2d error;
    MapFix coarse;
    SearchAndRefine(o, split, truth, 0.0, 0.0, {100, 150}, 400.0, &error, &coarse);
    EXPECT_EQ(coarse.status, MapFixStatus::kAmbiguous)
        << "at " << truth.transpose() << ": " << ToString(coarse.status) << " inliers "
        << coarse.inliers << " second " << coarse.second_inliers << " error " << error.transpose();
    EXPECT_GT(coarse.second_inliers, 0);
  }
}

// Same seed, same fix (to the last bit).
TEST_F(MapMatchCallas, SameSeedSameFix) {
  MapMatcher a{MapMatchOptions{}}, b{MapMatchOptions{}};
  Eigen::Vector2d ea, eb;
  const MapFix fa = Fix(a, *map_, {350, -520}, 1.0, 1.0, {10, 10}, &ea);
  const MapFix fb = Fix(b, *map_, {350, -520}, 1.0, 1.0, {10, 10}, &eb);
  ASSERT_EQ(fa.status, MapFixStatus::kFix);
  EXPECT_EQ(fa.enu_m, fb.enu_m);
  EXPECT_EQ(fa.inliers, fb.inliers);
}
#endif

}  // namespace
}  // namespace aerovo::map_match_test
