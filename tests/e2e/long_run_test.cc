// A long run through RunFlight (the `aerovo run` path, every output written): 10,000 frames of
// a simulated flight, rendered on the fly by an in-process FrameSource backed by the simulator
// (so that no 10,000-frame video has to be written first), with DJI SRT telemetry. Asserts that
// memory stays flat: the peak resident set grows by less than a stated bound between frame 1000
// and frame 10000. Figures (peak memory, growth, frames/s) are in BENCHMARKS.md, "Long run".
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <string>

#include <fmt/format.h>

#include "aerovo/core/timer.h"
#include "aerovo/frames/frame_source.h"
#include "aerovo/pipeline/runner.h"
#include "aerovo/sim/sim_writer.h"
#include "aerovo/sim/simulator.h"

namespace aerovo::long_run_test {
namespace {

namespace fs = std::filesystem;

// Frames of a Simulator, rendered when asked for (one at a time, nothing kept).
class SimulatorSource : public FrameSource {
 public:
  explicit SimulatorSource(const sim::Simulator& sim) : sim_(sim) {}
  bool Next(Frame& frame) override {
    if (next_ >= sim_.frame_count()) return false;
    ToGrayImage(sim_.RenderFrame(next_), frame.gray);
    frame.index = next_;
    frame.time_s = next_ / sim_.options().fps;
    frame.name = fmt::format("sim#{}", next_);
    ++next_;
    return true;
  }
  std::string Describe() const override {
    return fmt::format("simulator, {} frames", sim_.frame_count());
  }
  int ExpectedFrameCount() const override { return sim_.frame_count(); }

 private:
  const sim::Simulator& sim_;
  int next_ = 0;
};

// VmHWM (peak resident set) and VmRSS of this process, kB, from /proc/self/status.
struct Memory {
  long hwm_kb = -1, rss_kb = -1;
};
Memory ReadMemory() {
  Memory m;
  std::ifstream in("/proc/self/status");
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind("VmHWM:", 0) == 0) m.hwm_kb = std::stol(line.substr(6));
    if (line.rfind("VmRSS:", 0) == 0) m.rss_kb = std::stol(line.substr(6));
  }
  return m;
}

TEST(LongRun, TenThousandFramesWithFlatMemory) {
  // 120 legs of 150 m with 90 deg right turns (radius 20 m): a rounded square flown over and
  // over (so the terrain stays small), 2 m per frame (10 m/s at 5 fps), 100 m high, 320x240.
  sim::SimulationOptions o;
  o.flight.pattern = sim::FlightPattern::kTurns;
  o.flight.legs = 120;
  o.flight.leg_length_m = 150.0;
  o.flight.turn_angle_deg = 90.0;
  o.flight.turn_radius_m = 20.0;
  o.flight.height_m = 100.0;
  o.flight.speed_mps = 10.0;
  o.fps = 5.0;
  o.flight.max_duration_s = 1999.9;  // 10,000 frames
  o.camera.width_px = 320;
  o.camera.height_px = 240;
  o.camera.hfov_deg = 73.7;
  const sim::Simulator sim(sim::MakeTerrainGround(sim::FitTerrainToFlight(o)), o);
  constexpr int kFrames = 10000;
  ASSERT_EQ(sim.frame_count(), kFrames);

  const fs::path dir =
      fs::temp_directory_path() / ("aerovo_long_run_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  {
    std::ofstream srt(dir / "telemetry.srt");
    sim::WriteDjiSrt(srt, sim, "2026-05-01T10:00:00");
  }
  RunConfig c;
  c.input = "simulator";
  c.telemetry = (dir / "telemetry.srt").string();
  c.out = (dir / "run").string();
  c.hfov_deg = 73.7;
  // One thread: on 320x240 frames a second thread gives little, and the test's figure is the
  // per-frame path's memory, not its speed.
  c.odometry.surf.num_threads = 1;
  c.odometry.correspondence.match.num_threads = 1;
  c.quiet = true;

  Memory at_1000, at_10000;
  Stopwatch wall;
  double ms_at_1000 = 0.0;
  RunCallbacks cb;
  cb.progress = [&](int done, int, double) {
    if (done == 1000) {
      at_1000 = ReadMemory();
      ms_at_1000 = wall.elapsed_ms();
    }
    if (done == kFrames) at_10000 = ReadMemory();
  };
  const RunSummary s = RunFlight(c, std::make_unique<SimulatorSource>(sim), cb);
  const double ms_total = wall.elapsed_ms();
  ASSERT_EQ(s.frames_processed, kFrames);
  ASSERT_GT(at_1000.hwm_kb, 0);
  ASSERT_GT(at_10000.hwm_kb, 0);
  const long growth_kb = at_10000.hwm_kb - at_1000.hwm_kb;
  const double fps_steady = (kFrames - 1000) / ((ms_total - ms_at_1000) / 1000.0);
  std::cout << fmt::format(
      "long run: {} frames, peak RSS {:.1f} MB at frame 1000, {:.1f} MB at frame 10000 (growth "
      "{} kB = {:.1f} B/frame), RSS {:.1f} MB at the end; {:.1f} frames/s (frames 1000-10000); "
      "bridged {}, ATE SE(2) {:.2f} m over {:.0f} m\n",
      kFrames, at_1000.hwm_kb / 1024.0, at_10000.hwm_kb / 1024.0, growth_kb,
      growth_kb * 1024.0 / (kFrames - 1000), at_10000.rss_kb / 1024.0, fps_steady, s.frames_bridged,
      s.evaluation ? s.evaluation->se2.ate_m.rmse : -1.0,
      s.evaluation ? s.evaluation->se2.distance_flown_m : 0.0);
  // What may grow: the positions kept for the final comparison with GPS (2 x 24 bytes + an
  // index per frame with a fix, ~0.5 MB over 9000 frames) plus allocator slack. Anything that
  // kept a frame (77 kB), its features or a per-frame record would exceed 4 MB many times over.
  EXPECT_LT(growth_kb, 4 * 1024) << "memory grows with the number of frames";
  // The run itself is sound: every frame tracked, the outputs complete.
  EXPECT_EQ(s.frames_with_gps, kFrames);
  EXPECT_LE(s.frames_bridged, 10);
  ASSERT_TRUE(s.evaluation.has_value());
  EXPECT_NEAR(s.evaluation->se2.distance_flown_m, 2.0 * (kFrames - 1), 20.0);
  std::ifstream csv(dir / "run" / "frames.csv");
  int rows = -1;
  for (std::string line; std::getline(csv, line);) ++rows;
  EXPECT_EQ(rows, kFrames);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace aerovo::long_run_test
