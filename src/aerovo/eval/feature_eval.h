// Detector repeatability and descriptor matching score on image pairs related by a known
// homography, after Mikolajczyk, Tuytelaars, Schmid, Zisserman, Matas, Schaffalitzky, Kadir,
// Van Gool, "A comparison of affine region detectors", IJCV 65(1/2):43-72, 2005 (the Oxford
// benchmark protocol), with the conventions of OpenCV's cv::evaluateFeatureDetector
// (modules/features2d/src/evaluation.cpp), see docs/method.md, "Measuring features".
//
// Protocol, precisely (every number below is an option of FeatureEvalOptions):
//  1. A keypoint is the circular region of radius KeyPoint::size / 2 around its position
//     (OpenCV's convention; aerovo SURF keypoints use OpenCvKeypointSize(), i.e. the box-filter
//     size, so radius = 3.75 * SURF scale). Regions are ellipses {p : (p-c)^T M (p-c) < 1}.
//  2. Image-2 regions are mapped into image 1 with H2to1 = inverse(H1to2), linearised at the
//     centre (the projected circle becomes an ellipse); image-1 regions are mapped into image 2
//     the same way to test visibility.
//  3. Common part: by default (CommonPart::kBothImages, the paper's rule) a region is kept when
//     its bounding box lies strictly inside the image it was detected in AND its projection's
//     bounding box lies strictly inside the other image. CommonPart::kOpenCv reproduces
//     OpenCV 4.6 exactly: image-1 regions must lie inside image 1, image-2 regions' projections
//     inside image 1 (image-1 regions that fall outside image 2 still count in n1).
//     n1, n2 = numbers of regions kept.
//  4. Overlap error of a region pair (region 1 in image 1, region 2 projected into image 1):
//     both ellipses are scaled about their own centres by k = 30 px / sqrt(a1 * b1), where a1,
//     b1 are region 1's semi-axes, so region 1 gets a 30 px radius; the distance between the
//     centres is NOT scaled (as in Mikolajczyk's c_eoverlap and OpenCV). Then
//     error = 1 - area(intersection) / area(union). Pairs whose centres are 4 * sqrt(a1 * b1)
//     px or more apart get error 1 (OpenCV's candidate cut-off). Areas are computed by
//     integrating chord lengths (relative error < 1e-4), not sampled on a grid as OpenCV does
//     (its grid step is 1/50 of the box, ~1 % error), so a pair right at the threshold may
//     fall on the other side; counts agree with OpenCV within a few pairs (tested).
//  5. Correspondences: pairs with error <= 40 % (OpenCV: overlap >= 0.6), matched one-to-one
//     greedily by increasing overlap error. repeatability = correspondences / min(n1, n2).
//  6. Matching score (IJCV 2005, section 4.2; descriptors of the kept regions only): regions
//     are matched one-to-one by nearest neighbour in descriptor space, greedily by increasing
//     descriptor distance (the assignment of Mikolajczyk's repeatability.m): the closest pair
//     overall is matched first, then the closest pair among the still unmatched regions, and so
//     on. A match is correct when its two regions correspond (error <= 40 % as in 4).
//     matching score = correct matches / min(n1, n2). Distances: L2 for float descriptors
//     (SURF, SIFT), Hamming for binary ones (ORB, AKAZE's MLDB).
#pragma once

#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>

#include "aerovo/features/surf.h"

