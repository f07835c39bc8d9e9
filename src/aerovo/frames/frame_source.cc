#include "aerovo/frames/frame_source.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <iostream>
#include <map>
#include <optional>
#include <set>
#include <string_view>
#include <utility>

#include <fmt/format.h>
#include <opencv2/imgcodecs.hpp>  // cv::IMREAD_* (the calls: imageio/image_io.h)
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>  // cv::CAP_*

#include "aerovo/core/error.h"
#include "aerovo/core/text.h"
#include "aerovo/core/timer.h"
#include "aerovo/frames/image_file.h"
#include "aerovo/imageio/image_io.h"
#include "aerovo/telemetry/parse_util.h"

namespace aerovo {
namespace {

bool IsImageExtension(const std::filesystem::path& p) {
  const std::string ext = io_detail::ToLower(p.extension().string());
  return ext == ".jpg" || ext == ".jpeg" || ext == ".png" || ext == ".tif" || ext == ".tiff";
}

void FillFrame(const cv::Mat& bgr, bool keep_color, Frame& frame) {
  ToGrayImage(bgr, frame.gray);
  if (keep_color) {
    bgr.copyTo(frame.color);
  } else {
    frame.color.release();
  }
}

// Appends `token` to a '+'-separated flag list.
void AddFlag(std::string& flags, const char* token) {
  if (!flags.empty()) flags += '+';
  flags += token;
}

}  // namespace

std::uint64_t PixelHash(const GrayImage& image) {
  // 8 bytes at a time, multiply-rotate mixing (the multipliers are the 64-bit primes of
  // xxHash), in four independent lanes of 32-byte blocks so that the multiplications of one
  // lane do not wait for another's (about 4x faster than one chain); the 8-byte words and bytes
  // left at a row's end go into lane 0. Each step is a bijection of its lane for a given input,
  // and the lanes are combined by rotations and xor: one changed pixel changes the hash.
  constexpr std::uint64_t kP1 = 0x9E3779B185EBCA87ULL, kP2 = 0xC2B2AE3D27D4EB4FULL;
  const auto mix = [](std::uint64_t h, std::uint64_t w) {
    h ^= w * kP2;
    return ((h << 31) | (h >> 33)) * kP1;
  };
  std::uint64_t lane[4] = {kP2 ^ (static_cast<std::uint64_t>(image.width()) << 32) ^
                               static_cast<std::uint64_t>(image.height()),
                           kP1, kP1 ^ kP2, ~kP1};
  for (int y = 0; y < image.height(); ++y) {
    const std::uint8_t* row = image.row(y);
    int x = 0;
    for (; x + 32 <= image.width(); x += 32) {
      std::uint64_t w[4];
      std::memcpy(w, row + x, 32);
      for (int k = 0; k < 4; ++k) lane[k] = mix(lane[k], w[k]);
    }
    for (; x + 8 <= image.width(); x += 8) {
      std::uint64_t w;
      std::memcpy(&w, row + x, 8);
      lane[0] = mix(lane[0], w);
    }
    for (; x < image.width(); ++x) {
      lane[0] ^= row[x] * kP1;
      lane[0] = ((lane[0] << 23) | (lane[0] >> 41)) * kP2;
    }
  }
  const auto rotl = [](std::uint64_t v, int r) { return (v << r) | (v >> (64 - r)); };
  std::uint64_t h = lane[0] ^ rotl(lane[1], 7) ^ rotl(lane[2], 12) ^ rotl(lane[3], 18);
  h ^= h >> 33;
  h *= kP2;
  h ^= h >> 29;
  return h;
}

void ToGrayImage(const cv::Mat& image, GrayImage& out) {
  if (image.empty()) {
    out = GrayImage();
    return;
  }
  if (image.depth() != CV_8U) {
    throw InvalidArgument(
        fmt::format("ToGrayImage: expected an 8-bit image, got depth {}", image.depth()));
  }
  int code = -1;
  switch (image.channels()) {
    case 1:
      break;
    case 3:
      code = cv::COLOR_BGR2GRAY;
      break;
    case 4:
      code = cv::COLOR_BGRA2GRAY;
      break;
    default:
      throw InvalidArgument(
          fmt::format("ToGrayImage: unsupported channel count {}", image.channels()));
  }
  if (out.width() != image.cols || out.height() != image.rows) {
    out = GrayImage(image.cols, image.rows);
  }
  // Convert straight into the GrayImage's contiguous buffer.
  cv::Mat dst(image.rows, image.cols, CV_8UC1, out.data());
  if (code < 0) {
    image.copyTo(dst);
  } else {
    cv::cvtColor(image, dst, code);
  }
}

GrayImage ToGrayImage(const cv::Mat& image) {
  GrayImage out;
  ToGrayImage(image, out);
  return out;
}

void Validate(const FrameSourceOptions& o) {
  if (o.step < 1) throw InvalidArgument(fmt::format("FrameSourceOptions.step {} < 1", o.step));
  if (!std::isfinite(o.start_time_s) || o.start_time_s < 0.0) {
    throw InvalidArgument(
        fmt::format("FrameSourceOptions.start_time_s {} must be finite and >= 0", o.start_time_s));
  }
  if (!std::isfinite(o.photo_gap_s) || o.photo_gap_s < 0.0) {
    throw InvalidArgument(
        fmt::format("FrameSourceOptions.photo_gap_s {} must be finite and >= 0", o.photo_gap_s));
  }
  if (o.photo_flight < -1) {
    throw InvalidArgument(fmt::format(
        "FrameSourceOptions.photo_flight {} must be -1 (all), 0 (refuse a mixed folder) or a "
        "flight number >= 1",
        o.photo_flight));
  }
  if (o.video_threads < 0 || o.video_threads > 64) {
    throw InvalidArgument(
        fmt::format("FrameSourceOptions.video_threads {} must be in [0, 64] (0 = one per core)",
                    o.video_threads));
  }
  if (std::isnan(o.end_time_s) || o.end_time_s < o.start_time_s) {
    throw InvalidArgument(fmt::format("FrameSourceOptions.end_time_s {} must be >= start_time_s {}",
                                      o.end_time_s, o.start_time_s));
  }
}

// ------------------------------------------------------------------------------ video

namespace {

InputError VideoOpenError(const std::string& path, const std::string& why) {
  return InputError(fmt::format("cannot open video '{}': {}", path, why));
}

// What cv::VideoCapture says of an opened video (0: unknown).
struct OpenCvVideoInfo {
  int rotation_deg = 0;
  double fps = 0.0;
  int frame_count = 0;
  int width = 0, height = 0;
};

// Opens `path` with OpenCV's FFmpeg backend, frames as stored, never rotated by the
// container's rotation metadata: the same policy as photos (IMREAD_IGNORE_ORIENTATION). OpenCV
// 4.6 rotates by default (ORIENTATION_AUTO), which swaps width and height (for 4:3, a focal
// length from the field of view 25 % short: the true one is 33 % longer) and turns the image
// axes 90 degrees against the telemetry's yaw. Throws InputError when FFmpeg cannot read it.
OpenCvVideoInfo OpenWithOpenCv(imageio::VideoCapture& capture, const std::string& path) {
  if (!capture.open(path, cv::CAP_FFMPEG)) {
    throw VideoOpenError(
        path,
        "FFmpeg cannot read it (not a video, an unsupported codec, or a damaged or truncated "
        "container)");
  }
  OpenCvVideoInfo info;
  capture.set(cv::CAP_PROP_ORIENTATION_AUTO, 0);
  const double meta = capture.get(cv::CAP_PROP_ORIENTATION_META);
  if (std::isfinite(meta)) {
    info.rotation_deg = ((static_cast<int>(std::lround(meta)) % 360) + 360) % 360;
  }
  info.fps = capture.get(cv::CAP_PROP_FPS);
  if (!std::isfinite(info.fps) || info.fps <= 0.0 || info.fps > 10000.0) info.fps = 0.0;
  const double count = capture.get(cv::CAP_PROP_FRAME_COUNT);
  info.frame_count = std::isfinite(count) && count > 0 && count < 1e9 ? static_cast<int>(count) : 0;
  info.width = static_cast<int>(capture.get(cv::CAP_PROP_FRAME_WIDTH));
  info.height = static_cast<int>(capture.get(cv::CAP_PROP_FRAME_HEIGHT));
  return info;
}

// The stream's clock went back at frame `index` (see VideoFileSource::Next).
std::string ClockWentBackMessage(const std::string& path, int index, double last_ts_ms,
                                 double current_ts_ms, int width, int height, int cur_w,
                                 int cur_h) {
  return fmt::format(
      "video '{}' frame {}: the stream's timestamps go back from {:.3f} s to {:.3f} s: "
      "recordings joined into one file (concatenated MPEG-TS?) or a damaged stream, so the "
      "frames from {} on cannot be trusted as the same flight (OpenCV's decoder even delivers "
      "them at the first recording's size; split the video where its clock restarts, or "
      "re-encode it at one size, e.g. ffmpeg -i in -vf scale=W:H out.mp4){}",
      path, index, last_ts_ms / 1000.0, current_ts_ms / 1000.0, index,
      cur_w != width || cur_h != height
          ? fmt::format("; the size changes there too, from {}x{} to {}x{}", width, height, cur_w,
                        cur_h)
          : std::string());
}

std::string SizeChangedMessage(const std::string& path, int index, int width, int height, int cur_w,
                               int cur_h) {
  return fmt::format(
      "video '{}' frame {}: size changed from {}x{} to {}x{} (a resolution change mid-stream: "
      "recordings joined into one file, or a camera that switched modes; split the video "
      "there, or re-encode it at one size, e.g. ffmpeg -i in -vf scale=W:H out.mp4)",
      path, index, width, height, cur_w, cur_h);
}

std::string StaleDecoderMessage(const std::string& path, int index, int freeze_index, int repeats) {
  return fmt::format(
      "video '{}' frame {}: the decoder has returned the same image since frame {} ({} "
      "identical frames in a row after the video moved): stale decoding, typically a "
      "resolution change mid-stream (concatenated recordings, MPEG-TS) or a damaged stream; "
      "the frames from {} on cannot be trusted (split or re-encode the video at one size, "
      "e.g. ffmpeg -i in -vf scale=W:H out.mp4)",
      path, index, freeze_index, repeats + 1, freeze_index + 1);
}

}  // namespace

VideoFileSource::VideoFileSource(const std::filesystem::path& path,
                                 const FrameSourceOptions& options)
    : path_(path), options_(options) {
  Validate(options_);
  const std::string p = path.string();
  const auto fail = [&](const std::string& why) { return VideoOpenError(p, why); };
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) throw fail("no such file");
  if (!std::filesystem::is_regular_file(path, ec)) throw fail("not a regular file");
  if (std::filesystem::file_size(path, ec) == 0) throw fail("the file is empty (0 bytes)");
  if (options_.video_decoder != VideoDecoderChoice::kOpenCv) {
    // Ours (VideoDecoder): it never rotates; its errors name the file.
    decoder_ = std::make_unique<VideoDecoder>(path, options_.video_threads);
    rotation_deg_ = decoder_->rotation_deg();
    fps_ = decoder_->fps();
    frame_count_ = decoder_->frame_count();
    width_ = decoder_->width();
    height_ = decoder_->height();
  } else {
    const OpenCvVideoInfo info = OpenWithOpenCv(capture_, p);
    rotation_deg_ = info.rotation_deg;
    fps_ = info.fps;
    frame_count_ = info.frame_count;
    width_ = info.width;
    height_ = info.height;
  }
  if (rotation_deg_ != 0) {
    warnings_.push_back(fmt::format(
        "video '{}' has rotation metadata ({} degrees for display): its frames are processed as "
        "stored (sensor orientation, not rotated), like photos' EXIF orientation; focal length, "
        "field of view (hfov_deg: across the stored width) and heading refer to the sensor's "
        "axes",
        p, rotation_deg_));
  }

