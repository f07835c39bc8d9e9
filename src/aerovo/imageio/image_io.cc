#include "aerovo/imageio/image_io.h"

#include <dlfcn.h>
#include <unistd.h>

#include <atomic>
#include <cstdlib>
#include <filesystem>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

#include <fmt/format.h>

#include "aerovo/core/error.h"
#include "aerovo/imageio/opencv_io_table.h"

// Set by CMakeLists.txt: the plugin in the build tree, at the configured install prefix, and
// relative to the directory of an installed program (bindir -> libdir/aerovo).
#ifndef AEROVO_IMAGEIO_PLUGIN_BUILD_PATH
#error "AEROVO_IMAGEIO_PLUGIN_BUILD_PATH must be defined (src/aerovo/imageio/CMakeLists.txt)"
#endif

namespace aerovo {
namespace imageio {
namespace {

using detail::OpenCvIoTable;

// The directory of the running program (/proc/self/exe), empty when unknown.
std::string ProgramDirectory() {
  std::string buf(4096, '\0');
  const ssize_t n = ::readlink("/proc/self/exe", buf.data(), buf.size() - 1);
  if (n <= 0) return {};
  buf.resize(static_cast<std::size_t>(n));
  const std::size_t slash = buf.rfind('/');
  return slash == std::string::npos ? std::string() : buf.substr(0, slash);
}

// The plugin, loaded once per process. A failure is not remembered: the next call tries again
// and throws the same error.
std::mutex g_mutex;
std::atomic<const OpenCvIoTable*> g_table{nullptr};
std::string g_path;  // written once, under g_mutex, before g_table

const OpenCvIoTable& Table() {
  if (const OpenCvIoTable* t = g_table.load(std::memory_order_acquire)) return *t;
  std::lock_guard<std::mutex> lock(g_mutex);
  if (const OpenCvIoTable* t = g_table.load(std::memory_order_relaxed)) return *t;
  std::string from;
  const auto* t =
      static_cast<const OpenCvIoTable*>(detail::OpenPlugin(detail::PluginCandidates(), &from));
  g_path = std::move(from);
  g_table.store(t, std::memory_order_release);
  return *t;
}

}  // namespace

namespace detail {

std::vector<std::string> PluginCandidates() {
  std::vector<std::string> out;
  if (const char* env = std::getenv("AEROVO_IMAGEIO_PLUGIN"); env != nullptr && *env != '\0') {
    out.emplace_back(env);
  }
  if (const std::string dir = ProgramDirectory(); !dir.empty()) {
    // Lexically normal (no "bin/.."), as error messages and PluginPath() show it.
    out.push_back((std::filesystem::path(dir) / AEROVO_IMAGEIO_PLUGIN_FROM_BINDIR)
                      .lexically_normal()
                      .string());
  }
  out.emplace_back(AEROVO_IMAGEIO_PLUGIN_BUILD_PATH);
  out.emplace_back(AEROVO_IMAGEIO_PLUGIN_INSTALL_PATH);
  return out;
}

const void* OpenPlugin(const std::vector<std::string>& candidates, std::string* loaded_from) {
  std::string tried;
  for (const std::string& path : candidates) {
    if (::access(path.c_str(), F_OK) != 0) {
      tried += fmt::format("\n  {}: no such file", path);
      continue;
    }
    // RTLD_LOCAL: OpenCV's symbols stay out of the global scope. The plugin's handle is never
    // closed (its and OpenCV's objects live until the process ends); a rejected library's is.
    void* handle = ::dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
    if (handle == nullptr) {
      const char* why = ::dlerror();
      tried += fmt::format("\n  {}: {}", path, why != nullptr ? why : "dlopen failed");
      continue;
    }
    using Entry = const OpenCvIoTable* (*)();
    auto entry = reinterpret_cast<Entry>(::dlsym(handle, kOpenCvIoEntry));
    const OpenCvIoTable* table = entry != nullptr ? entry() : nullptr;
    if (table == nullptr) {
      tried += fmt::format("\n  {}: not an aerovo image I/O plugin (no {})", path, kOpenCvIoEntry);
      ::dlclose(handle);
      continue;
    }
    if (std::string(table->abi) != kOpenCvIoAbi) {
      tried += fmt::format("\n  {}: built for '{}', this program needs '{}'", path, table->abi,
                           kOpenCvIoAbi);
      ::dlclose(handle);
      continue;
    }
    if (loaded_from != nullptr) *loaded_from = path;
    return table;
  }
  throw InternalError(
      fmt::format("cannot load OpenCV's image and video I/O (aerovo's plugin {}), an incomplete "
                  "installation; tried:{}\nset AEROVO_IMAGEIO_PLUGIN to the plugin's path",
                  AEROVO_IMAGEIO_PLUGIN_NAME, tried));
}

}  // namespace detail

const std::string& PluginPath() {
  Table();
  return g_path;
}

bool PluginLoaded() { return g_table.load(std::memory_order_acquire) != nullptr; }

cv::Mat Read(const std::string& path, int flags) { return Table().read(path, flags); }

bool Write(const std::string& path, const cv::Mat& image, const std::vector<int>& params) {
  return Table().write(path, image, params);
}

bool Encode(const std::string& ext, const cv::Mat& image, std::vector<unsigned char>& buf,
            const std::vector<int>& params) {
  return Table().encode(ext, image, buf, params);
}

cv::Mat Decode(const std::vector<unsigned char>& buf, int flags) {
  return Table().decode(buf, flags);
}

int Fourcc(char c1, char c2, char c3, char c4) {
  // FOURCC: the four bytes in file order, the first in the low byte (as OpenCV's CV_FOURCC).
  return (static_cast<unsigned char>(c1)) | (static_cast<unsigned char>(c2) << 8) |
         (static_cast<unsigned char>(c3) << 16) | (static_cast<unsigned char>(c4) << 24);
}

// ---- VideoCapture

VideoCapture::~VideoCapture() {
  if (impl_ != nullptr) Table().capture_delete(impl_);
}

VideoCapture::VideoCapture(VideoCapture&& other) noexcept : impl_(other.impl_) {
  other.impl_ = nullptr;
}

VideoCapture& VideoCapture::operator=(VideoCapture&& other) noexcept {
  if (this != &other) {
    if (impl_ != nullptr) Table().capture_delete(impl_);
    impl_ = other.impl_;
    other.impl_ = nullptr;
  }
  return *this;
}

bool VideoCapture::open(const std::string& name, int api) {
  const OpenCvIoTable& t = Table();
  if (impl_ == nullptr) impl_ = t.capture_new();
  return t.capture_open_name(impl_, name, api);
}

bool VideoCapture::open(int index, int api) {
  const OpenCvIoTable& t = Table();
  if (impl_ == nullptr) impl_ = t.capture_new();
  return t.capture_open_index(impl_, index, api);
}

bool VideoCapture::isOpened() const { return impl_ != nullptr && Table().capture_is_opened(impl_); }

bool VideoCapture::grab() { return impl_ != nullptr && Table().capture_grab(impl_); }

bool VideoCapture::retrieve(cv::Mat& image) {
  return impl_ != nullptr && Table().capture_retrieve(impl_, image);
}

bool VideoCapture::read(cv::Mat& image) {
  if (impl_ == nullptr) {
    image.release();
    return false;
  }
  return Table().capture_read(impl_, image);
}

double VideoCapture::get(int property) const {
  return impl_ != nullptr ? Table().capture_get(impl_, property) : 0.0;
}

bool VideoCapture::set(int property, double value) {
  return impl_ != nullptr && Table().capture_set(impl_, property, value);
}

// ---- VideoWriter

VideoWriter::~VideoWriter() {
  if (impl_ != nullptr) Table().writer_delete(impl_);
}

bool VideoWriter::open(const std::string& path, int api, int fourcc, double fps, cv::Size size,
                       bool is_color) {
  const OpenCvIoTable& t = Table();
  if (impl_ == nullptr) impl_ = t.writer_new();
  return t.writer_open(impl_, path, api, fourcc, fps, size.width, size.height, is_color);
}

bool VideoWriter::isOpened() const { return impl_ != nullptr && Table().writer_is_opened(impl_); }

void VideoWriter::write(const cv::Mat& image) {
  if (impl_ != nullptr) Table().writer_write(impl_, image);
}

void VideoWriter::release() {
  if (impl_ != nullptr) Table().writer_release(impl_);
}

}  // namespace imageio
}  // namespace aerovo
