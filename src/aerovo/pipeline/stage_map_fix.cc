// The map-fix stage and sink (RunConfig::map; pipeline/map_fixer.h): every
// map_fix.every_n_frames-th frame processed, once the track is geo-referenced, is handed to
// the run's MapFixer with its prediction: the track's WGS84 position (GeoReferencer::
// Wgs84FromLocal of the frame's position) and ENU heading (the frame's heading plus
// GeoReferencer::rotation_rad), its height above ground, the processed frame's focal length
// and the frame's GPS (withheld or not) for the comparison. After the georeference stage, so
// that the frame that fixes the geo-reference is predicted already. The sink's End waits for
// the last attempt and writes map_fixes.csv and summary.json "map_fixes".
// With map_fix.apply, the fixes are fused into the run's pose graph, the online window's
// (stage_window.cc; frame_state.h WindowRuns): a fix is taken at a frame (MapFixer::TakeFix: a
// file source's next due frame, a live source's first frame after it is done), brought from
// the run's ENU frame into the local one (GeoReferencer: enu = R(rotation) local + t, fixed once
// ready) with its covariance, and given to FlightGraph::AddFix for the frame it was matched at;
// a fix the graph's gate rejects changes nothing, a fused one moves that frame by its
// covariance weight and every later frame with it, so that this frame's position and heading
// (FrameResult, local frame) and every output after this stage (frames.csv, the tracks, the
// pose stream, MAVLink, the comparisons) carry it, and the next frames are chained from it.
// Without a geo-reference from GPS the map's confirmed fix seeds it (MapFixer::TakeSeed); the
// frames wait for it at most map_fix.seed_wait_s (GiveUp: then written in the local frame, and
// the run stays local).
#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <optional>
#include <utility>

#include <Eigen/Geometry>
#include <fmt/format.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "aerovo/backend/similarity2.h"
#include "aerovo/core/angles.h"
#include "aerovo/odometry/attitude.h"
#include "aerovo/pipeline/frame_loop.h"
#include "aerovo/pipeline/map_fixer.h"

namespace aerovo::run_steps {
namespace {

// Floors of a fix's covariance: a fix is not trusted beyond its inliers' own RMS transfer error
// (MapFix::residual_m) per axis, and its heading beyond 0.5 degrees (the fit's covariance from
// the residuals leaves out the frame's tilt and the map's own errors).
constexpr double kHeadingFloorRad = 0.5 * kDegToRad;
// Frames remembered for the fixes still to come (a source frame -> its graph index): a fix
// taken more than this many frames after its frame is not fused (the worker does one attempt
// at a time, so a fix is at most a few attempts late).
constexpr std::size_t kFramesRemembered = 4096;
// The frame's pixels as the virtual nadir camera with the same centre and focal length sees them
// (odometry/attitude.h NadirFromCameraHomography with the attitude the odometry applied, principal
// point at the centre): the map fixer takes the frame's centre for the ground point under the
// camera (odometry/map_match.h), as the odometry's keypoints, mapped through the same homography,
// do. A frame without an applied attitude is copied as it is; pixels outside the tilted frame
// are 0.
GrayImage NadirPixels(const FrameState& f, double focal_px) {
  const int w = f.pixels.width, h = f.pixels.height;
  GrayImage out(w, h);
  const cv::Mat src(h, w, CV_8UC1, const_cast<std::uint8_t*>(f.pixels.data),
                    static_cast<std::size_t>(f.pixels.stride));
  cv::Mat dst(h, w, CV_8UC1, out.data());
  if (!f.attitude.camera) {
    src.copyTo(dst);
    return out;
  }
  const Eigen::Matrix3d m =
      NadirFromCameraHomography(*f.attitude.camera, focal_px, 0.5 * (w - 1), 0.5 * (h - 1));
  const cv::Matx33d nadir_from_frame(m(0, 0), m(0, 1), m(0, 2), m(1, 0), m(1, 1), m(1, 2),
                                     m(2, 0), m(2, 1), m(2, 2));
  cv::warpPerspective(src, dst, nadir_from_frame, dst.size(), cv::INTER_LINEAR,
                      cv::BORDER_CONSTANT, cv::Scalar(0));
  return out;
}

class MapFixStage : public FrameStage {
 public:
  const char* name() const override { return "map_fix"; }

