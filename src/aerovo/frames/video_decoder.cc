#include "aerovo/frames/video_decoder.h"

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>

#include <fmt/format.h>

extern "C" {
#include <libavcodec/avcodec.h>
#include <libavformat/avformat.h>
#include <libavutil/display.h>
#include <libavutil/pixdesc.h>
#include <libswscale/swscale.h>
}

#include "aerovo/core/error.h"
#include "aerovo/frames/av_error.h"
#include "aerovo/frames/image_file.h"

namespace aerovo {
namespace {

using frames_detail::AvErrorText;

double Rational(AVRational r) { return r.den == 0 ? 0.0 : static_cast<double>(r.num) / r.den; }

// True when plane 0 of `fmt` holds 8-bit luma, one byte per pixel (planar or semi-planar YUV,
// grey): the Y' plane can be read directly.
bool HasPlainLumaPlane(AVPixelFormat fmt) {
  const AVPixFmtDescriptor* d = av_pix_fmt_desc_get(fmt);
  if (d == nullptr || d->nb_components < 1) return false;
  if (d->flags & (AV_PIX_FMT_FLAG_RGB | AV_PIX_FMT_FLAG_PAL | AV_PIX_FMT_FLAG_BITSTREAM |
                  AV_PIX_FMT_FLAG_HWACCEL | AV_PIX_FMT_FLAG_FLOAT | AV_PIX_FMT_FLAG_BAYER)) {
    return false;
  }
  const AVComponentDescriptor& y = d->comp[0];
  return y.plane == 0 && y.depth == 8 && y.step == 1 && y.shift == 0 && y.offset == 0;
}

// Full range: the frame says so, or a deprecated yuvj format (full range by definition).
bool IsFullRange(const AVFrame* f) {
  if (f->color_range == AVCOL_RANGE_JPEG) return true;
  if (f->color_range == AVCOL_RANGE_MPEG) return false;
  const auto fmt = static_cast<AVPixelFormat>(f->format);
  return fmt == AV_PIX_FMT_YUVJ420P || fmt == AV_PIX_FMT_YUVJ422P || fmt == AV_PIX_FMT_YUVJ444P ||
         fmt == AV_PIX_FMT_YUVJ440P || fmt == AV_PIX_FMT_YUVJ411P;
}

// The swscale colour table of the frame's matrix (swscale's default, BT.601, when unstated).
const int* SwsTable(const AVFrame* f) {
  int cs = SWS_CS_DEFAULT;
  switch (f->colorspace) {
    case AVCOL_SPC_BT709:
      cs = SWS_CS_ITU709;
      break;
    case AVCOL_SPC_FCC:
      cs = SWS_CS_FCC;
      break;
    case AVCOL_SPC_SMPTE240M:
      cs = SWS_CS_SMPTE240M;
      break;
    case AVCOL_SPC_BT2020_NCL:
    case AVCOL_SPC_BT2020_CL:
      cs = SWS_CS_BT2020;
      break;
    default:
      break;
  }
  return sws_getCoefficients(cs);
}

// Converts frame `f` (any size and format) into `dst_format`, one packed plane at `dst` with
// `dst_stride` bytes per row, with swscale at the same size (bilinear, accurate rounding) and the
// frame's own matrix and range; `*ctx` is the cached context of that target, created or reused.
// Throws InputError naming `target` ("grey", "BGR") when swscale cannot convert the format.
void SwsConvert(const AVFrame* f, AVPixelFormat dst_format, const char* target, SwsContext** ctx,
                std::uint8_t* dst, int dst_stride) {
  const int w = f->width, h = f->height;
  const auto fmt = static_cast<AVPixelFormat>(f->format);
  *ctx = sws_getCachedContext(*ctx, w, h, fmt, w, h, dst_format, SWS_BILINEAR | SWS_ACCURATE_RND,
                              nullptr, nullptr, nullptr);
  if (*ctx == nullptr) {
    throw InputError(fmt::format("video: swscale cannot convert pixel format {} to {}",
                                 av_get_pix_fmt_name(fmt) ? av_get_pix_fmt_name(fmt) : "?",
                                 target));
  }
  const int* table = SwsTable(f);
  sws_setColorspaceDetails(*ctx, table, IsFullRange(f) ? 1 : 0, table, 1, 0, 1 << 16, 1 << 16);
  std::uint8_t* planes[4] = {dst, nullptr, nullptr, nullptr};
  int strides[4] = {dst_stride, 0, 0, 0};
  sws_scale(*ctx, f->data, f->linesize, 0, h, planes, strides);
}

}  // namespace

struct VideoDecoder::Av {
  AVFormatContext* format = nullptr;
  AVCodecContext* codec = nullptr;
  AVPacket* packet = nullptr;
  AVFrame* frame = nullptr;
  SwsContext* sws_gray = nullptr;
  SwsContext* sws_bgr = nullptr;
  int stream = -1;
  std::int64_t start_pts = 0;
  AVRational time_base{0, 1};
  bool flushing = false;  // the end of the file was reached; the decoder is being drained
  bool ended = false;
  bool have_frame = false;