namespace aerovo {

// ------------------------------------------------------------------------------------------
// Region geometry
// ------------------------------------------------------------------------------------------

/// Elliptic region {p : (p - centre)^T [a b; b c] (p - centre) < 1}, pixel frame of one image
/// ((0,0) = centre of the top-left pixel). a, c > 0 and a*c - b^2 > 0 (units 1/px^2).
struct EllipticRegion {
  double x = 0.0;  ///< Centre column, px.
  double y = 0.0;  ///< Centre row, px.
  double a = 1.0;
  double b = 0.0;
  double c = 1.0;
};

/// Circle of radius `radius_px` (> 0) around (x, y).
EllipticRegion CircularRegion(double x, double y, double radius_px);

/// Area in px^2: pi / sqrt(a*c - b^2).
double RegionArea(const EllipticRegion& r);

/// Geometric-mean radius sqrt(semi-axis1 * semi-axis2) in px: (a*c - b^2)^(-1/4).
double RegionRadius(const EllipticRegion& r);

/// Half width and half height (px) of the axis-aligned bounding box.
cv::Point2d RegionHalfExtent(const EllipticRegion& r);

/// The region mapped by homography dst_from_src, linearised at the centre: centre mapped
/// exactly, shape by the Jacobian J of the homography there (M' = J^-T M J^-1).
/// Throws InvalidArgument when the centre maps to infinity.
EllipticRegion ProjectRegion(const EllipticRegion& r, const cv::Matx33d& dst_from_src);

/// Area (px^2) of the intersection of two regions in the same frame.
double IntersectionArea(const EllipticRegion& r1, const EllipticRegion& r2);

/// Plain overlap error 1 - |r1 n r2| / |r1 u r2| of the regions as given (no normalisation).
double OverlapError(const EllipticRegion& r1, const EllipticRegion& r2);

/// Protocol overlap error (step 4 in the header comment): both regions scaled about their
/// centres so that r1 has radius `normalised_radius_px`, centre distance kept; 1 when the
/// centres are 4 * RegionRadius(r1) or more apart. r2_in_1 must be in r1's frame.
double NormalisedOverlapError(const EllipticRegion& r1, const EllipticRegion& r2_in_1,
                              double normalised_radius_px = 30.0);

// ------------------------------------------------------------------------------------------
// Scoring one image pair
// ------------------------------------------------------------------------------------------

/// Which regions count (step 3 in the header comment).
enum class CommonPart {
  kBothImages,  ///< Paper: inside its own image and, projected, inside the other image.
  kOpenCv,      ///< Exactly cv::evaluateFeatureDetector (OpenCV 4.6).
};

enum class FeatureDetectorKind { kSurf, kSift, kOrb, kAkaze };

/// "surf", "sift", "orb", "akaze".
const char* ToString(FeatureDetectorKind kind);
/// Parses one name (case-insensitive); throws InvalidArgument listing the valid names.
FeatureDetectorKind ParseFeatureDetectorKind(std::string_view name);
/// Parses "surf,sift,..." (no empty items, no duplicates); throws InvalidArgument.
std::vector<FeatureDetectorKind> ParseFeatureDetectorList(std::string_view comma_list);

/// Options of the feature evaluation.
struct FeatureEvalOptions {
  /// Oxford sequence folder names to evaluate (used by the driver that loads them).
  /// Default: the eight standard sequences.
  std::vector<std::string> sequences = {"bark",   "bikes", "boat", "graf",
                                        "leuven", "trees", "ubc",  "wall"};
  /// Target images N of the pairs img1 -> imgN, each in 2..6. Default: all five.
  std::vector<int> targets = {2, 3, 4, 5, 6};
  /// Detectors compared side by side, in table order. Default: all four.
  std::vector<FeatureDetectorKind> detectors = {
      FeatureDetectorKind::kSurf, FeatureDetectorKind::kSift, FeatureDetectorKind::kOrb,
      FeatureDetectorKind::kAkaze};
  /// aerovo SURF options. Default: MATLAB's defaults (threshold 1000, 3 octaves, 4 levels).
  SurfOptions surf;
  /// ORB's nfeatures (OpenCV default 500 is far fewer than the other detectors find on
  /// 800x640 images; 5000 makes the counts comparable). Other OpenCV detectors use
  /// OpenCV 4.6 defaults: SIFT (contrast 0.04, edge 10, sigma 1.6), AKAZE (threshold 0.001).
  int orb_max_features = 5000;
  /// Largest overlap error of a correspondence (0.4 = 40 %, IJCV 2005 and OpenCV).
  double max_overlap_error = 0.4;
  /// Radius regions are normalised to before measuring overlap, px (30, IJCV 2005 / OpenCV).
  double normalised_radius_px = 30.0;
  /// Which regions count. Default: the paper's rule.
  CommonPart common_part = CommonPart::kBothImages;
  /// Also compute the matching score (needs descriptors; costs a descriptor NN search).
  bool matching_score = true;
};

/// Throws InvalidArgument naming the offending field.
void Validate(const FeatureEvalOptions& options);

/// Scores of one detector on one image pair.
struct PairScore {
  int detected1 = 0;           ///< Keypoints detected in image 1 (before the common-part rule).
  int detected2 = 0;           ///< Keypoints detected in image 2.
  int n1 = 0;                  ///< Image-1 regions in the common part.
  int n2 = 0;                  ///< Image-2 regions in the common part.
  int correspondences = 0;     ///< One-to-one region correspondences (overlap error <= max).
  double repeatability = 0.0;  ///< correspondences / min(n1, n2); 0 when min(n1, n2) = 0.
  bool has_matching_score = false;  ///< False when descriptors were absent or not requested.
  int matches = 0;                  ///< One-to-one nearest-neighbour descriptor matches considered.
  int correct_matches = 0;          ///< Of those, the ones whose regions correspond.
  double matching_score = 0.0;      ///< correct_matches / min(n1, n2).
  double ms1 = 0.0;                 ///< Detect+describe time for image 1, ms (0 if not measured).
  double ms2 = 0.0;                 ///< Detect+describe time for image 2, ms.
};

/// Scores regions detected in two images whose relation is img2_from_img1 (H1to2).
/// keypoints: positions in px, KeyPoint::size > 0 (region radius = size / 2).
/// descriptors: one row per keypoint, CV_32F (L2) or CV_8U (Hamming), or empty to skip the
/// matching score. Throws InvalidArgument on empty image sizes, non-positive keypoint sizes,
/// descriptor rows/type mismatches or a singular homography.
PairScore ScoreImagePair(const std::vector<cv::KeyPoint>& keypoints1, const cv::Mat& descriptors1,
                         cv::Size image1_size, const std::vector<cv::KeyPoint>& keypoints2,
                         const cv::Mat& descriptors2, cv::Size image2_size,
                         const cv::Matx33d& img2_from_img1, const FeatureEvalOptions& options);

/// The descriptor assignment of step 6: one-to-one, greedily by increasing distance (L2 for
/// CV_32F rows, Hamming for CV_8U rows). Returns (row of d1, row of d2) pairs in the order
/// they were assigned; min(d1.rows, d2.rows) pairs. Equal distances are taken in a
/// deterministic order. Throws InvalidArgument unless both are CV_32F or both CV_8U, same width.
std::vector<std::pair<int, int>> GreedyDescriptorMatches(const cv::Mat& d1, const cv::Mat& d2);

// ------------------------------------------------------------------------------------------
// Detectors and whole sequences
// ------------------------------------------------------------------------------------------

/// Keypoints and descriptors of one detector on one image, as OpenCV types.
struct DetectedFeatures {
  std::vector<cv::KeyPoint> keypoints;
  cv::Mat descriptors;  ///< Rows parallel to keypoints (CV_32F or CV_8U).
  double ms = 0.0;      ///< Wall-clock detect+describe time, ms.
};

/// aerovo keypoint as cv::KeyPoint: size = OpenCvKeypointSize(kp), angle in degrees
/// (same image frame, x right, y down), response, octave, class_id = laplacian sign.
cv::KeyPoint ToCvKeyPoint(const Keypoint& kp);

/// Runs one detector+descriptor on a grey CV_8UC1 image. Throws InvalidArgument otherwise.
DetectedFeatures DetectFeatures(FeatureDetectorKind kind, const cv::Mat& gray,
                                const FeatureEvalOptions& options);

/// Results of one sequence: pairs[p].scores[d] is detector options.detectors[d] on
/// img1 -> img(pairs[p].target).
struct FeatureEvalPair {
  int target = 0;
  std::vector<PairScore> scores;
};
struct FeatureEvalSequence {
  std::string name;
  std::vector<FeatureEvalPair> pairs;
};

/// Evaluates every detector of `options` on img1 -> imgN of one sequence. images[0] is img1,
/// images[k] is img(targets[k-1]); h_from_img1[k-1] is its H1toN. Image 1 is detected once per
/// detector and reused for every pair. Throws InvalidArgument on mismatched sizes.
FeatureEvalSequence EvaluateFeatureSequence(const std::string& name,
                                            const std::vector<cv::Mat>& images,
                                            const std::vector<int>& targets,
                                            const std::vector<cv::Matx33d>& h_from_img1,
                                            const FeatureEvalOptions& options);

/// A readable fixed-width table (markdown = false) or a GitHub markdown table: one row per
/// sequence and pair, repeatability and matching score of each detector side by side, then
/// per-detector mean time per image.
std::string FormatFeatureEvalTable(const std::vector<FeatureEvalSequence>& sequences,
                                   const std::vector<FeatureDetectorKind>& detectors,
                                   bool markdown);

}  // namespace aerovo
