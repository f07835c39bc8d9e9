// The online window stage (backend.online, docs/backend.md "Online window"): the frame's
// odometry result added to the run's flight graph (odometry/flight_graph.h AddOnline: its step,
// its matches against recent keyframes, the last backend.window poses optimised), and the
// frame's position and heading replaced by the windowed estimate, so that every output after it
// (GPS check, geo-referencing, frames.csv and the track files, the pose stream, MAVLink) carries
// it. With map_fix.apply and without backend.online the window is "fixes only" (frame_state.h
// WindowRuns): the frames' steps into the graph, no keyframe matching, no closures, no
// summary.json "online"; the map-fix stage adds the fixes (FlightGraph::AddFix). The causal
// pixel transform (FrameResult::world_from_frame, transforms.csv) is left as the odometry made
// it. The frame's features are released from the FrameState here (the graph keeps those of its
// keyframes only). summary.json "online" counts the pairs and the stage's time.
// A whole-graph solve (a verified loop closure) that moves the frame's pose away from the causal
// prediction (the pose given for the previous frame moved by the frame's causal step) by more
// than mavlink::PoseJumpResetThresholdM of its standard deviation, or turns its heading by more
// than mavlink::HeadingJumpResetThresholdRad, sets FrameState::pose_reset (MAVLink
// reset_counter + 1; docs/autopilot.md "A pose that jumps").
#include <algorithm>
#include <cmath>
#include <memory>
#include <optional>

#include <Eigen/Eigenvalues>

#include "aerovo/core/timer.h"
#include "aerovo/mavlink/vision.h"
#include "aerovo/pipeline/frame_loop.h"

namespace aerovo::run_steps {
namespace {

class WindowStage : public FrameStage {
 public:
  const char* name() const override { return "window"; }

  void Process(FrameState& f, const RunContext& run) override {
    FlightRecording& flight = run.state->flight;
    if (f.lens_switched && flight.graph) flight.graph->DropKeyframes();
    const bool matching = run.config->backend.online;  // else "fixes only"
    if (!fitter_ && matching) {
      fitter_ = MakeStandardPairFitter(PairCorrespondenceOptions(*run.config),
                                       f.pixels.width, f.pixels.height);
    }
    BackendOptions options = run.config->backend;
    options.online = true;
    options.closures = options.closures && matching;
    // "Fixes only" without the offline optimisation: no keyframe is ever matched.
    if (!matching && !run.config->backend.enable) f.result.features.reset();
    const Stopwatch time;
    const std::uint64_t seed = run.config->odometry.correspondence.ransac.seed;
    const WindowedPose w = flight.GraphOf(options, f.pixels.width, f.pixels.height, seed)
                               .AddOnline(f.result, fitter_, seed);
    RecordFlightFrame(f, run);  // the causal pose, before it is replaced below
    f.result.features.reset();
    const backend::Similarity2 causal{f.result.position_m, f.result.heading_rad, 0.0};
    if (previous_) f.pose_reset = PoseJumped(w, causal, previous_->causal, previous_->windowed);
    previous_ = Given{causal, w.local_from_frame};
    f.result.position_m = w.local_from_frame.translation_m;
    f.result.heading_rad = w.local_from_frame.heading_rad;
    f.window = w;
    if (!matching) return;
    if (!run.summary->online) run.summary->online = RunSummary::Online{run.config->backend.window};
    RunSummary::Online& s = *run.summary->online;
    s.pairs_tried += w.pairs_tried;
    s.pairs_verified += w.pairs_verified;
    s.pairs_gated += w.pairs_gated;
    s.closures_tried += w.closures_tried;
    s.closures_verified += w.closures_verified;
    s.closures_gated += w.closures_gated;
    s.full_solves += w.full_solve ? 1 : 0;
    s.full_solve_ms += w.full_solve_ms;
    s.total_ms += time.elapsed_ms();
  }

 private:
  // The previous frame's causal pose and the windowed pose given for it.
  struct Given {
    backend::Similarity2 causal, windowed;
  };
  PairFitter fitter_;
  std::optional<Given> previous_;
};

}  // namespace

PoseReset PoseJumped(const WindowedPose& w, const backend::Similarity2& causal,
                     const backend::Similarity2& previous_causal,
                     const backend::Similarity2& previous_windowed) {
  if (!w.full_solve) return PoseReset{};
  const backend::Similarity2 predicted =
      previous_windowed * backend::Between(previous_causal, causal);
  const double jump_m = (w.local_from_frame.translation_m - predicted.translation_m).norm();
  const double turn_rad =
      backend::WrapAngleRad(w.local_from_frame.heading_rad - predicted.heading_rad);
  return JumpPastGates(jump_m, turn_rad, &w, PoseReset::Cause::kLoopClosure);
}

PoseReset JumpPastGates(double jump_m, double turn_rad, const WindowedPose* w,
                        PoseReset::Cause cause) {
  const bool moved = jump_m > mavlink::PoseJumpResetThresholdM(w ? WindowSigmaXyM(*w) : 0.0);
  const bool turned = std::abs(turn_rad) >
                      mavlink::HeadingJumpResetThresholdRad(w ? WindowSigmaHeadingRad(*w) : 0.0);
  PoseReset r;
  if (moved || turned) r.cause = cause;
  r.heading_only = turned && !moved;
  return r;
}

double WindowSigmaHeadingRad(const WindowedPose& w) {
  return w.has_covariance ? std::sqrt(std::max(0.0, w.covariance(2, 2))) : 0.0;
}

double WindowSigmaXyM(const WindowedPose& w) {
  if (!w.has_covariance) return 0.0;
  const Eigen::Matrix2d xy = w.covariance.topLeftCorner<2, 2>();
  return std::sqrt(std::max(0.0, Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(
                                     xy, Eigen::EigenvaluesOnly).eigenvalues().maxCoeff()));
}

std::unique_ptr<FrameStage> MakeWindowStage() { return std::make_unique<WindowStage>(); }

}  // namespace aerovo::run_steps
