#include "aerovo/eval/feature_eval.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <tuple>

#include <opencv2/features2d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "aerovo/core/angles.h"
#include "aerovo/core/error.h"
#include "aerovo/core/testing.h"
#include "aerovo/eval/oxford_dataset.h"

namespace aerovo::feature_eval_test {
namespace {

// Area of the lens where two circles (radii r1, r2, centre distance d) overlap; the standard
// closed form (e.g. Weisstein, MathWorld "Circle-Circle Intersection").
double LensArea(double r1, double r2, double d) {
  if (d >= r1 + r2) return 0.0;
  if (d <= std::abs(r1 - r2)) return kPi * std::pow(std::min(r1, r2), 2);
  const double a1 = r1 * r1 * std::acos((d * d + r1 * r1 - r2 * r2) / (2 * d * r1));
  const double a2 = r2 * r2 * std::acos((d * d + r2 * r2 - r1 * r1) / (2 * d * r2));
  const double k = 0.5 * std::sqrt((-d + r1 + r2) * (d + r1 - r2) * (d - r1 + r2) * (d + r1 + r2));
  return a1 + a2 - k;
}

double CircleOverlapError(double r1, double r2, double d) {
  const double inter = LensArea(r1, r2, d);
  return 1.0 - inter / (kPi * r1 * r1 + kPi * r2 * r2 - inter);
}

// ---------------------------------------------------------------------------------------
// Overlap geometry against closed forms

TEST(FeatureEvalOverlap, CirclesMatchClosedForm) {
  struct Case {
    double r1, r2, d;
  };
  for (const Case c : {Case{10, 10, 5}, Case{10, 10, 0.5}, Case{10, 10, 19}, Case{10, 6, 8},
                       Case{30, 20, 25}, Case{5, 12, 9}}) {
    const EllipticRegion a = CircularRegion(3.0, -2.0, c.r1);
    const EllipticRegion b = CircularRegion(3.0 + c.d * 0.6, -2.0 + c.d * 0.8, c.r2);
    const double want = LensArea(c.r1, c.r2, c.d);
    EXPECT_NEAR(IntersectionArea(a, b), want, 1e-4 * kPi * c.r1 * c.r1)
        << c.r1 << " " << c.r2 << " " << c.d;
    EXPECT_NEAR(OverlapError(a, b), CircleOverlapError(c.r1, c.r2, c.d), 1e-4);
  }
  // Hand-computed: concentric radii 10 and 5 -> error 1 - 25/100; inner circle off-centre but
  // fully inside (6 + 3 < 10) -> 1 - 36/100; disjoint -> 1; identical -> 0.
  EXPECT_NEAR(OverlapError(CircularRegion(0, 0, 10), CircularRegion(0, 0, 5)), 0.75, 1e-4);
  EXPECT_NEAR(OverlapError(CircularRegion(0, 0, 10), CircularRegion(3, 0, 6)), 0.64, 1e-4);
  EXPECT_DOUBLE_EQ(OverlapError(CircularRegion(0, 0, 10), CircularRegion(25, 0, 10)), 1.0);
  EXPECT_NEAR(OverlapError(CircularRegion(7, 7, 4), CircularRegion(7, 7, 4)), 0.0, 1e-6);
}

TEST(FeatureEvalOverlap, TiltedEllipseSelfOverlapAndArea) {
  // Ellipse with semi-axes 12 and 4 rotated by 30 degrees.
  const double th = kPi / 6, s1 = 12, s2 = 4;
  const cv::Matx22d r(std::cos(th), -std::sin(th), std::sin(th), std::cos(th));
  const cv::Matx22d m = r * cv::Matx22d(1 / (s1 * s1), 0, 0, 1 / (s2 * s2)) * r.t();
  const EllipticRegion e{5, 5, m(0, 0), m(0, 1), m(1, 1)};
  EXPECT_NEAR(RegionArea(e), kPi * s1 * s2, 1e-9);
  EXPECT_NEAR(RegionRadius(e), std::sqrt(s1 * s2), 1e-9);
  EXPECT_NEAR(IntersectionArea(e, e), kPi * s1 * s2, 1e-4 * kPi * s1 * s2);
  // The same ellipse rotated by 90 degrees about the same centre: the intersection of two
  // perpendicular ellipses with equal axes; by symmetry it is invariant to the swap.
  const cv::Matx22d q(0, -1, 1, 0);
  const cv::Matx22d m2 = q * m * q.t();
  const EllipticRegion f{5, 5, m2(0, 0), m2(0, 1), m2(1, 1)};
  EXPECT_NEAR(IntersectionArea(e, f), IntersectionArea(f, e), 1e-6);
  // Perpendicular ellipses with semi-axes a > b: intersection = 4 a b atan(b / a).
  EXPECT_NEAR(IntersectionArea(e, f), 4 * s1 * s2 * std::atan(s2 / s1), 1e-3);
}

TEST(FeatureEvalOverlap, NormalisedOverlapIsScaleInvariantAndCutOff) {
  // Radius 5 and 10, same centre: normalising keeps the ratio -> 1 - 1/4.
  EXPECT_NEAR(NormalisedOverlapError(CircularRegion(50, 50, 5), CircularRegion(50, 50, 10)), 0.75,
              1e-4);
  // Equal radius 5, 2 px apart: regions become radius 30, the distance stays 2 px.
  EXPECT_NEAR(NormalisedOverlapError(CircularRegion(0, 0, 5), CircularRegion(2, 0, 5)),
              CircleOverlapError(30, 30, 2), 1e-4);
  // Radius 1, 4.5 px apart: beyond the 4 * radius cut-off although the normalised circles
  // (radius 30, 4.5 px apart) overlap a lot.
  EXPECT_DOUBLE_EQ(NormalisedOverlapError(CircularRegion(0, 0, 1), CircularRegion(4.5, 0, 1)), 1.0);
  EXPECT_NEAR(NormalisedOverlapError(CircularRegion(0, 0, 1), CircularRegion(3.5, 0, 1)),
              CircleOverlapError(30, 30, 3.5), 1e-4);
  EXPECT_THROW(CircularRegion(0, 0, 0), InvalidArgument);
  EXPECT_THROW(OverlapError(EllipticRegion{0, 0, 1, 2, 1}, CircularRegion(0, 0, 1)),
               InvalidArgument);
}

TEST(FeatureEvalOverlap, ProjectRegionUsesTheLocalAffinity) {
  const EllipticRegion c = CircularRegion(10, 20, 5);
  const EllipticRegion s = ProjectRegion(c, cv::Matx33d(2, 0, 3, 0, 1, -4, 0, 0, 1));
  EXPECT_NEAR(s.x, 23, 1e-12);
  EXPECT_NEAR(s.y, 16, 1e-12);
  EXPECT_NEAR(s.a, 1.0 / 100, 1e-12);  // semi-axis 10 along x
  EXPECT_NEAR(s.b, 0.0, 1e-12);
  EXPECT_NEAR(s.c, 1.0 / 25, 1e-12);  // 5 along y
  const double th = 0.7;
  const EllipticRegion r = ProjectRegion(
      c, cv::Matx33d(std::cos(th), -std::sin(th), 0, std::sin(th), std::cos(th), 0, 0, 0, 1));
  EXPECT_NEAR(r.a, 1.0 / 25, 1e-12);
  EXPECT_NEAR(r.b, 0.0, 1e-12);
  EXPECT_NEAR(r.c, 1.0 / 25, 1e-12);
  // A projective homography: the region's area scales with the Jacobian determinant there.
  const cv::Matx33d h(1.1, 0.05, 3, -0.02, 0.95, 1, 1e-4, 2e-4, 1);
  const EllipticRegion p = ProjectRegion(c, h);
  const double w = h(2, 0) * 10 + h(2, 1) * 20 + h(2, 2);
  EXPECT_NEAR(p.x, (h(0, 0) * 10 + h(0, 1) * 20 + h(0, 2)) / w, 1e-12);
  const double jdet = cv::determinant(h) / (w * w * w);
  EXPECT_NEAR(RegionArea(p), RegionArea(c) * jdet, 1e-9 * RegionArea(c));
}

// ---------------------------------------------------------------------------------------
// Scoring with hand-made keypoints

std::vector<cv::KeyPoint> Grid(int n, float size, cv::Point2f offset) {
  std::vector<cv::KeyPoint> kps;
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) {
      kps.emplace_back(cv::Point2f(60.f + 40.f * i, 60.f + 40.f * j) + offset, size);
    }
  }
  return kps;
}

