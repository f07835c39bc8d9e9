// aerovo as a library, 2: the visual odometry frame by frame, from cv::Mat frames (a video read
// with OpenCV, or a list of image files) to positions in metres. No telemetry: the height above
// ground and the focal length are given (aerovo::RunFlight in pipeline/runner.h does a whole run
// with telemetry, geo-referencing and files).
// Usage: odometry_frames FOCAL_PX HEIGHT_M FPS VIDEO
//        odometry_frames FOCAL_PX HEIGHT_M FPS IMAGE IMAGE...
#include <cstdio>
#include <cstdlib>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "aerovo/odometry/visual_odometry.h"

int main(int argc, char** argv) {
  if (argc < 5) {
    std::fprintf(stderr, "usage: %s FOCAL_PX HEIGHT_M FPS VIDEO | IMAGE IMAGE...\n", argv[0]);
    return 2;
  }
  aerovo::OdometryOptions options;  // clustered RANSAC, affine, the paper's defaults
  options.focal_px = std::atof(argv[1]);          // focal length, pixels
  options.default_height_m = std::atof(argv[2]);  // height above ground, metres
  const double fps = std::atof(argv[3]);
  aerovo::VisualOdometry odometry(options);  // throws InvalidArgument for invalid options

  cv::VideoCapture video;
  if (argc == 5 && !video.open(argv[4])) {
    std::fprintf(stderr, "cannot open %s\n", argv[4]);
    return 1;
  }
  cv::Mat frame, gray;
  for (int i = 0;; ++i) {
    if (argc == 5) {
      if (!video.read(frame)) break;
      cv::cvtColor(frame, gray, cv::COLOR_BGR2GRAY);
    } else {
      if (4 + i >= argc) break;
      gray = cv::imread(argv[4 + i], cv::IMREAD_GRAYSCALE);
      if (gray.empty()) {
        std::fprintf(stderr, "cannot read %s\n", argv[4 + i]);
        return 1;
      }
    }
    // The cv::Mat as aerovo's view of 8-bit grey pixels: no copy, valid while `gray` is.
    const aerovo::GrayImageView view{gray.data, gray.cols, gray.rows,
                                     static_cast<std::ptrdiff_t>(gray.step[0])};
    const aerovo::FrameResult r = odometry.Process(view, i / fps);
    // position_m: camera centre in metres (x = first image right, y = first image up).
    std::printf("frame %d t %.2f s: x %.2f m, y %.2f m, %s, %d SURF points, %d inliers\n",
                r.index, r.time_s, r.position_m.x(), r.position_m.y(), aerovo::ToString(r.status),
                r.n_surf, r.n_inliers);
  }
  return 0;
}
