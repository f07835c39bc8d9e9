// The cost of the GPS plausibility checks per fix (docs/reliability.md, "Telemetry that lies"):
// GpsFixChecker::Check and GeoReferencer::Observe over a long simulated track (10 000 fixes,
// 10 m/s, 1.5 m of noise, one spike every 500 fixes), against Observe alone (the geo-referencing
// before the checks). Results in BENCHMARKS.md ("GPS plausibility checks").
#include <benchmark/benchmark.h>

#include <cmath>
#include <vector>

#include "aerovo/odometry/georef.h"
#include "aerovo/odometry/gps_check.h"

namespace {

struct Track {
  std::vector<aerovo::GeoPoint> gps;
  std::vector<Eigen::Vector2d> local;
};

const Track& LongTrack() {
  static const Track t = [] {
    Track t;
    const aerovo::LocalEnu enu(49.84, 24.03, 300.0);
    for (int i = 0; i < 10000; ++i) {
      const double s = 0.1 * i;  // 10 fixes per second
      double n = 1.5 * std::cos(5.3 * i);
      if (i % 500 == 250) n += 1112.0;
      t.gps.push_back(enu.Reverse(s * 10.0 + 1.5 * std::sin(7.1 * i), n, 100.0));
      t.local.emplace_back(0.0, s * 10.0);
    }
    return t;
  }();
  return t;
}

// Observe per fix, as a run without the checks (the GPS segment, then the fixed transform).
void BM_GeoRefObserve(benchmark::State& state) {
  const Track& t = LongTrack();
  for (auto _ : state) {
    aerovo::GeoRefOptions o;
    o.heading_source = aerovo::HeadingSource::kGpsSegment;
    aerovo::GeoReferencer geo(o);
    for (std::size_t i = 0; i < t.gps.size(); ++i) geo.Observe(t.local[i], t.gps[i], std::nullopt);
    benchmark::DoNotOptimize(geo.rotation_rad());
  }
  state.SetItemsProcessed(state.iterations() * static_cast<int64_t>(t.gps.size()));
}
BENCHMARK(BM_GeoRefObserve)->Unit(benchmark::kMicrosecond);

// The check and the robust Observe per fix, as a run with the checks (the default).
void BM_GpsCheckAndGeoRefObserve(benchmark::State& state) {
  const Track& t = LongTrack();
  for (auto _ : state) {
    aerovo::GeoRefOptions o;
    o.heading_source = aerovo::HeadingSource::kGpsSegment;
    o.outlier_m = 10.0;
    o.yaw_fixes = 3;
    aerovo::GeoReferencer geo(o);
    aerovo::GpsFixChecker check;
    int rejected = 0;
    for (std::size_t i = 0; i < t.gps.size(); ++i) {
      const auto v = check.Check(static_cast<int>(i), 0.1 * static_cast<double>(i), t.gps[i],
                                 std::nullopt, t.local[i], 0);
      rejected += v.accepted ? 0 : 1;
      geo.Observe(t.local[i], v.accepted ? std::optional<aerovo::GeoPoint>(t.gps[i]) : std::nullopt,
                  std::nullopt);
    }
    benchmark::DoNotOptimize(rejected);
  }
  state.SetItemsProcessed(state.iterations() * static_cast<int64_t>(t.gps.size()));
}
BENCHMARK(BM_GpsCheckAndGeoRefObserve)->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