  int start_index = 0;
  if (options_.start_time_s > 0.0) {
    if (fps_ <= 0.0) throw fail("start time given but the frame rate is unknown");
    start_index = static_cast<int>(std::ceil(options_.start_time_s * fps_ - 1e-6));
    if (frame_count_ > 0 && start_index >= frame_count_) {
      throw fail(fmt::format("start time {} s is past the end ({} frames at {} fps)",
                             options_.start_time_s, frame_count_, fps_));
    }
    if (decoder_) {
      // Decode and skip: exact (frame k is the k-th decoded frame, as Next() counts them),
      // without relying on the container's index or timestamps.
      if (!GrabTo(start_index)) throw fail(fmt::format("cannot reach frame {}", start_index));
    } else if (!capture_.set(cv::CAP_PROP_POS_FRAMES, start_index) ||
               static_cast<int>(capture_.get(cv::CAP_PROP_POS_FRAMES)) != start_index) {
      // OpenCV's FFmpeg seek lands on the exact frame (it decodes forward from a key frame).
      capture_.set(cv::CAP_PROP_POS_FRAMES, 0);
      for (int i = 0; i < start_index; ++i) {
        if (!capture_.grab()) throw fail(fmt::format("cannot reach frame {}", start_index));
      }
    }
  }
  next_index_ = start_index;
  if (!GrabOne() || !RetrieveGrabbed()) {
    throw fail(fmt::format("no frame could be decoded at frame {} (damaged or truncated file?)",
                           start_index));
  }
  ++next_index_;
  width_ = cur_w_;
  height_ = cur_h_;
  current_ts_ms_ = GrabbedTimestampMs();
}

