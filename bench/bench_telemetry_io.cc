// Input costs: telemetry parsing throughput (DJI SRT, GPX, CSV), telemetry lookups, and
// frame delivery (photo decode + grey conversion) per frame.
#include <benchmark/benchmark.h>

#include <filesystem>
#include <sstream>
#include <string>

#include <fmt/format.h>

#include "aerovo/frames/frame_source.h"
#include "aerovo/telemetry/telemetry_readers.h"

namespace {

// A 20-minute 30 fps flight in the current DJI bracketed format (36 000 subtitles).
std::string MakeSrt(int n) {
  std::string s;
  for (int i = 0; i < n; ++i) {
    const int ms0 = i * 1000 / 30, ms1 = (i + 1) * 1000 / 30;
    s += fmt::format(
        "{}\n00:{:02}:{:02},{:03} --> 00:{:02}:{:02},{:03}\n<font size=\"28\">FrameCnt: {}, "
        "DiffTime: 33ms\n2023-05-01 12:{:02}:{:02},{:03},000\n[iso : 100] [shutter : 1/500.0] "
        "[fnum : 280] [ev : 0] [ct : 5500] [color_md : default] [focal_len : 240] [latitude: "
        "{:.6f}] [longitude: {:.6f}] [rel_alt: {:.3f} abs_alt: {:.3f}] </font>\n\n",
        i + 1, ms0 / 60000, ms0 / 1000 % 60, ms0 % 1000, ms1 / 60000, ms1 / 1000 % 60, ms1 % 1000,
        i + 1, ms0 / 60000, ms0 / 1000 % 60, ms0 % 1000, 43.5 + i * 1e-6, 6.5 + i * 1e-6,
        100.0 + i * 1e-3, 350.0 + i * 1e-3);
  }
  return s;
}

std::string MakeGpx(int n) {
  std::string s = "<?xml version=\"1.0\"?>\n<gpx version=\"1.1\"><trk><trkseg>\n";
  for (int i = 0; i < n; ++i) {
    s += fmt::format(
        "<trkpt lat=\"{:.7f}\" lon=\"{:.7f}\"><ele>{:.2f}</ele><time>2023-05-01T{:02}:{:02}:{:02}Z"
        "</time></trkpt>\n",
        43.5 + i * 1e-6, 6.5 + i * 1e-6, 350.0 + i * 0.01, 12 + i / 3600, i / 60 % 60, i % 60);
  }
  return s + "</trkseg></trk></gpx>\n";
}

std::string MakeCsv(int n) {
  std::string s = "frame,time,lat,lon,alt,height,yaw\n";
  for (int i = 0; i < n; ++i) {
    s += fmt::format("{},{:.3f},{:.7f},{:.7f},{:.2f},{:.2f},{:.1f}\n", i, i / 30.0, 43.5 + i * 1e-6,
                     6.5 + i * 1e-6, 350.0, 100.0, i % 360 * 1.0);
  }
  return s;
}

template <typename Parse>
void RunParse(benchmark::State& state, const std::string& text, Parse parse) {
  for (auto _ : state) {
    std::istringstream in(text);
    auto r = parse(in);
    benchmark::DoNotOptimize(r.records);
  }
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations()) *
                          static_cast<int64_t>(text.size()));
}

void BM_ParseDjiSrt(benchmark::State& state) {
  const std::string text = MakeSrt(static_cast<int>(state.range(0)));
  RunParse(state, text, [](std::istream& in) { return aerovo::ParseDjiSrt(in, "bench.srt"); });
}
BENCHMARK(BM_ParseDjiSrt)->Arg(36000)->Unit(benchmark::kMillisecond);

void BM_ParseGpx(benchmark::State& state) {
  const std::string text = MakeGpx(static_cast<int>(state.range(0)));
  RunParse(state, text, [](std::istream& in) { return aerovo::ParseGpx(in, "bench.gpx"); });
}
BENCHMARK(BM_ParseGpx)->Arg(36000)->Unit(benchmark::kMillisecond);

void BM_ParseTelemetryCsv(benchmark::State& state) {
  const std::string text = MakeCsv(static_cast<int>(state.range(0)));
  RunParse(state, text,
           [](std::istream& in) { return aerovo::ParseTelemetryCsv(in, "bench.csv"); });
}
BENCHMARK(BM_ParseTelemetryCsv)->Arg(36000)->Unit(benchmark::kMillisecond);

void BM_TelemetryLookup(benchmark::State& state) {
  std::istringstream in(MakeSrt(36000));
  const aerovo::Telemetry t = aerovo::ParseDjiSrt(in, "bench.srt").telemetry;
  double time = 0.0;
  int frame = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(t.Lookup(time));
    benchmark::DoNotOptimize(t.AtFrame(frame));
    time = time > 1190.0 ? 0.0 : time + 0.1;
    frame = frame > 35000 ? 0 : frame + 3;
  }
}
BENCHMARK(BM_TelemetryLookup);

// Photo decode + BGR->grey + copy into GrayImage, per frame, on the tampa photos (800x600).
void BM_ImageFolderNext(benchmark::State& state) {
  const char* env = std::getenv("AEROVO_SHARED");
  const std::filesystem::path dir =
      std::filesystem::path(env && *env ? env : AEROVO_SHARED_DIR_DEFAULT) /
      "data/flights/tampa-phantom3";
  if (!std::filesystem::is_directory(dir)) {
    state.SkipWithError("shared data not found: data/flights/tampa-phantom3");
    return;
  }
  auto src = std::make_unique<aerovo::ImageFolderSource>(dir);
  aerovo::Frame f;
  for (auto _ : state) {
    if (!src->Next(f)) {
      state.PauseTiming();
      src = std::make_unique<aerovo::ImageFolderSource>(dir);
      state.ResumeTiming();
      src->Next(f);
    }
    benchmark::DoNotOptimize(f.gray.data());
  }
}
BENCHMARK(BM_ImageFolderNext)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
