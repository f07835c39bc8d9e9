#include "aerovo/frames/video_text_track.h"

#include <algorithm>
#include <cinttypes>
#include <cmath>
#include <fstream>
#include <memory>
#include <sstream>
#include <utility>
#include <vector>

#include <fmt/format.h>

extern "C" {
#include <libavcodec/avcodec.h>
#include <libavformat/avformat.h>
}

#include "aerovo/core/error.h"
#include "aerovo/frames/av_error.h"
#include "aerovo/telemetry/file_kind.h"
#include "aerovo/telemetry/parse_util.h"

namespace aerovo {
namespace {

// The whole track's text at most (a DJI caption is ~300 bytes per frame: 512 MiB is ~27 hours
// at 60 fps); beyond it the track is not captions.
constexpr std::size_t kMaxTrackBytes = std::size_t{512} << 20;

constexpr std::uint32_t Tag(char a, char b, char c, char d) {
  return static_cast<std::uint32_t>(static_cast<unsigned char>(a)) |
         (static_cast<std::uint32_t>(static_cast<unsigned char>(b)) << 8) |
         (static_cast<std::uint32_t>(static_cast<unsigned char>(c)) << 16) |
         (static_cast<std::uint32_t>(static_cast<unsigned char>(d)) << 24);
}

enum class SampleFormat { kNone, kTimedText, kPlainText };

// How the samples of `st` hold text: timed-text samples (a 16-bit count first) for MP4/MOV
// timed text, whether FFmpeg calls the stream mov_text or (QuickTime "text" or "tx3g" under a
// handler it does not map) a data stream; plain text for SubRip, plain text and WebVTT.
SampleFormat FormatOf(const AVStream* st) {
  const AVCodecParameters* par = st->codecpar;
  if (par->codec_type == AVMEDIA_TYPE_SUBTITLE) {
    switch (par->codec_id) {
      case AV_CODEC_ID_MOV_TEXT:
        return SampleFormat::kTimedText;
      case AV_CODEC_ID_SUBRIP:
      case AV_CODEC_ID_TEXT:
      case AV_CODEC_ID_WEBVTT:
        return SampleFormat::kPlainText;
      default:
        return SampleFormat::kNone;
    }
  }
  if (par->codec_type == AVMEDIA_TYPE_DATA &&
      (par->codec_tag == Tag('t', 'x', '3', 'g') || par->codec_tag == Tag('t', 'e', 'x', 't'))) {
    return SampleFormat::kTimedText;
  }
  return SampleFormat::kNone;
}

struct FormatCloser {
  void operator()(AVFormatContext* f) const { avformat_close_input(&f); }
};
using FormatPtr = std::unique_ptr<AVFormatContext, FormatCloser>;
struct PacketFreer {
  void operator()(AVPacket* p) const { av_packet_free(&p); }
};

using frames_detail::AvErrorText;

// Opens the container's header (no stream probing: MP4/MOV and Matroska declare their streams
// there). nullptr when FFmpeg cannot open it; `why` then says why.
FormatPtr OpenHeader(const std::filesystem::path& path, std::string* why) {
  AVFormatContext* f = nullptr;
  const int rc = avformat_open_input(&f, path.string().c_str(), nullptr, nullptr);
  if (rc < 0) {
    if (why != nullptr) *why = AvErrorText(rc);
    return nullptr;
  }
  return FormatPtr(f);
}

// The first stream with a text format aerovo reads, and its rank among the subtitle streams.
std::optional<VideoTextTrackInfo> FindTrack(const AVFormatContext* f) {
  int subtitles = 0;
  for (unsigned k = 0; k < f->nb_streams; ++k) {
    const AVStream* st = f->streams[k];
    const bool is_subtitle = st->codecpar->codec_type == AVMEDIA_TYPE_SUBTITLE;
    if (FormatOf(st) != SampleFormat::kNone) {
      VideoTextTrackInfo info;
      info.stream_index = static_cast<int>(k);
      info.subtitle_index = is_subtitle ? subtitles : -1;
      const char* name = avcodec_get_name(st->codecpar->codec_id);
      info.codec = st->codecpar->codec_type == AVMEDIA_TYPE_DATA ? "timed text (data stream)"
                                                                 : std::string(name);
      return info;
    }
    if (is_subtitle) ++subtitles;
  }
  return std::nullopt;
}

// "\r\n" and "\r" as "\n"; NUL bytes (padding some writers leave) dropped.
std::string NormalisedLines(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (std::size_t k = 0; k < text.size(); ++k) {
    const char c = text[k];
    if (c == '\0') continue;
    if (c == '\r') {
      out.push_back('\n');
      if (k + 1 < text.size() && text[k + 1] == '\n') ++k;
      continue;
    }
    out.push_back(c);
  }
  return out;
}

// The sample is text as it is: printable ASCII, tabs, line breaks and UTF-8 bytes (>= 0x80), no
// other control byte (a count's high byte is 0 for any text under 256 bytes).
bool IsPlainText(const std::uint8_t* data, std::size_t size) {
  for (std::size_t k = 0; k < size; ++k) {
    const std::uint8_t c = data[k];
    if (c < 0x20 && c != '\t' && c != '\n' && c != '\r') return false;
    if (c == 0x7F) return false;
  }
  return true;
}

// "HH:MM:SS,mmm" of `ms` milliseconds (SubRip's timing, as FFmpeg's SubRip muxer writes it).
std::string SrtTime(std::int64_t ms) {
  if (ms < 0) ms = 0;
  return fmt::format("{:02}:{:02}:{:02},{:03}", ms / 3600000, (ms / 60000) % 60, (ms / 1000) % 60,
                     ms % 1000);
}

}  // namespace

std::string TimedTextSampleText(const std::uint8_t* data, std::size_t size, std::string_view what) {
  if (size < 2) {
    throw InputError(
        fmt::format("{}: a timed-text sample of {} byte(s), shorter than its 2-byte "
                    "text length",
                    what, size));
  }
  const std::size_t n = (std::size_t{data[0]} << 8) | data[1];
  if (n > size - 2 && IsPlainText(data, size)) {
    // Text without the count, as some cameras write QuickTime "text" samples (ExifTool's
    // QuickTimeStream.pl strips the count only when it equals the sample's size less 2): a DJI
    // caption "F/2.8, SS 1000, ..." starts with bytes that read as a count of 17967.
    return NormalisedLines(std::string_view(reinterpret_cast<const char*>(data), size));
  }
  if (n > size - 2) {
    throw InputError(fmt::format(
        "{}: the timed-text sample says its text is {} bytes, but the sample holds {} after the "
        "length (a damaged track)",
        what, n, size - 2));
  }
  const std::uint8_t* t = data + 2;
  // UTF-16 (3GPP TS 26.245 5.16: text starting with a byte order mark), big- or little-endian.
  if (n >= 2 && ((t[0] == 0xFE && t[1] == 0xFF) || (t[0] == 0xFF && t[1] == 0xFE))) {
    return NormalisedLines(
        io_detail::Utf16ToUtf8(std::string_view(reinterpret_cast<const char*>(t + 2), n - 2),
                               t[0] == 0xFE, std::string(what)));
  }
  std::string_view text(reinterpret_cast<const char*>(t), n);
  if (text.rfind("\xEF\xBB\xBF", 0) == 0) text.remove_prefix(3);  // a UTF-8 byte order mark
  return NormalisedLines(text);
}

std::optional<VideoTextTrackInfo> FindVideoTextTrack(const std::filesystem::path& path) {
  const FormatPtr f = OpenHeader(path, nullptr);
  if (!f) return std::nullopt;
  return FindTrack(f.get());
}

VideoTextTrack ReadVideoTextTrack(const std::filesystem::path& path, bool skip_damaged) {
  const std::string name = path.string();
  std::string why;
  const FormatPtr f = OpenHeader(path, &why);
  if (!f) throw InputError(fmt::format("cannot read '{}' as a video: {}", name, why));
  std::optional<VideoTextTrackInfo> info = FindTrack(f.get());
  if (!info) {
    throw InputError(fmt::format(
        "'{}' has no subtitle track aerovo reads (MP4/MOV timed text, SubRip): no telemetry in the "
        "video (DJI aircraft write their captions there or in a .SRT beside it when video "
        "captions are on)",
        name));
  }
  const int index = info->stream_index;
  const AVStream* st = f->streams[index];
  const SampleFormat format = FormatOf(st);
  for (unsigned k = 0; k < f->nb_streams; ++k) {
    f->streams[k]->discard = static_cast<int>(k) == index ? AVDISCARD_DEFAULT : AVDISCARD_ALL;
  }
  // The track's times from the start of the video stream, as the frames' (video_decoder.cc).
  std::int64_t origin_us = 0;
  const int video = av_find_best_stream(f.get(), AVMEDIA_TYPE_VIDEO, -1, -1, nullptr, 0);
  if (video >= 0 && f->streams[video]->start_time != AV_NOPTS_VALUE) {
    origin_us = av_rescale_q(f->streams[video]->start_time, f->streams[video]->time_base,
                             AVRational{1, 1000000});
  }

  struct Cue {
    std::int64_t start_ms;
    std::int64_t end_ms;
    std::string text;
  };
  std::vector<Cue> cues;
  std::size_t bytes = 0;
  std::unique_ptr<AVPacket, PacketFreer> packet(av_packet_alloc());
  if (!packet) throw InputError(fmt::format("'{}': out of memory (packet)", name));
  int sample = 0;
  int damaged = 0;
  std::vector<std::string> warnings;
  // A damaged sample: an error, or with skip_damaged one more left out.
  const auto damage = [&](const std::string& message) {
    if (!skip_damaged) throw MalformedRecordError(message);
    if (++damaged <= kMaxListedDamaged) warnings.push_back(message + " (skipped)");
  };
  for (;;) {
    const int rc = av_read_frame(f.get(), packet.get());
    if (rc == AVERROR_EOF) break;
    if (rc < 0) {
      throw InputError(
          fmt::format("'{}': reading its subtitle track stopped after {} sample(s): {}", name,
                      sample, AvErrorText(rc)));
    }
    if (packet->stream_index != index) {
      av_packet_unref(packet.get());
      continue;
    }
    ++sample;
    const std::string what = fmt::format("{} (subtitle track, sample {})", name, sample);
    std::string text;
    std::string problem;
    try {
      text = format == SampleFormat::kTimedText
                 ? TimedTextSampleText(packet->data, static_cast<std::size_t>(packet->size), what)
                 : NormalisedLines(std::string_view(reinterpret_cast<const char*>(packet->data),
                                                    static_cast<std::size_t>(packet->size)));
    } catch (const InputError& e) {
      problem = e.what();
    }
    const std::int64_t pts = packet->pts != AV_NOPTS_VALUE ? packet->pts : packet->dts;
    const std::int64_t duration = packet->duration;
    av_packet_unref(packet.get());
    if (!problem.empty()) {
      damage(problem);
      continue;
    }
    while (!text.empty() && text.back() == '\n') text.pop_back();
    if (text.find_first_not_of(" \t\n") == std::string::npos) continue;  // a gap between cues
    if (pts == AV_NOPTS_VALUE) {
      damage(fmt::format("{}: the sample has no time", what));
      continue;
    }
    const std::int64_t start_us =
        av_rescale_q(pts, st->time_base, AVRational{1, 1000000}) - origin_us;
    const std::int64_t end_us =
        start_us +
        (duration > 0 ? av_rescale_q(duration, st->time_base, AVRational{1, 1000000}) : 0);
    bytes += text.size() + 40;
    if (bytes > kMaxTrackBytes) {
      throw InputError(
          fmt::format("'{}': its subtitle track holds more than {} MiB of text: not "
                      "captions",
                      name, kMaxTrackBytes >> 20));
    }
    cues.push_back({(start_us + 500) / 1000, (end_us + 500) / 1000, std::move(text)});
  }
  std::stable_sort(cues.begin(), cues.end(),
                   [](const Cue& a, const Cue& b) { return a.start_ms < b.start_ms; });
  VideoTextTrack track;
  track.info = *info;
  track.damaged = damaged;
  track.warnings = std::move(warnings);
  track.cues = static_cast<int>(cues.size());
  track.srt.reserve(bytes);
  for (std::size_t k = 0; k < cues.size(); ++k) {
    track.srt +=
        fmt::format("{}\n{} --> {}\n", k + 1, SrtTime(cues[k].start_ms), SrtTime(cues[k].end_ms));
    track.srt += cues[k].text;
    track.srt += "\n\n";
  }
  return track;
}

TelemetryReadResult ReadVideoTelemetry(const std::filesystem::path& path,
                                       const TelemetryReadOptions& options) {
  const VideoTextTrack track = ReadVideoTextTrack(path, options.lenient);
  if (track.cues == 0) {
    throw InputError(fmt::format("'{}': its subtitle track ({}) holds no text", path.string(),
                                 track.info.codec));
  }
  std::istringstream in(track.srt);
  const std::string source =
      track.info.subtitle_index >= 0
          ? fmt::format("{} (subtitle track {} as SRT)", path.string(), track.info.subtitle_index)
          : fmt::format("{} (text stream {} as SRT)", path.string(), track.info.stream_index);
  // The damaged samples are records skipped too: they and the track's malformed records share
  // the max_warnings messages (the damaged ones first, in the track's order).
  const std::size_t listed =
      std::min(track.warnings.size(), static_cast<std::size_t>(std::max(0, options.max_warnings)));
  TelemetryReadOptions srt_options = options;
  srt_options.max_warnings = options.max_warnings - static_cast<int>(listed);
  TelemetryReadResult r = ParseDjiSrt(in, source, srt_options);
  r.skipped_records += track.damaged;
  r.warnings.insert(r.warnings.begin(), track.warnings.begin(),
                    track.warnings.begin() + static_cast<std::ptrdiff_t>(listed));
  return r;
}

TelemetryReadResult ReadTelemetryInput(const std::filesystem::path& path,
                                       const TelemetryReadOptions& options) {
  std::ifstream in(path, std::ios::binary);
  if (in) {
    const std::string head = io_detail::ReadHead(in);
    if (io_detail::RecognizeFile(reinterpret_cast<const unsigned char*>(head.data()),
                                 head.size()) == io_detail::FileKind::kVideo) {
      return ReadVideoTelemetry(path, options);
    }
  }
  return ReadTelemetryFile(path, options);  // which names a missing or unreadable file
}

}  // namespace aerovo