bool VideoFileSource::GrabOne() { return decoder_ ? decoder_->Grab() : capture_.grab(); }

double VideoFileSource::GrabbedTimestampMs() const {
  if (decoder_) return decoder_->timestamp_ms();
  return capture_.get(cv::CAP_PROP_POS_MSEC);
}

bool VideoFileSource::RetrieveGrabbed() {
  if (decoder_) {
    decoder_->Gray(gray_);
    if (options_.keep_color) decoder_->Bgr(bgr_);
    cur_w_ = gray_.width();
    cur_h_ = gray_.height();
    return !gray_.empty();
  }
  if (!capture_.retrieve(bgr_) || bgr_.empty()) return false;
  cur_w_ = bgr_.cols;
  cur_h_ = bgr_.rows;
  return true;
}

void VideoFileSource::DeliverTo(Frame& frame) {
  if (!decoder_) {
    FillFrame(bgr_, options_.keep_color, frame);
    return;
  }
  // The caller's old image becomes the next decode target (same size: no allocation).
  std::swap(frame.gray, gray_);
  if (options_.keep_color) {
    bgr_.copyTo(frame.color);
  } else {
    frame.color.release();
  }
}

bool VideoFileSource::GrabTo(int target_index) {
  while (next_index_ < target_index) {
    if (!GrabOne()) return false;
    ++next_index_;
  }
  return true;
}

bool VideoFileSource::DecodeNextStep() {
  // The frame after the last delivered one may already be grabbed (look-ahead in Next).
  const int target = (lookahead_grabbed_ ? next_index_ - 2 : next_index_ - 1) + options_.step;
  bool ok;
  if (lookahead_grabbed_ && target == next_index_ - 1) {
    ok = RetrieveGrabbed();
    current_ts_ms_ = lookahead_ts_ms_;
  } else {
    ok = GrabTo(target) && GrabOne();
    if (ok) {
      ++next_index_;
      ok = RetrieveGrabbed();
    }
    current_ts_ms_ = GrabbedTimestampMs();
  }
  lookahead_grabbed_ = false;
  if (!ok) {
    done_ = true;
    if (frame_count_ > 0 && target < frame_count_ - 1) {
      warnings_.push_back(fmt::format(
          "video '{}' ended at frame {} but its header announces {} frames (truncated?)",
          path_.string(), next_index_, frame_count_));
    }
  }
  return ok;
}

bool VideoFileSource::LookAhead(int index) {
  if (GrabOne()) {
    ++next_index_;
    lookahead_grabbed_ = true;
    lookahead_ts_ms_ = GrabbedTimestampMs();
  } else if (frame_count_ > 0 && index < frame_count_ - 1) {
    done_ = true;
    warnings_.push_back(fmt::format(
        "video '{}' ended at frame {} but its header announces {} frames (truncated?); frame "
        "{}, the last one decoded, is dropped: a file cut mid-frame leaves it incomplete",
        path_.string(), index + 1, frame_count_, index));
    return false;
  }
  return true;
}

bool VideoFileSource::Next(Frame& frame) {
  if (done_) return false;
  int index;
  if (first_) {
    first_ = false;  // decoded at opening
    index = next_index_ - 1;
  } else {
    if (!DecodeNextStep()) return false;
    index = next_index_ - 1;
  }
  const double t = fps_ > 0.0                      ? index / fps_
                   : std::isfinite(current_ts_ms_) ? current_ts_ms_ / 1000.0
                                                   : 0.0;
  if (t > options_.end_time_s) {
    done_ = true;
    return false;
  }
  // Look-ahead: a file cut mid-frame ends with a partial packet that FFmpeg still decodes into
  // an incomplete or stale image (measured on a cut MJPG AVI: the last frame came out as a copy
  // of the one before, i.e. a silently wrong zero-motion step). So the next frame is grabbed
  // now; when the stream ends before its header's frame count, this last decoded frame is the
  // cut one and is dropped.
  if (!LookAhead(index)) return false;
  // The stream's clock going back, then on from there: recordings joined into one file (each
  // with its own clock, as when MPEG-TS files are concatenated). OpenCV 4.6 decodes the rest at
  // the first recording's size: a larger second recording as copies of the last frame (caught
  // below), a smaller one silently rescaled to the first size (measured: 640x360 then 320x240
  // delivered 320x240 content stretched to 640x360, every frame "different"). A clock that goes
  // back to 0 and stays there is OpenCV's end of stream (the decoder's last frames carry no
  // timestamp), hence the look-ahead frame must be later than this one.
  const double half_frame_ms = fps_ > 0.0 ? 500.0 / fps_ : 0.0;
  if (std::isfinite(last_ts_ms_) && std::isfinite(current_ts_ms_) && lookahead_grabbed_ &&
      current_ts_ms_ < last_ts_ms_ - half_frame_ms && lookahead_ts_ms_ > current_ts_ms_) {
    done_ = true;
    throw InputError(ClockWentBackMessage(path_.string(), index, last_ts_ms_, current_ts_ms_,
                                          width_, height_, cur_w_, cur_h_));
  }
  // A change of decoded size (ours sees every frame's own size; OpenCV's converts to the first
  // size, so only a larger frame that its swscale refuses would show here).
  if (cur_w_ != width_ || cur_h_ != height_) {
    done_ = true;
    throw InputError(SizeChangedMessage(path_.string(), index, width_, height_, cur_w_, cur_h_));
  }
  last_ts_ms_ = current_ts_ms_;
  DeliverTo(frame);
  // Repeated frames. The pixels are the only witness of a stale decoder: on a 320x240 + 640x360
  // MPEG-TS, OpenCV 4.6 returned copies of the last 320x240 frame for the whole second clip
  // while CAP_PROP_FRAME_WIDTH/HEIGHT kept saying 320x240 (FFmpeg's swscale refused the new
  // size, "Slice parameters 0, 360 are invalid", and the old buffer was handed back).
  frame.flags.clear();
  const std::uint64_t hash = PixelHash(frame.gray);
  if (have_hash_ && hash == last_hash_) {
    if (repeats_ == 0) freeze_index_ = last_index_;
    ++repeats_;
    if (moved_ && repeats_ >= kMaxRepeatedFrames) {
      done_ = true;
      throw InputError(StaleDecoderMessage(path_.string(), index, freeze_index_, repeats_));
    }
    AddFlag(frame.flags, kFrameFlagDuplicate);
    ++duplicates_;
  } else {
    if (have_hash_) moved_ = true;
    repeats_ = 0;
  }
  have_hash_ = true;
  last_hash_ = hash;
  last_index_ = index;
  frame.index = index;
  frame.time_s = t;
  frame.name = fmt::format("{}#{}", path_.filename().string(), index);
  return true;
}

