// libFuzzer target: video files (frames/frame_source.h VideoFileSource through aerovo's FFmpeg
// decoder, frames/video_decoder.h; frames/video_text_track.h, the captions inside a video read
// as telemetry), what `aerovo run VIDEO` and `aerovo telemetry VIDEO` read. Each input is
// written to video.mp4 in a private temporary folder (FFmpeg probes the content; the extension
// only breaks ties). FFmpeg is Debian's uninstrumented build: the coverage feedback comes from
// aerovo's frames and telemetry code, ASan still sees the heap.
//
// The telemetry read (strict and lenient) either throws InputError or returns what every
// telemetry read promises (fuzz_telemetry.h CheckResult); the frame source either throws InputError
// or delivers at most kMaxFrames frames, all of one size (a change of size is an error), indices
// increasing, finite times. Anything else (another exception, a crash, a sanitizer report, a
// broken promise) is a bug.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>

#include "aerovo/core/error.h"
#include "aerovo/frames/frame_source.h"
#include "aerovo/frames/video_text_track.h"
#include "fuzz_files.h"
#include "fuzz_telemetry.h"

namespace {

using aerovo::fuzz::Check;

// Frames read from one input: enough to pass the look-ahead, the repeated-frame check (6
// identical frames) and a size change, few enough for libFuzzer's speed.
constexpr int kMaxFrames = 12;

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const std::string path = aerovo::fuzz::MakeFolder("video") + "video.mp4";
  aerovo::fuzz::WriteInput(path, data, size);
  for (const bool lenient : {false, true}) {
    aerovo::TelemetryReadOptions options;
    options.lenient = lenient;
    options.max_warnings = 3;
    try {
      aerovo::fuzz::CheckResult(aerovo::ReadVideoTelemetry(path, options), options);
    } catch (const aerovo::InputError&) {
    }
  }
  try {
    aerovo::VideoFileSource source(path);
    (void)source.Describe();
    aerovo::Frame frame;
    int previous = -1, width = 0, height = 0;
    for (int n = 0; n < kMaxFrames && source.Next(frame); ++n) {
      Check(frame.index > previous && std::isfinite(frame.time_s));
      Check(frame.gray.width() > 0 && frame.gray.height() > 0);
      if (n == 0) width = frame.gray.width(), height = frame.gray.height();
      Check(frame.gray.width() == width && frame.gray.height() == height);
      previous = frame.index;
    }
  } catch (const aerovo::InputError&) {
  }
  return 0;
}