TEST(FeatureEvalScore, IdentityAndTranslationGiveFullRepeatability) {
  const cv::Size size(500, 500);
  FeatureEvalOptions o;
  const auto kps = Grid(10, 20, {0, 0});
  PairScore s = ScoreImagePair(kps, {}, size, kps, {}, size, cv::Matx33d::eye(), o);
  EXPECT_EQ(s.n1, 100);
  EXPECT_EQ(s.n2, 100);
  EXPECT_EQ(s.correspondences, 100);
  EXPECT_DOUBLE_EQ(s.repeatability, 1.0);
  EXPECT_FALSE(s.has_matching_score);
  // Image 2 = image 1 shifted by (+30, -20): every point moves, all remain inside.
  const auto moved = Grid(10, 20, {30, -20});
  s = ScoreImagePair(kps, {}, size, moved, {}, size, cv::Matx33d(1, 0, 30, 0, 1, -20, 0, 0, 1), o);
  EXPECT_EQ(s.correspondences, 100);
  EXPECT_DOUBLE_EQ(s.repeatability, 1.0);
  // 3 px localisation error on radius-10 regions normalised to 30 px: error
  // CircleOverlapError(30, 30, 3) ~ 0.12 < 0.4, still correspondences.
  const auto off = Grid(10, 20, {3, 0});
  s = ScoreImagePair(kps, {}, size, off, {}, size, cv::Matx33d::eye(), o);
  EXPECT_EQ(s.correspondences, 100);
  // Scale 1.5 between regions: error 1 - 1/2.25 = 0.556 > 0.4, none.
  const auto big = Grid(10, 30, {0, 0});
  s = ScoreImagePair(kps, {}, size, big, {}, size, cv::Matx33d::eye(), o);
  EXPECT_EQ(s.correspondences, 0);
  EXPECT_DOUBLE_EQ(s.repeatability, 0.0);
}