std::string VideoFileSource::Describe() const {
  return fmt::format("video '{}' {}x{} @ {:.3f} fps, {} frames, step {}", path_.string(), width_,
                     height_, fps_, frame_count_, options_.step);
}

int VideoFileSource::ExpectedFrameCount() const {
  if (frame_count_ <= 0 || fps_ <= 0.0) return -1;
  const int first = static_cast<int>(std::ceil(options_.start_time_s * fps_ - 1e-6));
  int last = frame_count_ - 1;
  if (std::isfinite(options_.end_time_s)) {
    last = std::min(last, static_cast<int>(std::floor(options_.end_time_s * fps_ + 1e-6)));
  }
  return last < first ? 0 : (last - first) / options_.step + 1;
}

// ------------------------------------------------------------------------------ folder

namespace {

namespace fs = std::filesystem;

// The photos of `folder`, sorted by file name. Hidden files and (with skip_non_images) other
// files are skipped with a warning and counted; another file throws InputError, as do an
// unreadable folder and one without photos.
std::vector<fs::path> ListPhotos(const fs::path& folder, const FrameSourceOptions& options,
                                 int& skipped_files, std::vector<std::string>& warnings) {
  std::error_code ec;
  std::vector<fs::path> files;
  for (const auto& entry : fs::directory_iterator(folder, ec)) {
    if (!entry.is_regular_file(ec)) continue;
    const std::string fname = entry.path().filename().string();
    if (!fname.empty() && fname[0] == '.') {
      // Hidden files: macOS "._DJI_0001.JPG" resource forks, ".DS_Store", editor backups.
      ++skipped_files;
      warnings.push_back(fmt::format("skipped hidden file '{}'", entry.path().string()));
      continue;
    }
    if (IsImageExtension(entry.path())) {
      files.push_back(entry.path());
    } else if (options.skip_non_images) {
      ++skipped_files;
      warnings.push_back(fmt::format("skipped '{}': not a photo (.jpg .jpeg .png .tif .tiff)",
                                     entry.path().string()));
    } else {
      throw InputError(
          fmt::format("image folder '{}' contains '{}', which is not a photo "
                      "(.jpg .jpeg .png .tif .tiff)",
                      folder.string(), entry.path().filename().string()));
    }
  }
  if (ec) {
    throw InputError(
        fmt::format("cannot list image folder '{}': {}", folder.string(), ec.message()));
  }
  if (files.empty()) {
    throw InputError(fmt::format("image folder '{}' has no photos (.jpg .jpeg .png .tif .tiff)",
                                 folder.string()));
  }
  std::sort(files.begin(), files.end());
  return files;
}

struct PhotoEntry {
  fs::path path;
  ImageMetadata meta;
  ImageFileCheck check;
};

// Each photo's file check (a truncated photo is said now, also on stderr) and metadata (when
// unreadable: a warning and empty metadata).
std::vector<PhotoEntry> ReadPhotoEntries(const std::vector<fs::path>& files,
                                         std::vector<std::string>& warnings) {
  std::vector<PhotoEntry> entries;
  for (const auto& f : files) {
    PhotoEntry e{f, {}, CheckImageFile(f)};
    if (static_cast<double>(e.check.width_px) * e.check.height_px > kMaxImagePixels) {
      throw InputError(fmt::format("photo '{}': {}", f.string(), e.check.problem));
    }
    if (e.check.truncated) {
      // Said now, before any decoding: libjpeg's own "Premature end of JPEG file", printed when
      // the photo is decoded, names no file.
      const std::string w = fmt::format(
          "photo '{}' is {}: when it decodes at all, the missing part is filled in (libjpeg: "
          "grey) and its frame is flagged 'truncated'",
          f.string(), e.check.problem);
      std::cerr << "warning: " << w << std::endl;
      warnings.push_back(w);
    }
    try {
      e.meta = ReadImageMetadata(f);
    } catch (const InputError& err) {
      // The photo may still decode; its metadata is just unusable. Say so, keep going.
      e.meta = ImageMetadata();
      e.meta.source = f.string();
      warnings.push_back(fmt::format("metadata ignored: {}", err.what()));
    }
    entries.push_back(std::move(e));
  }
  return entries;
}

// The photos of each size ("4000x3000 (44 photos), 640x512 (44 photos)"), the first 6 sizes.
std::string ListSizes(const std::vector<PhotoEntry>& entries) {
  std::map<std::pair<int, int>, int> count;
  std::vector<std::pair<int, int>> order;
  for (const PhotoEntry& e : entries) {
    if (e.meta.width_px <= 0 || e.meta.height_px <= 0) continue;
    if (count[{e.meta.width_px, e.meta.height_px}]++ == 0) {
      order.emplace_back(e.meta.width_px, e.meta.height_px);
    }
  }
  std::string listed;
  for (std::size_t k = 0; k < order.size() && k < 6; ++k) {
    const int n = count[order[k]];
    listed += fmt::format("{}{}x{} ({} photo{})", k ? ", " : "", order[k].first, order[k].second, n,
                          n == 1 ? "" : "s");
  }
  if (order.size() > 6) listed += fmt::format(" and {} more", order.size() - 6);
  return listed;
}

// FrameSourceOptions::photo_band as a photo size "WxH" (640x512), when it is one.
std::optional<std::pair<int, int>> SizeOfBand(std::string_view band) {
  const std::size_t x = band.find_first_of("xX");
  if (x == std::string_view::npos || x == 0 || x + 1 >= band.size() || x > 6 ||
      band.size() - x - 1 > 6) {
    return std::nullopt;
  }
  const auto digits = [](std::string_view t) {
    return std::all_of(t.begin(), t.end(), [](char c) { return c >= '0' && c <= '9'; });
  };
  const std::string_view w = band.substr(0, x), h = band.substr(x + 1);
  if (!digits(w) || !digits(h)) return std::nullopt;
  return std::pair{std::stoi(std::string(w)), std::stoi(std::string(h))};
}

// Keeps the photos of the size FrameSourceOptions::photo_band names ("640x512"), saying so in
// `warnings`; InputError listing the sizes when none has it.
void SelectSize(std::vector<PhotoEntry>& entries, std::pair<int, int> size, const fs::path& folder,
                std::vector<std::string>& warnings) {
  const auto other = [&](const PhotoEntry& e) {
    return e.meta.width_px != size.first || e.meta.height_px != size.second;
  };
  const auto kept =
      std::count_if(entries.begin(), entries.end(), [&](const PhotoEntry& e) { return !other(e); });
  if (kept == 0) {
    throw InputError(
        fmt::format("image folder '{}': photo_band {}x{} but no photo has that size "
                    "(the folder has {})",
                    folder.string(), size.first, size.second, ListSizes(entries)));
  }
  warnings.push_back(fmt::format(
      "image folder '{}': the {} photos of {}x{} are read, the {} of other sizes skipped "
      "(photo_band {}x{}; the folder has {})",
      folder.string(), kept, size.first, size.second,
      static_cast<std::ptrdiff_t>(entries.size()) - kept, size.first, size.second,
      ListSizes(entries)));
  entries.erase(std::remove_if(entries.begin(), entries.end(), other), entries.end());
}

// The camera of a multi-camera payload a photo names: its band (XMP Camera:BandName,
// multispectral cameras), else its camera (DJI drone-dji:ImageSource, payloads with wide, zoom
// and thermal cameras); empty when it names neither.
const std::string& PayloadCameraOf(const ImageMetadata& m) {
  return m.band_name.empty() ? m.image_source : m.band_name;
}

// A band or camera name as FrameSourceOptions::photo_band compares it: lower case, without spaces,
// '_' and '-'; "rgb" for a photo that names none.
std::string BandKey(std::string_view name) {
  std::string k;
  for (char c : name) {
    if (c != ' ' && c != '_' && c != '-') {
      k += (c >= 'A' && c <= 'Z') ? static_cast<char>(c - 'A' + 'a') : c;
    }
  }
  return k.empty() ? "rgb" : k;
}

// FrameSourceOptions::photo_band as BandKey, with the short names of DJI's cameras ("wide",
// "zoom", "thermal" or "infrared" for WideCamera, ZoomCamera, InfraredCamera).
std::string WantedBandKey(std::string_view name) {
  const std::string k = BandKey(name);
  if (k == "wide") return "widecamera";
  if (k == "zoom") return "zoomcamera";
  if (k == "thermal" || k == "infrared") return "infraredcamera";
  return k;
}

// The cameras of a payload in a folder, in the payload's order (Camera:RigCameraIndex, else the
// first photo's place in file-name order).
struct RigBand {
  std::string name;  // as the first photo of the band writes it; "RGB" for none
  std::string key;   // BandKey
  int count = 0;
  int order = 0;
};

// Keeps the photos of one camera when `entries` (in file-name order) hold the photos of a
// multi-camera payload, several per capture (FrameSourceOptions::photo_band), saying so in
// `warnings`; `band` gets the one read. The payload's photos are those that name their band or
// camera (PayloadCameraOf) and the others of the same make and model (DJI P4 Multispectral's RGB
// JPEGs name none); any other photo is left for the flight split to judge. A folder whose photos
// name none is left as it is.
void SelectBand(std::vector<PhotoEntry>& entries, const FrameSourceOptions& options,
                const fs::path& folder, std::vector<std::string>& warnings, std::string& band) {
  std::set<std::string> payload_models;
  for (const PhotoEntry& e : entries) {
    if (!PayloadCameraOf(e.meta).empty()) payload_models.insert(e.meta.make + " " + e.meta.model);
  }
  if (payload_models.empty()) {
    if (const auto size = SizeOfBand(options.photo_band)) {
      SelectSize(entries, *size, folder, warnings);
      band = fmt::format("{}x{}", size->first, size->second);
      return;
    }
    if (!options.photo_band.empty()) {
      throw InputError(fmt::format(
          "image folder '{}': photo_band '{}' but no photo names its band or camera (XMP "
          "Camera:BandName or drone-dji:ImageSource, written by multispectral cameras and DJI's "
          "payloads of several cameras): the folder is one camera's",
          folder.string(), Printable(options.photo_band, 40)));
    }
    return;
  }
  const auto in_payload = [&](const ImageMetadata& m) {
    return !PayloadCameraOf(m).empty() || payload_models.count(m.make + " " + m.model) > 0;
  };
  // A multispectral camera's photos that name no band are its RGB camera's (DJI P4
  // Multispectral); in a payload that names cameras they are just unnamed.
  const bool multispectral = std::any_of(entries.begin(), entries.end(), [](const PhotoEntry& e) {
    return !e.meta.band_name.empty();
  });
  const char* const unnamed = multispectral ? "RGB" : "(no camera named)";
  std::vector<RigBand> bands;
  std::map<std::string, std::size_t> band_of_key;  // a folder may name many bands: no scan
  int payload_photos = 0;
  for (std::size_t i = 0; i < entries.size(); ++i) {
    const ImageMetadata& m = entries[i].meta;
    if (!in_payload(m)) continue;
    ++payload_photos;
    const std::string& named = PayloadCameraOf(m);
    const std::string key = BandKey(named);
    const int order = m.rig_camera_index ? *m.rig_camera_index : 1001 + static_cast<int>(i);
    const auto [it, added] = band_of_key.emplace(key, bands.size());
    if (added) bands.push_back({named.empty() ? unnamed : named, key, 0, order});
    RigBand& b = bands[it->second];
    ++b.count;
    b.order = std::min(b.order, order);
  }
  std::stable_sort(bands.begin(), bands.end(),
                   [](const RigBand& a, const RigBand& b) { return a.order < b.order; });
  // The cameras and their photos, for messages (the first 12: a payload has 2 to 10).
  constexpr std::size_t kListedBands = 12;
  std::string listed;
  for (std::size_t k = 0; k < bands.size() && k < kListedBands; ++k) {
    listed += fmt::format("{}{} ({} photo{})", k ? ", " : "", bands[k].name, bands[k].count,
                          bands[k].count == 1 ? "" : "s");
  }
  if (bands.size() > kListedBands) {
    listed += fmt::format(" and {} more", bands.size() - kListedBands);
  }
  const RigBand* chosen = nullptr;
  if (!options.photo_band.empty()) {
    const std::string want = WantedBandKey(options.photo_band);
    for (const RigBand& b : bands) {
      if (b.key == want) chosen = &b;
    }
    if (chosen == nullptr) {
      throw InputError(fmt::format(
          "image folder '{}': photo_band '{}' is none of the bands or cameras its photos name "
          "(XMP Camera:BandName or drone-dji:ImageSource): {}",
          folder.string(), Printable(options.photo_band, 40), listed));
    }
  } else {
    // A DJI payload's wide (or visible) camera, RGB, green, blue: the most ground in the most
    // detail; for multispectral cameras OpenDroneMap's order. A payload's photos that name no
    // camera come after its wide camera (a photo whose XMP was stripped is not the payload's RGB).
    for (const auto& aliases :
         {std::vector<std::string>{"widecamera"},
          std::vector<std::string>{"visiblecamera", "visible"},
          std::vector<std::string>{"rgb", "redgreenblue"}, std::vector<std::string>{"green", "g"},
          std::vector<std::string>{"blue", "b"}}) {
      for (const RigBand& b : bands) {
        if (chosen == nullptr &&
            std::find(aliases.begin(), aliases.end(), b.key) != aliases.end()) {
          chosen = &b;
        }
      }
    }
    if (chosen == nullptr) chosen = &bands.front();
  }
  band = chosen->name;
  const std::string key = chosen->key;
  if (bands.size() > 1) {
    warnings.push_back(fmt::format(
        "image folder '{}' holds the photos of {} cameras of one payload (their band or camera, "
        "XMP Camera:BandName or drone-dji:ImageSource: {}): the {} photos of {} are read, the {} "
        "of the others skipped ({})",
        folder.string(), bands.size(), listed, chosen->count, band, payload_photos - chosen->count,
        options.photo_band.empty() ? "photo_band chooses another" : "photo_band"));
  }
  const auto skipped = [&](const PhotoEntry& e) {
    return in_payload(e.meta) && BandKey(PayloadCameraOf(e.meta)) != key;
  };
  // Captures (ImageMetadata::capture_id) without a photo of the camera read.
  std::vector<std::string> read_captures;
  for (const PhotoEntry& e : entries) {
    if (!e.meta.capture_id.empty() && !skipped(e)) read_captures.push_back(e.meta.capture_id);
  }
  std::sort(read_captures.begin(), read_captures.end());
  std::set<std::string> missing_ids;
  std::vector<std::string> missing_names;
  for (const PhotoEntry& e : entries) {
    const std::string& id = e.meta.capture_id;
    if (id.empty() || std::binary_search(read_captures.begin(), read_captures.end(), id) ||
        !missing_ids.insert(id).second) {
      continue;
    }
    missing_names.push_back(e.path.filename().string());
  }
  if (!missing_ids.empty() && !read_captures.empty()) {
    std::string names;
    for (std::size_t k = 0; k < missing_names.size() && k < 3; ++k) {
      names += fmt::format("{}'{}'", k ? ", " : "", missing_names[k]);
    }
    warnings.push_back(fmt::format(
        "image folder '{}': {} capture{} {} no photo of {} and {} not read (the capture of {}{})",
        folder.string(), missing_ids.size(), missing_ids.size() == 1 ? "" : "s",
        missing_ids.size() == 1 ? "has" : "have", band, missing_ids.size() == 1 ? "is" : "are",
        names, missing_names.size() > 3 ? ", ..." : ""));
  }
  entries.erase(std::remove_if(entries.begin(), entries.end(), skipped), entries.end());
}

std::string CameraOf(const ImageMetadata& m) {
  std::string c = fmt::format("{} {}", m.make, m.model);
  if (!m.serial_number.empty()) c += fmt::format(" serial {}", m.serial_number);
  return c;
}

// The flights of a photo sequence: start[k] is the first photo of flight k (then one past the
// last photo), reason[k] why flight k + 1 starts, naming both photos.
struct PhotoFlights {
  std::vector<std::size_t> start;
  std::vector<std::string> reason;
  int count() const { return static_cast<int>(start.size()) - 1; }
};

// A new flight starts at a photo from another camera or after a gap over photo_gap_s; a pause
// over a minute that is chained is said in `warnings`.
PhotoFlights SplitFlights(const std::vector<PhotoEntry>& entries, bool all_timed,
                          const FrameSourceOptions& options, const fs::path& folder,
                          std::vector<std::string>& warnings) {
  constexpr double kLongPhotoPauseS = 60.0;
  PhotoFlights flights{{0}, {}};
  // A photo whose metadata says nothing of its camera (unreadable, stripped) changes no flight.
  std::size_t last_known = entries.size();
  for (std::size_t i = 0; i < entries.size(); ++i) {
    if (!entries[i].meta.make.empty() || !entries[i].meta.model.empty()) {
      last_known = i;
      break;
    }
  }
  for (std::size_t i = 1; i < entries.size(); ++i) {
    const ImageMetadata& a = entries[i - 1].meta;
    const ImageMetadata& b = entries[i].meta;
    const std::string name_a = entries[i - 1].path.filename().string();
    const std::string name_b = entries[i].path.filename().string();
    const bool b_known = !b.make.empty() || !b.model.empty();
    std::string reason;
    if (b_known && last_known < i && CameraOf(entries[last_known].meta) != CameraOf(b)) {
      reason = fmt::format("'{}' is from another camera ({}) than '{}' ({})", name_b, CameraOf(b),
                           entries[last_known].path.filename().string(),
                           CameraOf(entries[last_known].meta));
    } else if (all_timed && options.photo_gap_s > 0.0 &&
               *b.capture_unix_time_s - *a.capture_unix_time_s > options.photo_gap_s) {
      reason = fmt::format(
          "'{}' was taken {:.0f} s after '{}' (a gap longer than photo_gap_s {} s)", name_b,
          *b.capture_unix_time_s - *a.capture_unix_time_s, name_a, options.photo_gap_s);
    }
    if (reason.empty() && all_timed &&
        *b.capture_unix_time_s - *a.capture_unix_time_s > kLongPhotoPauseS) {
      warnings.push_back(fmt::format(
          "image folder '{}': '{}' was taken {:.0f} s after '{}': chained as one flight (a "
          "pause shorter than photo_gap_s {} s)",
          folder.string(), name_b, *b.capture_unix_time_s - *a.capture_unix_time_s, name_a,
          options.photo_gap_s));
    }
    if (b_known) last_known = i;
    if (!reason.empty()) {
      flights.start.push_back(i);
      flights.reason.push_back(std::move(reason));
    }
  }
  flights.start.push_back(entries.size());
  return flights;
}

std::string DescribeFlights(const std::vector<PhotoEntry>& entries, const PhotoFlights& flights) {
  std::string d;
  for (int k = 0; k < flights.count(); ++k) {
    const std::size_t first = flights.start[k], end = flights.start[k + 1];
    d += fmt::format("{}flight {}: {} photos, '{}' to '{}'", k ? "; " : "", k + 1, end - first,
                     entries[first].path.filename().string(),
                     entries[end - 1].path.filename().string());
  }
  return d;
}

// Keeps the flight FrameSourceOptions::photo_flight asks for (all of them chained: -1), or
// throws InputError when the folder holds several and none was chosen, or fewer than asked.
void SelectFlight(std::vector<PhotoEntry>& entries, const PhotoFlights& flights,
                  const FrameSourceOptions& options, const fs::path& folder,
                  std::vector<std::string>& warnings) {
  const int count = flights.count();
  if (count > 1 && options.photo_flight == 0) {
    throw InputError(fmt::format(
        "image folder '{}' holds {} flights, which would be chained as one: {} ({}); give "
        "--photo-flight K to process flight K alone, or --photo-flight -1 to chain them",
        folder.string(), count, flights.reason.front(), DescribeFlights(entries, flights)));
  }
  if (options.photo_flight > count) {
    throw InputError(
        fmt::format("image folder '{}': photo_flight {} but the folder holds {} "
                    "flight{} ({})",
                    folder.string(), options.photo_flight, count, count == 1 ? "" : "s",
                    DescribeFlights(entries, flights)));
  }
  if (count > 1 && options.photo_flight >= 1) {
    const int k = options.photo_flight - 1;
    warnings.push_back(fmt::format("image folder '{}': processing flight {} of {} ({})",
                                   folder.string(), k + 1, count,
                                   DescribeFlights(entries, flights)));
    entries.erase(entries.begin() + static_cast<std::ptrdiff_t>(flights.start[k + 1]),
                  entries.end());
    entries.erase(entries.begin(), entries.begin() + static_cast<std::ptrdiff_t>(flights.start[k]));
  } else if (count > 1) {
    warnings.push_back(fmt::format("image folder '{}': {} flights chained as one ({}): {}",
                                   folder.string(), count, DescribeFlights(entries, flights),
                                   flights.reason.front()));
  }
}

// Throws InputError when two photos whose size is known differ in size.
void CheckOneSize(const std::vector<PhotoEntry>& entries, const fs::path& folder) {
  const PhotoEntry* sized = nullptr;
  for (const PhotoEntry& e : entries) {
    if (e.meta.width_px <= 0 || e.meta.height_px <= 0) continue;
    if (!sized) {
      sized = &e;
    } else if (e.meta.width_px != sized->meta.width_px ||
               e.meta.height_px != sized->meta.height_px) {
      throw InputError(fmt::format(
          "image folder '{}': photo '{}' is {}x{} but '{}' is {}x{} (mixed resolutions; all "
          "photos must have the same size; the folder has {}): the photos of a payload of "
          "cameras that do not name theirs (a Zenmuse XT2's visible and thermal photos)? give "
          "--photo-band WxH to read the photos of one size",
          folder.string(), e.path.filename().string(), e.meta.width_px, e.meta.height_px,
          sized->path.filename().string(), sized->meta.width_px, sized->meta.height_px,
          ListSizes(entries)));
    }
  }
}

}  // namespace

