#include "aerovo/odometry/visual_odometry.h"

#include "aerovo/backend/pixel_step.h"
#include "aerovo/backend/similarity2.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "aerovo/core/angles.h"
#include "aerovo/core/error.h"

namespace aerovo::visual_odometry_test {
namespace {

// Ground truth of the synthetic flights: ground sampling distance 0.1 m/px (height 50 m,
// focal 500 px), frames 320x240 cropped from a textured "ground" image.
constexpr double kFocalPx = 500.0, kHeightM = 50.0, kGsd = kHeightM / kFocalPx;
constexpr int kW = 320, kH = 240;

// Deterministic textured ground: blobs of many sizes and grey levels over multi-scale noise,
// so that SURF finds well-spread, distinctive points at every place.
cv::Mat MakeGround(int size, std::uint64_t seed) {
  cv::RNG rng(seed);
  cv::Mat ground(size, size, CV_32F, cv::Scalar(0));
  for (int octave = 0; octave < 4; ++octave) {
    const int cells = size >> (6 - octave);
    cv::Mat noise(cells, cells, CV_32F);
    rng.fill(noise, cv::RNG::UNIFORM, 0.0, 1.0);
    cv::Mat up;
    cv::resize(noise, up, ground.size(), 0, 0, cv::INTER_CUBIC);
    ground += up * (40.0 / (1 << octave));
  }
  // One draw per statement, y before x: a call's arguments are evaluated in an unspecified order
  // (x86-64 GCC: right to left, aarch64 GCC: left to right); this is the order x86-64 GCC used
  // for the former cv::Point(rng.uniform(0, size), rng.uniform(0, size)), so the ground is the
  // one the x86 tests were written against.
  for (int i = 0; i < size * size / 400; ++i) {
    const int cy = rng.uniform(0, size);
    const int cx = rng.uniform(0, size);
    const cv::Point c(cx, cy);
    const int radius = rng.uniform(2, 12);
    cv::circle(ground, c, radius, cv::Scalar(rng.uniform(0.0, 255.0)), cv::FILLED, cv::LINE_AA);
  }
  for (int i = 0; i < size * size / 4000; ++i) {
    const int ay = rng.uniform(0, size);
    const int ax = rng.uniform(0, size);
    const cv::Point a(ax, ay);
    const int dy = rng.uniform(-30, 30);
    const int dx = rng.uniform(-30, 30);
    const cv::Point b = a + cv::Point(dx, dy);
    cv::rectangle(ground, a, b, cv::Scalar(rng.uniform(0.0, 255.0)), cv::FILLED);
  }
  cv::GaussianBlur(ground, ground, cv::Size(0, 0), 1.0);
  cv::Mat out;
  ground.convertTo(out, CV_8U);
  return out;
}

struct TruePose {
  Eigen::Vector2d pos_m;  // local VO frame (x right, y up of frame 0)
  double heading;         // rad, CCW from local +y
};

// Renders the frame of a camera at `pose` over `ground`, whose pixel q0 is the local origin.
cv::Mat Render(const cv::Mat& ground, const cv::Point2d& q0, const TruePose& pose) {
  // big_px = q0 + F * pos / gsd + Rot(-heading) * (p - centre)  (see pose_chain.h frames)
  const double c = std::cos(-pose.heading), s = std::sin(-pose.heading);
  const double cx = 0.5 * (kW - 1), cy = 0.5 * (kH - 1);
  const double tx = q0.x + pose.pos_m.x() / kGsd - (c * cx - s * cy);
  const double ty = q0.y - pose.pos_m.y() / kGsd - (s * cx + c * cy);
  const cv::Matx23d big_from_frame(c, -s, tx, s, c, ty);
  cv::Mat frame;
  cv::warpAffine(ground, frame, big_from_frame, cv::Size(kW, kH),
                 cv::INTER_LINEAR | cv::WARP_INVERSE_MAP, cv::BORDER_REFLECT);
  return frame;
}

GrayImageView View(const cv::Mat& m) {
  return GrayImageView{m.data, m.cols, m.rows, static_cast<std::ptrdiff_t>(m.step)};
}

// A curving flight: 3.5 m (35 px) per frame, turning 3 degrees per frame to the left.
std::vector<TruePose> CurvedFlight(int n) {
  std::vector<TruePose> poses;
  Eigen::Vector2d p(0, 0);
  double heading = 0.0;
  for (int i = 0; i < n; ++i) {
    poses.push_back({p, heading});
    heading += 3.0 * kDegToRad;
    p += 3.5 * Eigen::Vector2d(-std::sin(heading), std::cos(heading));
  }
  return poses;
}

OdometryOptions SyntheticOptions() {
  OdometryOptions o;
  o.focal_px = kFocalPx;
  o.default_height_m = kHeightM;
  o.surf.num_threads = 1;
  o.correspondence.match.num_threads = 1;
  return o;
}

class SyntheticFlight : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { ground_ = new cv::Mat(MakeGround(1400, 7)); }
  static void TearDownTestSuite() { delete ground_; }
  static cv::Mat* ground_;
  const cv::Point2d q0_{700, 900};
};
cv::Mat* SyntheticFlight::ground_ = nullptr;

TEST_F(SyntheticFlight, RecoversCurvedTrajectory) {
  const std::vector<TruePose> truth = CurvedFlight(30);
  VisualOdometry vo(SyntheticOptions());
  double distance = 0.0;
  for (std::size_t i = 0; i < truth.size(); ++i) {
    const cv::Mat frame = Render(*ground_, q0_, truth[i]);
    const FrameResult r = vo.Process(View(frame), 0.5 * i);
    if (i > 0) distance += (truth[i].pos_m - truth[i - 1].pos_m).norm();
    ASSERT_EQ(r.index, static_cast<int>(i));
    EXPECT_EQ(r.status, i == 0 ? FrameStatus::kFirst : FrameStatus::kOk) << "frame " << i;
    EXPECT_GT(r.n_surf, 100);
    if (i > 0) {
      EXPECT_GE(r.n_inliers, 20);
    }
    // Within 0.2 % of the distance flown + 5 cm (measured: <= 1.7 cm over 100 m), heading
    // within 0.5 deg.
    EXPECT_LT((r.position_m - truth[i].pos_m).norm(), 0.05 + 0.002 * distance) << "frame " << i;
    EXPECT_NEAR(std::remainder(r.heading_rad - truth[i].heading, 2 * M_PI), 0.0, 0.5 * kDegToRad);
    EXPECT_NEAR(r.gsd_m_per_px, kGsd, 1e-12);
  }
  EXPECT_EQ(vo.stats().frames, 30);
  EXPECT_EQ(vo.stats().bridged, 0);
}

// A time, yaw or attitude that is not finite, or a height beyond 100 km, is refused naming the
// frame, and the frame is not counted: the next good frame continues the track. Before, a NaN
// yaw with heading_from_yaw made every later position NaN with status ok, and a height of
// 1e308 m positions of 1e303 m and inf (the Python bindings reach Process directly).
TEST_F(SyntheticFlight, NonFiniteTimeYawAttitudeOrAbsurdHeightIsRefusedNamingTheFrame) {
  const std::vector<TruePose> truth = CurvedFlight(4);
  OdometryOptions o = SyntheticOptions();
  o.heading_from_yaw = true;
  VisualOdometry vo(o);
  std::vector<cv::Mat> frames;
  for (const TruePose& p : truth) frames.push_back(Render(*ground_, q0_, p));
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  EXPECT_EQ(vo.Process(View(frames[0]), 0.0, kHeightM, 0.0).status, FrameStatus::kFirst);
  const auto message = [&](const std::function<void()>& f) {
    try {
      f();
    } catch (const std::exception& e) {
      return std::string(e.what());
    }
    return std::string("(accepted)");
  };
  EXPECT_EQ(message([&] { vo.Process(View(frames[1]), 0.5, kHeightM, nan); }),
            "VisualOdometry: frame 1: yaw_deg = nan is not finite");
  EXPECT_EQ(message([&] { vo.Process(View(frames[1]), 0.5, kHeightM, inf); }),
            "VisualOdometry: frame 1: yaw_deg = inf is not finite");
  EXPECT_EQ(message([&] { vo.Process(View(frames[1]), nan, kHeightM, 0.0); }),
            "VisualOdometry: frame 1: time_s = nan is not finite");
  EXPECT_EQ(message([&] {
              vo.Process(View(frames[1]), 0.5, kHeightM, 0.0, CameraAttitude{nan, 0.0});
            }),
            "VisualOdometry: frame 1: roll_deg = nan is not finite");
  EXPECT_EQ(message([&] {
              vo.Process(View(frames[1]), 0.5, kHeightM, 0.0, CameraAttitude{0.0, -inf});
            }),
            "VisualOdometry: frame 1: pitch_deg = -inf is not finite");
  const std::string high = message([&] { vo.Process(View(frames[1]), 0.5, 1e308, 0.0); });
  EXPECT_NE(high.find("frame 1: no valid height above ground"), std::string::npos) << high;
  EXPECT_EQ(vo.stats().frames, 1);
  // The flight goes on with good values, as if the refused calls had not been made.
  for (std::size_t i = 1; i < truth.size(); ++i) {
    const FrameResult r = vo.Process(View(frames[i]), 0.5 * i, kHeightM);
    EXPECT_EQ(r.index, static_cast<int>(i));
    EXPECT_EQ(r.status, FrameStatus::kOk) << "frame " << i;
    EXPECT_TRUE(r.position_m.allFinite());
  }
}

// SetShareFeatures: the results carry the frame's features and the step's inliers (for the
// offline optimisation, flight_graph.h), and the track is the same as without; each step's
// ground-plane factor (backend/pixel_step.h) is the true relative pose.
TEST_F(SyntheticFlight, SharesFeaturesAndStepInliersOnlyWhenAsked) {
  const std::vector<TruePose> truth = CurvedFlight(6);
  VisualOdometry plain(SyntheticOptions()), shared(SyntheticOptions());
  shared.SetShareFeatures(true);
  const Eigen::Vector2d centre(0.5 * (kW - 1), 0.5 * (kH - 1));
  for (std::size_t i = 0; i < truth.size(); ++i) {
    const cv::Mat frame = Render(*ground_, q0_, truth[i]);
    const FrameResult a = plain.Process(View(frame), 0.5 * i);
    const FrameResult b = shared.Process(View(frame), 0.5 * i);
    EXPECT_EQ(a.features, nullptr);
    EXPECT_EQ(a.step_inliers_curr_px.cols(), 0);
    ASSERT_NE(b.features, nullptr);
    EXPECT_EQ(static_cast<int>(b.features->size()), b.n_surf);
    EXPECT_EQ(a.position_m, b.position_m);
    if (i == 0) continue;
    EXPECT_EQ(b.step_inliers_curr_px.cols(), b.n_inliers) << "frame " << i;
    const backend::Similarity2 step =
        backend::PrevFromCurrOfPixelStep(b.curr_from_prev, centre, kGsd, kGsd);
    const backend::Similarity2 prev{truth[i - 1].pos_m, truth[i - 1].heading, 0.0};
    const backend::Similarity2 curr{truth[i].pos_m, truth[i].heading, 0.0};
    const backend::Similarity2 expected = backend::Between(prev, curr);
    EXPECT_LT((step.translation_m - expected.translation_m).norm(), 0.02) << "frame " << i;
    EXPECT_NEAR(backend::WrapAngleRad(step.heading_rad - expected.heading_rad), 0.0, 1e-3);
  }
}

TEST_F(SyntheticFlight, BridgesBlackAndForeignFramesAndReacquires) {
  const std::vector<TruePose> truth = CurvedFlight(24);
  const cv::Mat other_ground = MakeGround(600, 99);
  VisualOdometry vo(SyntheticOptions());
  std::vector<FrameResult> results;
  for (std::size_t i = 0; i < truth.size(); ++i) {
    cv::Mat frame = Render(*ground_, q0_, truth[i]);
    if (i == 10) frame.setTo(0);                                           // a black frame
    if (i == 17) frame = Render(other_ground, {300, 300}, {{0, 0}, 0.0});  // no overlap at all
    results.push_back(vo.Process(View(frame), 0.5 * i));
  }
  const double step = 3.5;
  EXPECT_EQ(results[10].status, FrameStatus::kBridged);
  EXPECT_EQ(results[10].failure, StepFailure::kTooFewFeatures);
  // Bridged with the previous step: no jump, within a few metres of the truth.
  EXPECT_LT((results[10].position_m - results[9].position_m).norm(), 1.5 * step);
  EXPECT_LT((results[10].position_m - truth[10].pos_m).norm(), 1.0);
  EXPECT_EQ(results[11].status, FrameStatus::kReacquired);
  EXPECT_EQ(results[11].reference_index, 9);
  EXPECT_EQ(results[17].status, FrameStatus::kBridged);
  EXPECT_NE(results[17].failure, StepFailure::kNone);
  EXPECT_LT((results[17].position_m - results[16].position_m).norm(), 1.5 * step);
  // Frame 18 cannot match the foreign frame 17: it re-acquires on 16.
  EXPECT_EQ(results[18].status, FrameStatus::kReacquired);
  EXPECT_EQ(results[18].reference_index, 16);
  for (std::size_t i = 0; i < truth.size(); ++i) {
    if (i == 10 || i == 17) continue;
    EXPECT_NE(results[i].status, FrameStatus::kBridged) << "frame " << i;
    EXPECT_LT((results[i].position_m - truth[i].pos_m).norm(), 0.6) << "frame " << i;
  }
  EXPECT_EQ(vo.stats().bridged, 2);
  EXPECT_EQ(vo.stats().reacquired, 2);
}

TEST_F(SyntheticFlight, RelocalisesAfterAJumpWithATurnBackOverEarlierGround) {
  // 16 frames north at 3.5 m per frame, then a jump (no overlap with frame 15) back over frame
  // 4's ground turned by 90 degrees, then on west. Constant velocity cannot predict it; the
  // keyframes (every 5th frame) can.
  std::vector<TruePose> truth;
  for (int i = 0; i < 16; ++i) truth.push_back({{0.0, 3.5 * i}, 0.0});
  for (int i = 0; i < 6; ++i) truth.push_back({{1.0 - 3.5 * i, 14.0}, M_PI / 2});
  VisualOdometry vo(SyntheticOptions());
  OdometryOptions no_reloc_opts = SyntheticOptions();
  no_reloc_opts.relocalize = false;
  VisualOdometry no_reloc(no_reloc_opts);
  for (std::size_t i = 0; i < truth.size(); ++i) {
    const cv::Mat frame = Render(*ground_, q0_, truth[i]);
    const FrameResult r = vo.Process(View(frame), i);
    const FrameResult n = no_reloc.Process(View(frame), i);
    if (i == 16) {
      EXPECT_EQ(r.status, FrameStatus::kReacquired);
      EXPECT_TRUE(r.relocalized);
      EXPECT_EQ(r.reference_index % 5, 0);
      EXPECT_EQ(n.status, FrameStatus::kBridged);
    } else {
      EXPECT_FALSE(r.relocalized) << "frame " << i;
    }
    EXPECT_LT((r.position_m - truth[i].pos_m).norm(), 0.1) << "frame " << i;
    EXPECT_NEAR(std::remainder(r.heading_rad - truth[i].heading, 2 * M_PI), 0.0, 0.01);
    if (i >= 17) {
      // Without relocalisation the rest of the flight stays wrong by metres.
      EXPECT_GT((n.position_m - truth[i].pos_m).norm(), 5.0) << "frame " << i;
    }
  }
  EXPECT_EQ(vo.stats().bridged, 0);
}

TEST_F(SyntheticFlight, DeterministicAndAffineChainAgrees) {
  const std::vector<TruePose> truth = CurvedFlight(12);
  OdometryOptions chain_opts = SyntheticOptions();
  chain_opts.scale_mode = ScaleMode::kAffineChain;
  chain_opts.surf.num_threads = 0;  // threads must not change the result
  chain_opts.correspondence.match.num_threads = 0;
  VisualOdometry a(SyntheticOptions()), b(SyntheticOptions()), chain(chain_opts);
  for (std::size_t i = 0; i < truth.size(); ++i) {
    const cv::Mat frame = Render(*ground_, q0_, truth[i]);
    const FrameResult ra = a.Process(View(frame), i), rb = b.Process(View(frame), i);
    const FrameResult rc = chain.Process(View(frame), i);
    EXPECT_EQ(ra.n_surf, rb.n_surf);
    EXPECT_EQ(ra.n_inliers, rb.n_inliers);
    EXPECT_EQ(ra.position_m, rb.position_m) << "frame " << i;
    EXPECT_EQ(ra.curr_from_prev, rb.curr_from_prev);
    // At constant height over flat ground the two scale modes agree closely.
    EXPECT_LT((rc.position_m - truth[i].pos_m).norm(), 0.3) << "frame " << i;
  }
}

TEST_F(SyntheticFlight, StandardUnguidedAndHomographyAlsoTrack) {
  const std::vector<TruePose> truth = CurvedFlight(10);
  OdometryOptions standard = SyntheticOptions();
  standard.correspondence.method = CorrespondenceMethod::kStandard;
  standard.correspondence.guided_matching = false;
  OdometryOptions homography = SyntheticOptions();
  homography.correspondence.model = MotionModel::kHomography;
  OdometryOptions cell_only = SyntheticOptions();
  cell_only.correspondence.clustered.refine_final_radius_px = 0.f;  // no final pass
  cell_only.correspondence.clustered.refine_fallback = false;
  VisualOdometry a(standard), b(homography), clustered(SyntheticOptions()), cell(cell_only);
  for (std::size_t i = 0; i < truth.size(); ++i) {
    const cv::Mat frame = Render(*ground_, q0_, truth[i]);
    const FrameResult ra = a.Process(View(frame), i), rb = b.Process(View(frame), i);
    const FrameResult rc = clustered.Process(View(frame), i);
    const FrameResult rd = cell.Process(View(frame), i);
    EXPECT_LT((ra.position_m - truth[i].pos_m).norm(), 0.1) << "frame " << i;
    EXPECT_LT((rb.position_m - truth[i].pos_m).norm(), 0.1) << "frame " << i;
    EXPECT_LT((rc.position_m - truth[i].pos_m).norm(), 0.1) << "frame " << i;
    // Cell fits alone extrapolate worse (measured up to ~0.15 m here): still bounded.
    EXPECT_LT((rd.position_m - truth[i].pos_m).norm(), 1.0) << "frame " << i;
    if (i > 0) {
      EXPECT_EQ(ra.cluster, -1);
      EXPECT_FALSE(ra.guided);
      EXPECT_GE(rc.cluster, 0) << "clustered RANSAC succeeds in a cell on clean frames";
      EXPECT_FALSE(rc.fell_back);
      EXPECT_LT(rd.n_matched, ra.n_matched) << "a cell has fewer matches than the frame";
      EXPECT_GE(rc.n_inliers, rd.n_inliers) << "refinement on all points keeps more inliers";
    }
    if (i > 1) {
      EXPECT_TRUE(rc.guided);
    }
  }
}

// The refinement's options are defaults of OdometryOptions::correspondence, not overrides: a
// user-set refine_final_min_shift_px (a gate the spread fit passes on these exact-affine frames)
// or refine_final_max_points (a cap below the frame's point count) changes which matches the
// steps are fitted on, while the track stays on the truth.
TEST_F(SyntheticFlight, HonoursUserSetFinalPassOptions) {
  const std::vector<TruePose> truth = CurvedFlight(8);
  constexpr int kCap = 40;
  OdometryOptions gated = SyntheticOptions();
  gated.correspondence.clustered.refine_final_min_shift_px = 1000.f;
  OdometryOptions capped = SyntheticOptions();
  capped.correspondence.clustered.refine_final_max_points = kCap;
  VisualOdometry full(SyntheticOptions()), g(gated), c(capped);
  int gated_steps = 0, capped_steps = 0;
  for (std::size_t i = 0; i < truth.size(); ++i) {
    const cv::Mat frame = Render(*ground_, q0_, truth[i]);
    const FrameResult rf = full.Process(View(frame), i);
    const FrameResult rg = g.Process(View(frame), i);
    const FrameResult rc = c.Process(View(frame), i);
    EXPECT_LT((rg.position_m - truth[i].pos_m).norm(), 0.1) << "frame " << i;
    EXPECT_LT((rc.position_m - truth[i].pos_m).norm(), 0.1) << "frame " << i;
    if (i == 0 || rf.cluster < 0 || rg.cluster < 0 || rc.cluster < 0) continue;
    ASSERT_GT(rf.n_surf, 4 * kCap) << "frame " << i << ": the cap must bite";
    // The final pass on every point fits on (nearly) all of them; the gated run keeps the
    // spread fit (at most refine_max_points = 180 spread points and the cell's matches).
    EXPECT_LT(rg.n_matched, rf.n_matched) << "frame " << i;
    gated_steps += rg.n_matched < rf.n_matched;
    // The capped final pass matched at most kCap points; when its fit is not adopted the
    // spread fit stays, which is not the uncapped run's either.
    EXPECT_NE(rc.n_matched, rf.n_matched) << "frame " << i;
    capped_steps += rc.n_matched <= kCap;
  }
  EXPECT_GE(gated_steps, 5);
  EXPECT_GE(capped_steps, 1) << "the capped final pass's fit was never adopted";
}

TEST(VisualOdometry, ValidateNamesBothFieldsOfAnImpossibleRefinement) {
  OdometryOptions o;
  o.correspondence.clustered.refine_final_radius_px = 0.f;  // no final pass, fall-back refit on
  try {
    Validate(o);
    ADD_FAILURE() << "no throw for refine_fallback without a final-pass radius";
  } catch (const InvalidArgument& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("refine_fallback"), std::string::npos) << what;
    EXPECT_NE(what.find("refine_final_radius_px"), std::string::npos) << what;
  }
  o.correspondence.clustered.refine_fallback = false;
  EXPECT_NO_THROW(Validate(o));
  o.correspondence.clustered.refine_fallback = true;
  o.correspondence.clustered.refine = false;  // the paper's method: no refinement at all
  EXPECT_NO_THROW(Validate(o));
}