TEST(FeatureEvalScore, CommonPartRules) {
  // A keypoint of image 1 at x = 450 maps to x = 550 in image 2 (translation +100), outside the
  // 500-wide image 2: the paper's rule drops it from n1, OpenCV's rule keeps it.
  const cv::Size size(500, 500);
  std::vector<cv::KeyPoint> k1 = {cv::KeyPoint(100, 100, 20), cv::KeyPoint(450, 200, 20),
                                  cv::KeyPoint(5, 300, 20)};  // last: region crosses x = 0
  std::vector<cv::KeyPoint> k2 = {cv::KeyPoint(200, 100, 20), cv::KeyPoint(60, 60, 20)};
  // k2[1] maps to (-40, 60) in image 1: outside image 1 under both rules.
  const cv::Matx33d h(1, 0, 100, 0, 1, 0, 0, 0, 1);
  FeatureEvalOptions o;
  PairScore s = ScoreImagePair(k1, {}, size, k2, {}, size, h, o);
  EXPECT_EQ(s.detected1, 3);
  EXPECT_EQ(s.n1, 1);
  EXPECT_EQ(s.n2, 1);
  EXPECT_EQ(s.correspondences, 1);
  o.common_part = CommonPart::kOpenCv;
  s = ScoreImagePair(k1, {}, size, k2, {}, size, h, o);
  EXPECT_EQ(s.n1, 2);
  EXPECT_EQ(s.n2, 1);
  EXPECT_DOUBLE_EQ(s.repeatability, 1.0);
}