ImageFolderSource::ImageFolderSource(const std::filesystem::path& folder,
                                     const FrameSourceOptions& options)
    : folder_(folder), options_(options) {
  Validate(options_);
  std::error_code ec;
  if (!std::filesystem::is_directory(folder, ec)) {
    throw InputError(
        fmt::format("cannot open image folder '{}': not a directory", folder.string()));
  }
  const std::vector<fs::path> files = ListPhotos(folder, options_, skipped_files_, warnings_);
  std::vector<PhotoEntry> entries = ReadPhotoEntries(files, warnings_);
  // One band of a rig before anything else: the other bands' photos share its capture times
  // and may name other cameras.
  SelectBand(entries, options_, folder, warnings_, band_);
  const bool all_timed = std::all_of(entries.begin(), entries.end(), [](const PhotoEntry& e) {
    return e.meta.capture_unix_time_s.has_value();
  });
  if (all_timed) {
    std::stable_sort(entries.begin(), entries.end(), [](const PhotoEntry& a, const PhotoEntry& b) {
      return *a.meta.capture_unix_time_s < *b.meta.capture_unix_time_s;
    });
  } else {
    warnings_.push_back(fmt::format(
        "image folder '{}': not every photo has an EXIF capture time: ordered by file name",
        folder.string()));
  }
  const PhotoFlights flights = SplitFlights(entries, all_timed, options_, folder, warnings_);
  flight_count_ = flights.count();
  SelectFlight(entries, flights, options_, folder, warnings_);
  CheckOneSize(entries, folder);
  for (std::size_t i = 0; i < entries.size(); ++i) {
    paths_.push_back(entries[i].path);
    checks_.push_back(std::move(entries[i].check));
    metadata_.push_back(std::move(entries[i].meta));
  }
  // The photos' times as their telemetry has them (TelemetryFromImages): shared capture times
  // spread within the second.
  times_ = PhotoTimes(metadata_);
  // First photo at or after the start time.
  while (next_ < paths_.size() && times_[next_] < options_.start_time_s) ++next_;
  // The image decoders (imageio/image_io.h: a plugin loaded on first use) are loaded here, with
  // the folder, not by the first frame: a missing plugin is an error when the source is opened,
  // and their one-time loading is not counted in the run's per-frame time.
  if (!paths_.empty()) imageio::PluginPath();
}