  void Process(FrameState& f, const RunContext& run) override {
    MapFixer& fixer = *run.map_fixer;
    const bool due = fixer.Due(processed_++);
    const GeoReferencer& georef = run.state->georef;
    if (!first_time_s_) first_time_s_ = f.frame.time_s;
    const bool unanchored = !georef.ready() && NoGpsToCome(run);
    if (unanchored && !fixer.gave_up_seed()) {
      if (const std::optional<MapFixRecord> seed = fixer.TakeSeed(due)) {
        Seed(*seed, f, run);
      } else if (f.frame.time_s - *first_time_s_ >= fixer.options().seed_wait_s) {
        GiveUp(f, run);
      }
    }
    if (fixer.options().apply) {
      graph_index_[f.frame.index] = f.result.index;
      if (graph_index_.size() > kFramesRemembered) graph_index_.erase(graph_index_.begin());
      if (georef.ready()) {
        if (const std::optional<MapFixRecord> fix = fixer.TakeFix(due); fix && fix->geo) {
          Fuse(*fix, f, run);
        }
      }
    }
    if (!due) return;
    const double focal_px = run.vo_options.focal_px;
    // No prediction: GPS to come, or none and the run local for good (GiveUp).
    if ((!georef.ready() && (!NoGpsToCome(run) || fixer.gave_up_seed())) || f.pixels.empty() ||
        !(f.height_m > 0.0) || !(focal_px > 0.0)) {
      fixer.CountNoPrediction();
      return;
    }
    MapFixJob job;
    job.frame = f.frame.index;
    job.time_s = f.frame.time_s;
    job.pixels = NadirPixels(f, focal_px);
    job.focal_px = focal_px;
    job.height_m = f.height_m;
    job.local_m = f.result.position_m;
    job.local_heading_rad = f.result.heading_rad;
    job.anchored = georef.ready();
    if (job.anchored) {
      job.heading_rad = f.result.heading_rad + georef.rotation_rad();
      job.predicted = georef.Wgs84FromLocal(f.result.position_m);
    }
    job.gps = f.gps ? f.gps : f.withheld_gps;
    fixer.Submit(std::move(job));
  }

 private:
  // No GPS will geo-reference the track: it is denied (and was not enough before the denial), or
  // the telemetry has no position at all. The map then seeds it (MapFixJob::anchored).
  bool NoGpsToCome(const RunContext& run) {
    if (run.state->denial_seen) return true;
    if (!telemetry_has_positions_) {
      telemetry_has_positions_ = false;
      if (run.telemetry != nullptr) {
        for (const TelemetrySample& s : run.telemetry->telemetry().samples()) {
          if (s.has_fix) {
            telemetry_has_positions_ = true;
            break;
          }
        }
      }
    }
    return !*telemetry_has_positions_;
  }

  // The geo-reference seeded from the map's confirmed fix `seed` (of this frame or an earlier
  // one: its local pose is the job's).
  void Seed(const MapFixRecord& seed, FrameState& f, const RunContext& run) {
    run.state->georef.SeedFromFix(seed.local_m, seed.local_heading_rad, *seed.geo,
                                  seed.fix.heading_rad);
    const double floor_m = seed.fix.residual_m;  // as Fuse floors a fix
    f.map_seed_var_m2 = seed.fix.position_cov_m2.trace() + floor_m * floor_m;
    if (run.log != nullptr) {
      *run.log << fmt::format(
          "frame {}: the geo-reference seeded from the map's fix of frame {} (confirming a "
          "whole-map search's)\n",
          f.frame.index, seed.frame);
    }
  }

  // No seed within map_fix.seed_wait_s: the held frames are written in the local frame with
  // this one (RunOutputs), and the run stays local (no later seed, no more unanchored attempts),
  // as a run whose map never matched is at its end (MapFixer::SummarizeSeed says why).
  void GiveUp(const FrameState& f, const RunContext& run) {
    run.map_fixer->GiveUpSeed(f.frame.index, f.frame.time_s);
    run.outputs->StopWaitingForHeading();
    if (run.log != nullptr) {
      *run.log << fmt::format(
          "frame {}: no geo-reference from the map after {:.1f} s (map_fix.seed_wait_s {} s): "
          "the held frames are written in the local frame and the run stays local\n",
          f.frame.index, f.frame.time_s - *first_time_s_, run.map_fixer->options().seed_wait_s);
    }
  }

