// The text track of a video file as telemetry. DJI aircraft that caption their videos write the
// captions (the same text as the .SRT they may also write beside the video) into the video file
// as a timed-text track: MP4/MOV timed text (3GPP TS 26.245 "tx3g", QuickTime "text"); some
// models (DJI Mini 2, Mini 4K, Mini 4 Pro) write no .SRT beside the video at all. This reads
// that track through FFmpeg's demuxer and hands it to the DJI SRT reader
// (telemetry/telemetry_readers.h ParseDjiSrt). docs/inputs.md "The telemetry inside a video".
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "aerovo/telemetry/telemetry_readers.h"

namespace aerovo {

/// A text track found in a video file.
struct VideoTextTrackInfo {
  int stream_index = -1;    ///< The container's stream number (ffmpeg's 0:N).
  int subtitle_index = -1;  ///< Its rank among the file's subtitle streams (ffmpeg's 0:s:N).
  std::string codec;        ///< FFmpeg's codec name: "mov_text", "subrip", "text", "webvtt".
};

/// The first text track of the video file at `path` whose samples aerovo reads: MP4/MOV timed
/// text (codec mov_text, or a data stream tagged "tx3g"/"text"), SubRip, plain text or WebVTT
/// (Matroska). nullopt when the file has none, or when FFmpeg cannot open it (the frame source
/// reports that). Reads the container's header only, not the samples.
std::optional<VideoTextTrackInfo> FindVideoTextTrack(const std::filesystem::path& path);

/// The text of one MP4/MOV timed-text sample (3GPP TS 26.245 section 5.17: a big-endian 16-bit
/// byte count, the text, then optional modifier boxes such as "styl", which are not text):
/// UTF-8, or UTF-16 when the text starts with a byte order mark (converted to UTF-8); line
/// breaks "\r\n" and "\r" become "\n". A sample whose count exceeds it and whose bytes are all
/// text is text without the count (some cameras write QuickTime text samples so). Throws
/// InputError naming `what` (the video and the cue) when the count exceeds a sample that is not
/// all text, or a UTF-16 text has an odd byte count.
std::string TimedTextSampleText(const std::uint8_t* data, std::size_t size, std::string_view what);

/// The text track of `path` as SubRip text: cues numbered from 1 in time order, each its start
/// and end time ("HH:MM:SS,mmm --> HH:MM:SS,mmm", the track's times from the start of the video
/// stream) and its text; empty cues (a gap in a timed-text track) are left out. This is what
/// `ffmpeg -i VIDEO -map 0:s:N track.srt` writes, so that line numbers agree. Throws InputError
/// naming the file when it has no text track, a cue is malformed or has no time, or the text
/// exceeds 512 MiB.
/// With `skip_damaged`, a damaged sample (TimedTextSampleText's errors, a sample without a time)
/// is left out, counted in `damaged` and named in `warnings` (the first kMaxListedDamaged).
struct VideoTextTrack {
  VideoTextTrackInfo info;
  int cues = 0;     ///< Cues written (empty ones left out).
  std::string srt;  ///< The track as SubRip text.
  int damaged = 0;  ///< Damaged samples left out (skip_damaged only).
  std::vector<std::string> warnings;
};
inline constexpr int kMaxListedDamaged = 5;
VideoTextTrack ReadVideoTextTrack(const std::filesystem::path& path, bool skip_damaged = false);

/// The telemetry in the text track of the video file `path`: ReadVideoTextTrack, then
/// ParseDjiSrt with the source named "<path> (subtitle track N as SRT)" (its lines are those of
/// the track as SubRip text, what `ffmpeg -i VIDEO -map 0:s:N track.srt` writes). Throws InputError
/// as both do; with options.lenient, damaged samples are skipped, counted in skipped_records and
/// listed in warnings, as malformed records are.
TelemetryReadResult ReadVideoTelemetry(const std::filesystem::path& path,
                                       const TelemetryReadOptions& options = {});

/// A file given as telemetry: a video container (MP4/MOV/3GP by its "ftyp"/"moov" box,
/// Matroska/WebM by its EBML magic) is read by ReadVideoTelemetry, anything else by
/// ReadTelemetryFile.
TelemetryReadResult ReadTelemetryInput(const std::filesystem::path& path,
                                       const TelemetryReadOptions& options = {});

}  // namespace aerovo
