// The table of functions through which aerovo::imageio (image_io.h) calls OpenCV's image codecs
// and video I/O (opencv_imgcodecs, opencv_videoio) in the plugin library that links them
// (plugin/opencv_io_plugin.cc). Internal to the module: the loader and the plugin are built
// together from this one declaration, and the loader accepts a plugin only when its `abi`
// string equals its own (kOpenCvIoAbi), so a table of another layout is never called.
//
// C++ types cross the boundary (cv::Mat, std::string, std::vector): the plugin is built by the
// same compiler, against the same OpenCV and libstdc++, as the code that loads it; exceptions
// (cv::Exception) propagate through the calls as they would from cv::imread itself.
#pragma once

#include <string>
#include <vector>

#include <opencv2/core/mat.hpp>
#include <opencv2/core/version.hpp>

namespace aerovo {
namespace imageio {
namespace detail {

/// The symbol the plugin exports (extern "C"): a function returning its table.
inline constexpr const char kOpenCvIoEntry[] = "aerovo_imageio_opencv_table";

/// Changes with the table's layout (the leading number) and with the OpenCV headers built
/// against.
inline constexpr const char kOpenCvIoAbi[] = "aerovo-imageio-1 opencv-" CV_VERSION;

struct OpenCvIoTable {
  const char* abi;  ///< kOpenCvIoAbi of the plugin's build
  // cv::imread / imwrite / imencode / imdecode.
  cv::Mat (*read)(const std::string& path, int flags);
  bool (*write)(const std::string& path, const cv::Mat& image, const std::vector<int>& params);
  bool (*encode)(const std::string& ext, const cv::Mat& image, std::vector<unsigned char>& buf,
                 const std::vector<int>& params);
  cv::Mat (*decode)(const std::vector<unsigned char>& buf, int flags);
  // cv::VideoCapture, behind an opaque handle made by capture_new.
  void* (*capture_new)();
  void (*capture_delete)(void* capture);
  bool (*capture_open_name)(void* capture, const std::string& name, int api);
  bool (*capture_open_index)(void* capture, int index, int api);
  bool (*capture_is_opened)(const void* capture);
  bool (*capture_grab)(void* capture);
  bool (*capture_retrieve)(void* capture, cv::Mat& image);
  bool (*capture_read)(void* capture, cv::Mat& image);
  double (*capture_get)(void* capture, int property);
  bool (*capture_set)(void* capture, int property, double value);
  // cv::VideoWriter, the same way.
  void* (*writer_new)();
  void (*writer_delete)(void* writer);
  bool (*writer_open)(void* writer, const std::string& path, int api, int fourcc, double fps,
                      int width, int height, bool is_color);
  bool (*writer_is_opened)(const void* writer);
  void (*writer_write)(void* writer, const cv::Mat& image);
  void (*writer_release)(void* writer);
};

}  // namespace detail
}  // namespace imageio
}  // namespace aerovo
