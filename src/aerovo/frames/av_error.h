// Internal to frames (FFmpeg stays private to aerovo_frames): FFmpeg's text for an error code.
#pragma once

#include <string>

extern "C" {
#include <libavutil/error.h>
}

namespace aerovo::frames_detail {

/// av_strerror's text for an FFmpeg error code (AVERROR_EOF, AVERROR_INVALIDDATA, ...).
inline std::string AvErrorText(int code) {
  char buf[AV_ERROR_MAX_STRING_SIZE] = {0};
  av_strerror(code, buf, sizeof(buf));
  return buf;
}

}  // namespace aerovo::frames_detail
