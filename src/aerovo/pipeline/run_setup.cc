// SetUpRun (frame_loop.h): the run from its first frame.
#include <optional>
#include <string>
#include <utility>

#include <fmt/format.h>

#include "aerovo/camera_files/calibration.h"
#include "aerovo/core/error.h"
#include "aerovo/pipeline/frame_loop.h"
#include "aerovo/pipeline/lens_prepass.h"
#include "aerovo/pipeline/lens_switch.h"
#include "aerovo/pipeline/map_fixer.h"

namespace aerovo::run_steps {
namespace {

// The camera of the first frame, and the reduction of frames above the pixel budget: reduced
// first, the camera model with them (focal scaled, principal point at the reduced centre), so
// undistortion and SURF work on the reduced frame. Video and live frames above the detection
// budget: an integer reduction (photo folders: the pixel budget alone).
void SetUpFrames(const RunSetup& setup, const FrameState& first, RunContext& run) {
  const RunConfig& config = *run.config;
  const Frame& frame = first.frame;
  run.width_px = frame.gray.width();
  run.height_px = frame.gray.height();
  const ImageFolderSource* folder = setup.folder;
  const ImageMetadata* photo =
      folder != nullptr && !folder->metadata().empty() ? &folder->metadata().front() : nullptr;
  // The 35 mm focal length of the first frame's record, else of the telemetry's first record
  // that has one: the first frame may come before the telemetry's first record, or its record
  // may have been skipped as malformed (--lenient-telemetry).
  std::optional<TelemetrySample> focal_sample = first.sample;
  if ((!first.sample || !first.sample->focal_length_35mm_mm) && run.telemetry != nullptr &&
      config.focal_px <= 0.0 && config.hfov_deg <= 0.0 && config.calibration.empty() &&
      photo == nullptr) {
    for (const TelemetrySample& s : run.telemetry->telemetry().samples()) {
      if (!s.focal_length_35mm_mm) continue;
      if (!focal_sample) focal_sample = TelemetrySample{};
      focal_sample->focal_length_35mm_mm = s.focal_length_35mm_mm;
      run.summary->warnings.push_back(fmt::format(
          "{}: its telemetry record has no 35 mm focal length; the camera's is the first one "
          "the telemetry has, {:.2f} mm ({}; give --focal-px or --hfov-deg to set it)",
          frame.name, *s.focal_length_35mm_mm, s.origin.empty() ? "its first record" : s.origin));
      break;
    }
  }
  run.camera = ResolveRunCamera(config, setup.focal_from_sim, run.width_px, run.height_px, photo,
                                focal_sample, frame.name);
  run.summary->focal_px = run.camera.focal_px;
  run.summary->focal_source = run.camera.focal_source;
  run.reducer = std::make_unique<FrameReducer>(run.width_px, run.height_px, config.max_megapixels,
                                               folder != nullptr ? 0.0 : config.detect_megapixels);
  const int pw = run.reducer->out_width_px(), ph = run.reducer->out_height_px();
  run.reduced_from_full = run.reducer->reduced_from_full();
  run.vo_options = setup.vo_options;
  run.vo_options.focal_px = run.camera.focal_px * run.reducer->focal_scale();
  run.vo_options.default_height_m = config.altitude_m;
  if (!run.reducer->active()) run.reducer.reset();
  // SURF's smallest box filter is 9x9 px (features/surf.cc, CheckImage): smaller frames (a 2x2
  // video) have no feature. Before the first frame, naming it (was SURF's own error, naming no
  // file).
  constexpr int kMinFramePx = 9;
  if (pw < kMinFramePx || ph < kMinFramePx) {
    throw InputError(fmt::format(
        "{}: the frames are {}x{} px{}: smaller than SURF's smallest filter ({}x{} px), no "
        "feature can be found in them",
        frame.name, run.width_px, run.height_px,
        pw != run.width_px || ph != run.height_px ? fmt::format(" (reduced to {}x{})", pw, ph)
                                                  : std::string(),
        kMinFramePx, kMinFramePx));
  }
  run.summary->processed_width_px = pw;
  run.summary->processed_height_px = ph;
  run.summary->frame_scale = static_cast<double>(pw) / run.width_px;
}

// Where the heights come from; with the autopilot's, waits for its first one.
void SetUpHeight(RunContext& run) {
  const RunConfig& config = *run.config;
  run.height_source = config.altitude_m > 0.0    ? HeightSource::kFlag
                      : run.link_reads_autopilot ? HeightSource::kMavlink
                                                 : HeightSource::kTelemetry;
  run.summary->height_source = ToString(run.height_source);
  if (run.height_source == HeightSource::kMavlink &&
      !run.link->WaitForHeight(config.mavlink_wait_s) && run.log) {
    *run.log << fmt::format("mavlink: no height from the autopilot after {:.1f} s ({})\n",
                            config.mavlink_wait_s, mavlink::DescribeNoHeight(run.link->stats()));
  }
}

// The camera's tilt from the pre-pass (RunConfig::attitude_estimation): a significant estimate
// is every frame's camera attitude (RunContext::estimated_attitude); logged.
void ApplyAttitudeEstimate(const AttitudePrepass& a, RunContext& run) {
  run.summary->attitude_estimate = ToJson(a);
  if (a.applied) run.estimated_attitude = a.estimate->attitude;
  if (!run.log || a.status == LensPrepassStatus::kSkipped) return;
  if (a.applied) {
    const AttitudeEstimate& e = *a.estimate;
    *run.log << fmt::format(
        "attitude: estimated from {} frame pairs: roll {:.2f} +- {:.2f}, pitch {:.2f} +- {:.2f} "
        "deg ({:.1f} deg from nadir, cost drop {:.0f} %), applied to every frame ({:.0f} ms)\n",
        e.pairs_used, e.attitude.roll_deg, e.sigma_roll_deg, e.attitude.pitch_deg,
        e.sigma_pitch_deg, e.tilt_deg, 100.0 * e.cost_drop, a.estimate_ms);
  } else {
    *run.log << fmt::format("attitude: self-calibration {}: {}\n", ToString(a.status), a.why);
  }
}

// The pre-pass before the first frame is processed, when the camera's tilt is estimated
// (RunConfig::attitude_estimation; `lens_skip`: why the lens is not, "" = it is too): both
// applied from the first frame; a significant lens estimate is written to lens_estimate.yaml.
void RunPrepassNow(const std::string& lens_skip, RunContext& run) {
  const RunConfig& config = *run.config;
  PrepassRequest request;
  request.lens = lens_skip.empty();
  request.attitude = true;
  request.calibrated = run.camera.calibrated;
  LensPrepass prepass =
      RunLensPrepass(config, run.width_px, run.height_px, run.camera.focal_px, request);
  if (prepass.applied) {
    run.camera.calibrated = *prepass.lens;
    WriteCalibration((run.out_dir / kLensEstimateYaml).string(), *prepass.lens,
                     CalibrationFormat::kOpenCv);
  }
  if (!request.lens) prepass.why = lens_skip;
  ApplyAttitudeEstimate(prepass.attitude, run);
  nlohmann::json lens = ToJson(prepass);
  if (request.lens) {
    lens["switch_frame"] = 0;  // applied from the first frame
    lens["wait_ms"] = prepass.total_ms;
    lens["frames_replayed"] = 0;
  }
  run.summary->lens_estimate = lens;
  if (!request.lens || !run.log) return;
  if (prepass.applied) {
    *run.log << fmt::format(
        "lens: estimated from {} frame pairs before the first frame: {} k1 = {:.4f} +- {:.4f} "
        "(cost drop {:.0f} %), applied; written to {} ({:.0f} ms)\n",
        prepass.estimate->pairs_used, ToString(prepass.estimate->family), prepass.estimate->k,
        prepass.estimate->sigma_k, 100.0 * prepass.estimate->cost_drop,
        (run.out_dir / kLensEstimateYaml).string(), prepass.total_ms);
  } else {
    *run.log << fmt::format("lens: self-calibration {}: {} ({:.0f} ms)\n",
                            ToString(prepass.status), prepass.why, prepass.total_ms);
  }
}

// Lens self-calibration (RunConfig::lens_estimation): the pre-pass started on its own thread,
// its estimate applied at the switch frame (pipeline/lens_switch.h); when the camera's tilt is
// estimated too (AttitudePrepassSkipReason ""), before the first frame (RunPrepassNow).
void StartPrepass(const RunSetup& setup, const FrameState& first, RunContext& run) {
  const RunConfig& config = *run.config;
  LensPrepass skipped;
  skipped.why = LensPrepassSkipReason(config, setup.source_live);
  AttitudePrepass attitude;
  attitude.why = AttitudePrepassSkipReason(config, setup.source_live, run.link_reads_autopilot,
                                           first.sample, setup.folder != nullptr);
  if (attitude.why.empty()) {
    RunPrepassNow(skipped.why, run);
    return;
  }
  ApplyAttitudeEstimate(attitude, run);
  if (skipped.why.empty()) {
    // A live source's pairs are its own frames as delivered (lens_switch.h).
    auto feed = setup.source_live ? std::make_shared<LivePairFeed>() : nullptr;
    run.lens_switch = std::make_unique<LensSwitch>(
        std::make_unique<LensPrepassTask>(config, run.width_px, run.height_px,
                                          run.camera.focal_px, run.stop, feed),
        first.frame.time_s, feed, LensSwitch::FilePosesReplaceable(run));
    run.summary->lens_estimate = {{"status", "pending"}, {"applied", false}};
    if (run.log) {
      *run.log << fmt::format(
          "lens: self-calibration started beside the odometry; its estimate is taken at the "
          "first frame {:.1f} s into the stream (or the {}th)\n",
          kLensSwitchAfterS, kLensSwitchMaxFrames + 1);
    }
    return;
  }
  run.summary->lens_estimate = ToJson(skipped);
}

}  // namespace

void LogLensPrepass(const RunContext& run, const LensPrepass& prepass, int switch_frame,
                    double waited_ms) {
  if (!run.log) return;
  const std::string waited =
      waited_ms >= 1.0 ? fmt::format(", the run waited {:.0f} ms for it", waited_ms) : "";
  if (prepass.applied && switch_frame >= 0) {
    *run.log << fmt::format(
        "lens: estimated from {} frame pairs beside the odometry: {} k1 = {:.4f} +- {:.4f} "
        "(cost drop {:.0f} %), applied from frame {} on (reset); written to {} ({:.0f} ms{})\n",
        prepass.estimate->pairs_used, ToString(prepass.estimate->family), prepass.estimate->k,
        prepass.estimate->sigma_k, 100.0 * prepass.estimate->cost_drop, switch_frame,
        (run.out_dir / kLensEstimateYaml).string(), prepass.total_ms, waited);
  } else {
    const bool skipped = prepass.status == LensPrepassStatus::kSkipped;
    *run.log << fmt::format(
        "lens: self-calibration {}: {}{}\n", ToString(prepass.status), prepass.why,
        skipped ? "" : fmt::format(" ({:.0f} ms{})", prepass.total_ms, waited));
  }
}

// Lens distortion: whole frames remapped before SURF, or the keypoints undistorted in the
// odometry (RunConfig::undistort).
LensPath MakeLensPath(const RunContext& run, const RunCamera& camera, VisualOdometry& odometry) {
  const RunConfig& config = *run.config;
  const int pw = run.summary->processed_width_px, ph = run.summary->processed_height_px;
  const std::optional<CameraIntrinsics> lens =
      RunLens(config, camera, pw, ph, run.vo_options.focal_px);
  LensPath p;
  if (!lens) return p;
  double scale_change = 0.0;
  const UndistortMode path = ChooseUndistortion(config.undistort, *lens, &scale_change);
  p.scale_change = scale_change;
  if (path == UndistortMode::kPoints) {
    odometry.SetLensUndistortion(*lens);
    p.undistortion = UndistortionPath::kPoints;
  } else {
    p.undistorter = std::make_unique<FrameUndistorter>(*lens);
    p.undistortion = UndistortionPath::kFrames;
  }
  return p;
}

void InstallLensPath(RunContext& run, LensPath path) {
  run.undistorter = std::move(path.undistorter);
  run.undistortion = path.undistortion;
  if (!path.scale_change) return;  // no lens: the summary's fields as they were
  run.summary->lens_scale_change = *path.scale_change;
  run.summary->undistortion = ToString(run.undistortion);
}

void SetUpUndistortion(RunContext& run) {
  InstallLensPath(run, MakeLensPath(run, run.camera, *run.odometry));
}

namespace {

void LogSetUp(const RunContext& run) {
  if (!run.log) return;
  const RunConfig& config = *run.config;
  std::ostream& log = *run.log;
  log << fmt::format("camera: {}x{} px, focal {:.1f} px ({}), height from {}\n", run.width_px,
                     run.height_px, run.camera.focal_px, run.camera.focal_source,
                     ToString(run.height_source));
  log << "camera: " << run.camera.description << "\n";
  if (run.undistortion != UndistortionPath::kNone) {
    log << fmt::format(
        "lens: undistortion of the {} (local scale change {:.1f} % over the "
        "frame; undistort {})\n",
        run.undistortion == UndistortionPath::kPoints ? "keypoints" : "whole frames",
        100.0 * run.summary->lens_scale_change, ToString(config.undistort));
  }
  if (run.reducer) {
    const bool detect = run.reducer->factor() > 1;
    log << fmt::format(
        "frames reduced to {}x{} px before SURF ({:.1f} MP > {} {}), focal {:.1f} px\n",
        run.summary->processed_width_px, run.summary->processed_height_px,
        static_cast<double>(run.width_px) * run.height_px / 1e6,
        detect ? "detect_megapixels" : "max_megapixels",
        detect ? config.detect_megapixels : config.max_megapixels, run.vo_options.focal_px);
  }
}

}  // namespace

std::unique_ptr<RunContext> SetUpRun(RunSetup setup, const FrameState& first) {
  auto run = std::make_unique<RunContext>(std::move(setup.base));
  SetUpFrames(setup, first, *run);
  SetUpHeight(*run);
  run->odometry = std::make_unique<VisualOdometry>(run->vo_options);
  // The offline optimisation's keyframes and step factors (sink_flight_graph.cc).
  // The step's inliers are the step factor's evidence (also the window's with map_fix.apply).
  run->odometry->SetShareFeatures(run->config->backend.enable || WindowRuns(*run));
  StartPrepass(setup, first, *run);
  SetUpUndistortion(*run);
  run->outputs = std::make_unique<RunOutputs>(
      run->out_dir, *run->config, run->camera, run->summary->height_source, run->width_px,
      run->height_px, first.frame.time_s, first.sample, *run->callbacks,
      !run->telemetry->empty() || run->maps != nullptr);  // a map may seed the geo-reference
  // The files wait for the lens switch's replayed poses (pipeline/lens_switch.h).
  if (run->lens_switch && run->lens_switch->replaces_file_poses()) run->outputs->HoldForReplay();
  if (run->maps != nullptr) {
    run->map_fixer =
        std::make_shared<MapFixer>(*run->maps, run->config->map_fix, setup.source_live);
  }
  LogSetUp(*run);
  return run;
}

}  // namespace aerovo::run_steps
