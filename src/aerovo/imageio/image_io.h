// Image and video files through OpenCV (opencv_imgcodecs, opencv_videoio), loaded on first use.
//
// OpenCV's image codecs and video I/O need ~220 shared libraries in Debian 12 (GStreamer,
// GDAL, OpenEXR, libheif, ...); linked into a program they are all loaded, and their symbols
// bound, before `main`: most of every aerovo process's start-up (BENCHMARKS.md "Start-up").
// Here they live in a plugin library (plugin/opencv_io_plugin.cc) that is loaded the first time
// a function below reads or writes an image or opens a video, so that a process that does
// neither does not pay for them. Each function behaves as the OpenCV call it names (same
// arguments, results and exceptions); the OpenCV enums (cv::IMREAD_*, cv::IMWRITE_*,
// cv::CAP_*) are used as they are.
//
// Where the plugin is found (the first that loads and was built with this code; PluginPath()):
//  1. the file named by the environment variable AEROVO_IMAGEIO_PLUGIN, when set;
//  2. <directory of the running program>/<libdir relative to bindir>/aerovo/<plugin>: an
//     installed `aerovo` at any prefix;
//  3. the plugin of the build tree this code was built in;
//  4. <CMAKE_INSTALL_FULL_LIBDIR>/aerovo/<plugin>: the prefix the build was configured for.
// When none loads, the call throws InternalError naming every path tried and why it failed.
#pragma once

#include <string>
#include <vector>

#include <opencv2/core/mat.hpp>

namespace aerovo {
namespace imageio {

/// cv::imread: the image at `path`, empty when it cannot be read.
cv::Mat Read(const std::string& path, int flags);
/// cv::imwrite: false (or cv::Exception) when `image` cannot be written to `path`.
bool Write(const std::string& path, const cv::Mat& image, const std::vector<int>& params = {});
/// cv::imencode into `buf` by the format of the extension `ext` (".jpg", ".png").
bool Encode(const std::string& ext, const cv::Mat& image, std::vector<unsigned char>& buf,
            const std::vector<int>& params = {});
/// cv::imdecode: the image encoded in `buf`, empty when it cannot be decoded.
cv::Mat Decode(const std::vector<unsigned char>& buf, int flags);

/// cv::VideoWriter::fourcc: the four characters of a codec as one int (c1 in the low byte).
int Fourcc(char c1, char c2, char c3, char c4);

/// cv::VideoCapture. Constructing one loads nothing; open() loads the plugin.
class VideoCapture {
 public:
  VideoCapture() = default;
  ~VideoCapture();
  VideoCapture(const VideoCapture&) = delete;
  VideoCapture& operator=(const VideoCapture&) = delete;
  VideoCapture(VideoCapture&& other) noexcept;
  VideoCapture& operator=(VideoCapture&& other) noexcept;

  /// A file or stream URL with a backend (cv::CAP_ANY, cv::CAP_FFMPEG, cv::CAP_V4L2, ...).
  bool open(const std::string& name, int api = 0);
  /// A camera by index.
  bool open(int index, int api = 0);
  bool isOpened() const;
  bool grab();
  bool retrieve(cv::Mat& image);
  bool read(cv::Mat& image);
  /// A cv::CAP_PROP_* property; 0 when nothing is open (as OpenCV).
  double get(int property) const;
  bool set(int property, double value);

 private:
  void* impl_ = nullptr;  // the plugin's cv::VideoCapture, made by open()
};

/// cv::VideoWriter. Constructing one loads nothing; open() loads the plugin.
class VideoWriter {
 public:
  VideoWriter() = default;
  ~VideoWriter();
  VideoWriter(const VideoWriter&) = delete;
  VideoWriter& operator=(const VideoWriter&) = delete;

  /// cv::VideoWriter::open(path, api, fourcc, fps, size, is_color).
  bool open(const std::string& path, int api, int fourcc, double fps, cv::Size size,
            bool is_color = true);
  bool isOpened() const;
  void write(const cv::Mat& image);
  /// Finishes the file (also done by the destructor).
  void release();

 private:
  void* impl_ = nullptr;
};

/// Loads the plugin now if it is not loaded (throws InternalError as above) and returns the
/// path it was loaded from.
const std::string& PluginPath();
/// True once the plugin is loaded in this process.
bool PluginLoaded();

namespace detail {
/// Loads the first of `candidates` that dlopen() opens and whose table's ABI string matches
/// this build's, without caching; throws InternalError listing each candidate and why it was
/// not used. `loaded_from` receives the path used. For the tests.
const void* OpenPlugin(const std::vector<std::string>& candidates, std::string* loaded_from);
/// The candidates in the order above (the environment read now).
std::vector<std::string> PluginCandidates();
}  // namespace detail

}  // namespace imageio
}  // namespace aerovo