bool ImageFolderSource::Next(Frame& frame) {
  if (next_ >= paths_.size() || times_[next_] > options_.end_time_s) return false;
  const std::size_t i = next_;
  next_ += static_cast<std::size_t>(options_.step);
  Read(i, frame);
  return true;
}

void ImageFolderSource::Read(std::size_t i, Frame& frame) {
  if (i >= paths_.size()) {
    throw InvalidArgument(fmt::format("ImageFolderSource::Read: photo {} of {}", i, paths_.size()));
  }
  const std::string name = paths_[i].filename().string();
  const ImageFileCheck& check = checks_[i];
  if (!check.problem.empty() && !check.truncated) {
    throw InputError(fmt::format("cannot decode photo '{}' (frame {}): {}", paths_[i].string(), i,
                                 check.problem));
  }
  // Pixel geometry as stored: a nadir camera's EXIF orientation must not rotate the frames.
  // More than 8 bits per sample (multispectral bands, radiometric thermal TIFFs): the photo's
  // own range onto 8 bits (ToEightBit), not OpenCV's high byte.
  const cv::Mat bgr = ToEightBit(imageio::Read(
      paths_[i].string(), cv::IMREAD_COLOR | cv::IMREAD_IGNORE_ORIENTATION | cv::IMREAD_ANYDEPTH));
  if (bgr.empty()) {
    throw InputError(fmt::format("cannot decode photo '{}' (frame {}): {}", paths_[i].string(), i,
                                 check.truncated ? check.problem : "not an image or damaged"));
  }
  if (width_ == 0) {
    width_ = bgr.cols;
    height_ = bgr.rows;
  } else if (bgr.cols != width_ || bgr.rows != height_) {
    throw InputError(
        fmt::format("photo '{}' (frame {}) is {}x{} but the sequence is {}x{} (mixed "
                    "resolutions)",
                    paths_[i].string(), i, bgr.cols, bgr.rows, width_, height_));
  }
  FillFrame(bgr, options_.keep_color, frame);
  frame.flags.clear();
  if (check.truncated) AddFlag(frame.flags, kFrameFlagTruncated);
  // A photo copied under another name (or shot twice): its step would read as a true standstill.
  const std::uint64_t hash = PixelHash(frame.gray);
  if (have_hash_ && hash == last_hash_) AddFlag(frame.flags, kFrameFlagDuplicate);
  have_hash_ = true;
  last_hash_ = hash;
  frame.index = static_cast<int>(i);
  frame.time_s = times_[i];
  frame.name = name;
}

