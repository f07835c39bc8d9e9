#include "aerovo/eval/feature_eval.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <queue>
#include <sstream>
#include <tuple>

#include <opencv2/features2d.hpp>

#include "aerovo/core/angles.h"
#include "aerovo/core/error.h"
#include "aerovo/core/parallel.h"
#include "aerovo/core/timer.h"

namespace aerovo {

namespace {

double Det(const EllipticRegion& r) { return r.a * r.c - r.b * r.b; }

void CheckRegion(const EllipticRegion& r, const char* what) {
  if (!(r.a > 0.0) || !(r.c > 0.0) || !(Det(r) > 0.0) || !std::isfinite(r.x) ||
      !std::isfinite(r.y)) {
    throw InvalidArgument(std::string(what) + ": not a valid ellipse (need a > 0, c > 0, " +
                          "a*c - b^2 > 0, finite centre)");
  }
}

// The chord of a centred ellipse on the vertical line at abscissa x: the ellipse equation
// solved for y. Returns false when the line misses the ellipse.
inline bool Chord(const EllipticRegion& r, double det, double x, double* lo, double* hi) {
  const double s2 = r.c - det * x * x;
  if (s2 <= 0.0) return false;
  const double s = std::sqrt(s2);
  *lo = (-r.b * x - s) / r.c;
  *hi = (-r.b * x + s) / r.c;
  return true;
}

// Number of quadrature nodes for the intersection integral. With the sine substitution
// below the integrand has no square-root end singularities, only kinks where the bounding
// arc switches ellipse, so the midpoint rule converges fast: 200 nodes give a relative area
// error below 1e-4 on the cases in the tests.
constexpr int kQuadratureNodes = 200;

bool InsideImage(const EllipticRegion& r, cv::Size size) {
  // Strict inequalities, as OpenCV's filterEllipticKeyPointsByImageSize.
  const cv::Point2d h = RegionHalfExtent(r);
  return r.x - h.x > 0.0 && r.x + h.x < size.width && r.y - h.y > 0.0 && r.y + h.y < size.height;
}

struct Candidate {
  double error;
  int i;
  int j;
  bool operator<(const Candidate& o) const {
    return std::tie(error, i, j) < std::tie(o.error, o.i, o.j);
  }
};

cv::Mat GatherRows(const cv::Mat& src, const std::vector<int>& rows) {
  cv::Mat dst(static_cast<int>(rows.size()), src.cols, src.type());
  for (std::size_t k = 0; k < rows.size(); ++k)
    src.row(rows[k]).copyTo(dst.row(static_cast<int>(k)));
  return dst;
}

}  // namespace

// Greedy one-to-one assignment by increasing descriptor distance (repeatability.m's rule),
// computed lazily: each row keeps its K nearest columns; a row whose candidates are all taken
// is searched again among the free columns only. Exact: a row's heap entry never
// under-estimates its best free distance, so pairs leave the heap in global distance order.
std::vector<std::pair<int, int>> GreedyDescriptorMatches(const cv::Mat& d1, const cv::Mat& d2) {
  std::vector<std::pair<int, int>> out;
  if (d1.rows == 0 || d2.rows == 0) return out;
  if (d1.type() != d2.type() || d1.cols != d2.cols || (d1.type() != CV_32F && d1.type() != CV_8U)) {
    throw InvalidArgument(
        "GreedyDescriptorMatches: descriptors must both be CV_32F or both CV_8U, same width");
  }
  const int norm = d1.type() == CV_8U ? cv::NORM_HAMMING : cv::NORM_L2;
  cv::BFMatcher matcher(norm, false);
  const int k = std::min(8, d2.rows);
  std::vector<std::vector<cv::DMatch>> knn;
  matcher.knnMatch(d1, d2, knn, k);
  std::vector<std::size_t> next(knn.size(), 0);
  std::vector<char> used2(d2.rows, 0);
  using Entry = std::tuple<float, int, int>;  // distance, row, column
  std::priority_queue<Entry, std::vector<Entry>, std::greater<Entry>> heap;
  for (int i = 0; i < d1.rows; ++i) {
    if (!knn[i].empty()) heap.emplace(knn[i][0].distance, i, knn[i][0].trainIdx);
  }
  cv::Mat mask(1, d2.rows, CV_8U);
  int free2 = d2.rows;
  while (!heap.empty() && free2 > 0) {
    const auto [dist, i, j] = heap.top();
    heap.pop();
    if (!used2[j]) {
      used2[j] = 1;
      --free2;
      out.emplace_back(i, j);
      continue;
    }
    auto& list = knn[i];
    std::size_t& n = next[i];
    while (n < list.size() && used2[list[n].trainIdx]) ++n;
    if (n == list.size()) {
      for (int c = 0; c < d2.rows; ++c) mask.at<uchar>(0, c) = used2[c] ? 0 : 255;
      std::vector<std::vector<cv::DMatch>> again;
      matcher.knnMatch(d1.row(i), d2, again, std::min(k, free2), mask);
      list = again.empty() ? std::vector<cv::DMatch>{} : again[0];
      for (auto& m : list) m.queryIdx = i;
      n = 0;
      if (list.empty()) continue;
    }
    heap.emplace(list[n].distance, i, list[n].trainIdx);
  }
  return out;
}

// ------------------------------------------------------------------------------------------
// Region geometry

EllipticRegion CircularRegion(double x, double y, double radius_px) {
  if (!(radius_px > 0.0) || !std::isfinite(radius_px)) {
    throw InvalidArgument("CircularRegion: radius must be > 0 px, got " +
                          std::to_string(radius_px));
  }
  const double f = 1.0 / (radius_px * radius_px);
  return EllipticRegion{x, y, f, 0.0, f};
}

double RegionArea(const EllipticRegion& r) { return kPi / std::sqrt(Det(r)); }

double RegionRadius(const EllipticRegion& r) { return std::pow(Det(r), -0.25); }

cv::Point2d RegionHalfExtent(const EllipticRegion& r) {
  const double det = Det(r);
  return {std::sqrt(r.c / det), std::sqrt(r.a / det)};
}

EllipticRegion ProjectRegion(const EllipticRegion& r, const cv::Matx33d& h) {
  const double p1 = h(0, 0) * r.x + h(0, 1) * r.y + h(0, 2);
  const double p2 = h(1, 0) * r.x + h(1, 1) * r.y + h(1, 2);
  const double p3 = h(2, 0) * r.x + h(2, 1) * r.y + h(2, 2);
  if (p3 == 0.0 || !std::isfinite(p3)) {
    throw InvalidArgument("ProjectRegion: the homography maps the centre to infinity");
  }
  // Jacobian of (p1/p3, p2/p3) at the centre.
  cv::Matx22d j(h(0, 0) / p3 - p1 * h(2, 0) / (p3 * p3), h(0, 1) / p3 - p1 * h(2, 1) / (p3 * p3),
                h(1, 0) / p3 - p2 * h(2, 0) / (p3 * p3), h(1, 1) / p3 - p2 * h(2, 1) / (p3 * p3));
  const double jdet = j(0, 0) * j(1, 1) - j(0, 1) * j(1, 0);
  if (jdet == 0.0) throw InvalidArgument("ProjectRegion: singular homography at the centre");
  const cv::Matx22d jinv(j(1, 1) / jdet, -j(0, 1) / jdet, -j(1, 0) / jdet, j(0, 0) / jdet);
  const cv::Matx22d m(r.a, r.b, r.b, r.c);
  const cv::Matx22d mp = jinv.t() * m * jinv;
  return EllipticRegion{p1 / p3, p2 / p3, mp(0, 0), 0.5 * (mp(0, 1) + mp(1, 0)), mp(1, 1)};
}

double IntersectionArea(const EllipticRegion& r1, const EllipticRegion& r2) {
  CheckRegion(r1, "IntersectionArea: region 1");
  CheckRegion(r2, "IntersectionArea: region 2");
  const double det1 = Det(r1), det2 = Det(r2);
  const double w1 = std::sqrt(r1.c / det1), w2 = std::sqrt(r2.c / det2);
  const double dx = r2.x - r1.x, dy = r2.y - r1.y;  // r2's centre in r1-centred coordinates
  const double lo = std::max(-w1, dx - w2), hi = std::min(w1, dx + w2);
  if (lo >= hi) return 0.0;
  // x = m + h sin(t), t in (-pi/2, pi/2): dx = h cos(t) dt removes the sqrt behaviour of the
  // chord length at both ends (each end is an ellipse's extreme point).
  const double m = 0.5 * (lo + hi), h = 0.5 * (hi - lo);
  const double dt = kPi / kQuadratureNodes;
  double sum = 0.0;
  for (int k = 0; k < kQuadratureNodes; ++k) {
    const double t = -0.5 * kPi + (k + 0.5) * dt;
    const double x = m + h * std::sin(t);
    double lo1, hi1, lo2, hi2;
    if (!Chord(r1, det1, x, &lo1, &hi1) || !Chord(r2, det2, x - dx, &lo2, &hi2)) continue;
    const double len = std::min(hi1, hi2 + dy) - std::max(lo1, lo2 + dy);
    if (len > 0.0) sum += len * std::cos(t);
  }
  return sum * h * dt;
}

double OverlapError(const EllipticRegion& r1, const EllipticRegion& r2) {
  const double inter = IntersectionArea(r1, r2);
  const double uni = RegionArea(r1) + RegionArea(r2) - inter;
  return 1.0 - inter / uni;
}

double NormalisedOverlapError(const EllipticRegion& r1, const EllipticRegion& r2_in_1,
                              double normalised_radius_px) {
  CheckRegion(r1, "NormalisedOverlapError: region 1");
  CheckRegion(r2_in_1, "NormalisedOverlapError: region 2");
  if (!(normalised_radius_px > 0.0)) {
    throw InvalidArgument("NormalisedOverlapError: normalised_radius_px must be > 0");
  }
  const double radius1 = RegionRadius(r1);
  const double ddx = r2_in_1.x - r1.x, ddy = r2_in_1.y - r1.y;
  if (ddx * ddx + ddy * ddy >= 16.0 * radius1 * radius1) return 1.0;
  const double k = normalised_radius_px / radius1;
  const double s = 1.0 / (k * k);
  const EllipticRegion n1{r1.x, r1.y, r1.a * s, r1.b * s, r1.c * s};
  const EllipticRegion n2{r2_in_1.x, r2_in_1.y, r2_in_1.a * s, r2_in_1.b * s, r2_in_1.c * s};
  return OverlapError(n1, n2);
}

// ------------------------------------------------------------------------------------------
// Options

const char* ToString(FeatureDetectorKind kind) {
  switch (kind) {
    case FeatureDetectorKind::kSurf:
      return "surf";
    case FeatureDetectorKind::kSift:
      return "sift";
    case FeatureDetectorKind::kOrb:
      return "orb";
    case FeatureDetectorKind::kAkaze:
      return "akaze";
  }
  return "?";
}

FeatureDetectorKind ParseFeatureDetectorKind(std::string_view name) {
  std::string lower(name);
  for (char& ch : lower) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
  for (auto kind : {FeatureDetectorKind::kSurf, FeatureDetectorKind::kSift,
                    FeatureDetectorKind::kOrb, FeatureDetectorKind::kAkaze}) {
    if (lower == ToString(kind)) return kind;
  }
  throw InvalidArgument("unknown detector '" + std::string(name) +
                        "' (valid: surf, sift, orb, akaze)");
}

std::vector<FeatureDetectorKind> ParseFeatureDetectorList(std::string_view list) {
  std::vector<FeatureDetectorKind> out;
  std::size_t start = 0;
  while (true) {
    const std::size_t comma = list.find(',', start);
    const std::string_view item = list.substr(
        start, comma == std::string_view::npos ? std::string_view::npos : comma - start);
    if (item.empty()) {
      throw InvalidArgument("detector list '" + std::string(list) + "' has an empty item");
    }
    const FeatureDetectorKind kind = ParseFeatureDetectorKind(item);
    if (std::find(out.begin(), out.end(), kind) != out.end()) {
      throw InvalidArgument("detector '" + std::string(item) + "' listed twice");
    }
    out.push_back(kind);
    if (comma == std::string_view::npos) break;
    start = comma + 1;
  }
  return out;
}

void Validate(const FeatureEvalOptions& o) {
  if (o.sequences.empty()) throw InvalidArgument("FeatureEvalOptions.sequences is empty");
  if (o.targets.empty()) throw InvalidArgument("FeatureEvalOptions.targets is empty");
  for (std::size_t k = 0; k < o.targets.size(); ++k) {
    if (o.targets[k] < 2 || o.targets[k] > 6) {
      throw InvalidArgument("FeatureEvalOptions.targets: " + std::to_string(o.targets[k]) +
                            " is outside 2..6");
    }
    if (std::count(o.targets.begin(), o.targets.end(), o.targets[k]) > 1) {
      throw InvalidArgument("FeatureEvalOptions.targets: " + std::to_string(o.targets[k]) +
                            " listed twice");
    }
  }
  if (o.detectors.empty()) throw InvalidArgument("FeatureEvalOptions.detectors is empty");
  for (auto d : o.detectors) {
    if (std::count(o.detectors.begin(), o.detectors.end(), d) > 1) {
      throw InvalidArgument(std::string("FeatureEvalOptions.detectors: ") + ToString(d) +
                            " listed twice");
    }
  }
  if (std::find(o.detectors.begin(), o.detectors.end(), FeatureDetectorKind::kSurf) !=
      o.detectors.end()) {
    Validate(o.surf);
  }
  if (o.orb_max_features <= 0) {
    throw InvalidArgument("FeatureEvalOptions.orb_max_features must be > 0");
  }
  if (!(o.max_overlap_error > 0.0 && o.max_overlap_error < 1.0)) {
    throw InvalidArgument("FeatureEvalOptions.max_overlap_error must be in (0, 1)");
  }
  if (!(o.normalised_radius_px > 0.0) || !std::isfinite(o.normalised_radius_px)) {
    throw InvalidArgument("FeatureEvalOptions.normalised_radius_px must be > 0");
  }
}

// ------------------------------------------------------------------------------------------
// One pair

PairScore ScoreImagePair(const std::vector<cv::KeyPoint>& keypoints1, const cv::Mat& descriptors1,
                         cv::Size size1, const std::vector<cv::KeyPoint>& keypoints2,
                         const cv::Mat& descriptors2, cv::Size size2,
                         const cv::Matx33d& img2_from_img1, const FeatureEvalOptions& options) {
  if (size1.width <= 0 || size1.height <= 0 || size2.width <= 0 || size2.height <= 0) {
    throw InvalidArgument("ScoreImagePair: empty image size");
  }
  if (!(options.max_overlap_error > 0.0 && options.max_overlap_error < 1.0) ||
      !(options.normalised_radius_px > 0.0)) {
    throw InvalidArgument("ScoreImagePair: invalid overlap options (see Validate)");
  }
  if (std::abs(cv::determinant(img2_from_img1)) < 1e-15) {
    throw InvalidArgument("ScoreImagePair: img2_from_img1 is singular");
  }
  const cv::Matx33d img1_from_img2 = img2_from_img1.inv();

  auto to_regions = [](const std::vector<cv::KeyPoint>& kps, const char* which) {
    std::vector<EllipticRegion> regions;
    regions.reserve(kps.size());
    for (std::size_t i = 0; i < kps.size(); ++i) {
      const cv::KeyPoint& kp = kps[i];
      if (!(kp.size > 0.f) || !std::isfinite(kp.size) || !std::isfinite(kp.pt.x) ||
          !std::isfinite(kp.pt.y)) {
        throw InvalidArgument(std::string("ScoreImagePair: keypoint ") + std::to_string(i) +
                              " of image " + which + " has size " + std::to_string(kp.size) +
                              " (must be > 0) or a non-finite position");
      }
      regions.push_back(CircularRegion(kp.pt.x, kp.pt.y, 0.5 * kp.size));
    }
    return regions;
  };
  const std::vector<EllipticRegion> r1 = to_regions(keypoints1, "1");
  const std::vector<EllipticRegion> r2 = to_regions(keypoints2, "2");

  PairScore score;
  score.detected1 = static_cast<int>(r1.size());
  score.detected2 = static_cast<int>(r2.size());

  // Common part. r2t = image-2 regions in image 1, where overlaps are measured.
  std::vector<int> keep1, keep2;
  std::vector<EllipticRegion> r2t;
  for (std::size_t i = 0; i < r1.size(); ++i) {
    bool keep = InsideImage(r1[i], size1);
    if (keep && options.common_part == CommonPart::kBothImages) {
      keep = InsideImage(ProjectRegion(r1[i], img2_from_img1), size2);
    }
    if (keep) keep1.push_back(static_cast<int>(i));
  }
  for (std::size_t j = 0; j < r2.size(); ++j) {
    const EllipticRegion t = ProjectRegion(r2[j], img1_from_img2);
    bool keep = InsideImage(t, size1);
    if (keep && options.common_part == CommonPart::kBothImages) {
      keep = InsideImage(r2[j], size2);
    }
    if (keep) {
      keep2.push_back(static_cast<int>(j));
      r2t.push_back(t);
    }
  }
  score.n1 = static_cast<int>(keep1.size());
  score.n2 = static_cast<int>(keep2.size());
  const int min_n = std::min(score.n1, score.n2);

  // Correspondences: all pairs under the overlap threshold, then one-to-one by increasing
  // error (OpenCV sorts by decreasing overlap; same order).
  const double max_err = options.max_overlap_error;
  const double min_area_ratio = 1.0 - max_err;  // overlap <= smaller area / larger area
  std::vector<double> area2(r2t.size());
  for (std::size_t j = 0; j < r2t.size(); ++j) area2[j] = RegionArea(r2t[j]);
  std::vector<Candidate> candidates;
  // Per-worker lists, joined in worker order; the sort below makes the order of the result
  // independent of the schedule (Candidate's order is total).
  const int threads = ResolveThreadCount(0);
  std::vector<std::vector<Candidate>> local(threads);
  ParallelFor(threads, score.n1, 16, [&](long a_begin, long a_end, int worker) {
    for (int a = static_cast<int>(a_begin); a < a_end; ++a) {
      const EllipticRegion& p = r1[keep1[a]];
      const double radius = RegionRadius(p);
      const double max_d2 = 16.0 * radius * radius;
      const double area1 = RegionArea(p);
      for (int b = 0; b < score.n2; ++b) {
        const double dx = r2t[b].x - p.x, dy = r2t[b].y - p.y;
        if (dx * dx + dy * dy >= max_d2) continue;
        // Areas scale alike under the normalisation, so the ratio bound holds unscaled.
        if (std::min(area1, area2[b]) < min_area_ratio * std::max(area1, area2[b])) continue;
        const double err = NormalisedOverlapError(p, r2t[b], options.normalised_radius_px);
        if (err <= max_err) local[worker].push_back({err, a, b});
      }
    }
  });
  for (const std::vector<Candidate>& l : local)
    candidates.insert(candidates.end(), l.begin(), l.end());
  std::sort(candidates.begin(), candidates.end());
  {
    std::vector<char> used1(score.n1, 0), used2(score.n2, 0);
    for (const Candidate& c : candidates) {
      if (used1[c.i] || used2[c.j]) continue;
      used1[c.i] = used2[c.j] = 1;
      ++score.correspondences;
    }
  }
  score.repeatability = min_n > 0 ? static_cast<double>(score.correspondences) / min_n : 0.0;

  // Matching score.
  const bool have_desc = !descriptors1.empty() && !descriptors2.empty();
  if (options.matching_score && have_desc) {
    if (descriptors1.rows != score.detected1 || descriptors2.rows != score.detected2) {
      throw InvalidArgument(
          "ScoreImagePair: descriptor rows (" + std::to_string(descriptors1.rows) + ", " +
          std::to_string(descriptors2.rows) + ") differ from keypoint counts (" +
          std::to_string(score.detected1) + ", " + std::to_string(score.detected2) + ")");
    }
    if (descriptors1.type() != descriptors2.type() || descriptors1.cols != descriptors2.cols ||
        (descriptors1.type() != CV_32F && descriptors1.type() != CV_8U)) {
      throw InvalidArgument(
          "ScoreImagePair: descriptors must both be CV_32F or both CV_8U, same width");
    }
    const std::vector<std::pair<int, int>> matches =
        GreedyDescriptorMatches(GatherRows(descriptors1, keep1), GatherRows(descriptors2, keep2));
    score.has_matching_score = true;
    score.matches = static_cast<int>(matches.size());
    for (const auto& [a, b] : matches) {
      const double err = NormalisedOverlapError(r1[keep1[a]], r2t[b], options.normalised_radius_px);
      if (err <= max_err) ++score.correct_matches;
    }
    score.matching_score = min_n > 0 ? static_cast<double>(score.correct_matches) / min_n : 0.0;
  }
  return score;
}

// ------------------------------------------------------------------------------------------
// Detectors

cv::KeyPoint ToCvKeyPoint(const Keypoint& kp) {
  return cv::KeyPoint(kp.x, kp.y, OpenCvKeypointSize(kp),
                      static_cast<float>(kp.orientation * 180.0 / kPi), kp.response, kp.octave,
                      kp.laplacian);
}

DetectedFeatures DetectFeatures(FeatureDetectorKind kind, const cv::Mat& gray,
                                const FeatureEvalOptions& options) {
  if (gray.empty() || gray.type() != CV_8UC1) {
    throw InvalidArgument("DetectFeatures: need a non-empty CV_8UC1 image");
  }
  DetectedFeatures out;
  Stopwatch watch;
  switch (kind) {
    case FeatureDetectorKind::kSurf: {
      Surf surf(options.surf);
      const GrayImageView view{gray.data, gray.cols, gray.rows,
                               static_cast<std::ptrdiff_t>(gray.step)};
      SurfResult r = surf.DetectAndDescribe(view);
      const FeatureSet& f = r.features;
      out.keypoints.reserve(f.size());
      for (const Keypoint& kp : f.keypoints) out.keypoints.push_back(ToCvKeyPoint(kp));
      out.descriptors.create(static_cast<int>(f.size()), f.descriptor_size, CV_32F);
      for (std::size_t i = 0; i < f.size(); ++i) {
        std::copy(f.descriptor(i), f.descriptor(i) + f.descriptor_size,
                  out.descriptors.ptr<float>(static_cast<int>(i)));
      }
      break;
    }
    case FeatureDetectorKind::kSift:
      cv::SIFT::create()->detectAndCompute(gray, cv::noArray(), out.keypoints, out.descriptors);
      break;
    case FeatureDetectorKind::kOrb:
      cv::ORB::create(options.orb_max_features)
          ->detectAndCompute(gray, cv::noArray(), out.keypoints, out.descriptors);
      break;
    case FeatureDetectorKind::kAkaze:
      cv::AKAZE::create()->detectAndCompute(gray, cv::noArray(), out.keypoints, out.descriptors);
      break;
  }
  out.ms = watch.elapsed_ms();
  return out;
}

FeatureEvalSequence EvaluateFeatureSequence(const std::string& name,
                                            const std::vector<cv::Mat>& images,
                                            const std::vector<int>& targets,
                                            const std::vector<cv::Matx33d>& h_from_img1,
                                            const FeatureEvalOptions& options) {
  Validate(options);
  if (images.size() != targets.size() + 1 || h_from_img1.size() != targets.size()) {
    throw InvalidArgument("EvaluateFeatureSequence(" + name + "): need img1 plus one image and " +
                          "one homography per target (" + std::to_string(targets.size()) +
                          " targets, " + std::to_string(images.size()) + " images, " +
                          std::to_string(h_from_img1.size()) + " homographies)");
  }
  FeatureEvalSequence seq;
  seq.name = name;
  seq.pairs.resize(targets.size());
  for (std::size_t p = 0; p < targets.size(); ++p) {
    seq.pairs[p].target = targets[p];
    seq.pairs[p].scores.resize(options.detectors.size());
  }
  for (std::size_t d = 0; d < options.detectors.size(); ++d) {
    const DetectedFeatures f1 = DetectFeatures(options.detectors[d], images[0], options);
    for (std::size_t p = 0; p < targets.size(); ++p) {
      const DetectedFeatures f2 = DetectFeatures(options.detectors[d], images[p + 1], options);
      PairScore s = ScoreImagePair(f1.keypoints, f1.descriptors, images[0].size(), f2.keypoints,
                                   f2.descriptors, images[p + 1].size(), h_from_img1[p], options);
      s.ms1 = f1.ms;
      s.ms2 = f2.ms;
      seq.pairs[p].scores[d] = s;
    }
  }
  return seq;
}

// ------------------------------------------------------------------------------------------
// Table

std::string FormatFeatureEvalTable(const std::vector<FeatureEvalSequence>& sequences,
                                   const std::vector<FeatureDetectorKind>& detectors,
                                   bool markdown) {
  std::ostringstream os;
  char buf[128];
  const std::size_t nd = detectors.size();
  std::vector<double> sum_rep(nd, 0.0), sum_ms(nd, 0.0), sum_time(nd, 0.0), sum_n(nd, 0.0);
  std::vector<int> count(nd, 0), count_ms(nd, 0);
  auto fmt_ms = [&](const PairScore& s) -> std::string {
    if (!s.has_matching_score) return "    -";
    std::snprintf(buf, sizeof buf, "%.3f", s.matching_score);
    return buf;
  };
  if (markdown) {
    os << "| Sequence | Pair |";
    for (auto d : detectors) os << ' ' << ToString(d) << " rep |";
    for (auto d : detectors) os << ' ' << ToString(d) << " MS |";
    os << "\n|---|---|";
    for (std::size_t k = 0; k < 2 * nd; ++k) os << "---:|";
    os << '\n';
  } else {
    os << "Repeatability (rep) and matching score (MS): Mikolajczyk et al. IJCV 2005 protocol\n"
          "(overlap error <= 40 %, regions normalised to 30 px, common part only, / min(n1, "
          "n2))\n\n";
    std::snprintf(buf, sizeof buf, "%-8s %-5s", "sequence", "pair");
    os << buf;
    for (auto d : detectors) {
      std::snprintf(buf, sizeof buf, " | %-11s", ToString(d));
      os << buf;
    }
    std::snprintf(buf, sizeof buf, "\n%-14s", "");
    os << buf;
    for (std::size_t d = 0; d < nd; ++d) os << " |   rep    MS";
    os << '\n' << std::string(14 + 14 * nd, '-') << '\n';
  }
  for (const auto& seq : sequences) {
    for (const auto& pair : seq.pairs) {
      const std::string label = "1->" + std::to_string(pair.target);
      if (markdown) {
        os << "| " << seq.name << " | " << label << " |";
        for (std::size_t d = 0; d < nd && d < pair.scores.size(); ++d) {
          std::snprintf(buf, sizeof buf, " %.3f |", pair.scores[d].repeatability);
          os << buf;
        }
        for (std::size_t d = 0; d < nd && d < pair.scores.size(); ++d) {
          os << ' ' << fmt_ms(pair.scores[d]) << " |";
        }
        os << '\n';
      } else {
        std::snprintf(buf, sizeof buf, "%-8s %-5s", seq.name.c_str(), label.c_str());
        os << buf;
        for (std::size_t d = 0; d < nd && d < pair.scores.size(); ++d) {
          std::snprintf(buf, sizeof buf, " | %5.3f %5s", pair.scores[d].repeatability,
                        fmt_ms(pair.scores[d]).c_str());
          os << buf;
        }
        os << '\n';
      }
      for (std::size_t d = 0; d < nd && d < pair.scores.size(); ++d) {
        const PairScore& s = pair.scores[d];
        sum_rep[d] += s.repeatability;
        sum_time[d] += s.ms2;
        sum_n[d] += s.detected2;
        ++count[d];
        if (s.has_matching_score) {
          sum_ms[d] += s.matching_score;
          ++count_ms[d];
        }
      }
    }
  }
  os << '\n';
  if (markdown) {
    os << "| Detector | mean rep | mean MS | mean keypoints per image | mean ms per image |\n"
          "|---|---:|---:|---:|---:|\n";
  } else {
    os << "detector  mean rep  mean MS  keypoints/image  ms/image (detect+describe)\n";
  }
  for (std::size_t d = 0; d < nd; ++d) {
    const double c = std::max(1, count[d]);
    char ms_text[16] = "-";
    if (count_ms[d] > 0) std::snprintf(ms_text, sizeof ms_text, "%.3f", sum_ms[d] / count_ms[d]);
    if (markdown) {
      std::snprintf(buf, sizeof buf, "| %s | %.3f | %s | %.0f | %.1f |\n", ToString(detectors[d]),
                    sum_rep[d] / c, ms_text, sum_n[d] / c, sum_time[d] / c);
    } else {
      std::snprintf(buf, sizeof buf, "%-8s  %8.3f  %7s  %15.0f  %8.1f\n", ToString(detectors[d]),
                    sum_rep[d] / c, ms_text, sum_n[d] / c, sum_time[d] / c);
    }
    os << buf;
  }
  return os.str();
}

}  // namespace aerovo