TEST(FeatureEvalScore, MatchingScoreIsGreedyOneToOne) {
  const cv::Size size(400, 200);
  const std::vector<cv::KeyPoint> kps = {cv::KeyPoint(100, 100, 20), cv::KeyPoint(200, 100, 20),
                                         cv::KeyPoint(300, 100, 20)};
  // Region a's descriptor is also the nearest neighbour of b's (distance 0.45): plain nearest
  // neighbour would match b wrongly; one-to-one greedy takes (a, a') first, then b -> b'.
  cv::Mat d1 = (cv::Mat_<float>(3, 3) << 1, 0, 0, 0.9f, 0.43589f, 0, 0, 0, 1);
  cv::Mat d2 = (cv::Mat_<float>(3, 3) << 1, 0, 0, 0, 1, 0, 0, 0, 1);
  FeatureEvalOptions o;
  PairScore s = ScoreImagePair(kps, d1, size, kps, d2, size, cv::Matx33d::eye(), o);
  ASSERT_TRUE(s.has_matching_score);
  EXPECT_EQ(s.matches, 3);
  EXPECT_EQ(s.correct_matches, 3);
  EXPECT_DOUBLE_EQ(s.matching_score, 1.0);
  // Swap b' and c': descriptors now pair b with c' and c with b': 1 of 3 correct.
  cv::Mat d2s = (cv::Mat_<float>(3, 3) << 1, 0, 0, 0, 0, 1, 0, 1, 0);
  cv::Mat d1s = (cv::Mat_<float>(3, 3) << 1, 0, 0, 0, 1, 0, 0, 0, 1);
  s = ScoreImagePair(kps, d1s, size, kps, d2s, size, cv::Matx33d::eye(), o);
  EXPECT_EQ(s.correct_matches, 1);
  EXPECT_NEAR(s.matching_score, 1.0 / 3, 1e-12);
  // Binary descriptors (Hamming) work the same way.
  cv::Mat b1 = (cv::Mat_<uchar>(3, 1) << 0x0F, 0xF0, 0xFF);
  cv::Mat b2 = (cv::Mat_<uchar>(3, 1) << 0x0F, 0xF0, 0xFF);
  s = ScoreImagePair(kps, b1, size, kps, b2, size, cv::Matx33d::eye(), o);
  EXPECT_EQ(s.correct_matches, 3);
  EXPECT_THROW(ScoreImagePair(kps, d1, size, kps, b2, size, cv::Matx33d::eye(), o),
               InvalidArgument);
  EXPECT_THROW(
      ScoreImagePair({cv::KeyPoint(1, 1, 0)}, {}, size, kps, {}, size, cv::Matx33d::eye(), o),
      InvalidArgument);
}

TEST(FeatureEvalScore, GreedyMatchesEqualBruteForceReference) {
  // Low-dimensional random descriptors: many rows share nearest neighbours, so rows exhaust
  // their cached candidates and are searched again. The result must equal the textbook greedy
  // assignment over the full sorted distance list.
  std::mt19937 rng(7);
  std::normal_distribution<float> g(0.f, 1.f);
  cv::Mat d1(90, 3, CV_32F), d2(70, 3, CV_32F);
  for (int i = 0; i < d1.rows; ++i)
    for (int k = 0; k < 3; ++k) d1.at<float>(i, k) = g(rng);
  for (int i = 0; i < d2.rows; ++i)
    for (int k = 0; k < 3; ++k) d2.at<float>(i, k) = 0.3f * g(rng) + 2.f;  // a cluster apart
  std::vector<std::tuple<double, int, int>> all;
  for (int i = 0; i < d1.rows; ++i)
    for (int j = 0; j < d2.rows; ++j) all.emplace_back(cv::norm(d1.row(i), d2.row(j)), i, j);
  std::sort(all.begin(), all.end());
  std::vector<std::pair<int, int>> want;
  std::vector<char> u1(d1.rows, 0), u2(d2.rows, 0);
  for (const auto& [d, i, j] : all) {
    if (u1[i] || u2[j]) continue;
    u1[i] = u2[j] = 1;
    want.emplace_back(i, j);
  }
  EXPECT_EQ(GreedyDescriptorMatches(d1, d2), want);
}

