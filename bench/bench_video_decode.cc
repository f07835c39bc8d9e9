// Decoding a video to grey frames, our decoder (frames/video_decoder.h: FFmpeg's
// libraries, grey from the luma plane) against OpenCV's cv::VideoCapture (BGR, then
// cv::cvtColor), side by side: VideoFileSource::Next per iteration (one frame), 1080p and 4K
// H.264. CPU time is the whole process's (MeasureProcessCPUTime: the codec's own threads
// count), Time is wall-clock. The videos are made on first use by the ffmpeg program (testsrc2
// with temporal noise, 45 frames at 30 fps, libx264 veryfast, GOP 30, at a drone camera's bit
// rate: 30 Mbit/s at 1080p, 100 Mbit/s at 4K, as DJI's H.264 modes) in a temp dir removed at
// exit; the benchmarks fail with a message when ffmpeg or libx264 is missing.
#include <benchmark/benchmark.h>

#include <unistd.h>

#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <utility>

#include <fmt/format.h>

#include "aerovo/frames/ffmpeg_test_util.h"
#include "aerovo/frames/frame_source.h"

namespace {

namespace fs = std::filesystem;

class Videos {
 public:
  ~Videos() {
    std::error_code ec;
    if (!dir_.empty()) fs::remove_all(dir_, ec);
  }
  // "" when the video cannot be made.
  const std::string& Get(int w, int h) {
    const auto key = std::make_pair(w, h);
    auto it = paths_.find(key);
    if (it != paths_.end()) return it->second;
    if (dir_.empty()) {
      dir_ = fs::temp_directory_path() / fmt::format("aerovo_bench_video_{}", ::getpid());
      fs::create_directories(dir_);
    }
    const std::string path = (dir_ / fmt::format("{}x{}.mp4", w, h)).string();
    const int mbps = w * h > 2100000 ? 100 : 30;
    const bool ok =
        aerovo::io_test::RunFfmpeg({"-f",        "lavfi",
                                    "-i",        fmt::format("testsrc2=size={}x{}:rate=30", w, h),
                                    "-vf",       "noise=alls=8:allf=t",
                                    "-frames:v", "45",
                                    "-pix_fmt",  "yuv420p",
                                    "-c:v",      "libx264",
                                    "-preset",   "veryfast",
                                    "-b:v",      fmt::format("{}M", mbps),
                                    "-maxrate",  fmt::format("{}M", mbps),
                                    "-bufsize",  fmt::format("{}M", 2 * mbps),
                                    "-g",        "30",
                                    path});
    return paths_[key] = ok ? path : std::string();
  }

 private:
  fs::path dir_;
  std::map<std::pair<int, int>, std::string> paths_;
};

Videos& TheVideos() {
  static Videos v;
  return v;
}

// Args: width, height, decoder (0 = ours, 1 = OpenCV), threads (ours; 0 = one per core),
// keep_color (0/1).
void BM_VideoNextFrame(benchmark::State& state) {
  const int w = static_cast<int>(state.range(0)), h = static_cast<int>(state.range(1));
  const std::string& path = TheVideos().Get(w, h);
  if (path.empty()) {
    state.SkipWithError("cannot make the video (ffmpeg with libx264 needed)");
    return;
  }
  aerovo::FrameSourceOptions o;
  o.video_decoder = state.range(2) == 0 ? aerovo::VideoDecoderChoice::kFfmpeg
                                        : aerovo::VideoDecoderChoice::kOpenCv;
  o.video_threads = static_cast<int>(state.range(3));
  o.keep_color = state.range(4) != 0;
  auto src = std::make_unique<aerovo::VideoFileSource>(path, o);
  aerovo::Frame f;
  std::int64_t frames = 0;
  for (auto _ : state) {
    if (!src->Next(f)) {
      state.PauseTiming();
      src = std::make_unique<aerovo::VideoFileSource>(path, o);
      state.ResumeTiming();
      if (!src->Next(f)) {
        state.SkipWithError("no frame");
        break;
      }
    }
    benchmark::DoNotOptimize(f.gray.data());
    ++frames;
  }
  state.SetItemsProcessed(frames);
  state.SetLabel(fmt::format("{}{}{}", state.range(2) == 0 ? "ours" : "opencv",
                             state.range(2) == 0 ? fmt::format(" threads {}", state.range(3)) : "",
                             state.range(4) != 0 ? " +bgr" : ""));
}
BENCHMARK(BM_VideoNextFrame)
    ->ArgNames({"w", "h", "opencv", "threads", "bgr"})
    ->Args({1920, 1080, 0, 1, 0})
    ->Args({1920, 1080, 0, 2, 0})
    ->Args({1920, 1080, 1, 0, 0})
    ->Args({3840, 2160, 0, 1, 0})
    ->Args({3840, 2160, 0, 2, 0})
    ->Args({3840, 2160, 0, 0, 0})
    ->Args({3840, 2160, 0, 2, 1})
    ->Args({3840, 2160, 1, 0, 0})
    ->MeasureProcessCPUTime()
    ->Unit(benchmark::kMillisecond);

}  // namespace
BENCHMARK_MAIN();