std::string ImageFolderSource::Describe() const {
  return fmt::format("image folder '{}': {} photos, {} other files skipped, step {}",
                     folder_.string(), paths_.size(), skipped_files_, options_.step);
}

int ImageFolderSource::ExpectedFrameCount() const {
  std::size_t first = 0;
  while (first < times_.size() && times_[first] < options_.start_time_s) ++first;
  std::size_t end = first;
  while (end < times_.size() && times_[end] <= options_.end_time_s) ++end;
  if (end <= first) return 0;
  return static_cast<int>((end - first - 1) / static_cast<std::size_t>(options_.step) + 1);
}

// ------------------------------------------------------------------------------ live

LiveSource::LiveSource(int camera_index, const FrameSourceOptions& options)
    : spec_(std::to_string(camera_index)), options_(options) {
  Validate(options_);
  if (camera_index < 0) {
    throw InputError(fmt::format("cannot open live source '{}': negative camera index", spec_));
  }
  capture_.open(camera_index);
  Init();
}

LiveSource::LiveSource(const std::string& device_or_url, const FrameSourceOptions& options)
    : spec_(device_or_url), options_(options) {
  Validate(options_);
  // FFmpeg reads streams (rtsp, http, udp, files); V4L2 reads device nodes. Naming the backend
  // avoids OpenCV's fallback through every backend (GStreamer's noisy, leaky pipeline setup).
  const bool device = device_or_url.rfind("/dev/", 0) == 0;
  capture_.open(device_or_url, device ? cv::CAP_V4L2 : cv::CAP_FFMPEG);
  Init();
}

