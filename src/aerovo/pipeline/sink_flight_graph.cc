// The flight graph sink (backend.enable): the frame's odometry result added to the run's flight
// graph (odometry/flight_graph.h: its pose, its step as a factor, its features when it becomes
// a keyframe) with its source index and time, for the offline optimisation after the last frame
// (run_steps.h OptimizeFlight). The frame's features are released from the FrameState here
// (the graph keeps those of its keyframes only). Also the frame's world_from_frame and causal
// pose, for transforms_optimized.csv (run_steps.h FlightRecording).
#include <memory>

#include <Eigen/LU>

#include "aerovo/pipeline/frame_loop.h"

namespace aerovo::run_steps {

void RecordFlightFrame(const FrameState& f, const RunContext& run) {
  FlightRecording& flight = run.state->flight;
  const FrameResult& r = f.result;
  if (flight.frames.empty()) {
    // local_from_frame of the first frame (position 0, heading 0: pose_chain.h): pixels
    // about the image centre, y flipped, times the ground sampling distance.
    Eigen::Matrix3d local_from_first = Eigen::Matrix3d::Identity();
    const Eigen::Vector2d centre(0.5 * (f.pixels.width - 1), 0.5 * (f.pixels.height - 1));
    local_from_first.topLeftCorner<2, 2>() << r.gsd_m_per_px, 0.0, 0.0, -r.gsd_m_per_px;
    local_from_first.topRightCorner<2, 1>() = -local_from_first.topLeftCorner<2, 2>() * centre;
    flight.world_from_local = r.world_from_frame * local_from_first.inverse();
  }
  flight.frames.push_back(f.frame.index);
  flight.times_s.push_back(f.frame.time_s);
  flight.world_from_frame.push_back(
      run.reducer ? Eigen::Matrix3d(r.world_from_frame * run.reduced_from_full)
                  : r.world_from_frame);
  flight.causal.push_back(backend::Similarity2{r.position_m, r.heading_rad, 0.0});
}

namespace {

class FlightGraphSink : public FrameSink {
 public:
  const char* name() const override { return "flight_graph"; }

  void Write(FrameState& f, const RunContext& run) override {
    FlightRecording& flight = run.state->flight;
    if (f.lens_switched && flight.graph) flight.graph->DropKeyframes();
    flight.GraphOf(run.config->backend, f.pixels.width, f.pixels.height,
                   run.config->odometry.correspondence.ransac.seed)
        .Add(f.result);
    RecordFlightFrame(f, run);
    f.result.features.reset();
  }
};

}  // namespace

std::unique_ptr<FrameSink> MakeFlightGraphSink() { return std::make_unique<FlightGraphSink>(); }

}  // namespace aerovo::run_steps