TEST(FeatureEvalOptionsTest, ValidateAndParse) {
  FeatureEvalOptions o;
  EXPECT_NO_THROW(Validate(o));
  auto bad = o;
  bad.targets = {1};
  EXPECT_THROW(Validate(bad), InvalidArgument);
  bad = o;
  bad.max_overlap_error = 1.0;
  EXPECT_THROW(Validate(bad), InvalidArgument);
  bad = o;
  bad.detectors = {FeatureDetectorKind::kOrb, FeatureDetectorKind::kOrb};
  EXPECT_THROW(Validate(bad), InvalidArgument);
  EXPECT_EQ(
      ParseFeatureDetectorList("SIFT,orb"),
      (std::vector<FeatureDetectorKind>{FeatureDetectorKind::kSift, FeatureDetectorKind::kOrb}));
  EXPECT_THROW(ParseFeatureDetectorList("sift,,orb"), InvalidArgument);
  EXPECT_THROW(ParseFeatureDetectorList("brisk"), InvalidArgument);
}

// ---------------------------------------------------------------------------------------
// Real detectors on synthetic images with a known homography

// Smooth random texture with blobs at several scales (deterministic).
cv::Mat Texture(int w, int h, unsigned seed) {
  cv::Mat acc(h, w, CV_32F, cv::Scalar(0));
  cv::RNG rng(seed);
  for (int sigma : {2, 4, 8, 16}) {
    cv::Mat noise(h, w, CV_32F);
    rng.fill(noise, cv::RNG::NORMAL, 0.0, 1.0);
    cv::GaussianBlur(noise, noise, cv::Size(), sigma);
    cv::normalize(noise, noise, 0, 1, cv::NORM_MINMAX);
    acc += noise;
  }
  cv::Mat out;
  cv::normalize(acc, acc, 0, 255, cv::NORM_MINMAX);
  acc.convertTo(out, CV_8U);
  return out;
}

TEST(FeatureEvalDetectors, IdenticalTranslatedAndWarpedImages) {
  const cv::Mat big = Texture(720, 560, 11);
  const cv::Rect roi1(40, 40, 640, 480);
  const cv::Mat img1 = big(roi1).clone();
  // Pure translation by (-16, -24) px (a multiple of 8 so that image pyramids sample alike).
  const cv::Mat img_t = big(roi1 + cv::Point(16, 24)).clone();
  const cv::Matx33d h_t(1, 0, -16, 0, 1, -24, 0, 0, 1);
  // Rotation by 20 degrees and scale 1.2 about the centre.
  cv::Matx23d a = cv::getRotationMatrix2D(cv::Point2f(320, 240), 20, 1.2);
  const cv::Matx33d h_w(a(0, 0), a(0, 1), a(0, 2), a(1, 0), a(1, 1), a(1, 2), 0, 0, 1);
  cv::Mat img_w;
  cv::warpPerspective(img1, img_w, h_w, img1.size(), cv::INTER_LINEAR, cv::BORDER_REFLECT);

  FeatureEvalOptions o;
  for (auto kind : {FeatureDetectorKind::kSift, FeatureDetectorKind::kSurf}) {
    SCOPED_TRACE(ToString(kind));
    const DetectedFeatures f1 = DetectFeatures(kind, img1, o);
    ASSERT_GT(f1.keypoints.size(), 100u);
    PairScore s = ScoreImagePair(f1.keypoints, f1.descriptors, img1.size(), f1.keypoints,
                                 f1.descriptors, img1.size(), cv::Matx33d::eye(), o);
    EXPECT_DOUBLE_EQ(s.repeatability, 1.0);
    EXPECT_GT(s.matching_score, 0.97);  // duplicate positions (SIFT orientations) may swap
    const DetectedFeatures ft = DetectFeatures(kind, img_t, o);
    s = ScoreImagePair(f1.keypoints, f1.descriptors, img1.size(), ft.keypoints, ft.descriptors,
                       img_t.size(), h_t, o);
    EXPECT_GT(s.repeatability, 0.95);
    EXPECT_GT(s.matching_score, 0.9);
    const DetectedFeatures fw = DetectFeatures(kind, img_w, o);
    s = ScoreImagePair(f1.keypoints, f1.descriptors, img1.size(), fw.keypoints, fw.descriptors,
                       img_w.size(), h_w, o);
    EXPECT_GT(s.repeatability, 0.5);
    EXPECT_GT(s.matching_score, 0.3);
    EXPECT_LE(s.matching_score, s.repeatability);
  }
}