TEST(VisualOdometry, RejectsBadInputAndOptions) {
  OdometryOptions o = SyntheticOptions();
  o.correspondence.min_inliers = 2;  // below the affine minimal sample
  EXPECT_THROW(VisualOdometry{o}, InvalidArgument);
  o = SyntheticOptions();
  o.max_anisotropy = 0.5;
  EXPECT_THROW(VisualOdometry{o}, InvalidArgument);
  o = SyntheticOptions();
  o.max_scale_change = 1.5;
  EXPECT_THROW(Validate(o), InvalidArgument);
  o = SyntheticOptions();
  o.default_height_m = 0.0;
  VisualOdometry vo(o);
  cv::Mat frame(kH, kW, CV_8U, cv::Scalar(0));
  EXPECT_THROW(vo.Process(GrayImageView{}, 0.0), InvalidArgument);
  EXPECT_THROW(vo.Process(View(frame), 0.0), InputError);  // no height for a metric run
  VisualOdometry vo2(SyntheticOptions());
  vo2.Process(View(frame), 0.0);
  cv::Mat other(kH + 2, kW, CV_8U, cv::Scalar(0));
  EXPECT_THROW(vo2.Process(View(other), 1.0), InputError);
}

}  // namespace
}  // namespace aerovo::visual_odometry_test
