// Per-frame cost of the run outputs and of the trajectory evaluation.
//   BM_TrackWriterSetAppend: one TrackWriterSet::Append (frames.csv, vo/gps .tum, .geojson,
//     .kml, .gpx, vo_frames.geojson; 11 files, each kept valid) into a folder under $TMPDIR.
//     The files grow during the run, so a flat time per frame shows the O(1) tail rewriting.
//   BM_CompareTrajectories/N: SE(2) + Sim(2) evaluation of N associated points (3 segment
//     lengths).
#include <benchmark/benchmark.h>

#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include "aerovo/eval/trajectory_eval.h"
#include "aerovo/outputs/track_writers.h"

namespace {

void BM_TrackWriterSetAppend(benchmark::State& state) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("aerovo_bench_writers_" + std::to_string(getpid()));
  std::filesystem::remove_all(dir);
  aerovo::TrackWriterOptions options;
  options.enu_origin = aerovo::GeoPoint{50.45, 30.52, 180.0};
  options.time_origin_unix_s = 1.6e9;
  int i = 0;
  {
    aerovo::TrackWriterSet set(dir, options);
    aerovo::FrameRecord r;
    for (auto _ : state) {
      r.frame = i;
      r.time_s = 0.04 * i;
      r.x_m = 0.5 * i;
      r.y_m = 0.2 * i;
      r.geo = aerovo::GeoPoint{50.45 + 1e-6 * i, 30.52 + 4e-6 * i, 180.0};
      set.Append(r, aerovo::GeoPoint{50.45 + 1.1e-6 * i, 30.52 + 4e-6 * i, 181.0});
      ++i;
    }
  }
  state.SetItemsProcessed(i);
  std::filesystem::remove_all(dir);
}
BENCHMARK(BM_TrackWriterSetAppend)->Unit(benchmark::kMicrosecond);

void BM_CompareTrajectories(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  std::vector<aerovo::TrajectoryPoint2D> enu, vo;
  for (int i = 0; i < n; ++i) {
    const double s = 2.0 * i;
    enu.push_back({double(i), s + 30.0 * std::sin(s / 50.0), 40.0 * std::cos(s / 70.0)});
    vo.push_back({double(i), 1.01 * enu.back().x + 3.0, 0.99 * enu.back().y - 1.0});
  }
  for (auto _ : state) {
    benchmark::DoNotOptimize(aerovo::CompareTrajectories(vo, enu));
  }
  state.SetItemsProcessed(state.iterations() * n);
}
BENCHMARK(BM_CompareTrajectories)->Arg(200)->Arg(10000)->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