void LiveSource::Init() {
  if (!capture_.isOpened()) {
    throw InputError(fmt::format(
        "cannot open live source '{}': no such camera/device, or the stream is unreachable",
        spec_));
  }
  t0_ = SteadySeconds();
}

bool LiveSource::Next(Frame& frame) {
  while (!done_) {
    // Drop the frames between two delivered ones without decoding them.
    bool ok = true;
    if (next_index_ > 0) {
      for (int i = 1; i < options_.step && ok; ++i, ++next_index_) ok = capture_.grab();
    }
    ok = ok && capture_.read(bgr_) && !bgr_.empty();
    if (!ok) {
      done_ = true;
      warnings_.push_back(
          fmt::format("live source '{}' stopped after {} frames", spec_, next_index_));
      return false;
    }
    const int index = next_index_++;
    std::string unusable;
    const double t =
        times_.Next(SteadySeconds() - t0_, capture_.get(cv::CAP_PROP_POS_MSEC), &unusable);
    if (!unusable.empty() && times_.arrival_steps() == 1) {
      warnings_.push_back(fmt::format(
          "live source '{}': frame {} has no usable presentation time ({}): timed by its "
          "arrival when so",
          spec_, index, unusable));
    }
    if (t < options_.start_time_s) continue;
    if (t > options_.end_time_s) {
      done_ = true;
      return false;
    }
    FillFrame(bgr_, options_.keep_color, frame);
    frame.flags.clear();
    const std::uint64_t hash = PixelHash(frame.gray);
    if (have_hash_ && hash == last_hash_) AddFlag(frame.flags, kFrameFlagDuplicate);
    have_hash_ = true;
    last_hash_ = hash;
    frame.index = index;
    frame.time_s = t;
    frame.name = fmt::format("live#{}", index);
    return true;
  }
  return false;
}

double LiveFrameTimes::Next(double arrival_s, double stream_ms, std::string* unusable) {
  // A step of the source's own time counts when it moves forward by no more than the arrival did
  // plus kMaxEarlyS: frames buffered at a stream's start arrive together, but a jump of minutes
  // (a restarted sender, a timestamp wrap) is not the flight's time.
  constexpr double kMaxEarlyS = 1.0;
  const double stream_s = stream_ms / 1000.0;
  double t = arrival_s;
  if (have_) {
    const double arrival_step_s = arrival_s - last_arrival_s_;
    const double stream_step_s = stream_s - last_stream_s_;
    const bool usable = std::isfinite(stream_step_s) && stream_step_s > 0.0 &&
                        stream_step_s <= arrival_step_s + kMaxEarlyS;
    t = last_time_s_ + (usable ? stream_step_s : std::max(arrival_step_s, 1e-6));
    if (!usable) {
      ++arrival_steps_;
      if (unusable != nullptr) {
        *unusable = fmt::format("{:.3f} s after the previous frame's, arrived {:.3f} s after it",
                                stream_step_s, arrival_step_s);
      }
    }
  }
  have_ = true;
  last_arrival_s_ = arrival_s;
  last_stream_s_ = stream_s;
  last_time_s_ = t;
  return t;
}

std::string LiveSource::Describe() const {
  return fmt::format("live source '{}' ({}x{}), step {}", spec_,
                     static_cast<int>(capture_.get(cv::CAP_PROP_FRAME_WIDTH)),
                     static_cast<int>(capture_.get(cv::CAP_PROP_FRAME_HEIGHT)), options_.step);
}

// ------------------------------------------------------------------------------ factory

std::unique_ptr<FrameSource> OpenFrameSource(const std::string& spec,
                                             const FrameSourceOptions& options) {
  if (spec.empty()) throw InputError("empty frame source");
  if (std::all_of(spec.begin(), spec.end(), [](char c) { return c >= '0' && c <= '9'; }) &&
      spec.size() <= 4) {
    return std::make_unique<LiveSource>(std::stoi(spec), options);
  }
  if (spec.find("://") != std::string::npos || spec.rfind("/dev/", 0) == 0) {
    return std::make_unique<LiveSource>(spec, options);
  }
  const std::filesystem::path path(spec);
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) {
    return std::make_unique<ImageFolderSource>(path, options);
  }
  if (std::filesystem::exists(path, ec)) return std::make_unique<VideoFileSource>(path, options);
  throw InputError(fmt::format("frame source '{}': no such file or directory", spec));
}

}  // namespace aerovo
