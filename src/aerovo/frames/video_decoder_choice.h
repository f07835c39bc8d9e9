// Which decoder reads video files: FrameSourceOptions::video_decoder (frames/frame_source.h) and
// the run option video_decoder (pipeline/run_config.h). A header of its own so that the options'
// schema can name it without OpenCV's or FFmpeg's headers.
#pragma once

#include "aerovo/core/options.h"

namespace aerovo {

enum class VideoDecoderChoice {
  kAuto,    ///< kFfmpeg (the default decoder).
  kFfmpeg,  ///< frames/video_decoder.h: FFmpeg's libraries, grey from the luma plane.
  kOpenCv,  ///< cv::VideoCapture (FFmpeg backend), grey from its BGR image.
};

inline const char* ToString(VideoDecoderChoice c) {
  return c == VideoDecoderChoice::kAuto     ? "auto"
         : c == VideoDecoderChoice::kFfmpeg ? "ffmpeg"
                                            : "opencv";
}

template <>
struct options::EnumTraits<VideoDecoderChoice>
    : options::EnumList<VideoDecoderChoice, ToString, VideoDecoderChoice::kAuto,
                        VideoDecoderChoice::kFfmpeg, VideoDecoderChoice::kOpenCv> {};

}  // namespace aerovo