  // `fix` (of an earlier frame, or this one) into the run's flight graph; this frame's pose
  // replaced by the graph's newest estimate when it is fused.
  void Fuse(const MapFixRecord& fix, FrameState& f, const RunContext& run) {
    FlightGraph* graph = run.state->flight.graph.get();
    const auto it = graph_index_.find(fix.frame);
    if (graph == nullptr || it == graph_index_.end()) {  // its frame forgotten: not fused
      run.map_fixer->SetGraphVerdict(false, false);
      return;
    }
    const GeoReferencer& georef = run.state->georef;
    const double rotation = georef.rotation_rad();
    const Eigen::Matrix2d local_from_enu = Eigen::Rotation2Dd(-rotation).toRotationMatrix();
    const Eigen::Vector2d enu = georef.enu().Forward(*fix.geo).head<2>();
    GraphFix g;
    g.frame = it->second;
    g.position_m = local_from_enu * (enu - georef.EnuFromLocal(Eigen::Vector2d::Zero()));
    const double floor_m = fix.fix.residual_m;
    g.position_cov_m2 = local_from_enu * fix.fix.position_cov_m2 * local_from_enu.transpose() +
                        floor_m * floor_m * Eigen::Matrix2d::Identity();
    if (std::isfinite(fix.fix.heading_var_rad2) && fix.fix.heading_var_rad2 >= 0.0) {
      g.heading_rad = backend::WrapAngleRad(fix.fix.heading_rad - rotation);
      g.heading_var_rad2 = fix.fix.heading_var_rad2 + kHeadingFloorRad * kHeadingFloorRad;
    }
    if (!(g.position_cov_m2.determinant() > 0.0)) {  // a degenerate fit: not fused
      run.map_fixer->SetGraphVerdict(false, false);
      return;
    }
    // The graph's first fix: the track's placement is only as good as its geo-reference, which
    // the fixer's own gate bounded (the wide search's radius before the run's first fix, else
    // the local gate): that radius taken as 3 sigma (MapMatchOptions).
    if (graph->fixes_fused() == 0) {
      const MapMatchOptions& mo = run.map_fixer->options();
      const double radius_m = fix.search ? std::max(mo.search_wide_radius_m, mo.search_radius_m)
                                         : (mo.gate_m > 0.0 ? mo.gate_m : mo.search_radius_m);
      g.placement_sigma_m = radius_m / 3.0;
    }
    const FixOutcome o = graph->AddFix(g);
    run.map_fixer->SetGraphVerdict(o.fused, !o.fused);
    f.map_fix_frame = fix.frame;
    f.map_fix = o.fused ? FrameState::MapFixTaken::kFused : FrameState::MapFixTaken::kGated;
    if (!o.fused) return;
    f.map_fix_moved_m = (o.newest.translation_m - f.result.position_m).norm();
    const double turn_rad = backend::WrapAngleRad(o.newest.heading_rad - f.result.heading_rad);
    f.result.position_m = o.newest.translation_m;
    f.result.heading_rad = o.newest.heading_rad;
    if (f.window) f.window->local_from_frame = o.newest;
    // A jump past the autopilots' innovation gates is a reset, unless the window stage flagged
    // one already (JumpPastGates, frame_loop.h).
    if (!f.pose_reset) {
      f.pose_reset = JumpPastGates(f.map_fix_moved_m, turn_rad, f.window ? &*f.window : nullptr,
                                   PoseReset::Cause::kMapFix);
    }
  }

  int processed_ = 0;             // frames seen by this stage
  std::optional<double> first_time_s_;  // the first frame's time, s (map_fix.seed_wait_s)
  std::optional<bool> telemetry_has_positions_;  // NoGpsToCome, once
  std::map<int, int> graph_index_;  // map_fix.apply: source frame -> flight graph index
};

class MapFixSink : public FrameSink {
 public:
  const char* name() const override { return "map_fix"; }
  void Write(FrameState&, const RunContext&) override {}
  void End(const LoopEnd&, const RunContext* run) override {
    if (run == nullptr || !run->map_fixer) return;
    try {
      run->map_fixer->Finish(run->out_dir, run->summary);
    } catch (const Error& e) {  // the last attempt's map read, or map_fixes.csv's write
      run->summary->warnings.push_back(std::string("map fixes: ") + e.what());
    }
  }
};

}  // namespace

std::unique_ptr<FrameStage> MakeMapFixStage() { return std::make_unique<MapFixStage>(); }
std::unique_ptr<FrameSink> MakeMapFixSink() { return std::make_unique<MapFixSink>(); }

}  // namespace aerovo::run_steps