TEST(FeatureEvalDetectors, AgreesWithOpenCvEvaluateFeatureDetector) {
  // OpenCV's own implementation of the protocol (grid-sampled overlap) on the warped pair:
  // with the OpenCV common-part rule our correspondence counts must agree within 2 %.
  const cv::Mat img1 = Texture(640, 480, 3);
  const cv::Matx33d h(0.9, 0.15, 10, -0.12, 1.05, 20, 2e-5, -1e-5, 1);
  cv::Mat img2;
  cv::warpPerspective(img1, img2, h, img1.size(), cv::INTER_LINEAR, cv::BORDER_REFLECT);
  FeatureEvalOptions o;
  o.common_part = CommonPart::kOpenCv;
  o.matching_score = false;
  for (auto kind : {FeatureDetectorKind::kSift, FeatureDetectorKind::kSurf}) {
    SCOPED_TRACE(ToString(kind));
    DetectedFeatures f1 = DetectFeatures(kind, img1, o);
    DetectedFeatures f2 = DetectFeatures(kind, img2, o);
    const PairScore s =
        ScoreImagePair(f1.keypoints, {}, img1.size(), f2.keypoints, {}, img2.size(), h, o);
    float cv_rep = -1.f;
    int cv_corr = -1;
    cv::evaluateFeatureDetector(img1, img2, cv::Mat(h), &f1.keypoints, &f2.keypoints, cv_rep,
                                cv_corr, cv::Ptr<cv::FeatureDetector>());
    ASSERT_GT(cv_corr, 50);
    EXPECT_NEAR(s.correspondences, cv_corr, 0.02 * cv_corr + 2);
    EXPECT_NEAR(s.repeatability, cv_rep, 0.02);
  }
}

// ---------------------------------------------------------------------------------------
// Oxford data: aerovo SURF must not regress below the floors recorded in BENCHMARKS.md
// ("## Feature evaluation (Oxford)"): each floor is 0.02 below the first measured value.

struct Floor {
  const char* sequence;
  double repeatability_1to2;
};

TEST(FeatureEvalOxford, SurfRepeatabilityFloors) {
  AEROVO_REQUIRE_SHARED(graf, "data/oxford/graf/img1.png");
  const Floor floors[] = {
      {"graf", 0.647}, {"boat", 0.690}, {"bikes", 0.866}, {"leuven", 0.809}, {"wall", 0.769}};
  FeatureEvalOptions o;
  o.detectors = {FeatureDetectorKind::kSurf};
  o.matching_score = false;
  for (const Floor& f : floors) {
    SCOPED_TRACE(f.sequence);
    const OxfordSequence seq =
        LoadOxfordSequence(aerovo::testing::SharedDir() / "data/oxford" / f.sequence, {2});
    const FeatureEvalSequence r =
        EvaluateFeatureSequence(seq.name, seq.images, seq.targets, seq.h_from_img1, o);
    const PairScore& s = r.pairs.at(0).scores.at(0);
    std::printf("%s 1->2: surf n1 %d n2 %d corr %d rep %.4f\n", f.sequence, s.n1, s.n2,
                s.correspondences, s.repeatability);
    EXPECT_GE(s.repeatability, f.repeatability_1to2);
  }
}

}  // namespace
}  // namespace aerovo::feature_eval_test
