// The flight graph sink (backend.enable): the frame's odometry result added to the run's flight
// graph (odometry/flight_graph.h: its pose, its step as a factor, its features when it becomes
// a keyframe) with its source index and time, for the offline optimisation after the last frame
// (run_steps.h OptimizeFlight). The frame's features are released from the FrameState here
// (the graph keeps those of its keyframes only).
#include <memory>

#include "aerovo/pipeline/frame_loop.h"

namespace aerovo::run_steps {
namespace {

class FlightGraphSink : public FrameSink {
 public:
  const char* name() const override { return "flight_graph"; }

  void Write(FrameState& f, const RunContext& run) override {
    FlightRecording& flight = run.state->flight;
    if (f.lens_switched && flight.graph) flight.graph->DropKeyframes();
    flight.GraphOf(run.config->backend, f.pixels.width, f.pixels.height).Add(f.result);
    flight.Record(f.frame.index, f.frame.time_s);
    f.result.features.reset();
  }
};

}  // namespace

std::unique_ptr<FrameSink> MakeFlightGraphSink() { return std::make_unique<FlightGraphSink>(); }

}  // namespace aerovo::run_steps
