// A video file decoded with FFmpeg's libraries (libavformat + libavcodec + libswscale), frame
// by frame, delivering 8-bit grey straight from the decoder's luma plane (no BGR on the way).
// Used by VideoFileSource (frames/frame_source.h) when FrameSourceOptions::video_decoder is auto or
// ffmpeg. The FFmpeg headers stay in video_decoder.cc (linked PRIVATE to aerovo_frames).
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>

#include <opencv2/core.hpp>

#include "aerovo/core/image.h"

namespace aerovo {

/// One video stream of a file, decoded in order. RAII: the demuxer, decoder, packet, frame and
/// swscale contexts are freed by the destructor. Not copyable; not thread-safe (one thread at a
/// time, e.g. PrefetchSource's reader thread).
///
/// Grey (Gray()): for 8-bit YUV formats (yuv420p, yuvj420p, nv12, yuv422p, yuv444p, gray...)
/// the luma plane Y' itself, which the encoder computed as Y' = Kr R' + Kg G' + Kb B' with the
/// stream's own colour matrix (BT.601: 0.299 0.587 0.114; BT.709: 0.2126 0.7152 0.0722: the
/// luminance equations of ITU-R BT.601-7 and BT.709-6), so no matrix is applied here and none
/// can be wrong (OpenCV's path, YUV -> BGR -> grey, clips saturated colours). Range:
/// full-range ("pc", JPEG; AVCOL_RANGE_JPEG or a yuvj format) is copied as is; limited range
/// ("tv", AVCOL_RANGE_MPEG, and the default of non-yuvj formats as in FFmpeg) has Y' in
/// [16, 235] (the recommendations' 8-bit quantisation, Y' = 219 E'Y + 16) and is mapped exactly
/// to full range by grey = clamp(round((Y' - 16) * 255 / 219), 0, 255) (LimitedToFullLuma).
/// Other formats
/// (10-bit, packed YUYV, RGB, palette) go through swscale to GRAY8 with the frame's source range
/// and colour matrix (swscale's default BT.601 when the stream states none), full-range output.
/// Colour (Bgr()): swscale to BGR24 with the frame's matrix and range, for keep_color only.
///
/// Errors: the constructor throws InputError "cannot open video '<path>': <reason>" when FFmpeg
/// cannot read the file, finds no video stream or has no decoder for it, or when the stream's
/// frames have more than kMaxImagePixels (frames/image_file.h; a larger frame met later is not
/// allocated by FFmpeg: AVCodecContext::max_pixels, a packet that does not decode). Grab()
/// returns false at
/// the end of the stream, also after kMaxFailedPackets packets in a row that do not decode (a
/// damaged stream); failed_packets() counts the packets the decoder refused.
class VideoDecoder {
 public:
  /// `threads`: the codec's thread count (frame + slice threading); 0 = FFmpeg's choice (one
  /// per core), 1 = decode on the calling thread only.
  explicit VideoDecoder(const std::filesystem::path& path, int threads);
  ~VideoDecoder();
  VideoDecoder(const VideoDecoder&) = delete;
  VideoDecoder& operator=(const VideoDecoder&) = delete;

  /// Frames per second from the stream (its average frame rate, else FFmpeg's guess from the
  /// stream's timing: av_guess_frame_rate); 0 when unknown.
  double fps() const { return fps_; }
  /// Frames from the container's header, else round(duration * fps); 0 when unknown (both as
  /// OpenCV's FFmpeg backend computes CAP_PROP_FRAME_COUNT, so a cut file is found the same way).
  int frame_count() const { return frame_count_; }
  /// Coded size from the stream's header, pixels (a decoded frame may differ: frame_width()).
  int width() const { return width_; }
  int height() const { return height_; }
  /// Rotation for display from the stream's display matrix, degrees clockwise in [0, 360)
  /// (0 when there is none); frames are never rotated here.
  int rotation_deg() const { return rotation_deg_; }
  /// The decoder's name ("h264", "mpeg2video", "mjpeg"...).
  const std::string& codec_name() const { return codec_name_; }
  /// Threads the codec was opened with (after FFmpeg's choice for 0).
  int threads() const;

  /// Decodes the next frame (no conversion). False at the end of the stream.
  bool Grab();
  /// Moves to the key frame at or before `time_s` (seconds from the stream's start time, the
  /// clock of timestamp_ms()) with the demuxer's seek (av_seek_frame, AVSEEK_FLAG_BACKWARD; the
  /// decoder flushed): the next Grab() returns that key frame, whose own timestamp_ms() says
  /// where it landed. False when the file cannot seek (nothing moved).
  bool SeekBefore(double time_s);
  /// From the next packet on, frames no other frame refers to (non-reference B frames) are not
  /// decoded at all (AVCodecContext::skip_frame AVDISCARD_NONREF; `skip` false: every frame,
  /// the default). The frames still decoded are decoded exactly as without; Grab() returns the
  /// next decoded one, so its timestamp_ms() says which.
  void SkipNonReferenceFrames(bool skip);
  /// Of the frame Grab() last returned: its own decoded size, pixels.
  int frame_width() const;
  int frame_height() const;
  /// Of the frame Grab() last returned: its presentation time, ms from the stream's start time
  /// ((best-effort pts - stream start_time) * time_base; CAP_PROP_POS_MSEC's rule); NaN when
  /// the frame carries no timestamp.
  double timestamp_ms() const;
  /// The frame Grab() last returned as grey (see the class comment) into `out`, reusing its
  /// storage when the size matches. Precondition: Grab() returned true.
  void Gray(GrayImage& out);
  /// The same frame as 8-bit BGR into `out` (reallocated only when the size changes).
  void Bgr(cv::Mat& out);
  /// The limited-to-full range rule for one luma value: clamp(round((y - 16) * 255 / 219), 0,
  /// 255) with halves rounded up, computed as ((clamp(y - 16, 0, 219) * 2385 + 986) >> 11),
  /// integer arithmetic the compiler vectorises (equal to the rule for all 256 values; tested).
  static constexpr std::uint8_t LimitedToFullLuma(int y) {
    const int v = y < 16 ? 0 : (y > 235 ? 219 : y - 16);
    return static_cast<std::uint8_t>((v * 2385 + 986) >> 11);
  }
  /// Packets the decoder refused so far (damaged data).
  int failed_packets() const { return failed_packets_; }
  /// Packets in a row without a frame after which Grab() gives up (OpenCV's grab() limit too).
  static constexpr int kMaxFailedPackets = 512;

 private:
  struct Av;  // the FFmpeg objects (video_decoder.cc)
  std::unique_ptr<Av> av_;
  double fps_ = 0.0;
  int frame_count_ = 0;
  int width_ = 0, height_ = 0;
  int rotation_deg_ = 0;
  std::string codec_name_;
  int failed_packets_ = 0;
};

}  // namespace aerovo