  ~Av() {
    sws_freeContext(sws_gray);
    sws_freeContext(sws_bgr);
    av_frame_free(&frame);
    av_packet_free(&packet);
    avcodec_free_context(&codec);
    avformat_close_input(&format);
  }
};

VideoDecoder::VideoDecoder(const std::filesystem::path& path, int threads) : av_(new Av) {
  const std::string p = path.string();
  const auto fail = [&](const std::string& why) {
    return InputError(fmt::format("cannot open video '{}': {}", p, why));
  };
  int rc = avformat_open_input(&av_->format, p.c_str(), nullptr, nullptr);
  if (rc < 0) {
    throw fail(fmt::format(
        "FFmpeg cannot read it ({}: not a video, an unsupported container, or a damaged or "
        "truncated file)",
        AvErrorText(rc)));
  }
  rc = avformat_find_stream_info(av_->format, nullptr);
  if (rc < 0) throw fail(fmt::format("FFmpeg finds no stream information ({})", AvErrorText(rc)));
  const AVCodec* codec = nullptr;
  av_->stream = av_find_best_stream(av_->format, AVMEDIA_TYPE_VIDEO, -1, -1, &codec, 0);
  if (av_->stream == AVERROR_STREAM_NOT_FOUND) throw fail("it has no video stream");
  if (av_->stream < 0 || codec == nullptr) {
    throw fail("FFmpeg has no decoder for its video stream (unsupported codec)");
  }
  AVStream* st = av_->format->streams[av_->stream];
  av_->codec = avcodec_alloc_context3(codec);
  if (av_->codec == nullptr) throw fail("out of memory (decoder)");
  rc = avcodec_parameters_to_context(av_->codec, st->codecpar);
  if (rc < 0) throw fail(fmt::format("bad codec parameters ({})", AvErrorText(rc)));
  // Frames as large as photos may be (image_file.h kMaxImagePixels): a stream whose header asks
  // for more is refused before a frame is decoded, and FFmpeg refuses to allocate a larger frame
  // met later (AVCodecContext::max_pixels: a size changed mid-stream).
  const double pixels = static_cast<double>(st->codecpar->width) * st->codecpar->height;
  if (pixels > kMaxImagePixels) {
    throw fail(fmt::format(
        "its frames are {} x {} px ({:.0f} megapixels), more than the {:.0f} "
        "megapixels aerovo decodes (kMaxImagePixels; 8K video has 33)",
        st->codecpar->width, st->codecpar->height, pixels / 1e6, kMaxImagePixels / 1e6));
  }
  av_->codec->max_pixels = static_cast<std::int64_t>(kMaxImagePixels);
  av_->codec->thread_count = threads;
  av_->codec->thread_type = FF_THREAD_FRAME | FF_THREAD_SLICE;
  av_->codec->pkt_timebase = st->time_base;
  rc = avcodec_open2(av_->codec, codec, nullptr);
  if (rc < 0)
    throw fail(fmt::format("cannot open the {} decoder ({})", codec->name, AvErrorText(rc)));
  av_->packet = av_packet_alloc();
  av_->frame = av_frame_alloc();
  if (av_->packet == nullptr || av_->frame == nullptr) throw fail("out of memory (frame)");
  av_->time_base = st->time_base;
  av_->start_pts = st->start_time == AV_NOPTS_VALUE ? 0 : st->start_time;
  codec_name_ = codec->name;
  width_ = st->codecpar->width;
  height_ = st->codecpar->height;

  fps_ = Rational(st->avg_frame_rate);
  if (!(fps_ > 0.0)) fps_ = Rational(av_guess_frame_rate(av_->format, st, nullptr));
  if (!std::isfinite(fps_) || fps_ <= 0.0 || fps_ > 10000.0) fps_ = 0.0;
  std::int64_t count = st->nb_frames;
  if (count <= 0 && fps_ > 0.0) {
    double duration_s =
        av_->format->duration > 0 ? static_cast<double>(av_->format->duration) / AV_TIME_BASE : 0.0;
    if (duration_s <= 0.0 && st->duration > 0) duration_s = st->duration * Rational(st->time_base);
    count = static_cast<std::int64_t>(std::floor(duration_s * fps_ + 0.5));
  }
  frame_count_ = count > 0 && count < 1000000000 ? static_cast<int>(count) : 0;

  std::size_t size = 0;
  const std::uint8_t* matrix = av_stream_get_side_data(st, AV_PKT_DATA_DISPLAYMATRIX, &size);
  if (matrix != nullptr && size >= 9 * sizeof(std::int32_t)) {
    // av_display_rotation_get's angle as it is, as OpenCV's CAP_PROP_ORIENTATION_META takes
    // it: measured, MP4s tagged rotate=90/180/270 (ffmpeg -metadata:s:v rotate=N, "turn N
    // degrees clockwise to display") give 90/180/270 (test VideoDecoder.RotationMetadata...).
    const double deg = av_display_rotation_get(reinterpret_cast<const std::int32_t*>(matrix));
    if (std::isfinite(deg)) {
      rotation_deg_ = ((static_cast<int>(std::lround(deg)) % 360) + 360) % 360;
    }
  }
}

VideoDecoder::~VideoDecoder() = default;

int VideoDecoder::threads() const { return av_->codec->thread_count; }

bool VideoDecoder::SeekBefore(double time_s) {
  Av& a = *av_;
  if (!std::isfinite(time_s) || a.time_base.num <= 0 || a.time_base.den <= 0) return false;
  const auto ts = a.start_pts + static_cast<std::int64_t>(std::floor(time_s / av_q2d(a.time_base)));
  if (av_seek_frame(a.format, a.stream, ts, AVSEEK_FLAG_BACKWARD) < 0) return false;
  avcodec_flush_buffers(a.codec);
  a.flushing = false;
  a.ended = false;
  a.have_frame = false;
  return true;
}

void VideoDecoder::SkipNonReferenceFrames(bool skip) {
  av_->codec->skip_frame = skip ? AVDISCARD_NONREF : AVDISCARD_DEFAULT;
}

bool VideoDecoder::Grab() {
  Av& a = *av_;
  a.have_frame = false;
  if (a.ended) return false;
  int failed_in_a_row = 0;
  for (;;) {
    const int rc = avcodec_receive_frame(a.codec, a.frame);
    if (rc == 0) {
      a.have_frame = true;
      return true;
    }
    if (rc == AVERROR_EOF || a.flushing) {
      // Drained (or a decoding error while draining: nothing more will come).
      a.ended = true;
      return false;
    }
    if (rc != AVERROR(EAGAIN)) {
      ++failed_packets_;
      if (++failed_in_a_row >= kMaxFailedPackets) {
        a.ended = true;
        return false;
      }
    }
    // The decoder wants input: the next packet of our stream, or the end.
    bool sent = false;
    while (!sent) {
      const int r = av_read_frame(a.format, a.packet);
      if (r < 0) {  // end of file or a read error: drain the decoder
        avcodec_send_packet(a.codec, nullptr);
        a.flushing = true;
        break;
      }
      if (a.packet->stream_index == a.stream) {
        const int s = avcodec_send_packet(a.codec, a.packet);
        if (s < 0 && s != AVERROR(EAGAIN)) {
          ++failed_packets_;
          if (++failed_in_a_row >= kMaxFailedPackets) {
            av_packet_unref(a.packet);
            a.ended = true;
            return false;
          }
        } else {
          sent = true;
        }
      }
      av_packet_unref(a.packet);
    }
  }
}

int VideoDecoder::frame_width() const { return av_->have_frame ? av_->frame->width : 0; }
int VideoDecoder::frame_height() const { return av_->have_frame ? av_->frame->height : 0; }

double VideoDecoder::timestamp_ms() const {
  const Av& a = *av_;
  if (!a.have_frame || a.frame->best_effort_timestamp == AV_NOPTS_VALUE) {
    return std::numeric_limits<double>::quiet_NaN();
  }
  return static_cast<double>(a.frame->best_effort_timestamp - a.start_pts) * Rational(a.time_base) *
         1000.0;
}

void VideoDecoder::Gray(GrayImage& out) {
  Av& a = *av_;
  if (!a.have_frame) throw InvalidArgument("VideoDecoder::Gray: no frame grabbed");
  const AVFrame* f = a.frame;
  const int w = f->width, h = f->height;
  if (out.width() != w || out.height() != h) out = GrayImage(w, h);
  const bool full = IsFullRange(f);
  const auto fmt = static_cast<AVPixelFormat>(f->format);
  if (HasPlainLumaPlane(fmt)) {
    for (int y = 0; y < h; ++y) {
      const std::uint8_t* src = f->data[0] + static_cast<std::ptrdiff_t>(y) * f->linesize[0];
      std::uint8_t* dst = out.row(y);
      if (full) {
        std::memcpy(dst, src, static_cast<std::size_t>(w));
      } else {
        for (int x = 0; x < w; ++x) dst[x] = LimitedToFullLuma(src[x]);
      }
    }
    return;
  }
  SwsConvert(f, AV_PIX_FMT_GRAY8, "grey", &a.sws_gray, out.data(), w);
}

void VideoDecoder::Bgr(cv::Mat& out) {
  Av& a = *av_;
  if (!a.have_frame) throw InvalidArgument("VideoDecoder::Bgr: no frame grabbed");
  const AVFrame* f = a.frame;
  out.create(f->height, f->width, CV_8UC3);
  SwsConvert(f, AV_PIX_FMT_BGR24, "BGR", &a.sws_bgr, out.data, static_cast<int>(out.step[0]));
}

}  // namespace aerovo
