// The plugin that holds OpenCV's image codecs and video I/O for aerovo::imageio (image_io.h):
// a shared library loaded on the first image or video read or written, so that a process that
// does neither (`aerovo --version`, a telemetry command, a run of a video through aerovo's own
// FFmpeg decoder) does not load opencv_imgcodecs, opencv_videoio and the ~220 libraries they
// need (GStreamer, GDAL, OpenEXR...; BENCHMARKS.md "Start-up"). Each function is the OpenCV
// call of the same name; the table is declared in opencv_io_table.h.
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>

#include "aerovo/imageio/opencv_io_table.h"

namespace {

using aerovo::imageio::detail::OpenCvIoTable;

cv::Mat Read(const std::string& path, int flags) { return cv::imread(path, flags); }
bool Write(const std::string& path, const cv::Mat& image, const std::vector<int>& params) {
  return cv::imwrite(path, image, params);
}
bool Encode(const std::string& ext, const cv::Mat& image, std::vector<unsigned char>& buf,
            const std::vector<int>& params) {
  return cv::imencode(ext, image, buf, params);
}
cv::Mat Decode(const std::vector<unsigned char>& buf, int flags) {
  return cv::imdecode(buf, flags);
}

cv::VideoCapture& Cap(void* c) { return *static_cast<cv::VideoCapture*>(c); }
void* CaptureNew() { return new cv::VideoCapture(); }
void CaptureDelete(void* c) { delete static_cast<cv::VideoCapture*>(c); }
bool CaptureOpenName(void* c, const std::string& name, int api) { return Cap(c).open(name, api); }
bool CaptureOpenIndex(void* c, int index, int api) { return Cap(c).open(index, api); }
bool CaptureIsOpened(const void* c) { return static_cast<const cv::VideoCapture*>(c)->isOpened(); }
bool CaptureGrab(void* c) { return Cap(c).grab(); }
bool CaptureRetrieve(void* c, cv::Mat& image) { return Cap(c).retrieve(image); }
bool CaptureRead(void* c, cv::Mat& image) { return Cap(c).read(image); }
double CaptureGet(void* c, int property) { return Cap(c).get(property); }
bool CaptureSet(void* c, int property, double value) { return Cap(c).set(property, value); }

cv::VideoWriter& Wr(void* w) { return *static_cast<cv::VideoWriter*>(w); }
void* WriterNew() { return new cv::VideoWriter(); }
void WriterDelete(void* w) { delete static_cast<cv::VideoWriter*>(w); }
bool WriterOpen(void* w, const std::string& path, int api, int fourcc, double fps, int width,
                int height, bool is_color) {
  return Wr(w).open(path, api, fourcc, fps, cv::Size(width, height), is_color);
}
bool WriterIsOpened(const void* w) { return static_cast<const cv::VideoWriter*>(w)->isOpened(); }
void WriterWrite(void* w, const cv::Mat& image) { Wr(w).write(image); }
void WriterRelease(void* w) { Wr(w).release(); }

constexpr OpenCvIoTable kTable = {
    aerovo::imageio::detail::kOpenCvIoAbi,
    Read,
    Write,
    Encode,
    Decode,
    CaptureNew,
    CaptureDelete,
    CaptureOpenName,
    CaptureOpenIndex,
    CaptureIsOpened,
    CaptureGrab,
    CaptureRetrieve,
    CaptureRead,
    CaptureGet,
    CaptureSet,
    WriterNew,
    WriterDelete,
    WriterOpen,
    WriterIsOpened,
    WriterWrite,
    WriterRelease,
};

}  // namespace

extern "C" __attribute__((visibility("default"))) const OpenCvIoTable*
aerovo_imageio_opencv_table() {
  return &kTable;
}
