// aerovo as a library, 1: SURF on two images and the correspondence stage between them (the
// paper's clustered RANSAC), from image files read with OpenCV.
// Usage: surf_pair PREV_IMAGE CURR_IMAGE
#include <cstdio>
#include <optional>

#include <opencv2/imgcodecs.hpp>

#include "aerovo/correspondence/correspondence.h"
#include "aerovo/features/surf.h"

// A cv::Mat of 8-bit grey pixels seen as aerovo's image view (no copy; the Mat must outlive it).
aerovo::GrayImageView ViewOf(const cv::Mat& gray) {
  return {gray.data, gray.cols, gray.rows, static_cast<std::ptrdiff_t>(gray.step[0])};
}

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: %s PREV_IMAGE CURR_IMAGE\n", argv[0]);
    return 2;
  }
  const cv::Mat prev_img = cv::imread(argv[1], cv::IMREAD_GRAYSCALE);
  const cv::Mat curr_img = cv::imread(argv[2], cv::IMREAD_GRAYSCALE);
  if (prev_img.empty() || curr_img.empty()) {
    std::fprintf(stderr, "cannot read %s\n", prev_img.empty() ? argv[1] : argv[2]);
    return 1;
  }

  aerovo::Surf surf;  // MATLAB detectSURFFeatures defaults: threshold 1000, 3 octaves, 4 levels
  const aerovo::FeatureSet prev = surf.DetectAndDescribe(ViewOf(prev_img)).features;
  const aerovo::FeatureSet curr = surf.DetectAndDescribe(ViewOf(curr_img)).features;
  std::printf("SURF points: %zu and %zu\n", prev.size(), curr.size());

  aerovo::CorrespondenceOptions options;  // clustered RANSAC, affine
  aerovo::CorrespondenceStage stage(options);
  // No previous step (first pair): clustered RANSAC assumes zero motion for its crop.
  const aerovo::CorrespondenceResult r =
      stage.Run(prev, prev_img.cols, prev_img.rows, curr, std::nullopt);
  if (!r.success) {
    std::printf("no transform found\n");
    return 1;
  }
  const Eigen::Matrix3d& t = r.curr_from_prev;  // prev pixels -> curr pixels
  std::printf("inliers: %d of %zu matches\n", r.num_inliers, r.matches.size());
  std::printf("curr_from_prev: [%.4f %.4f %.2f; %.4f %.4f %.2f]\n", t(0, 0), t(0, 1), t(0, 2),
              t(1, 0), t(1, 1), t(1, 2));
  return 0;
}
