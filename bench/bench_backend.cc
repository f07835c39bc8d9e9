// The pose-graph back-end's solve time (backend/pose_graph.h): the whole-flight optimisation
// (OptimizeAll) of synthetic lawnmower surveys of about 200, 2000 and 10 000 poses, chained
// odometry plus loop closures between neighbouring strips (backend/testing.h), and the online
// window (OptimizeWindow over the last 30 poses, the older ones held) on the same graphs, alone
// and slid through the whole flight.
// Results in BENCHMARKS.md ("Pose-graph back-end").
#include <benchmark/benchmark.h>

#include <map>

#include "aerovo/backend/pose_graph.h"
#include "aerovo/backend/testing.h"

namespace {

using aerovo::backend::PoseGraph;
using aerovo::backend::testing::Lawnmower;
using aerovo::backend::testing::LawnmowerSpec;

// Surveys by their approximate size: strips of strip_length_m at a frame every 10 m, 40 m apart.
LawnmowerSpec SpecFor(int approx_poses) {
  LawnmowerSpec s;
  if (approx_poses <= 200) {
    s.strips = 5;
    s.strip_length_m = 400.0;  // 217 poses
  } else if (approx_poses <= 2000) {
    s.strips = 20;
    s.strip_length_m = 1000.0;  // 2077 poses
  } else {
    s.strips = 48;
    s.strip_length_m = 2000.0;  // 9789 poses
  }
  return s;
}

const Lawnmower& Survey(int approx_poses) {
  static std::map<int, Lawnmower> cache;
  auto it = cache.find(approx_poses);
  if (it == cache.end()) {
    it = cache.emplace(approx_poses, aerovo::backend::testing::MakeLawnmower(SpecFor(approx_poses)))
             .first;
  }
  return it->second;
}

void SetCounters(benchmark::State& state, const PoseGraph& g, int iterations) {
  state.counters["poses"] = g.num_poses();
  state.counters["factors"] =
      static_cast<double>(g.relative_factors().size() + g.absolute_factors().size());
  state.counters["lm_iterations"] = iterations;
}

// The offline optimisation of the whole survey from the chained odometry.
void BM_OptimizeAll(benchmark::State& state) {
  const Lawnmower& l = Survey(static_cast<int>(state.range(0)));
  const PoseGraph g = aerovo::backend::testing::MakeGraph(l, true);
  int iterations = 0;
  double end_error_m = 0.0;
  for (auto _ : state) {
    const aerovo::backend::PoseGraphResult r = aerovo::backend::OptimizeAll(g);
    iterations = r.iterations;
    end_error_m = (r.local_from_frame.back().translation_m - l.truth.back().translation_m).norm();
  }
  SetCounters(state, g, iterations);
  state.counters["end_error_m"] = end_error_m;
  state.counters["chained_end_error_m"] =
      (l.chained.back().translation_m - l.truth.back().translation_m).norm();
}
BENCHMARK(BM_OptimizeAll)->Arg(200)->Arg(2000)->Arg(10000)->Unit(benchmark::kMillisecond);

// The online window: the last 30 poses of the survey free, every older pose held at the
// chained estimate (the cost of one frame's window at the end of the flight).
void BM_OptimizeWindow30(benchmark::State& state) {
  const Lawnmower& l = Survey(static_cast<int>(state.range(0)));
  const PoseGraph g = aerovo::backend::testing::MakeGraph(l, true);
  const int last = g.num_poses() - 1;
  int iterations = 0;
  for (auto _ : state) {
    const aerovo::backend::PoseGraphResult r = aerovo::backend::OptimizeWindow(g, last - 29, last);
    iterations = r.iterations;
    benchmark::DoNotOptimize(r.final_cost);
  }
  SetCounters(state, g, iterations);
}
BENCHMARK(BM_OptimizeWindow30)->Arg(200)->Arg(2000)->Arg(10000)->Unit(benchmark::kMicrosecond);

// The online use through a whole flight: each new pose added with its odometry factor (and the
// closures whose poses both exist), then the last 30 poses optimised with the older ones held at
// their windowed estimates, as a run would per frame. Time per flight; per pose: divide by poses.
void BM_SlidingWindow30(benchmark::State& state) {
  const Lawnmower& l = Survey(static_cast<int>(state.range(0)));
  double end_error_m = 0.0;
  for (auto _ : state) {
    const PoseGraph g = aerovo::backend::testing::SlideWindow(l, 30);
    end_error_m = (g.estimates().back().translation_m - l.truth.back().translation_m).norm();
  }
  state.counters["poses"] = static_cast<double>(l.truth.size());
  state.counters["end_error_m"] = end_error_m;
  state.counters["chained_end_error_m"] =
      (l.chained.back().translation_m - l.truth.back().translation_m).norm();
}
BENCHMARK(BM_SlidingWindow30)->Arg(200)->Arg(2000)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
